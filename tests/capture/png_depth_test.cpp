/// @file png_depth_test.cpp
/// @brief Tests for src/capture/png_depth.h: exact round trips, PNG byte order, and every rejected
/// input (missing, not a PNG, truncated anywhere, corrupt, 8-bit, colour) as a corrupt_frame
/// status.
#include "capture/png_depth.h"

#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <png.h>
#include <zlib.h>

#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::read_bytes;
using testing::ScratchDir;
using testing::write_text;

/// Writes a PNG with libpng exactly as given: `rows` holds PNG-order (big-endian) sample bytes.
void write_raw_png(const std::string& path, int width, int height, int bit_depth, int color_type,
                   const std::vector<std::vector<unsigned char>>& rows,
                   int interlace = PNG_INTERLACE_NONE) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  ASSERT_NE(file, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, file);
  png_set_IHDR(png, info, width, height, bit_depth, color_type, interlace,
               PNG_COMPRESSION_TYPE_BASE, PNG_FILTER_TYPE_BASE);
  if (color_type == PNG_COLOR_TYPE_PALETTE) {
    png_color palette[2] = {{0, 0, 0}, {255, 255, 255}};
    png_set_PLTE(png, info, palette, 2);
  }
  png_write_info(png, info);
  std::vector<png_bytep> pointers;
  for (const auto& r : rows) pointers.push_back(const_cast<png_bytep>(r.data()));
  png_write_image(png, pointers.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  std::fclose(file);
}

Image<std::uint16_t> random_depth(int width, int height, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, 65535);
  Image<std::uint16_t> image(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) image(x, y) = static_cast<std::uint16_t>(value(rng));
  image(0, 0) = 0;
  image(width - 1, height - 1) = 65535;
  return image;
}

/// Expects a corrupt_frame whose one-line message names `path` and contains `reason`.
void expect_corrupt(const Status& s, const std::string& path, const std::string& reason) {
  EXPECT_EQ(s.code(), Status::Code::kCorruptFrame) << s.message();
  EXPECT_EQ(s.message().rfind(path, 0), 0u) << s.message();
  EXPECT_NE(s.message().find(reason), std::string::npos) << s.message();
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
}

TEST(PngDepth, RoundTripIsExactAndReusesTheImage) {
  ScratchDir dir;
  const Image<std::uint16_t> a = random_depth(37, 23, 1);
  const Image<std::uint16_t> b = random_depth(640, 480, 2);
  write_depth_png(dir.file("a.png"), a);
  write_depth_png(dir.file("b.png"), b);
  Image<std::uint16_t> out;
  ASSERT_TRUE(read_depth_png(dir.file("b.png"), out).is_ok());
  EXPECT_EQ(out, b);
  const std::uint16_t* storage = out.data();
  ASSERT_TRUE(read_depth_png(dir.file("a.png"), out).is_ok());
  EXPECT_EQ(out, a);
  EXPECT_EQ(out.data(), storage);  // the smaller image reuses the allocation
}

TEST(PngDepth, IdenticalInputGivesIdenticalBytes) {
  ScratchDir dir;
  const Image<std::uint16_t> a = random_depth(64, 48, 3);
  write_depth_png(dir.file("a.png"), a);
  write_depth_png(dir.file("b.png"), a);
  EXPECT_EQ(read_bytes(dir.file("a.png")), read_bytes(dir.file("b.png")));
}

TEST(PngDepth, SamplesAreBigEndianInTheFile) {
  ScratchDir dir;
  // 0x0102 stored big-endian as PNG requires; also interlaced (Adam7) files decode.
  std::vector<std::vector<unsigned char>> rows(3, std::vector<unsigned char>(2 * 5));
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) {
      rows[y][2 * x] = static_cast<unsigned char>(x + 1);
      rows[y][2 * x + 1] = static_cast<unsigned char>(y + 2);
    }
  for (int interlace : {PNG_INTERLACE_NONE, PNG_INTERLACE_ADAM7}) {
    write_raw_png(dir.file("be.png"), 5, 3, 16, PNG_COLOR_TYPE_GRAY, rows, interlace);
    Image<std::uint16_t> out;
    ASSERT_TRUE(read_depth_png(dir.file("be.png"), out).is_ok());
    ASSERT_EQ(out.width(), 5);
    ASSERT_EQ(out.height(), 3);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 5; ++x) EXPECT_EQ(out(x, y), ((x + 1) << 8) | (y + 2));
  }
  // And write_depth_png stores what libpng reads back without transformations.
  Image<std::uint16_t> one(1, 1, 0x0102);
  write_depth_png(dir.file("one.png"), one);
  std::FILE* file = std::fopen(dir.file("one.png").c_str(), "rb");
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, file);
  png_read_info(png, info);
  unsigned char raw[2] = {};
  png_read_row(png, raw, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  std::fclose(file);
  EXPECT_EQ(raw[0], 0x01);
  EXPECT_EQ(raw[1], 0x02);
}

TEST(PngDepth, MissingFile) {
  ScratchDir dir;
  Image<std::uint16_t> out;
  const std::string path = dir.file("none.png");
  expect_corrupt(read_depth_png(path, out), path, "missing file");
  expect_corrupt(read_depth_png(path, out, 12), path + " (frame 12)", "missing file");
  expect_corrupt(read_depth_png(dir.str(), out), dir.str(), "cannot read");  // a folder
}

TEST(PngDepth, NotAPng) {
  ScratchDir dir;
  const std::string path = dir.file("x.png");
  Image<std::uint16_t> out;
  write_text(path, "this is a text file, not an image\n");
  expect_corrupt(read_depth_png(path, out), path, "not a PNG");
  write_text(path, "");
  expect_corrupt(read_depth_png(path, out), path, "empty file");
  write_text(path, "\x89PNG");
  expect_corrupt(read_depth_png(path, out), path, "truncated");  // a cut-short signature
}

TEST(PngDepth, TruncatedAnywhere) {
  ScratchDir dir;
  write_depth_png(dir.file("full.png"), random_depth(24, 16, 4));
  const std::string full = read_bytes(dir.file("full.png"));
  const std::string path = dir.file("cut.png");
  Image<std::uint16_t> out;
  write_text(path, full.substr(0, full.size() / 2));
  expect_corrupt(read_depth_png(path, out), path, "truncated PNG");
  for (std::size_t cut = 1; cut < full.size(); cut += 7) {
    write_text(path, full.substr(0, cut));
    const Status s = read_depth_png(path, out);
    EXPECT_EQ(s.code(), Status::Code::kCorruptFrame) << "cut at " << cut;
  }
}

TEST(PngDepth, CorruptBytes) {
  ScratchDir dir;
  write_depth_png(dir.file("full.png"), random_depth(24, 16, 5));
  std::string bytes = read_bytes(dir.file("full.png"));
  const std::string path = dir.file("bad.png");
  Image<std::uint16_t> out;
  for (std::size_t at = 8; at < bytes.size(); at += 11) {
    std::string damaged = bytes;
    damaged[at] = static_cast<char>(damaged[at] ^ 0x5a);
    write_text(path, damaged);
    // Chunk CRCs catch a flipped byte anywhere (these files have no ancillary chunks).
    const Status s = read_depth_png(path, out);
    EXPECT_EQ(s.code(), Status::Code::kCorruptFrame) << "byte " << at;
  }
}

TEST(PngDepth, HeaderPromisingMorePixelsThanTheDataHolds) {
  ScratchDir dir;
  write_depth_png(dir.file("small.png"), Image<std::uint16_t>(4, 4, 7));
  std::string bytes = read_bytes(dir.file("small.png"));
  // IHDR width/height (bytes 16-23) set to 30000 x 30000, with the chunk's CRC (bytes 29-32) fixed.
  for (int k : {16, 20}) {
    bytes[k] = 0, bytes[k + 1] = 0, bytes[k + 2] = 0x75, bytes[k + 3] = 0x30;
  }
  const auto crc =
      static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(bytes.data() + 12), 17));
  for (int k = 0; k < 4; ++k) bytes[29 + k] = static_cast<char>(crc >> (24 - 8 * k));
  const std::string path = dir.file("huge.png");
  write_text(path, bytes);
  Image<std::uint16_t> out;
  expect_corrupt(read_depth_png(path, out), path, "30000x30000 pixels cannot fit in");
  EXPECT_LE(out.size(), 16u);  // nothing allocated for the claimed size
}

TEST(PngDepth, EightBitGrey) {
  ScratchDir dir;
  const std::string path = dir.file("g8.png");
  write_raw_png(path, 4, 2, 8, PNG_COLOR_TYPE_GRAY, {{1, 2, 3, 4}, {5, 6, 7, 8}});
  Image<std::uint16_t> out;
  expect_corrupt(read_depth_png(path, out), path, "8-bit grey PNG");
}

TEST(PngDepth, ColourPngs) {
  ScratchDir dir;
  Image<std::uint16_t> out;
  const std::string rgb16 = dir.file("rgb16.png");
  write_raw_png(rgb16, 1, 1, 16, PNG_COLOR_TYPE_RGB, {{0, 1, 0, 2, 0, 3}});
  expect_corrupt(read_depth_png(rgb16, out), rgb16, "16-bit RGB PNG");
  const std::string rgb8 = dir.file("rgb8.png");
  write_raw_png(rgb8, 2, 1, 8, PNG_COLOR_TYPE_RGB, {{1, 2, 3, 4, 5, 6}});
  expect_corrupt(read_depth_png(rgb8, out), rgb8, "8-bit RGB PNG");
  const std::string rgba = dir.file("rgba.png");
  write_raw_png(rgba, 1, 1, 8, PNG_COLOR_TYPE_RGB_ALPHA, {{1, 2, 3, 4}});
  expect_corrupt(read_depth_png(rgba, out), rgba, "RGBA");
  const std::string grey_alpha = dir.file("ga.png");
  write_raw_png(grey_alpha, 1, 1, 16, PNG_COLOR_TYPE_GRAY_ALPHA, {{0, 1, 0, 2}});
  expect_corrupt(read_depth_png(grey_alpha, out), grey_alpha, "grey+alpha");
  const std::string palette = dir.file("pal.png");
  write_raw_png(palette, 2, 1, 8, PNG_COLOR_TYPE_PALETTE, {{0, 1}});
  expect_corrupt(read_depth_png(palette, out), palette, "palette");
}

TEST(PngDepth, WriteErrors) {
  ScratchDir dir;
  EXPECT_THROW(write_depth_png(dir.file("empty.png"), Image<std::uint16_t>()), Error);
  try {
    write_depth_png(dir.file("no/such/dir/x.png"), Image<std::uint16_t>(2, 2));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no/such/dir/x.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace aoscan
