/// @file png_read.h
/// @brief Reading 16-bit greyscale PNGs (depth maps: TUM RGB-D recordings, test frames) with
/// libdeflate for the common case and libpng for the rest; every failure is a one-line status
/// naming the file.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/status.h"

namespace aoscan {

/// Decodes the 16-bit greyscale PNG at `path` into `out` (raw units, host byte order), reusing
/// `out`'s allocation and per-thread decode buffers (safe to call from several threads). Returns
/// ok, or corrupt_frame with a one-line message "PATH: reason" (or "PATH (frame N): reason" when
/// `frame_index` is given) for a missing or unreadable file, bytes that are not a PNG, a truncated
/// or corrupt PNG, and any PNG that is not 16-bit grey (8-bit, RGB, RGBA, palette, grey + alpha
/// are rejected, never converted). On failure `out`'s content is unspecified. Never throws.
/// The common PNG (one run of IDAT chunks, not interlaced, all critical chunks well formed) is
/// inflated by libdeflate and unfiltered without libpng, about twice as fast (the depth frames of a
/// replay); libpng decodes the rest and words every error.
Status read_grey16_png(const std::string& path, Image<std::uint16_t>& out,
                       std::optional<std::uint64_t> frame_index = std::nullopt);

namespace detail {

/// The common path of read_grey16_png() on a whole file's bytes: true when it decoded them into
/// `out`, false when they are not the common case or not valid (then libpng decides; `out` may
/// have been resized). It takes only a PNG that libpng would decode, and decodes the same pixels
/// (fuzz/png_fuzz.cpp checks both on every input).
bool decode_grey16_png_common(const std::vector<unsigned char>& bytes, Image<std::uint16_t>& out);

/// read_grey16_png() through libpng alone (the tests compare the two paths).
Status read_grey16_png_libpng(const std::string& path, Image<std::uint16_t>& out,
                              std::optional<std::uint64_t> frame_index = std::nullopt);

}  // namespace detail

}  // namespace aoscan
