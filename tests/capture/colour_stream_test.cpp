// Tests of what the live cameras share about colour: decoding RGB24, YUYV and MJPEG frames, the
// nominal and registered colour cameras, and pairing depth frames with colour frames by time.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "capture/colour_stream.h"

namespace aoscan {
namespace {

Image<Rgb8> uniform(int width, int height, Rgb8 c) {
  return Image<Rgb8>(width, height, c);
}

TEST(ColourDecode, Rgb24RowsWithPadding) {
  const int width = 2, height = 2, stride = 8;  // 2 padding bytes per row
  std::vector<std::uint8_t> buffer = {1, 2, 3, 4, 5, 6, 0xEE, 0xEE, 7, 8, 9, 10, 11, 12};
  Image<Rgb8> out;
  ASSERT_TRUE(decode_colour_frame(ColourPixelFormat::kRgb24, buffer.data(), buffer.size(), width,
                                  height, stride, out, "cam")
                  .is_ok());
  ASSERT_EQ(out.width(), 2);
  ASSERT_EQ(out.height(), 2);
  EXPECT_EQ(out(0, 0), (Rgb8{1, 2, 3}));
  EXPECT_EQ(out(1, 0), (Rgb8{4, 5, 6}));
  EXPECT_EQ(out(0, 1), (Rgb8{7, 8, 9}));
  EXPECT_EQ(out(1, 1), (Rgb8{10, 11, 12}));
  const Status short_frame = decode_colour_frame(ColourPixelFormat::kRgb24, buffer.data(), 13,
                                                 width, height, stride, out, "cam (frame 3)");
  EXPECT_EQ(short_frame.code(), Status::Code::kCorruptFrame);
  EXPECT_NE(short_frame.message().find("cam (frame 3): short colour frame (13 of 14 bytes)"),
            std::string::npos)
      << short_frame.message();
  EXPECT_EQ(decode_colour_frame(ColourPixelFormat::kRgb24, buffer.data(), buffer.size(), 3, 2, 8,
                                out, "c")
                .code(),
            Status::Code::kCorruptFrame);  // 9 bytes of pixels do not fit 8 bytes per line
  EXPECT_EQ(decode_colour_frame(ColourPixelFormat::kRgb24, nullptr, 0, 1, 1, 3, out, "c").code(),
            Status::Code::kCorruptFrame);
}

TEST(ColourDecode, YuyvIsBt601LimitedRange) {
  // Two pixel pairs: white and black sharing chroma 128; BT.601 red (Y 81, U 90, V 240) twice.
  const std::vector<std::uint8_t> buffer = {235, 128, 16, 128, 81, 90, 81, 240};
  Image<Rgb8> out;
  ASSERT_TRUE(decode_colour_frame(ColourPixelFormat::kYuyv, buffer.data(), buffer.size(), 4, 1, 8,
                                  out, "cam")
                  .is_ok());
  EXPECT_EQ(out(0, 0), (Rgb8{255, 255, 255}));
  EXPECT_EQ(out(1, 0), (Rgb8{0, 0, 0}));
  EXPECT_EQ(out(2, 0), (Rgb8{255, 0, 0}));
  EXPECT_EQ(out(3, 0), (Rgb8{255, 0, 0}));
  // Mid grey: Y 126 -> round((126 - 16) * 298 / 256) = 128.
  const std::vector<std::uint8_t> grey = {126, 128, 126, 128};
  ASSERT_TRUE(
      decode_colour_frame(ColourPixelFormat::kYuyv, grey.data(), 4, 2, 1, 4, out, "c").is_ok());
  EXPECT_EQ(out(1, 0), (Rgb8{128, 128, 128}));
  // An odd width has no YUYV layout.
  EXPECT_EQ(decode_colour_frame(ColourPixelFormat::kYuyv, grey.data(), 4, 1, 1, 4, out, "c").code(),
            Status::Code::kCorruptFrame);
}

TEST(ColourDecode, MjpegFramesAndGarbage) {
  cv::Mat image(16, 24, CV_8UC3, cv::Scalar(40, 120, 200));  // BGR
  std::vector<std::uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  Image<Rgb8> out;
  ASSERT_TRUE(decode_colour_frame(ColourPixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 0, 0, 0,
                                  out, "cam")
                  .is_ok());
  ASSERT_EQ(out.width(), 24);
  ASSERT_EQ(out.height(), 16);
  // A flat JPEG decodes to within a step or two of its colour.
  EXPECT_NEAR(out(5, 5).r, 200, 2);
  EXPECT_NEAR(out(5, 5).g, 120, 2);
  EXPECT_NEAR(out(5, 5).b, 40, 2);
  // With the stream's negotiated size: the frame's own, or refused by its header.
  EXPECT_TRUE(decode_colour_frame(ColourPixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 24, 16, 0,
                                  out, "cam")
                  .is_ok());
  EXPECT_EQ(decode_colour_frame(ColourPixelFormat::kMjpeg, jpeg.data(), jpeg.size(), 32, 16, 0,
                                out, "cam (frame 2)")
                .message(),
            "cam (frame 2): size 24x16 differs from 32x16 of the colour camera");
  const std::vector<std::uint8_t> garbage(100, 0x5a);
  const Status bad = decode_colour_frame(ColourPixelFormat::kMjpeg, garbage.data(), garbage.size(),
                                         0, 0, 0, out, "cam (frame 9)");
  EXPECT_EQ(bad.code(), Status::Code::kCorruptFrame);
  EXPECT_EQ(bad.message().rfind("cam (frame 9): ", 0), 0u) << bad.message();
  // Half a JPEG: never a crash, either a corrupt frame or a (partly grey) image of its size.
  const Status half = decode_colour_frame(ColourPixelFormat::kMjpeg, jpeg.data(), jpeg.size() / 2,
                                          0, 0, 0, out, "c");
  if (half.is_ok()) {
    EXPECT_EQ(out.width(), 24);
  } else {
    EXPECT_EQ(half.code(), Status::Code::kCorruptFrame);
  }
}

TEST(ColourCameras, NominalAndRegisteredAtAnotherResolution) {
  const ColourCamera nominal = ColourCamera::nominal(640, 480, -0.025);
  EXPECT_FALSE(nominal.registered);
  EXPECT_EQ(nominal.intrinsics.fx, 525.0);
  EXPECT_EQ(nominal.intrinsics.cx, 319.5);
  double u = 0, v = 0;
  ASSERT_TRUE(nominal.project(Eigen::Vector3d(0.025, 0.0, 1.0), u, v));
  EXPECT_DOUBLE_EQ(u, 319.5);  // the colour camera sits 25 mm along +x
  EXPECT_DOUBLE_EQ(v, 239.5);

  const Intrinsics depth{320, 240, 262.5, 262.5, 159.5, 119.5};
  const ColourCamera same = registered_colour_camera(depth, 320, 240);
  EXPECT_TRUE(same.registered);
  EXPECT_TRUE(same.intrinsics == depth);
  const ColourCamera doubled = registered_colour_camera(depth, 640, 480);
  EXPECT_FALSE(doubled.registered);
  EXPECT_EQ(doubled.intrinsics.fx, 525.0);
  EXPECT_EQ(doubled.intrinsics.cx, 319.5);
  // Depth pixel (x, y) is colour pixel (2x + 0.5, 2y + 0.5): the same ray on a finer grid.
  const Eigen::Vector3d p((100.0 - depth.cx) / depth.fx, (30.0 - depth.cy) / depth.fy, 1.0);
  ASSERT_TRUE(doubled.project(p, u, v));
  EXPECT_NEAR(u, 200.5, 1e-9);
  EXPECT_NEAR(v, 60.5, 1e-9);
}

/// Commits a uniform colour frame stamped `t`.
void add(ColourPairer& pairer, double t, Rgb8 c, int width = 4, int height = 3) {
  pairer.next_buffer() = uniform(width, height, c);
  pairer.commit(t);
}

DepthFrame depth_at(double t) {
  DepthFrame f;
  f.timestamp_s = t;
  return f;
}

TEST(ColourPairer, NearestWithinTwentyMillisecondsEachUsedOnce) {
  const ColourCamera camera = registered_colour_camera(Intrinsics{4, 3, 4, 4, 1.5, 1}, 4, 3);
  ColourPairer pairer;
  add(pairer, 0.990, Rgb8{1, 0, 0});
  add(pairer, 1.004, Rgb8{2, 0, 0});
  add(pairer, 1.030, Rgb8{3, 0, 0});
  DepthFrame f = depth_at(1.0);
  pairer.pair(f, camera, "cam (frame 0)");
  EXPECT_TRUE(f.colour_error.empty()) << f.colour_error;
  ASSERT_EQ(f.colour.width(), 4);
  EXPECT_EQ(f.colour(0, 0), (Rgb8{2, 0, 0}));  // 4 ms beats 10 ms
  EXPECT_EQ(f.colour_timestamp_s, 1.004);
  ASSERT_TRUE(f.colour_camera);
  EXPECT_TRUE(f.colour_camera->registered);
  // The same time again: 1.004 is used, 0.990 (10 ms) is next.
  DepthFrame g = depth_at(1.0);
  pairer.pair(g, camera, "cam (frame 1)");
  EXPECT_EQ(g.colour(0, 0), (Rgb8{1, 0, 0}));
  EXPECT_EQ(g.colour_timestamp_s, 0.990);
  // 1.030 is 21 ms from 1.051: too far.
  DepthFrame h = depth_at(1.051);
  pairer.pair(h, camera, "cam (frame 2)");
  EXPECT_TRUE(h.colour.empty());
  EXPECT_EQ(h.colour_error, "cam (frame 2): no colour frame within 20 ms");
  ASSERT_TRUE(h.colour_camera);  // the source has colour all the same
  EXPECT_EQ(pairer.frames_received(), 3u);
}

TEST(ColourPairer, WaitsOnlyForAFlowingStreamThatIsBehind) {
  ColourPairer pairer;
  EXPECT_TRUE(pairer.worth_waiting(1.0));    // starting: the first colour frame may be coming
  EXPECT_TRUE(pairer.worth_waiting(1.19));
  EXPECT_FALSE(pairer.worth_waiting(1.21));  // over 200 ms of depth and no colour yet: not waited for
  add(pairer, 0.98, Rgb8{});
  EXPECT_TRUE(pairer.worth_waiting(1.0));   // the next one may be nearer
  EXPECT_FALSE(pairer.worth_waiting(0.98));  // one at the very time is here
  EXPECT_FALSE(pairer.worth_waiting(0.97));  // one after it is here
  EXPECT_TRUE(pairer.worth_waiting(1.17));
  EXPECT_FALSE(pairer.worth_waiting(1.19));  // over 200 ms without colour: stopped
}

TEST(ColourPairer, WrongSizesAndFailedFramesAreErrorsOfTheirDepthFrame) {
  const ColourCamera camera = ColourCamera::nominal(4, 3, 0.0);
  ColourPairer pairer(2);
  add(pairer, 1.0, Rgb8{9, 9, 9}, 5, 3);
  pairer.next_buffer();
  pairer.commit_failed(2.0, "cam (frame 4): short colour frame (7 of 36 bytes)");
  DepthFrame f = depth_at(1.01);
  pairer.pair(f, camera, "cam (frame 1)");
  EXPECT_TRUE(f.colour.empty());
  EXPECT_EQ(f.colour_error, "cam (frame 1): colour frame of 5x3 differs from 4x3 of the colour "
                            "camera");
  DepthFrame g = depth_at(2.0);
  pairer.pair(g, camera, "cam (frame 2)");
  EXPECT_EQ(g.colour_error, "cam (frame 4): short colour frame (7 of 36 bytes)");
  // Capacity 2: a third frame replaces the oldest; the buffers are recycled, and a frame's old
  // colour buffer goes back to the pairer.
  add(pairer, 3.0, Rgb8{7, 7, 7});
  DepthFrame h = depth_at(3.0);
  pairer.pair(h, camera, "cam (frame 3)");
  EXPECT_TRUE(h.colour_error.empty()) << h.colour_error;
  EXPECT_EQ(h.colour(3, 2), (Rgb8{7, 7, 7}));
  DepthFrame late = depth_at(1.0);
  pairer.pair(late, camera, "cam (frame 9)");
  EXPECT_EQ(late.colour_error, "cam (frame 9): no colour frame within 20 ms");  // 1.0 was dropped
}

}  // namespace
}  // namespace aoscan
