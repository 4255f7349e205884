/// @file colour_image_test.cpp
/// @brief Tests for src/io/colour_image.h: every pixel layout read as exact 8-bit RGB, JPEG within
/// its loss, the PNG round trip, and every unreadable file as a one-line corrupt_frame.
#include "io/colour_image.h"

#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// Pixel (x, y) of the test images: every channel differs and varies across the image.
Rgb8 pattern(int x, int y) {
  return {static_cast<std::uint8_t>(10 * x + y), static_cast<std::uint8_t>(200 - 7 * y),
          static_cast<std::uint8_t>(3 * x * y)};
}

constexpr int kWidth = 11, kHeight = 7;

/// The pattern as an OpenCV image of `type` (BGR order; grey = the red channel).
cv::Mat pattern_mat(int type) {
  cv::Mat m(kHeight, kWidth, type);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const Rgb8 p = pattern(x, y);
      switch (type) {
        case CV_8UC1: m.at<std::uint8_t>(y, x) = p.r; break;
        case CV_8UC3: m.at<cv::Vec3b>(y, x) = {p.b, p.g, p.r}; break;
        case CV_8UC4: m.at<cv::Vec4b>(y, x) = {p.b, p.g, p.r, 77}; break;
        case CV_16UC3:
          m.at<cv::Vec3w>(y, x) = {static_cast<std::uint16_t>(257 * p.b),
                                   static_cast<std::uint16_t>(257 * p.g + 100),
                                   static_cast<std::uint16_t>(257 * p.r - (p.r > 0 ? 100 : 0))};
          break;
        case CV_16UC1: m.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(257 * p.r); break;
        default: ADD_FAILURE() << "type " << type;
      }
    }
  return m;
}

TEST(ColourImage, EveryLayoutReadsAsExactRgb) {
  ScratchDir dir;
  struct Case {
    int type;
    bool grey;
  };
  for (const Case c : {Case{CV_8UC3, false}, Case{CV_8UC4, false}, Case{CV_8UC1, true},
                       Case{CV_16UC3, false}, Case{CV_16UC1, true}}) {
    const std::string path = dir.file("image_" + std::to_string(c.type) + ".png");
    ASSERT_TRUE(cv::imwrite(path, pattern_mat(c.type)));
    Image<Rgb8> out;
    const Status s = read_colour_image(path, out);
    ASSERT_TRUE(s.is_ok()) << s.message();
    ASSERT_EQ(out.width(), kWidth);
    ASSERT_EQ(out.height(), kHeight);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const Rgb8 p = pattern(x, y);
        // 16-bit values within 100 of 257 * v round to v.
        ASSERT_EQ(out(x, y), (c.grey ? Rgb8{p.r, p.r, p.r} : p)) << "type " << c.type;
      }
  }
}

TEST(ColourImage, JpegWithinItsLoss) {
  ScratchDir dir;
  const std::string path = dir.file("flat.jpg");
  // A flat colour: JPEG keeps it within a level or two.
  ASSERT_TRUE(cv::imwrite(path, cv::Mat(16, 24, CV_8UC3, cv::Scalar(40, 120, 200)),
                          {cv::IMWRITE_JPEG_QUALITY, 95}));
  Image<Rgb8> out;
  ASSERT_TRUE(read_colour_image(path, out).is_ok());
  ASSERT_EQ(out.width(), 24);
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_NEAR(out.data()[i].r, 200, 2);
    EXPECT_NEAR(out.data()[i].g, 120, 2);
    EXPECT_NEAR(out.data()[i].b, 40, 2);
  }
}

TEST(ColourImage, EncodedJpegDecodesWithinItsLossAndKeepsRgbOrder) {
  // Two flat halves (red-ish left, blue-ish right): a swap of R and B would be 160 levels off.
  Image<Rgb8> image(32, 16);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) image(x, y) = x < 16 ? Rgb8{200, 120, 40} : Rgb8{30, 60, 190};
  std::vector<std::uint8_t> jpeg = {1, 2, 3};  // replaced
  encode_colour_jpeg(image, 95, jpeg);
  ASSERT_GT(jpeg.size(), 2u);
  EXPECT_EQ(jpeg[0], 0xFF);  // JPEG's start-of-image marker
  EXPECT_EQ(jpeg[1], 0xD8);
  Image<Rgb8> out;
  ASSERT_TRUE(decode_colour_image(jpeg.data(), jpeg.size(), out, "encoded").is_ok());
  ASSERT_EQ(out.width(), 32);
  ASSERT_EQ(out.height(), 16);
  for (int y = 0; y < 16; ++y)
    for (int x : {2, 5, 26, 29}) {  // away from the edge between the halves
      const Rgb8 want = image(x, y);
      EXPECT_NEAR(out(x, y).r, want.r, 4) << x << "," << y;
      EXPECT_NEAR(out(x, y).g, want.g, 4) << x << "," << y;
      EXPECT_NEAR(out(x, y).b, want.b, 4) << x << "," << y;
    }
  EXPECT_THROW(encode_colour_jpeg(Image<Rgb8>(), 90, jpeg), Error);
}

TEST(ColourImage, WrittenPngReadsBackExactly) {
  ScratchDir dir;
  Image<Rgb8> image(kWidth, kHeight);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) image(x, y) = pattern(x, y);
  write_colour_png(dir.file("rgb.png"), image);
  Image<Rgb8> out;
  ASSERT_TRUE(read_colour_image(dir.file("rgb.png"), out).is_ok());
  ASSERT_EQ(out.width(), kWidth);
  for (std::size_t i = 0; i < out.size(); ++i) ASSERT_EQ(out.data()[i], image.data()[i]);
}

TEST(ColourImage, UnreadableFilesAreOneLineCorruptFrames) {
  ScratchDir dir;
  write_text(dir.file("empty.png"), "");
  write_text(dir.file("text.jpg"), "not an image at all");
  ASSERT_TRUE(cv::imwrite(dir.file("whole.png"), pattern_mat(CV_8UC3)));
  const std::string bytes = testing::read_bytes(dir.file("whole.png"));
  write_text(dir.file("truncated.png"), bytes.substr(0, bytes.size() / 2));
  struct Case {
    std::string file, says;
  };
  for (const Case& c : {Case{"missing.png", "cannot open"}, Case{"empty.png", "empty"},
                        Case{"text.jpg", "can be decoded"},
                        Case{"truncated.png", "can be decoded"}}) {
    Image<Rgb8> out;
    const Status s = read_colour_image(dir.file(c.file), out, 12);
    EXPECT_EQ(s.code(), Status::Code::kCorruptFrame) << c.file;
    EXPECT_NE(s.message().find(dir.file(c.file) + " (frame 12): "), std::string::npos)
        << s.message();
    EXPECT_NE(s.message().find(c.says), std::string::npos) << s.message();
    EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
  }
}

/// The bytes of a hex string.
std::vector<std::uint8_t> from_hex(const std::string& hex) {
  std::vector<std::uint8_t> bytes;
  for (std::size_t k = 0; k + 1 < hex.size(); k += 2)
    bytes.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(k, 2), nullptr, 16)));
  return bytes;
}

TEST(ColourImage, AHeaderDeclaringTooManyPixelsIsRefusedBeforeTheCodecRuns) {
  // Found by the colour_image fuzz target (a timeout): 286 bytes of JPEG whose frame header,
  // after one stray byte that libjpeg skips, declares 65479 x 1773 pixels; the decoder filled
  // them in for over 10 s.
  const std::vector<std::uint8_t> bomb = from_hex(
      "ffd8ffe000104a4649468900010100000100010000ffdb004300030202030202"
      "0303030304030104050805050404050a070706080c0a0c0c0b0a7e0b0d0e1210"
      "0d0e110e0b0b1016101113141515150c0f171816141812141514ffdb00430103"
      "040405040509050509140d0b0414141414141414141414141414141414141414"
      "14141414141414141414141414141414141414141414141414141414141414ff"
      "c000110806edffc703012200021101031101ffc4001f00000105010101010101"
      "00000000000000000102030405060708090a0bc6c7c8c9ca3cd5d6d7d8d9dae2"
      "e3e6e7e8e9eaf2f3f4f5f6f7f8f9faffda000c03010002110311003f00ec34ff"
      "00845e0efb2a1fdecbe15f49f6f53f529e658de67fbf9ffe04ff00ccffd9");
  ASSERT_EQ(bomb.size(), 286u);
  Image<Rgb8> out;
  Status s = decode_colour_image(bomb.data(), bomb.size(), out, "bomb.jpg");
  EXPECT_EQ(s.code(), Status::Code::kCorruptFrame);
  EXPECT_EQ(s.message(), "bomb.jpg: declares 65479 x 1773 pixels, more than the 33554432 a colour "
                         "image may have");
  // A JPEG and a PNG of the 11 x 7 pattern whose headers claim one row more than 8192 x 4096.
  std::vector<std::uint8_t> jpeg, png;
  ASSERT_TRUE(cv::imencode(".jpg", pattern_mat(CV_8UC3), jpeg));
  ASSERT_TRUE(cv::imencode(".png", pattern_mat(CV_8UC3), png));
  for (std::size_t k = 2; k + 8 < jpeg.size(); ++k)
    if (jpeg[k] == 0xff && jpeg[k + 1] == 0xc0) {  // baseline SOF: length, precision, H, W
      jpeg[k + 5] = 0x10;  // 4097
      jpeg[k + 6] = 0x01;
      jpeg[k + 7] = 0x20;  // 8192
      jpeg[k + 8] = 0x00;
      break;
    }
  const std::uint8_t big[8] = {0, 0, 0x20, 0, 0, 0, 0x10, 0x01};  // IHDR: 8192 x 4097
  std::copy(big, big + 8, png.begin() + 16);
  for (const auto* bytes : {&jpeg, &png}) {
    s = decode_colour_image(bytes->data(), bytes->size(), out, "big");
    EXPECT_EQ(s.message(), "big: declares 8192 x 4097 pixels, more than the 33554432 a colour "
                           "image may have");
  }
  // Formats other than JPEG and PNG are not handed to the codec.
  std::vector<std::uint8_t> bmp;
  ASSERT_TRUE(cv::imencode(".bmp", pattern_mat(CV_8UC3), bmp));
  s = decode_colour_image(bmp.data(), bmp.size(), out, "image.bmp");
  EXPECT_EQ(s.message(), "image.bmp: not a JPEG or PNG colour image that can be decoded");
  // The pattern itself still decodes, the JPEG's stray-byte skipping included: one byte between
  // its first segment (APP0) and the next marker.
  ASSERT_TRUE(cv::imencode(".jpg", pattern_mat(CV_8UC3), jpeg));
  ASSERT_EQ(jpeg[2], 0xff);
  const std::size_t next = 4 + (std::size_t{jpeg[4]} << 8 | jpeg[5]);
  jpeg.insert(jpeg.begin() + static_cast<std::ptrdiff_t>(next), 0x00);
  EXPECT_TRUE(decode_colour_image(jpeg.data(), jpeg.size(), out, "stray.jpg").is_ok());
  EXPECT_EQ(out.width(), kWidth);
  EXPECT_EQ(out.height(), kHeight);
}

TEST(ColourImage, AnImageOfAnotherSizeThanExpectedIsRefusedBeforeTheCodecRuns) {
  std::vector<std::uint8_t> jpeg, png;
  ASSERT_TRUE(cv::imencode(".jpg", pattern_mat(CV_8UC3), jpeg));
  ASSERT_TRUE(cv::imencode(".png", pattern_mat(CV_8UC3), png));
  Image<Rgb8> out;
  for (const auto* bytes : {&jpeg, &png}) {
    ASSERT_TRUE(decode_colour_image(bytes->data(), bytes->size(), out, "f",
                                    ExpectedSize{kWidth, kHeight})
                    .is_ok());
    EXPECT_EQ(out.width(), kWidth);
    const Status s = decode_colour_image(bytes->data(), bytes->size(), out, "f (frame 3)",
                                         ExpectedSize{kWidth, kHeight + 1});
    EXPECT_EQ(s.code(), Status::Code::kCorruptFrame);
    EXPECT_EQ(s.message(), "f (frame 3): size 11x7 differs from 11x8 of the colour camera");
    // Refused by its header: the header alone (the rest cut off, which the codec would not
    // decode) gets the same message.
    const std::size_t header = bytes == &png ? 33 : jpeg.size() / 3;
    EXPECT_EQ(decode_colour_image(bytes->data(), header, out, "f (frame 3)",
                                  ExpectedSize{kWidth, kHeight + 1})
                  .message(),
              s.message());
    EXPECT_NE(decode_colour_image(bytes->data(), header, out, "f (frame 3)",
                                  ExpectedSize{kWidth, kHeight})
                  .message(),
              s.message());
  }
  // From a file, with the frame named.
  ScratchDir dir;
  ASSERT_TRUE(cv::imwrite(dir.file("rgb.png"), pattern_mat(CV_8UC3)));
  EXPECT_EQ(read_colour_image(dir.file("rgb.png"), out, 4, ExpectedSize{640, 480}).message(),
            dir.file("rgb.png") + " (frame 4): size 11x7 differs from 640x480 of the colour camera");
}

}  // namespace
}  // namespace aoscan
