// Tests of --camera FILE: a camera.json replacing a source's calibration and colour camera.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "capture/camera_file.h"
#include "capture/source.h"
#include "support/scratch_dir.h"

namespace fs = std::filesystem;

namespace aoscan {
namespace {

TEST(CameraFile, ReplacesIntrinsicsScaleAndColourCameraOfEveryFrame) {
  testing::ScratchDir scratch;
  const fs::path path = scratch.folder("camera_file") / "cam.json";
  std::ofstream(path) << R"({ "fx": 600.5, "fy": 601.25, "cx": 318.75, "cy": 241.5,
    "depth_scale": 1000,
    "colour": { "width": 320, "height": 240, "fx": 265, "fy": 265, "cx": 160, "cy": 120,
                "depth_to_colour": [1, 0, 0, -0.025, 0, 1, 0, 0, 0, 0, 1, 0] } })";
  const CameraInfo info = read_camera_file(path.string());
  auto source = with_camera_file(open_source("synth:corner?frames=2&colour=on"), info,
                                 path.string());
  EXPECT_EQ(source->intrinsics().fx, 600.5);
  EXPECT_EQ(source->intrinsics().width, 640);  // the file gives no size: the source's
  EXPECT_EQ(source->calibration_origin(), path.string() + " (--camera)");
  EXPECT_EQ(source->colour_origin(), path.string() + " (--camera)");
  DepthFrame frame;
  ASSERT_TRUE(source->read(frame).is_ok());
  EXPECT_EQ(frame.intrinsics.fy, 601.25);
  EXPECT_EQ(frame.intrinsics.cx, 318.75);
  EXPECT_EQ(frame.depth_scale, 1000.0);
  ASSERT_TRUE(frame.colour_camera);
  EXPECT_FALSE(frame.colour_camera->registered);
  EXPECT_EQ(frame.colour_camera->intrinsics.fx, 265.0);
  EXPECT_EQ(frame.colour_camera->T_colour_depth.translation().x(), -0.025);
  // The synthetic colour is 640x480, the file's colour camera 320x240: a colour skip, the depth
  // is kept.
  EXPECT_TRUE(frame.colour.empty());
  EXPECT_EQ(frame.colour_error, "synth:corner?frames=2&colour=on frame 0: colour image of "
                                "640x480 differs from 320x240 of the colour camera in " +
                                    path.string());
  EXPECT_EQ(frame.depth.width(), 640);
}

TEST(CameraFile, RegisteredColourFollowsTheFileAndColourOffIsHandedOn) {
  testing::ScratchDir scratch;
  const fs::path path = scratch.folder("registered") / "cam.json";
  std::ofstream(path) << R"({ "width": 640, "height": 480, "fx": 500, "fy": 500, "cx": 320,
    "cy": 240, "depth_scale": 1000, "colour": { "registered": true } })";
  auto source = with_camera_file(open_source("synth:corner?frames=1&colour=on"),
                                 read_camera_file(path.string()), path.string());
  DepthFrame frame;
  ASSERT_TRUE(source->read(frame).is_ok());
  ASSERT_TRUE(frame.colour_camera);
  EXPECT_TRUE(frame.colour_camera->registered);
  EXPECT_EQ(frame.colour_camera->intrinsics.fx, 500.0);
  EXPECT_EQ(frame.colour.width(), 640);
  EXPECT_TRUE(frame.colour_error.empty());

  auto off = with_camera_file(open_source("synth:corner?frames=1&colour=on"),
                              read_camera_file(path.string()), path.string());
  off->want_colour(false);
  ASSERT_TRUE(off->read(frame).is_ok());
  EXPECT_TRUE(frame.colour.empty());  // the wrapped source was told: nothing rendered
}

TEST(CameraFile, BadFilesAreUsageErrorsNamingThem) {
  testing::ScratchDir scratch;
  const fs::path dir = scratch.folder("bad");
  try {
    read_camera_file((dir / "none.json").string());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()),
              "--camera " + (dir / "none.json").string() + ": cannot open camera file");
  }
  const fs::path wide = dir / "wide.json";
  std::ofstream(wide) << R"({ "width": 800, "height": 600, "fx": 500, "fy": 500, "cx": 400,
    "cy": 300, "depth_scale": 1000 })";
  try {
    with_camera_file(open_source("synth:corner?frames=1"), read_camera_file(wide.string()),
                     wide.string());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
    EXPECT_EQ(std::string(e.what()), wide.string() + ": a 800x600 camera, but synth:corner?frames=1 "
                                                     "delivers 640x480 depth");
  }
}

}  // namespace
}  // namespace aoscan
