/// @file png_depth.cpp
/// @brief Depth PNGs through the io module's 16-bit grey PNG reader and writer.
#include "capture/png_depth.h"

#include "io/png_read.h"
#include "io/png_write.h"

namespace aoscan {

Status read_depth_png(const std::string& path, Image<std::uint16_t>& out,
                      std::optional<std::uint64_t> frame_index) {
  return read_grey16_png(path, out, frame_index);
}

void write_depth_png(const std::string& path, const Image<std::uint16_t>& depth) {
  write_png(path, depth.width(), depth.height(), PngFormat::kGrey16,
            [&depth](int y) -> const void* { return depth.row(y); });
}

}  // namespace aoscan
