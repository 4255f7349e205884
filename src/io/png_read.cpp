/// @file png_read.cpp
/// @brief Decoding of 16-bit grey PNGs: the common case (one run of IDAT chunks, no interlacing)
/// inflated by libdeflate and unfiltered here, everything else (and every error message) by
/// libpng, with setjmp/longjmp error handling kept inside a small function that owns no C++
/// objects.
#include "io/png_read.h"

#include <algorithm>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <type_traits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <libdeflate.h>
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

/// A big-endian 32-bit number (PNG's chunk lengths, sizes and CRCs).
std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

/// Walks the chunks after the signature up to IEND; false when a chunk's length runs past the end
/// of the file. libpng allocates (and clears) a chunk's buffer from that length before it reads
/// the data, so a 69-byte file claiming a 1.8 GB zTXt chunk would cost 1.8 GB before failing as
/// truncated.
bool chunks_fit(const std::vector<unsigned char>& bytes) {
  std::size_t pos = 8;
  while (bytes.size() - pos >= 8) {
    const std::uint64_t length = be32(bytes.data() + pos);
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

/// The CRC of a chunk (over its type and data) equals the one stored after it.
bool chunk_crc_ok(const unsigned char* chunk, std::uint32_t length) {
  return libdeflate_crc32(0, chunk + 4, std::size_t{length} + 4) == be32(chunk + 8 + length);
}

bool is_letter(unsigned char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}

/// Where a row's Paeth unfiltering stands: the left and upper-left byte of each of a pixel's two
/// bytes, which are two independent chains along the row.
struct PaethChains {
  int a[2] = {0, 0};
  int c[2] = {0, 0};
};

/// Undoes the Paeth filter of the 16-bit pixel at byte `i` of `row` in place, `up` the unfiltered
/// row above.
inline void unpaeth_pixel(unsigned char* row, const unsigned char* up, std::size_t i,
                          PaethChains& s) {
  for (int k = 0; k < 2; ++k) {
    const int b = up[i + k];
    const int pa = std::abs(b - s.c[k]), pb = std::abs(s.a[k] - s.c[k]),
              pc = std::abs(s.a[k] + b - 2 * s.c[k]);
    const int predictor = (pa <= pb && pa <= pc) ? s.a[k] : (pb <= pc ? b : s.c[k]);
    s.a[k] = (row[i + k] + predictor) & 0xFF;
    row[i + k] = static_cast<unsigned char>(s.a[k]);
    s.c[k] = b;
  }
}

#if defined(__SSE2__)
/// Most rows RedKitchen's depth PNGs hold are Paeth rows: up to this many consecutive ones are
/// unfiltered together.
constexpr int kPaethRows = 4;

/// Undoes the Paeth filter of `n` (2 to kPaethRows) consecutive rows (`first`, the next one
/// `stride` bytes further, ...) in place, `prev` the unfiltered row above the first: the same
/// bytes as unfilter_row() on each row in turn. A row's Paeth bytes form two chains along it
/// (a pixel's high and low byte), each waiting on its own last result; here the rows go along
/// together, each one pixel behind the row above it, so that a step's 2 n chains are the lanes of
/// one vector: lane (j, k) holds byte k of row j's pixel x - j at step x. Its pixel above is what
/// lane (j - 1, k) found at the step before (a shift of the lanes; the first row reads `prev`),
/// its upper-left the pixel above of the step before. A lane before its row's first pixel keeps
/// zeros (left and upper-left of a row's first pixel are 0), one past its row's end is neither
/// read nor written.
void unpaeth_rows(unsigned char* first, std::size_t stride, int n, const unsigned char* prev,
                  std::size_t bytes) {
  const long w = static_cast<long>(bytes / 2);
  const __m128i zero = _mm_setzero_si128(), low_byte = _mm_set1_epi16(0xFF);
  const auto abs16 = [&](__m128i v) { return _mm_max_epi16(v, _mm_sub_epi16(zero, v)); };
  const auto select = [](__m128i mask, __m128i if_set, __m128i if_clear) {
    return _mm_or_si128(_mm_and_si128(mask, if_set), _mm_andnot_si128(mask, if_clear));
  };
  const auto pair = [](const unsigned char* p) { return p[0] | (p[1] << 8); };
  __m128i a = zero, above_before = zero;  // per lane: the left byte; the pixel above last step
  // One step; `edge`: some row has no pixel x - j (the first and last n - 1 steps).
  const auto step = [&](long x, auto edge) {
    const auto has_pixel = [&](int j) {
      return !decltype(edge)::value || (x - j >= 0 && x - j < w);
    };
    __m128i raw = zero, above_first = zero;  // eight bytes in the low half, widened below
    if (has_pixel(0)) above_first = _mm_insert_epi16(zero, pair(prev + 2 * x), 0);
    const auto in = [&](int j) {
      return pair(first + static_cast<std::size_t>(j) * stride + 2 * (x - j));
    };
    if (has_pixel(0)) raw = _mm_insert_epi16(raw, in(0), 0);
    if (has_pixel(1)) raw = _mm_insert_epi16(raw, in(1), 1);
    if (n > 2 && has_pixel(2)) raw = _mm_insert_epi16(raw, in(2), 2);
    if (n > 3 && has_pixel(3)) raw = _mm_insert_epi16(raw, in(3), 3);
    raw = _mm_unpacklo_epi8(raw, zero);
    const __m128i b = _mm_or_si128(_mm_slli_si128(a, 4), _mm_unpacklo_epi8(above_first, zero));
    const __m128i c = above_before;
    const __m128i bc = _mm_sub_epi16(b, c), ac = _mm_sub_epi16(a, c);
    const __m128i pa = abs16(bc), pb = abs16(ac), pc = abs16(_mm_add_epi16(bc, ac));
    const __m128i not_a = _mm_or_si128(_mm_cmpgt_epi16(pa, pb), _mm_cmpgt_epi16(pa, pc));
    const __m128i predictor = select(not_a, select(_mm_cmpgt_epi16(pb, pc), c, b), a);
    a = _mm_and_si128(_mm_add_epi16(raw, predictor), low_byte);
    above_before = b;
    const __m128i bytes8 = _mm_packus_epi16(a, a);
    const auto out = [&](int j, int v) {
      unsigned char* o = first + static_cast<std::size_t>(j) * stride + 2 * (x - j);
      o[0] = static_cast<unsigned char>(v & 0xFF);
      o[1] = static_cast<unsigned char>(v >> 8);
    };
    if (has_pixel(0)) out(0, _mm_extract_epi16(bytes8, 0));
    if (has_pixel(1)) out(1, _mm_extract_epi16(bytes8, 1));
    if (n > 2 && has_pixel(2)) out(2, _mm_extract_epi16(bytes8, 2));
    if (n > 3 && has_pixel(3)) out(3, _mm_extract_epi16(bytes8, 3));
  };
  const long inner_end = std::max<long>(n - 1, w);
  long x = 0;
  for (; x < n - 1; ++x) step(x, std::true_type{});
  for (; x < inner_end; ++x) step(x, std::false_type{});
  for (; x < w + n - 1; ++x) step(x, std::true_type{});
}
#endif

/// Undoes the PNG filter of one row of 16-bit grey pixels (2 bytes a pixel) in place; `prev` is
/// the unfiltered row above (zeros for the first row). False for an unknown filter type.
bool unfilter_row(int type, unsigned char* row, const unsigned char* prev, std::size_t bytes) {
  switch (type) {
    case 0:
      return true;
    case 1: {  // Sub: a running sum of the pixels, bytewise
      std::size_t i = 2;
#if defined(__SSE2__)
      // Eight pixels at a time: their prefix sum in three shifted adds, plus the last pixel
      // before them in every lane.
      __m128i carry = _mm_setzero_si128();
      for (i = 0; i + 16 <= bytes; i += 16) {
        __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + i));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 2));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 4));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 8));
        v = _mm_add_epi8(v, carry);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(row + i), v);
        carry = _mm_shuffle_epi32(_mm_shufflehi_epi16(v, 0xFF), 0xFF);
      }
      i = std::max<std::size_t>(i, 2);
#endif
      for (; i < bytes; ++i) row[i] = static_cast<unsigned char>(row[i] + row[i - 2]);
      return true;
    }
    case 2: {  // Up
      std::size_t i = 0;
#if defined(__SSE2__)
      for (; i + 16 <= bytes; i += 16)
        _mm_storeu_si128(reinterpret_cast<__m128i*>(row + i),
                         _mm_add_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(row + i)),
                                      _mm_loadu_si128(reinterpret_cast<const __m128i*>(prev + i))));
#endif
      for (; i < bytes; ++i) row[i] = static_cast<unsigned char>(row[i] + prev[i]);
      return true;
    }
    case 3:  // Average
      for (std::size_t i = 0; i < bytes; ++i) {
        const unsigned left = i >= 2 ? row[i - 2] : 0u;
        row[i] = static_cast<unsigned char>(row[i] + ((left + prev[i]) >> 1));
      }
      return true;
    case 4: {  // Paeth
      PaethChains chains;
      for (std::size_t i = 0; i < bytes; i += 2) unpaeth_pixel(row, prev, i, chains);
      return true;
    }
    default:
      return false;
  }
}

struct FreeDecompressor {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

}  // namespace

namespace detail {

bool decode_grey16_png_common(const std::vector<unsigned char>& bytes, Image<std::uint16_t>& out) {
  thread_local std::vector<unsigned char> stream, rows;
  thread_local std::unique_ptr<libdeflate_decompressor, FreeDecompressor> inflater;
  const std::size_t size = bytes.size();
  const unsigned char* data = bytes.data();
  // The signature and IHDR first: 16-bit grey, deflate, standard filters, not interlaced.
  constexpr std::size_t kIhdrEnd = 8 + 8 + 13 + 4;
  if (size < kIhdrEnd || std::memcmp(data, "\x89PNG\r\n\x1a\n", 8) != 0 || be32(data + 8) != 13 ||
      std::memcmp(data + 12, "IHDR", 4) != 0 || !chunk_crc_ok(data + 8, 13))
    return false;
  const std::uint32_t width = be32(data + 16), height = be32(data + 20);
  if (width == 0 || height == 0 || width > kMaxSide || height > kMaxSide || data[24] != 16 ||
      data[25] != 0 || data[26] != 0 || data[27] != 0 || data[28] != 0)
    return false;
  const std::size_t row_bytes = 2 * std::size_t{width};
  const std::size_t raw_bytes = std::size_t{height} * (row_bytes + 1);
  if (static_cast<double>(raw_bytes) > 1100.0 * static_cast<double>(size)) return false;
  // The chunks up to IEND: one run of IDAT chunks (their CRCs right), letters for names, no other
  // critical chunk, none longer than libpng's default limit for a chunk (larger ones it may
  // refuse).
  constexpr std::uint32_t kChunkLimit = 8000000;
  const unsigned char* single = nullptr;  // the IDAT data when there is one IDAT chunk
  std::size_t single_length = 0, idat_chunks = 0;
  stream.clear();
  enum { kBefore, kInside, kAfter } idat = kBefore;
  for (std::size_t pos = kIhdrEnd;;) {
    if (size - pos < 12) return false;
    const std::uint32_t length = be32(data + pos);
    if (length > size - pos - 12) return false;
    const unsigned char* type = data + pos + 4;
    if (!is_letter(type[0]) || !is_letter(type[1]) || !is_letter(type[2]) || !is_letter(type[3]))
      return false;
    if (std::memcmp(type, "IDAT", 4) == 0) {
      if (idat == kAfter || length > kChunkLimit || !chunk_crc_ok(data + pos, length)) return false;
      idat = kInside;
      if (++idat_chunks == 1) {
        single = data + pos + 8;
        single_length = length;
      } else {
        if (idat_chunks == 2) stream.assign(single, single + single_length);
        stream.insert(stream.end(), data + pos + 8, data + pos + 8 + length);
      }
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      if (idat == kBefore || length != 0 || !chunk_crc_ok(data + pos, 0)) return false;
      break;
    } else if (type[0] >= 'A' && type[0] <= 'Z') {
      return false;  // PLTE, a second IHDR or an unknown critical chunk: libpng's to judge
    } else {
      if (length > kChunkLimit) return false;
      if (idat == kInside) idat = kAfter;
    }
    pos += 12 + std::size_t{length};
  }
  const unsigned char* in = idat_chunks == 1 ? single : stream.data();
  const std::size_t in_length = idat_chunks == 1 ? single_length : stream.size();
  // The zlib stream must end exactly where the rows and the IDAT data end.
  if (!inflater) {
    inflater.reset(libdeflate_alloc_decompressor());
    if (!inflater) return false;
  }
  if (rows.size() < raw_bytes) rows.resize(raw_bytes);
  std::size_t used_in = 0, written = 0;
  if (libdeflate_zlib_decompress_ex(inflater.get(), in, in_length, rows.data(), raw_bytes, &used_in,
                                    &written) != LIBDEFLATE_SUCCESS ||
      used_in != in_length || written != raw_bytes)
    return false;
  const int w = static_cast<int>(width), h = static_cast<int>(height);
  if (out.width() != w || out.height() != h) out.resize(w, h);
  thread_local std::vector<unsigned char> zeros;
  if (zeros.size() < row_bytes) zeros.assign(row_bytes, 0);
  const unsigned char* prev = zeros.data();
  const std::size_t stride = row_bytes + 1;
  const auto row_at = [&](int y) { return rows.data() + static_cast<std::size_t>(y) * stride; };
  for (int y = 0; y < h;) {
    int done = 1;
#if defined(__SSE2__)
    while (done < kPaethRows && y + done < h && row_at(y)[0] == 4 && row_at(y + done)[0] == 4)
      ++done;
    if (done > 1) unpaeth_rows(row_at(y) + 1, stride, done, prev, row_bytes);
#endif
    if (done == 1 && !unfilter_row(row_at(y)[0], row_at(y) + 1, prev, row_bytes)) return false;
    for (int j = 0; j < done; ++j, ++y) {
      const unsigned char* row = row_at(y);
      std::uint16_t* dst = out.row(y);
      for (int x = 0; x < w; ++x)  // big-endian samples
        dst[x] = static_cast<std::uint16_t>((row[1 + 2 * x] << 8) | row[2 + 2 * x]);
      prev = row + 1;
    }
  }
  return true;
}

}  // namespace detail

namespace {

/// read_grey16_png(), through the common path first when `common` is set.
Status read_png(const std::string& path, Image<std::uint16_t>& out,
                std::optional<std::uint64_t> frame_index, bool common) {
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
    if (common && detail::decode_grey16_png_common(bytes, out)) return Status::ok();
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

}  // namespace

Status read_grey16_png(const std::string& path, Image<std::uint16_t>& out,
                       std::optional<std::uint64_t> frame_index) {
  return read_png(path, out, frame_index, true);
}

Status detail::read_grey16_png_libpng(const std::string& path, Image<std::uint16_t>& out,
                                      std::optional<std::uint64_t> frame_index) {
  return read_png(path, out, frame_index, false);
}

}  // namespace aoscan
