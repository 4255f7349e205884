/// @file png_read.cpp
/// @brief libpng decoding of 16-bit grey PNGs, with setjmp/longjmp error handling kept inside a
/// small function that owns no C++ objects.
#include "io/png_read.h"

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include <png.h>

namespace aoscan {
namespace {

/// Largest accepted image side; larger headers are treated as corrupt rather than allocated.
constexpr png_uint_32 kMaxSide = 1 << 15;

bool host_is_little_endian() {
  const std::uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// Everything the decoder's callbacks touch; plain data so that longjmp skips no destructor.
struct DecodeState {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  std::size_t pos = 0;
  bool truncated = false;
  char message[200] = {};
};

void on_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<DecodeState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

void read_from_memory(png_structp png, png_bytep out, png_size_t length) {
  auto* state = static_cast<DecodeState*>(png_get_io_ptr(png));
  if (length > state->size - state->pos) {
    state->truncated = true;
    png_error(png, "truncated PNG");
  }
  std::memcpy(out, state->data + state->pos, length);
  state->pos += length;
}

enum class DecodeResult { kOk, kFailed, kNotGrey16 };

/// Header facts reported when the PNG is not 16-bit grey.
struct Header {
  int bit_depth = 0;
  int color_type = 0;
};

/// The setjmp-protected decode. Only plain locals live here; `out` and `rows` are resized before
/// libpng calls that may longjmp, never during them.
DecodeResult decode(DecodeState& state, Header& header, Image<std::uint16_t>& out,
                    std::vector<png_bytep>& rows) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, on_error, on_warning);
  if (!png) {
    std::snprintf(state.message, sizeof state.message, "out of memory");
    return DecodeResult::kFailed;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(state.message, sizeof state.message, "out of memory");
    return DecodeResult::kFailed;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return DecodeResult::kFailed;
  }
  png_set_read_fn(png, &state, read_from_memory);
  png_set_user_limits(png, kMaxSide, kMaxSide);
  png_read_info(png, info);
  header.bit_depth = png_get_bit_depth(png, info);
  header.color_type = png_get_color_type(png, info);
  if (header.bit_depth != 16 || header.color_type != PNG_COLOR_TYPE_GRAY) {
    png_destroy_read_struct(&png, &info, nullptr);
    return DecodeResult::kNotGrey16;
  }
  // zlib cannot expand data more than about 1032:1, so a header promising far more pixels than
  // the file can hold is corrupt; rejecting it here avoids allocating for it.
  const double raw_bytes = static_cast<double>(png_get_image_height(png, info)) *
                           (2.0 * png_get_image_width(png, info) + 1.0);
  if (raw_bytes > 1100.0 * static_cast<double>(state.size)) {
    std::snprintf(state.message, sizeof state.message, "%ux%u pixels cannot fit in %zu bytes",
                  png_get_image_width(png, info), png_get_image_height(png, info), state.size);
    png_destroy_read_struct(&png, &info, nullptr);
    return DecodeResult::kFailed;
  }
  if (host_is_little_endian()) png_set_swap(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const int width = static_cast<int>(png_get_image_width(png, info));
  const int height = static_cast<int>(png_get_image_height(png, info));
  if (out.width() != width || out.height() != height) out.resize(width, height);  // else no fill
  rows.resize(static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) rows[y] = reinterpret_cast<png_bytep>(out.row(y));
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return DecodeResult::kOk;
}

const char* colour_name(int color_type) {
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY:
      return "grey";
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      return "grey+alpha";
    case PNG_COLOR_TYPE_RGB:
      return "RGB";
    case PNG_COLOR_TYPE_RGB_ALPHA:
      return "RGBA";
    case PNG_COLOR_TYPE_PALETTE:
      return "palette";
    default:
      return "unknown colour type";
  }
}

/// Walks the chunks after the signature up to IEND; false when a chunk's length runs past the end
/// of the file. libpng allocates (and clears) a chunk's buffer from that length before it reads
/// the data, so a 69-byte file claiming a 1.8 GB zTXt chunk would cost 1.8 GB before failing as
/// truncated.
bool chunks_fit(const std::vector<unsigned char>& bytes) {
  std::size_t pos = 8;
  while (bytes.size() - pos >= 8) {
    const std::uint64_t length = (std::uint64_t{bytes[pos]} << 24) | (bytes[pos + 1] << 16) |
                                 (bytes[pos + 2] << 8) | bytes[pos + 3];
    if (length + 4 > bytes.size() - pos - 8) return false;  // the data and the CRC
    if (std::memcmp(bytes.data() + pos + 4, "IEND", 4) == 0) break;
    pos += 8 + length + 4;
  }
  return true;  // a file cut between two chunks is libpng's to report
}

/// Reads the whole file into `bytes` (reused); returns 0 or an errno value.
int read_file(const std::string& path, std::vector<unsigned char>& bytes) {
  errno = 0;
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return errno ? errno : EIO;
  bytes.clear();
  constexpr std::size_t kStep = 1 << 16;
  std::size_t used = 0;
  for (;;) {
    if (bytes.size() < used + kStep) bytes.resize(used + kStep);
    const std::size_t n = std::fread(bytes.data() + used, 1, kStep, file);
    used += n;
    if (n < kStep) break;
  }
  const int error = std::ferror(file) ? (errno ? errno : EIO) : 0;
  std::fclose(file);
  bytes.resize(used);  // never shrinks the capacity
  return error;
}

}  // namespace

Status read_grey16_png(const std::string& path, Image<std::uint16_t>& out,
                       std::optional<std::uint64_t> frame_index) {
  thread_local std::vector<unsigned char> bytes;
  thread_local std::vector<png_bytep> rows;
  auto fail = [&](const std::string& reason) {
    std::string label = path;
    if (frame_index) label += " (frame " + std::to_string(*frame_index) + ")";
    return Status::corrupt_frame(label + ": " + reason);
  };

  try {
    if (const int err = read_file(path, bytes); err != 0)
      return fail(err == ENOENT ? "missing file"
                                : std::string("cannot read: ") + std::strerror(err));
    if (bytes.empty()) return fail("empty file");
    if (bytes.size() < 8 || png_sig_cmp(bytes.data(), 0, 8) != 0) {
      // A prefix of the signature is a PNG cut short, anything else is not a PNG.
      const bool prefix = png_sig_cmp(bytes.data(), 0, bytes.size()) == 0;
      return fail(prefix ? "truncated PNG" : "not a PNG file");
    }
    if (!chunks_fit(bytes)) return fail("truncated PNG");
    DecodeState state;
    state.data = bytes.data();
    state.size = bytes.size();
    Header header;
    switch (decode(state, header, out, rows)) {
      case DecodeResult::kOk:
        return Status::ok();
      case DecodeResult::kNotGrey16:
        return fail(std::to_string(header.bit_depth) + "-bit " + colour_name(header.color_type) +
                    " PNG, expected 16-bit grey depth");
      case DecodeResult::kFailed:
        break;
    }
    return fail(state.truncated ? "truncated PNG" : std::string("corrupt PNG: ") + state.message);
  } catch (const std::exception& e) {  // allocation failure while sizing the image
    return fail(std::string("cannot decode: ") + e.what());
  }
}

}  // namespace aoscan
