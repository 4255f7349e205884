/// @file png_write.h
/// @brief Writing PNG files with libpng (depth recordings, view snapshots); every failure, a full
/// disk included, is an Error naming the file.
#pragma once

#include <functional>
#include <string>

namespace aoscan {

/// Pixel layout of the rows handed to write_png().
enum class PngFormat {
  kGrey16,  ///< uint16 per pixel in host byte order (written big-endian, as PNG requires)
  kRgb8,    ///< 3 bytes per pixel: red, green, blue
};

/// Writes a `width` x `height` PNG whose row y is `row(y)` (zlib level 2 with the "up" filter:
/// fast, and compact for depth maps). Throws usage_error for an empty image and Error(kFailure)
/// naming the file when it cannot be written.
void write_png(const std::string& path, int width, int height, PngFormat format,
               const std::function<const void*(int y)>& row);

}  // namespace aoscan
