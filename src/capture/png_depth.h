/// @file png_depth.h
/// @brief 16-bit greyscale PNG depth maps (the TUM RGB-D file format), decoded and encoded with
/// libpng.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/status.h"

namespace aoscan {

/// Decodes the 16-bit greyscale PNG at `path` into `out` (raw depth units, host byte order),
/// reusing `out`'s allocation and per-thread decode buffers (safe to call from several threads).
/// Returns ok, or corrupt_frame with a one-line message "PATH: reason" (or "PATH (frame N): reason"
/// when `frame_index` is given) for a missing or unreadable file, bytes that are not a PNG, a
/// truncated or corrupt PNG, and any PNG that is not 16-bit grey (8-bit, RGB, RGBA, palette, grey +
/// alpha are rejected, never converted). On failure `out`'s content is unspecified. Never throws.
Status read_depth_png(const std::string& path, Image<std::uint16_t>& out,
                      std::optional<std::uint64_t> frame_index = std::nullopt);

/// Encodes `depth` (raw units) as a 16-bit greyscale PNG at `path` (zlib level 2, "up" filter:
/// fast to write and to read back). Throws usage_error for an empty image and Error (exit code 1)
/// when the file cannot be written.
void write_depth_png(const std::string& path, const Image<std::uint16_t>& depth);

}  // namespace aoscan
