/// @file png_read.h
/// @brief Reading 16-bit greyscale PNGs with libpng (depth maps: TUM RGB-D recordings, test
/// frames); every failure is a one-line status naming the file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/status.h"

namespace aoscan {

/// Decodes the 16-bit greyscale PNG at `path` into `out` (raw units, host byte order), reusing
/// `out`'s allocation and per-thread decode buffers (safe to call from several threads). Returns
/// ok, or corrupt_frame with a one-line message "PATH: reason" (or "PATH (frame N): reason" when
/// `frame_index` is given) for a missing or unreadable file, bytes that are not a PNG, a truncated
/// or corrupt PNG, and any PNG that is not 16-bit grey (8-bit, RGB, RGBA, palette, grey + alpha
/// are rejected, never converted). On failure `out`'s content is unspecified. Never throws.
Status read_grey16_png(const std::string& path, Image<std::uint16_t>& out,
                       std::optional<std::uint64_t> frame_index = std::nullopt);

}  // namespace aoscan
