/// @file png_write.cpp
/// @brief libpng encoder behind write_png().
#include "io/png_write.h"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "core/status.h"

namespace aoscan {
namespace {

/// A fast zlib level, and the "up" filter, which suits smooth depth and is the cheapest filter to
/// undo when a recording is read back.
constexpr int kCompressionLevel = 2;
constexpr int kFilters = PNG_FILTER_UP;

struct EncodeState {
  char message[200] = {};
};

void on_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<EncodeState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

bool host_is_little_endian() {
  const std::uint16_t probe = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

/// The setjmp-protected encode into an open file; only plain locals live here. False with
/// state.message on failure.
bool encode(EncodeState& state, std::FILE* file, int width, int height, PngFormat format,
            const std::function<const void*(int)>& row) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state, on_error, on_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_compression_level(png, kCompressionLevel);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, kFilters);
  const bool grey16 = format == PngFormat::kGrey16;
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               grey16 ? 16 : 8, grey16 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  png_write_info(png, info);
  if (grey16 && host_is_little_endian()) png_set_swap(png);
  // libpng copies each row before its transformations, so the caller's rows are never modified.
  for (int y = 0; y < height; ++y) png_write_row(png, static_cast<png_const_bytep>(row(y)));
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void write_png(const std::string& path, int width, int height, PngFormat format,
               const std::function<const void*(int y)>& row) {
  if (width <= 0 || height <= 0) throw usage_error(path + ": refusing to write an empty image");
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw Error(ExitCode::kFailure, path + ": cannot write: " + std::strerror(errno));
  EncodeState state;
  const bool encoded = encode(state, file, width, height, format, row);
  const bool stream_failed = std::ferror(file) != 0;
  const int saved_errno = errno;
  const bool closed = std::fclose(file) == 0;
  if (!encoded || stream_failed || !closed) {
    const std::string why = !encoded && state.message[0]
                                ? state.message
                                : std::strerror(saved_errno ? saved_errno : EIO);
    throw Error(ExitCode::kFailure, path + ": cannot write PNG: " + why);
  }
}

}  // namespace aoscan
