/// @file camera_json_test.cpp
/// @brief Tests for src/io/camera_json.h: parsing, every rejected input, round trip, folder
/// defaults.
#include "io/camera_json.h"

#include <gtest/gtest.h>

#include "core/status.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

using testing::ScratchDir;
using testing::write_text;

/// Runs read_camera_json on `json` and returns the input_error message (fails if none is thrown).
std::string error_for(const ScratchDir& dir, const std::string& json) {
  const std::string path = dir.file("camera.json");
  write_text(path, json);
  try {
    read_camera_json(path, 640, 480);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    const std::string message = e.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
  }
  ADD_FAILURE() << "no error for " << json;
  return "";
}

TEST(CameraJson, ReadsContractExample) {
  ScratchDir dir;
  write_text(dir.file("camera.json"),
             R"({ "fx": 585.0, "fy": 584.5, "cx": 320.0, "cy": 240.25, "depth_scale": 1000.0 })");
  const CameraInfo info = read_camera_json(dir.file("camera.json"), 320, 240);
  EXPECT_EQ(info.intrinsics, (Intrinsics{320, 240, 585.0, 584.5, 320.0, 240.25}));
  EXPECT_EQ(info.depth_scale, 1000.0);
  EXPECT_FALSE(info.size_given);
}

TEST(CameraJson, ReadsWidthAndHeight) {
  ScratchDir dir;
  write_text(dir.file("camera.json"), R"({"width": 320, "height": 240.0, "fx": 1, "fy": 2,
      "cx": -3.5, "cy": 0, "depth_scale": 5000, "comment": "extra keys are ignored"})");
  const CameraInfo info = read_camera_json(dir.file("camera.json"), 640, 480);
  EXPECT_EQ(info.intrinsics, (Intrinsics{320, 240, 1.0, 2.0, -3.5, 0.0}));
  EXPECT_EQ(info.depth_scale, 5000.0);
  EXPECT_TRUE(info.size_given);
}

TEST(CameraJson, MissingFile) {
  ScratchDir dir;
  EXPECT_THROW(read_camera_json(dir.file("none.json"), 640, 480), Error);
}

TEST(CameraJson, MissingField) {
  ScratchDir dir;
  const auto m = error_for(dir, R"({"fx": 585, "fy": 585, "cx": 320, "depth_scale": 1000})");
  EXPECT_NE(m.find("'cy'"), std::string::npos) << m;
}

TEST(CameraJson, NegativeFocalLength) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": -585, "fy": 585, "cx": 320, "cy": 240, "depth_scale": 1})");
  EXPECT_NE(m.find("'fx'"), std::string::npos) << m;
}

TEST(CameraJson, ZeroDepthScale) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": 585, "fy": 585, "cx": 320, "cy": 240, "depth_scale": 0})");
  EXPECT_NE(m.find("'depth_scale'"), std::string::npos) << m;
}

TEST(CameraJson, NanLiteralIsInvalidJson) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": NaN, "fy": 585, "cx": 320, "cy": 240, "depth_scale": 1})");
  EXPECT_NE(m.find("invalid JSON"), std::string::npos) << m;
  EXPECT_NE(m.find("'fx'"), std::string::npos) << m;
}

TEST(CameraJson, StringValue) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": 585, "fy": "585", "cx": 320, "cy": 240, "depth_scale": 1})");
  EXPECT_NE(m.find("'fy'"), std::string::npos) << m;
  EXPECT_NE(m.find("not a number"), std::string::npos) << m;
}

TEST(CameraJson, BooleanIsNotANumber) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": 585, "fy": 585, "cx": true, "cy": 240, "depth_scale": 1})");
  EXPECT_NE(m.find("'cx'"), std::string::npos) << m;
}

TEST(CameraJson, OverflowingNumber) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"fx": 585, "fy": 585, "cx": 320, "cy": 1e999, "depth_scale": 1})");
  EXPECT_NE(m.find("'cy'"), std::string::npos) << m;
}

TEST(CameraJson, NonIntegerWidth) {
  ScratchDir dir;
  const auto m = error_for(
      dir,
      R"({"width": 640.5, "height": 480, "fx": 5, "fy": 5, "cx": 3, "cy": 2, "depth_scale": 1})");
  EXPECT_NE(m.find("'width'"), std::string::npos) << m;
}

TEST(CameraJson, NonPositiveHeight) {
  ScratchDir dir;
  const auto m = error_for(
      dir, R"({"width": 640, "height": 0, "fx": 5, "fy": 5, "cx": 3, "cy": 2, "depth_scale": 1})");
  EXPECT_NE(m.find("'height'"), std::string::npos) << m;
}

TEST(CameraJson, WidthWithoutHeight) {
  ScratchDir dir;
  const auto m =
      error_for(dir, R"({"width": 640, "fx": 5, "fy": 5, "cx": 3, "cy": 2, "depth_scale": 1})");
  EXPECT_NE(m.find("'height'"), std::string::npos) << m;
}

TEST(CameraJson, GarbledJson) {
  ScratchDir dir;
  const auto m = error_for(dir, R"({"fx": 585, "fy": 585,, "cx)");
  EXPECT_NE(m.find("invalid JSON"), std::string::npos) << m;
}

TEST(CameraJson, NotAnObject) {
  ScratchDir dir;
  error_for(dir, "[585, 585, 320, 240, 1000]");
}

TEST(CameraJson, WriteReadRoundTripIsExact) {
  ScratchDir dir;
  const Intrinsics k{641, 479, 585.123456789012345, 1.0 / 3.0, 320.1, 239.7e-3};
  const double scale = 5000.0 / 7.0;
  write_camera_json(dir.file("camera.json"), k, scale);
  const CameraInfo info = read_camera_json(dir.file("camera.json"), 1, 1);
  EXPECT_EQ(info.intrinsics, k);
  EXPECT_EQ(info.depth_scale, scale);
  EXPECT_TRUE(info.size_given);
}

TEST(CameraJson, WriteRejectsInvalidCalibration) {
  ScratchDir dir;
  Intrinsics k;
  k.fx = 0;
  EXPECT_THROW(write_camera_json(dir.file("camera.json"), k, 1000.0), Error);
  EXPECT_THROW(write_camera_json(dir.file("camera.json"), Intrinsics{}, -1.0), Error);
  EXPECT_THROW(write_camera_json(dir.file("no/such/dir/camera.json"), Intrinsics{}, 1.0), Error);
}

TEST(CameraJson, ColourCameraRoundTripIsExact) {
  ScratchDir dir;
  ColourCamera colour;
  colour.intrinsics = Intrinsics{1280, 960, 1050.25, 1049.5, 639.5, 481.0 / 3.0};
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.3, -1.0, 0.2).normalized()).toRotationMatrix();
  colour.T_colour_depth = Pose(R, Eigen::Vector3d(-0.025, 0.001, 0.0005));
  const Intrinsics depth{640, 480, 585.0, 585.0, 320.0, 240.0};
  write_camera_json(dir.file("camera.json"), depth, 1000.0, &colour);
  const CameraInfo info = read_camera_json(dir.file("camera.json"), 1, 1);
  EXPECT_EQ(info.intrinsics, depth);
  ASSERT_TRUE(info.colour.has_value());
  EXPECT_FALSE(info.colour->registered);
  EXPECT_EQ(info.colour->intrinsics, colour.intrinsics);
  // Written to the last bit; read back as the nearest rotation, which R already is to rounding.
  EXPECT_LT((info.colour->T_colour_depth.rotation() - R).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(info.colour->T_colour_depth.translation(), colour.T_colour_depth.translation());
  // A depth point 2 m ahead lands where the calibration says.
  double u = 0.0, v = 0.0;
  ASSERT_TRUE(info.colour->project(Eigen::Vector3d(0.1, -0.2, 2.0), u, v));
  const Eigen::Vector3d q = R * Eigen::Vector3d(0.1, -0.2, 2.0) + colour.T_colour_depth.translation();
  EXPECT_NEAR(u, 1050.25 * q.x() / q.z() + 639.5, 1e-9);
  EXPECT_NEAR(v, 1049.5 * q.y() / q.z() + 481.0 / 3.0, 1e-9);
}

TEST(CameraJson, RegisteredColourCamera) {
  ScratchDir dir;
  write_text(dir.file("camera.json"), R"({ "fx": 585, "fy": 585, "cx": 320, "cy": 240,
      "depth_scale": 1000, "colour": { "registered": true } })");
  const CameraInfo info = read_camera_json(dir.file("camera.json"), 640, 480);
  ASSERT_TRUE(info.colour.has_value());
  EXPECT_TRUE(info.colour->registered);
  EXPECT_EQ(info.colour->intrinsics, info.intrinsics);
  EXPECT_EQ(info.colour->T_colour_depth.matrix(), Eigen::Matrix4d::Identity());
  write_camera_json(dir.file("again.json"), info.intrinsics, 1000.0, &*info.colour);
  const CameraInfo again = read_camera_json(dir.file("again.json"), 1, 1);
  ASSERT_TRUE(again.colour.has_value());
  EXPECT_TRUE(again.colour->registered);
  // Without a colour object there is no colour camera.
  write_camera_json(dir.file("plain.json"), info.intrinsics, 1000.0);
  EXPECT_FALSE(read_camera_json(dir.file("plain.json"), 1, 1).colour.has_value());
}

TEST(CameraJson, BadColourCamera) {
  ScratchDir dir;
  const std::string head = R"({ "fx": 585, "fy": 585, "cx": 320, "cy": 240, "depth_scale": 1000, )";
  const std::string pinhole = R"("width": 640, "height": 480, "fx": 525, "fy": 525, "cx": 320, "cy": 240)";
  EXPECT_NE(error_for(dir, head + R"("colour": 3 })").find("'colour' must hold"), std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { "registered": "yes" } })").find("colour.registered"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { "registered": true, "fx": 1 } })")
                .find("takes no other key"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { "fx": 525, "fy": 525, "cx": 320, "cy": 240,
                "depth_to_colour": [1,0,0,0, 0,1,0,0, 0,0,1,0] } })")
                .find("'colour.width' and 'colour.height' are required"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { )" + pinhole + " } }").find("colour.depth_to_colour"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { )" + pinhole +
                               R"(, "depth_to_colour": [1,0,0, 0,1,0, 0,0,1] } })")
                .find("12 numbers"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { )" + pinhole +
                               R"(, "depth_to_colour": [1,0,0,0, 0,1,0,0, 0,0,1,"x"] } })")
                .find("element 11"),
            std::string::npos);
  // A scale, a mirror: not a rotation.
  EXPECT_NE(error_for(dir, head + R"("colour": { )" + pinhole +
                               R"(, "depth_to_colour": [2,0,0,0, 0,1,0,0, 0,0,1,0] } })")
                .find("not a rotation"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { )" + pinhole +
                               R"(, "depth_to_colour": [-1,0,0,0, 0,1,0,0, 0,0,1,0] } })")
                .find("not a rotation"),
            std::string::npos);
  EXPECT_NE(error_for(dir, head + R"("colour": { "width": 0, "height": 480, "fx": 525, "fy": 525,
                "cx": 320, "cy": 240, "depth_to_colour": [1,0,0,0, 0,1,0,0, 0,0,1,0] } })")
                .find("width"),
            std::string::npos);
}

TEST(CameraJson, FolderDefaults) {
  const CameraInfo fr1 = default_camera_for_folder("/data/rgbd_dataset_freiburg1_desk");
  EXPECT_EQ(fr1.intrinsics, (Intrinsics{640, 480, 517.3, 516.5, 318.6, 255.3}));
  const CameraInfo fr2 = default_camera_for_folder("/data/rgbd_dataset_freiburg2_xyz/");
  EXPECT_EQ(fr2.intrinsics, (Intrinsics{640, 480, 520.9, 521.0, 325.1, 249.7}));
  const CameraInfo fr3 = default_camera_for_folder("rgbd_dataset_freiburg3_office");
  EXPECT_EQ(fr3.intrinsics, (Intrinsics{640, 480, 535.4, 539.2, 320.1, 247.6}));
  // Only the folder's own name counts, not its parents.
  const CameraInfo other = default_camera_for_folder("/data/freiburg1/kitchen");
  EXPECT_EQ(other.intrinsics, (Intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5}));
  for (const CameraInfo& c : {fr1, fr2, fr3, other}) {
    EXPECT_EQ(c.depth_scale, 5000.0);
    EXPECT_FALSE(c.size_given);
  }
}

}  // namespace
}  // namespace aoscan
