/// @file tum_source_test.cpp
/// @brief Tests for src/capture/tum_source.h: a TUM folder built in the test with broken frames,
/// opening errors, default calibration, ground-truth association, and the real 7-Scenes recording.
#include "capture/tum_source.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>

#include <gtest/gtest.h>

#include "capture/png_depth.h"
#include "io/camera_json.h"
#include "io/colour_image.h"
#include "io/tum.h"
#include "support/error_message.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

/// The message of the bad-input error (exit code 3) that `f` throws.
std::string error_message(const std::function<void()>& f) {
  return testing::error_message(f, ExitCode::kBadInput);
}

using testing::read_bytes;
using testing::ScratchDir;
using testing::write_text;

/// Frame i of the synthetic recordings: a ramp that differs per frame.
Image<std::uint16_t> frame_image(int i, int width = 16, int height = 12) {
  Image<std::uint16_t> image(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      image(x, y) = static_cast<std::uint16_t>(1000 * i + 37 * x + 5 * y + (x == y ? 0 : 1));
  return image;
}

/// Folder <scratch>/NAME with frames 0..5 listed at t = 1 + i/30 s: frame 2 missing, frame 3
/// truncated, frame 4 of another size; the others are frame_image(i).
std::string build_folder(const ScratchDir& scratch, const std::string& name) {
  const std::string folder = scratch.file(name);
  std::filesystem::create_directories(folder + "/depth");
  std::string list = "# depth maps\n# timestamp filename\n";
  for (int i = 0; i < 6; ++i) {
    char line[64];
    std::snprintf(line, sizeof line, "%.6f depth/%d.png\n", 1.0 + i / 30.0, i);
    list += line;
    const std::string png = folder + "/depth/" + std::to_string(i) + ".png";
    if (i == 2) continue;
    write_depth_png(png, i == 4 ? frame_image(i, 8, 6) : frame_image(i));
    if (i == 3) {
      const std::string bytes = read_bytes(png);
      write_text(png, bytes.substr(0, bytes.size() / 2));
    }
  }
  write_text(folder + "/depth.txt", list);
  return folder;
}

TEST(TumSource, BrokenFramesAreCountedSkipsAndTheRestDecodesExactly) {
  ScratchDir scratch;
  const std::string folder = build_folder(scratch, "rgbd_dataset_freiburg2_test");
  const auto source = open_tum_folder(folder + "/");
  EXPECT_EQ(source->name(), folder);
  ASSERT_EQ(source->size(), std::optional<std::size_t>(6));
  EXPECT_FALSE(source->live());
  // No camera.json: freiburg2 calibration, size of the first frame.
  const Intrinsics fr2{16, 12, 520.9, 521.0, 325.1, 249.7};
  EXPECT_EQ(source->intrinsics(), fr2);
  EXPECT_EQ(source->depth_scale(), 5000.0);

  DepthFrame frame;
  std::vector<int> decoded;
  std::vector<std::string> skipped;
  for (;;) {
    const Status s = source->read(frame);
    if (s.code() == Status::Code::kEndOfStream) break;
    if (s.code() == Status::Code::kCorruptFrame) {
      skipped.push_back(s.message());
      continue;
    }
    ASSERT_TRUE(s.is_ok()) << s.message();
    const int i = static_cast<int>(frame.sequence);
    decoded.push_back(i);
    EXPECT_EQ(frame.depth, frame_image(i));
    EXPECT_EQ(frame.intrinsics, fr2);
    EXPECT_EQ(frame.depth_scale, 5000.0);
    EXPECT_NEAR(frame.timestamp_s, 1.0 + i / 30.0, 5e-7);  // written with %.6f
    EXPECT_EQ(frame.origin, folder + "/depth/" + std::to_string(i) + ".png");
    EXPECT_FALSE(frame.T_world_camera_gt.has_value());
  }
  EXPECT_EQ(decoded, (std::vector<int>{0, 1, 5}));
  ASSERT_EQ(skipped.size(), 3u);
  EXPECT_EQ(skipped[0], folder + "/depth/2.png (frame 2): missing file");
  EXPECT_EQ(skipped[1], folder + "/depth/3.png (frame 3): truncated PNG");
  EXPECT_EQ(skipped[2],
            folder + "/depth/4.png (frame 4): size 8x6 differs from 16x12 of the first frame");
  EXPECT_EQ(source->read(frame).code(), Status::Code::kEndOfStream);  // and stays there
}

TEST(TumSource, FirstGoodFrameSetsTheSize) {
  ScratchDir scratch;
  const std::string folder = build_folder(scratch, "plain");
  std::filesystem::remove(folder + "/depth/0.png");
  std::filesystem::remove(folder + "/depth/1.png");
  std::filesystem::remove(folder + "/depth/5.png");
  const auto source = open_tum_folder(folder);
  // Frame 4 (8x6) is the first that decodes; default calibration for a plain folder name.
  EXPECT_EQ(source->intrinsics(), (Intrinsics{8, 6, 525.0, 525.0, 319.5, 239.5}));
  DepthFrame frame;
  std::vector<Status::Code> codes;
  for (Status s = source->read(frame); s.code() != Status::Code::kEndOfStream;
       s = source->read(frame))
    codes.push_back(s.code());
  using C = Status::Code;
  EXPECT_EQ(codes, (std::vector<C>{C::kCorruptFrame, C::kCorruptFrame, C::kCorruptFrame,
                                   C::kCorruptFrame, C::kOk, C::kCorruptFrame}));
  EXPECT_EQ(frame.sequence, 4u);
  EXPECT_EQ(frame.depth, frame_image(4, 8, 6));
}

TEST(TumSource, CameraJsonSizeDecidesWhichFramesFit) {
  ScratchDir scratch;
  const std::string folder = build_folder(scratch, "rgbd_dataset_freiburg1_x");
  write_text(folder + "/camera.json",
             R"({"width": 8, "height": 6, "fx": 585, "fy": 586, "cx": 4, "cy": 3,
                 "depth_scale": 1000})");
  const auto source = open_tum_folder(folder);
  const Intrinsics k{8, 6, 585.0, 586.0, 4.0, 3.0};
  EXPECT_EQ(source->intrinsics(), k);
  EXPECT_EQ(source->depth_scale(), 1000.0);
  DepthFrame frame;
  std::vector<std::string> messages;
  int ok = 0;
  for (Status s = source->read(frame); s.code() != Status::Code::kEndOfStream;
       s = source->read(frame)) {
    if (s.is_ok()) {
      ++ok;
      EXPECT_EQ(frame.sequence, 4u);
      EXPECT_EQ(frame.intrinsics, k);
      EXPECT_EQ(frame.depth_scale, 1000.0);
    } else {
      messages.push_back(s.message());
    }
  }
  EXPECT_EQ(ok, 1);
  ASSERT_EQ(messages.size(), 5u);
  EXPECT_EQ(messages[0],
            folder + "/depth/0.png (frame 0): size 16x12 differs from 8x6 of the camera.json");
}

TEST(TumSource, OpeningErrors) {
  ScratchDir scratch;
  EXPECT_EQ(error_message([&] { open_tum_folder(scratch.file("nope")); }),
            scratch.file("nope") + ": no such folder");
  EXPECT_NE(error_message([&] {
              open_tum_folder(scratch.str());
            }).find(scratch.file("depth.txt") + ": missing"),
            std::string::npos);
  write_text(scratch.file("depth.txt"), "# nothing here\n");
  EXPECT_EQ(error_message([&] { open_tum_folder(scratch.str()); }),
            scratch.file("depth.txt") + ": lists no frames");
  write_text(scratch.file("depth.txt"), "# header\n0.0 depth/0.png\n0.1\n");
  EXPECT_NE(error_message([&] {
              open_tum_folder(scratch.str());
            }).find(scratch.file("depth.txt") + ":3:"),
            std::string::npos);
  write_text(scratch.file("depth.txt"), "0.0 depth/0.png\n");
  write_text(scratch.file("camera.json"), R"({"fx": 1})");
  EXPECT_NE(error_message([&] { open_tum_folder(scratch.str()); }).find("camera.json"),
            std::string::npos);
  std::filesystem::remove(scratch.file("camera.json"));
  write_text(scratch.file("groundtruth.txt"), "# gt\n0 0 0 0 0 0 0 1\n0.1 0 0 zero 0 0 0 1\n");
  EXPECT_NE(error_message([&] {
              open_tum_folder(scratch.str());
            }).find(scratch.file("groundtruth.txt") + ":3:"),
            std::string::npos);
  // A folder whose frames are all unreadable opens; every read is a counted skip.
  std::filesystem::remove(scratch.file("groundtruth.txt"));
  const auto source = open_tum_folder(scratch.str());
  DepthFrame frame;
  EXPECT_EQ(source->read(frame).code(), Status::Code::kCorruptFrame);
  EXPECT_EQ(source->read(frame).code(), Status::Code::kEndOfStream);
}

TEST(TumSource, GroundTruthByNearestTimestampWithin20ms) {
  ScratchDir scratch;
  const std::string folder = build_folder(scratch, "gt");
  // Poses at the frame times shifted by +10 ms (frame 0), -15 ms (frame 1), +30 ms (frame 5: too
  // far), plus a decoy 25 ms from frame 0; written out of order.
  auto pose_line = [](double t, double x) {
    char line[128];
    std::snprintf(line, sizeof line, "%.6f %.3f 0 0 0 0 0.6 0.8\n", t, x);
    return std::string(line);
  };
  write_text(folder + "/groundtruth.txt",
             "# timestamp tx ty tz qx qy qz qw\n" + pose_line(1.0 + 5 / 30.0 + 0.030, 5.0) +
                 pose_line(1.0 + 0.010, 0.5) + pose_line(1.0 - 0.025, -1.0) +
                 pose_line(1.0 + 1 / 30.0 - 0.015, 1.5));
  const auto source = open_tum_folder(folder);
  DepthFrame frame;
  std::map<std::uint64_t, std::optional<Pose>> gt;
  for (Status s = source->read(frame); s.code() != Status::Code::kEndOfStream;
       s = source->read(frame))
    if (s.is_ok()) gt[frame.sequence] = frame.T_world_camera_gt;
  ASSERT_EQ(gt.size(), 3u);
  ASSERT_TRUE(gt[0].has_value());
  EXPECT_EQ(gt[0]->translation(), Eigen::Vector3d(0.5, 0, 0));
  const Eigen::Matrix3d rz = Eigen::Quaterniond(0.8, 0, 0, 0.6).toRotationMatrix();
  EXPECT_LT((gt[0]->rotation() - rz).norm(), 1e-15);
  ASSERT_TRUE(gt[1].has_value());
  EXPECT_EQ(gt[1]->translation(), Eigen::Vector3d(1.5, 0, 0));
  EXPECT_FALSE(gt[5].has_value());
}

/// Colour frame i of the synthetic recordings: a flat colour per frame.
Image<Rgb8> colour_image(int i, int width = 16, int height = 12) {
  return Image<Rgb8>(width, height,
                     Rgb8{static_cast<std::uint8_t>(10 * i), 50, static_cast<std::uint8_t>(200 - i)});
}

/// Folder <scratch>/NAME with six good depth frames at t = 1 + i/30 s and rgb.txt: colour of
/// frame 0 exact, of frame 1 5 ms later, of frame 2 missing, of frame 3 corrupt, of frame 4 of
/// another size; none within 20 ms of frame 5.
std::string build_colour_folder(const ScratchDir& scratch, const std::string& name) {
  const std::string folder = scratch.file(name);
  std::filesystem::create_directories(folder + "/depth");
  std::filesystem::create_directories(folder + "/rgb");
  std::string depth_list, colour_list = "# colour\n";
  for (int i = 0; i < 6; ++i) {
    char line[64];
    const double t = 1.0 + i / 30.0;
    std::snprintf(line, sizeof line, "%.6f depth/%d.png\n", t, i);
    depth_list += line;
    write_depth_png(folder + "/depth/" + std::to_string(i) + ".png", frame_image(i));
    if (i == 5) continue;
    std::snprintf(line, sizeof line, "%.6f rgb/%d.png\n", t + (i == 1 ? 0.005 : 0.0), i);
    colour_list += line;
    const std::string png = folder + "/rgb/" + std::to_string(i) + ".png";
    if (i == 2) continue;
    if (i == 3) {
      write_text(png, "garbage");
      continue;
    }
    write_colour_png(png, i == 4 ? colour_image(i, 8, 6) : colour_image(i));
  }
  write_text(folder + "/depth.txt", depth_list);
  write_text(folder + "/rgb.txt", colour_list);
  return folder;
}

TEST(TumSource, ColourIsAssociatedAndEveryColourFailureKeepsTheDepth) {
  ScratchDir scratch;
  const std::string folder = build_colour_folder(scratch, "colour");
  const auto source = open_tum_folder(folder);
  EXPECT_NE(source->colour_origin().find("assumed registered"), std::string::npos);
  DepthFrame frame;
  const char* errors[] = {"", "", "cannot open colour image", "can be decoded",
                          "size 8x6 differs from 16x12 of the colour camera",
                          "no colour frame within 20 ms"};
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(source->read(frame).is_ok()) << "frame " << i;
    // The depth is always there.
    ASSERT_EQ(frame.depth.width(), 16);
    EXPECT_EQ(frame.depth(3, 2), frame_image(i)(3, 2));
    ASSERT_TRUE(frame.colour_camera.has_value());
    EXPECT_TRUE(frame.colour_camera->registered);
    EXPECT_EQ(frame.colour_camera->intrinsics, frame.intrinsics);
    if (i < 2) {
      EXPECT_EQ(frame.colour_error, "") << "frame " << i;
      ASSERT_EQ(frame.colour.width(), 16);
      EXPECT_EQ(frame.colour(5, 5), colour_image(i)(5, 5));
      // rgb.txt holds 6 decimals.
      EXPECT_NEAR(frame.colour_timestamp_s, 1.0 + i / 30.0 + (i == 1 ? 0.005 : 0.0), 1e-6);
    } else {
      EXPECT_TRUE(frame.colour.empty()) << "frame " << i;
      EXPECT_NE(frame.colour_error.find(errors[i]), std::string::npos) << frame.colour_error;
      EXPECT_EQ(frame.colour_error.find('\n'), std::string::npos);
    }
  }
  // Colour not wanted: nothing decoded.
  const auto plain = open_tum_folder(folder);
  plain->want_colour(false);
  ASSERT_TRUE(plain->read(frame).is_ok());
  EXPECT_TRUE(frame.colour.empty());
  EXPECT_EQ(frame.colour_error, "");
}

TEST(TumSource, ColourCameraFromCameraJsonAndBrokenRgbListsLeaveDepthOnly) {
  ScratchDir scratch;
  const std::string folder = build_colour_folder(scratch, "calibrated");
  ColourCamera camera;
  camera.intrinsics = Intrinsics{16, 12, 20.0, 20.0, 8.0, 6.0};
  camera.T_colour_depth = Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.025, 0.0, 0.0));
  write_camera_json(folder + "/camera.json", Intrinsics{16, 12, 18.0, 18.0, 8.0, 6.0}, 1000.0,
                    &camera);
  {
    const auto source = open_tum_folder(folder);
    EXPECT_EQ(source->colour_origin(), folder + "/camera.json");
    DepthFrame frame;
    ASSERT_TRUE(source->read(frame).is_ok());
    ASSERT_TRUE(frame.colour_camera.has_value());
    EXPECT_FALSE(frame.colour_camera->registered);
    EXPECT_EQ(frame.colour_camera->intrinsics, camera.intrinsics);
    EXPECT_EQ(frame.colour_camera->T_colour_depth.translation(),
              camera.T_colour_depth.translation());
    EXPECT_EQ(frame.colour(0, 0), colour_image(0)(0, 0));
  }
  // A garbled rgb.txt: the recording is read without colour.
  write_text(folder + "/rgb.txt", "1.0 rgb/0.png\nnot a line\n");
  const auto source = open_tum_folder(folder);
  EXPECT_EQ(source->colour_origin(), "");
  DepthFrame frame;
  ASSERT_TRUE(source->read(frame).is_ok());
  EXPECT_FALSE(frame.colour_camera.has_value());
  EXPECT_TRUE(frame.colour.empty());
  EXPECT_EQ(frame.colour_error, "");
}

TEST(TumSource, RealRedKitchen) {
  const std::string folder = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";
  if (!std::filesystem::exists(folder + "/depth.txt"))
    GTEST_SKIP() << folder << " is absent; real-data test skipped";
  const auto source = open_tum_folder(folder);
  EXPECT_EQ(source->size(), std::optional<std::size_t>(500));
  EXPECT_EQ(source->intrinsics(), (Intrinsics{640, 480, 585.0, 585.0, 320.0, 240.0}));
  EXPECT_EQ(source->depth_scale(), 1000.0);
  const auto gt = read_trajectory(folder + "/groundtruth.txt");
  ASSERT_GE(gt.size(), 10u);

  DepthFrame frame;
  constexpr int kFrames = 10;
  double read_ms = 0;
  for (int i = 0; i < kFrames; ++i) {
    const auto start = std::chrono::steady_clock::now();
    const Status s = source->read(frame);
    read_ms +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(s.is_ok()) << s.message();
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(i));
    EXPECT_EQ(frame.depth.width(), 640);
    EXPECT_EQ(frame.depth.height(), 480);
    EXPECT_EQ(frame.intrinsics, source->intrinsics());
    EXPECT_EQ(frame.depth_scale, 1000.0);
    EXPECT_NEAR(frame.timestamp_s, i / 30.0, 1e-6);
    ASSERT_TRUE(frame.T_world_camera_gt.has_value()) << "frame " << i;
    EXPECT_EQ(frame.T_world_camera_gt->translation(), gt[i].T_world_camera.translation());
    // Kinect depth in millimetres (README: valid 0.8-4.0 m, about 11 % invalid; 65535 is invalid).
    std::size_t valid = 0;
    std::uint16_t nearest = 65535;
    for (std::size_t p = 0; p < frame.depth.size(); ++p) {
      const std::uint16_t d = frame.depth.data()[p];
      if (d == 0 || d == 65535) continue;
      ++valid;
      nearest = std::min(nearest, d);
    }
    EXPECT_GT(valid, frame.depth.size() / 2) << "frame " << i;
    EXPECT_GE(nearest, 400) << "frame " << i;
  }
  std::printf("[ info ] redkitchen: read() %.2f ms per frame (PNG decode + ground truth)\n",
              read_ms / kFrames);
}

}  // namespace
}  // namespace aoscan
