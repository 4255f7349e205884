// Tests for src/io/png_read.cpp beyond what tests/capture/png_depth_test.cpp covers through
// read_depth_png: inputs found by fuzz/png_fuzz, and the common path (libdeflate and the
// unfiltering here) against libpng.
#include "io/png_read.h"

#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <png.h>

#include "support/scratch_dir.h"

namespace aoscan {
namespace {

// Found by fuzz/png_fuzz: 69 bytes (a 2x2 grey PNG whose third chunk, zTXt, claims 1869573999
// bytes) made libpng allocate and clear 1.8 GB before it failed as truncated (50 s under ASan).
// Every chunk's length is now checked against the file before libpng sees it: the process's peak
// memory does not grow by the claimed size.
TEST(PngRead, ChunkLongerThanTheFileIsTruncatedWithoutAllocatingIt) {
  testing::ScratchDir dir;
  const std::string bytes(
      "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x02\x00\x00"
      "\x00\x02\x08\x00\x00\x00\x00\x57\xdd\x52\xf8\x00\x00\x00\x0e\x73\x42\x49\x54\x78\xda\x63"
      "\x10\x50\xc4\x8b\x00\x00\x00\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x6f\x7a\x54\x58"
      "\x74\x6f\x6f",
      69);
  const std::string path = dir.file("ztxt.png");
  testing::write_text(path, bytes);
  Image<std::uint16_t> out;
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  const Status s = read_grey16_png(path, out, 3);
  getrusage(RUSAGE_SELF, &after);
  EXPECT_EQ(s.code(), Status::Code::kCorruptFrame);
  EXPECT_EQ(s.message(), path + " (frame 3): truncated PNG");
  EXPECT_LT(after.ru_maxrss - before.ru_maxrss, 100 * 1024);  // KiB: far below the 1.8 GB claim
}

/// Options of a PNG written by libpng for the tests below.
struct PngOptions {
  int filters = PNG_ALL_FILTERS;  ///< PNG_FILTER_NONE ... PNG_ALL_FILTERS
  bool interlaced = false;
  std::size_t idat_bytes = 8192;  ///< the compression buffer: the size of each IDAT chunk
  bool text_chunks = false;       ///< a tEXt chunk before the image data and one after
  int bit_depth = 16;
};

/// Writes `pixels` (w x h, row-major) as a grey PNG with libpng.
void write_png(const std::string& path, int w, int h, const std::vector<std::uint16_t>& pixels,
               const PngOptions& o) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, file);
  png_set_compression_buffer_size(png, o.idat_bytes);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, o.filters);
  png_set_IHDR(png, info, w, h, o.bit_depth, PNG_COLOR_TYPE_GRAY,
               o.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_BASE,
               PNG_FILTER_TYPE_BASE);
  png_text before{};
  char key[] = "Comment", text[] = "before the image data";
  before.compression = PNG_TEXT_COMPRESSION_NONE;
  before.key = key;
  before.text = text;
  if (o.text_chunks) png_set_text(png, info, &before, 1);
  png_write_info(png, info);
  std::vector<png_byte> bytes(static_cast<std::size_t>(w) * 2);
  const int passes = png_set_interlace_handling(png);
  for (int pass = 0; pass < passes; ++pass)
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const std::uint16_t v = pixels[static_cast<std::size_t>(y) * w + x];
        if (o.bit_depth == 16) {
          bytes[2 * x] = static_cast<png_byte>(v >> 8);
          bytes[2 * x + 1] = static_cast<png_byte>(v & 0xFF);
        } else {
          bytes[x] = static_cast<png_byte>(v & 0xFF);
        }
      }
      png_write_row(png, bytes.data());
    }
  char text_after[] = "after the image data";
  png_text after = before;
  after.text = text_after;
  if (o.text_chunks) png_set_text(png, info, &after, 1);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  std::fclose(file);
}

/// Depth-like pixels: smooth slopes with steps, holes (0) and noise, over the whole 16-bit range
/// where `full_range` (so that every byte of a sample varies).
std::vector<std::uint16_t> test_pixels(int w, int h, unsigned seed, bool full_range) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-3, 3), any(0, 65535), hole(0, 30);
  std::vector<std::uint16_t> p(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int v = 800 + 5 * x + 3 * y + (x > w / 2 ? 700 : 0) + noise(rng);
      if (full_range) v = (x + y) % 7 == 0 ? any(rng) : v * 13;
      if (hole(rng) == 0) v = 0;
      p[static_cast<std::size_t>(y) * w + x] = static_cast<std::uint16_t>(v & 0xFFFF);
    }
  return p;
}

std::vector<unsigned char> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The pixels libpng decodes and the common path's, and whether the common path took the file.
void expect_both_paths_agree(const std::string& path, bool common_expected) {
  Image<std::uint16_t> by_libpng, by_common, by_reader;
  ASSERT_TRUE(detail::read_grey16_png_libpng(path, by_libpng).is_ok()) << path;
  EXPECT_EQ(detail::decode_grey16_png_common(file_bytes(path), by_common), common_expected) << path;
  ASSERT_TRUE(read_grey16_png(path, by_reader).is_ok()) << path;
  ASSERT_EQ(by_reader.width(), by_libpng.width());
  ASSERT_EQ(by_reader.height(), by_libpng.height());
  for (int y = 0; y < by_libpng.height(); ++y)
    for (int x = 0; x < by_libpng.width(); ++x) {
      ASSERT_EQ(by_reader(x, y), by_libpng(x, y)) << path << " at " << x << "," << y;
      if (common_expected) {
        ASSERT_EQ(by_common(x, y), by_libpng(x, y)) << path;
      }
    }
}

TEST(PngRead, TheCommonPathDecodesEveryFilterAsLibpngDoes) {
  testing::ScratchDir dir;
  const int filters[] = {PNG_FILTER_NONE, PNG_FILTER_SUB,   PNG_FILTER_UP,
                         PNG_FILTER_AVG,  PNG_FILTER_PAETH, PNG_ALL_FILTERS};
  // Heights and widths around the Paeth rows that the common path unfilters together (up to
  // four, each one pixel behind the one above): runs of 2, 3 and 4 rows, rows narrower than that.
  const int sizes[][2] = {{1, 1}, {1, 7}, {2, 2}, {3, 6}, {4, 5}, {5, 3}, {33, 17}, {640, 48}};
  int files = 0;
  for (const int filter : filters)
    for (const auto& size : sizes)
      for (const bool full_range : {false, true}) {
        const std::string path = dir.file("f" + std::to_string(files++) + ".png");
        PngOptions o;
        o.filters = filter;
        o.idat_bytes = files % 2 == 0 ? 8192 : 97;  // one IDAT chunk or many
        o.text_chunks = files % 3 == 0;
        write_png(path, size[0], size[1], test_pixels(size[0], size[1], files, full_range), o);
        expect_both_paths_agree(path, true);
      }
}

TEST(PngRead, WhatTheCommonPathDoesNotTakeLibpngDecodes) {
  testing::ScratchDir dir;
  const std::string interlaced = dir.file("interlaced.png");
  PngOptions o;
  o.interlaced = true;
  write_png(interlaced, 37, 21, test_pixels(37, 21, 1, true), o);
  expect_both_paths_agree(interlaced, false);
}

/// A copy of the PNG at `path` with byte `offset` changed, at `name`.
std::string with_byte_changed(const testing::ScratchDir& dir, const std::string& path,
                              std::size_t offset, const std::string& name) {
  std::vector<unsigned char> bytes = file_bytes(path);
  EXPECT_LT(offset, bytes.size());
  bytes[offset] ^= 0x5A;
  const std::string out = dir.file(name);
  testing::write_text(out, std::string(bytes.begin(), bytes.end()));
  return out;
}

TEST(PngRead, BrokenFilesFailWithLibpngsMessages) {
  testing::ScratchDir dir;
  const std::string good = dir.file("good.png");
  PngOptions o;
  o.idat_bytes = 200;
  write_png(good, 40, 30, test_pixels(40, 30, 5, false), o);
  const std::vector<unsigned char> bytes = file_bytes(good);
  // The first IDAT chunk: a byte of its data (CRC wrong), and the same with the CRC fixed (the
  // zlib stream broken: libdeflate fails, libpng words it).
  std::size_t idat = 8;
  while (std::string(bytes.begin() + idat + 4, bytes.begin() + idat + 8) != "IDAT")
    idat += 12 + ((bytes[idat] << 24) | (bytes[idat + 1] << 16) | (bytes[idat + 2] << 8) |
                  bytes[idat + 3]);
  const std::vector<std::string> broken = {
      with_byte_changed(dir, good, 17, "ihdr_crc.png"),  // IHDR width
      with_byte_changed(dir, good, idat + 20, "idat_crc.png"),
      with_byte_changed(dir, good, bytes.size() - 2, "iend_crc.png"),
  };
  for (const std::string& path : broken) {
    Image<std::uint16_t> a, b;
    const Status by_reader = read_grey16_png(path, a, 4);
    const Status by_libpng = detail::read_grey16_png_libpng(path, b, 4);
    EXPECT_FALSE(detail::decode_grey16_png_common(file_bytes(path), a)) << path;
    EXPECT_EQ(by_reader.code(), by_libpng.code()) << path;
    EXPECT_EQ(by_reader.message(), by_libpng.message()) << path;
    EXPECT_FALSE(by_reader.is_ok()) << path;
  }
  // An 8-bit grey PNG is libpng's to reject, with its message.
  const std::string eight = dir.file("eight.png");
  o.bit_depth = 8;
  write_png(eight, 4, 4, test_pixels(4, 4, 2, false), o);
  Image<std::uint16_t> image;
  EXPECT_FALSE(detail::decode_grey16_png_common(file_bytes(eight), image));
  EXPECT_EQ(read_grey16_png(eight, image).message(),
            eight + ": 8-bit grey PNG, expected 16-bit grey depth");
}

TEST(PngRead, TheCommonPathDecodesTheRealRecordingAsLibpngDoes) {
  const std::string folder = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen/depth";
  if (!std::filesystem::is_directory(folder))
    GTEST_SKIP() << "the shared recording is absent: " << folder;
  for (int i = 0; i < 500; i += 25) {
    char name[64];
    std::snprintf(name, sizeof name, "/frame-%06d.png", i);
    expect_both_paths_agree(folder + name, true);
  }
}

}  // namespace
}  // namespace aoscan
