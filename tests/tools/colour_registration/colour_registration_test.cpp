// Tests for tools/colour_registration: on synthetic depth/colour pairs with a known registration
// (flat cards of different colours in front of a wall, the colour camera offset and rotated, with
// its own focal length) the estimator recovers the transform and the focal length, the edge
// distance drops below a pixel on pairs it did not fit; the tool's folder reader names the file
// of each bad input, and the executable exits 2 and 3 as the contract says; the bundled RedKitchen
// calibration reads back; on RedKitchen (when the shared data is present) the estimator brings the
// edges within 2 px.
#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "core/status.h"
#include "io/camera_json.h"
#include "io/png_write.h"
#include "registration.h"
#include "support/cli_util.h"
#include "support/scratch_dir.h"

namespace aoscan::colour_registration {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A rectangle parallel to the image planes at depth z (depth camera frame, metres).
struct Card {
  double x0, x1, y0, y1, z;
  Rgb8 colour;
};

/// Cards in front of a wall; the nearest hit along a ray from `origin` with direction `dir`.
struct CardScene {
  double wall_z = 3.2;
  Rgb8 wall{30, 30, 30};
  std::vector<Card> cards;

  double hit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, Rgb8* colour) const {
    double best = (wall_z - origin.z()) / dir.z();
    if (colour) *colour = wall;
    for (const Card& c : cards) {
      const double s = (c.z - origin.z()) / dir.z();
      if (!(s > 0.0) || s >= best) continue;
      const Eigen::Vector3d p = origin + s * dir;
      if (p.x() < c.x0 || p.x() > c.x1 || p.y() < c.y0 || p.y() > c.y1) continue;
      best = s;
      if (colour) *colour = c.colour;
    }
    return best;
  }
};

/// Scene `k`: five cards at depths 0.9-2.3 m whose layout changes with k (no randomness). Their
/// colours differ in grey level by 40 from each other and from the wall (the estimator's Canny
/// runs on the grey image).
CardScene make_scene(int k) {
  CardScene s;
  const Rgb8 colours[] = {{150, 50, 40},
                          {40, 150, 90},
                          {90, 170, 250},
                          {250, 180, 100},
                          {240, 240, 200}};  // grey 79, 110, 155, 192, 236
  for (int i = 0; i < 5; ++i) {
    const double z = 0.9 + 0.35 * ((i + 2 * k) % 5) + 0.05 * k;
    const double cx = (-0.5 + 0.25 * i + 0.07 * std::sin(1.3 * k + i)) * z / 1.6;
    const double cy = (0.25 * std::cos(0.9 * k + 1.7 * i)) * z / 1.6;
    const double hw = (0.10 + 0.03 * ((i + k) % 3)) * z / 1.6,
                 hh = (0.12 + 0.04 * ((i * k) % 3)) * z / 1.6;
    s.cards.push_back({cx - hw, cx + hw, cy - hh, cy + hh, z, colours[(i + k) % 5]});
  }
  return s;
}

Intrinsics depth_camera() {
  Intrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 585.0;
  k.cx = 320.0;
  k.cy = 240.0;
  return k;
}

/// The colour camera the tests must recover: 2.6 cm baseline with a few mm off-axis, a rotation
/// of about 0.7 degrees, focal 532 px (the nominal 525 is the starting point), centred.
ColourCamera true_colour_camera() {
  ColourCamera c = ColourCamera::nominal(640, 480);
  c.intrinsics.fx = c.intrinsics.fy = 532.0;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.4 * kPi / 180, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(-0.5 * kPi / 180, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.3 * kPi / 180, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  c.T_colour_depth = Pose(R, Eigen::Vector3d(-0.026, 0.004, -0.003));
  return c;
}

/// Depth in millimetres of the ray through each pixel centre.
Image<std::uint16_t> render_depth(const CardScene& scene, const Intrinsics& k) {
  Image<std::uint16_t> depth(k.width, k.height);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d dir((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
      depth(x, y) = static_cast<std::uint16_t>(
          std::lround(1000.0 * scene.hit(Eigen::Vector3d::Zero(), dir, nullptr)));
    }
  return depth;
}

/// The colour image seen by `camera`, 4x4 supersampled (edges anti-aliased at sub-pixel positions).
Image<Rgb8> render_colour(const CardScene& scene, const ColourCamera& camera) {
  const Intrinsics& k = camera.intrinsics;
  const Eigen::Matrix3d Rt = camera.T_colour_depth.rotation().transpose();
  const Eigen::Vector3d origin = -(Rt * camera.T_colour_depth.translation());
  Image<Rgb8> out(k.width, k.height);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      int r = 0, g = 0, b = 0;
      for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx) {
          const double u = x - 0.375 + 0.25 * sx, v = y - 0.375 + 0.25 * sy;
          const Eigen::Vector3d dir =
              Rt * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
          Rgb8 c;
          scene.hit(origin, dir, &c);
          r += c.r;
          g += c.g;
          b += c.b;
        }
      out(x, y) =
          Rgb8{static_cast<std::uint8_t>((r + 8) / 16), static_cast<std::uint8_t>((g + 8) / 16),
               static_cast<std::uint8_t>((b + 8) / 16)};
    }
  return out;
}

/// The pairs of scenes first..first+count-1. Their depth is exact: the edge points go on the
/// boundary between the two pixels of a jump (at the nearer pixel, the real cameras' default, the
/// focal length comes out 1.2 px long here).
std::vector<EdgeFrame> synthetic_frames(int first, int count) {
  EdgeOptions options;
  options.placement = EdgePlacement::kBoundary;
  std::vector<EdgeFrame> frames;
  const ColourCamera truth = true_colour_camera();
  for (int k = first; k < first + count; ++k) {
    const CardScene scene = make_scene(k);
    frames.push_back(make_edge_frame(render_depth(scene, depth_camera()), 1000.0, depth_camera(),
                                     render_colour(scene, truth), options, k));
  }
  return frames;
}

TEST(ColourRegistration, RecoversAKnownRegistrationOfSyntheticPairs) {
  const std::vector<EdgeFrame> fit = synthetic_frames(0, 5);
  const std::vector<EdgeFrame> held_out = synthetic_frames(5, 2);
  for (const EdgeFrame& f : fit) ASSERT_GT(f.points.size(), 500u) << "frame " << f.frame;
  const FitResult r = fit_colour_camera(fit, ColourCamera::nominal(640, 480));
  const ColourCamera truth = true_colour_camera();

  const Eigen::Vector3d dt =
      r.camera.T_colour_depth.translation() - truth.T_colour_depth.translation();
  const double angle_deg = Eigen::AngleAxisd(r.camera.T_colour_depth.rotation() *
                                             truth.T_colour_depth.rotation().transpose())
                               .angle() *
                           180.0 / kPi;
  std::printf(
      "synthetic: translation error %.2f mm, rotation error %.3f deg, focal %.2f px (true "
      "532)\n",
      1e3 * dt.norm(), angle_deg, r.camera.intrinsics.fx);
  // Edges are located to about half a pixel (Canny's pixel grid, depth's pixel boundaries): a
  // 0.5 px shift at 2 m and 532 px is 1.9 mm, or 0.054 degrees; averaged over thousands of edge
  // points the errors are well below that. Tolerances: 2 mm, 0.1 degree, 1 px of focal length.
  EXPECT_LT(dt.norm(), 0.002);
  EXPECT_LT(angle_deg, 0.1);
  EXPECT_NEAR(r.camera.intrinsics.fx, 532.0, 1.0);
  EXPECT_EQ(r.camera.intrinsics.fy, r.camera.intrinsics.fx);
  EXPECT_EQ(r.camera.intrinsics.cx, 319.5);  // kept at the nominal image centre
  EXPECT_EQ(r.camera.intrinsics.cy, 239.5);
  EXPECT_FALSE(r.camera.registered);

  const EdgeDistances before = measure_edge_distances(held_out, nullptr);
  const EdgeDistances after = measure_edge_distances(held_out, &r.camera);
  std::printf("synthetic held-out: before median %.2f px, after median %.2f px (p90 %.2f)\n",
              before.median_px, after.median_px, after.p90_px);
  EXPECT_GT(before.median_px, 5.0);
  EXPECT_LT(after.median_px, 1.0);
  EXPECT_GT(after.points, 1000u);
}

TEST(ColourRegistration, TooFewEdgesIsABadInputError) {
  std::vector<EdgeFrame> frames = synthetic_frames(0, 1);
  frames[0].points.resize(50);
  frames[0].depth_pixels.resize(50);
  try {
    fit_colour_camera(frames, ColourCamera::nominal(640, 480));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    EXPECT_NE(std::string(e.what()).find("too few depth edges"), std::string::npos) << e.what();
  }
}

/// The message and code of register_recording on `folder`.
Error registration_error(const std::string& folder) {
  try {
    RecordingOptions o;
    o.step = 1;
    register_recording(folder, o);
  } catch (const Error& e) {
    return e;
  }
  return Error(ExitCode::kOk, "no error");
}

TEST(ColourRegistration, BadFoldersAreOneLineErrorsNamingTheFile) {
  testing::ScratchDir scratch;
  const std::string dir = scratch.file("rec");
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/depth.txt") << "# timestamp filename\n0.0 depth/0.png\n0.1 depth/1.png\n";
  {
    const Error e = registration_error(dir);
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    EXPECT_EQ(std::string(e.what()),
              dir + "/rgb.txt: not found (the recording has no colour stream)");
  }
  // Both depth frames missing, colour garbage: every pair skipped, the first skip quoted.
  std::ofstream(dir + "/rgb.txt") << "0.0 rgb/0.png\n0.1 rgb/1.png\n";
  std::filesystem::create_directories(dir + "/rgb");
  std::ofstream(dir + "/rgb/0.png") << "not a png";
  const Image<std::uint16_t> depth(640, 480, 1000);
  std::filesystem::create_directories(dir + "/depth");
  write_png(dir + "/depth/0.png", 640, 480, PngFormat::kGrey16,
            [&](int y) { return depth.row(y); });
  {
    const Error e = registration_error(dir);
    EXPECT_EQ(e.code(), ExitCode::kBadInput);
    const std::string m = e.what();
    EXPECT_NE(m.find(dir + ": no usable depth/colour pair among 2 read (first: " + dir +
                     "/rgb/0.png: cannot read the colour image)"),
              std::string::npos)
        << m;
    EXPECT_EQ(m.find('\n'), std::string::npos);
  }
  // Options out of range are usage errors.
  RecordingOptions o;
  o.step = 0;
  try {
    register_recording(dir, o);
    ADD_FAILURE() << "no error for step 0";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kUsage);
  }
}

/// Runs aoscan-colour-registration (next to aoscan) with `args`; output kept in `scratch`.
testing::CliRun run_tool(const std::string& args, const std::filesystem::path& scratch) {
  const std::filesystem::path tool =
      std::filesystem::path(AOSCAN_BINARY).parent_path() / "aoscan-colour-registration";
  const std::string cmd = testing::quote(tool.string()) + " " + args + " > " +
                          testing::quote((scratch / "stdout.txt").string()) + " 2> " +
                          testing::quote((scratch / "stderr.txt").string()) + " < /dev/null";
  return testing::collect(testing::exit_code_of(std::system(cmd.c_str())), scratch);
}

TEST(ColourRegistration, ToolExitCodes) {
  testing::ScratchDir scratch;
  const std::filesystem::path dir = scratch.path("rec");
  std::filesystem::create_directories(dir);
  EXPECT_EQ(run_tool("", scratch.path("")).exit_code, 2);  // FOLDER and --out are required
  EXPECT_EQ(run_tool(testing::quote(dir.string()) + " --out x.json --frames 0", scratch.path(""))
                .exit_code,
            2);
  std::ofstream(dir / "depth.txt") << "0.0 depth/0.png\n";
  const testing::CliRun r = run_tool(
      testing::quote(dir.string()) + " --out " + testing::quote(scratch.file("camera.json")),
      scratch.path(""));
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.err, "aoscan-colour-registration: " + (dir / "rgb.txt").string() +
                       ": not found (the recording has no colour stream)\n");
  EXPECT_FALSE(std::filesystem::exists(scratch.path("camera.json")));
}

TEST(ColourRegistration, TheBundledRedKitchenCalibrationReads) {
  const std::string path =
      std::string(AOSCAN_SOURCE_DIR) + "/recordings/7scenes-redkitchen.camera.json";
  const CameraInfo info = read_camera_json(path, 640, 480);
  EXPECT_EQ(info.intrinsics.fx, 585.0);
  EXPECT_EQ(info.depth_scale, 1000.0);
  ASSERT_TRUE(info.colour.has_value());
  EXPECT_FALSE(info.colour->registered);
  EXPECT_EQ(info.colour->intrinsics.width, 640);
  EXPECT_NEAR(info.colour->intrinsics.fx, 526.4, 0.1);
  // The colour camera about 2.5 cm to the depth camera's right (+x), as on a Kinect v1.
  const Pose& T = info.colour->T_colour_depth;
  const Eigen::Vector3d centre = -(T.rotation().transpose() * T.translation());
  EXPECT_NEAR(centre.x(), 0.0251, 0.001);
  EXPECT_LT(centre.tail<2>().norm(), 0.005);
}

TEST(ColourRegistration, RegistersRedKitchenWithinTwoPixels) {
  const std::string kitchen = std::string(AOSCAN_SHARED_DATA_DIR) + "/7scenes-redkitchen";
  if (!std::filesystem::exists(kitchen + "/rgb.txt"))
    GTEST_SKIP() << "no " << kitchen << "/rgb.txt (shared data absent)";
  RecordingOptions o;
  o.max_frames = 16;  // pairs 0, 30, ..., 450: 8 fitted, 8 measured
  o.step = 30;
  const RecordingResult r = register_recording(kitchen, o);
  EXPECT_EQ(r.skipped, 0u);
  EXPECT_TRUE(r.held_out);
  std::printf(
      "RedKitchen, 8+8 pairs: before median %.2f px, after %.2f px; baseline %.1f mm, "
      "focal %.1f px\n",
      r.before.median_px, r.after.median_px, 1e3 * r.fit.camera.T_colour_depth.translation().norm(),
      r.fit.camera.intrinsics.fx);
  EXPECT_LT(r.after.median_px, 2.0);
  EXPECT_GT(r.before.median_px, 2.0 * r.after.median_px);
  // A Kinect v1: colour camera about 2.5 cm beside the depth camera, focal near 525 px.
  EXPECT_NEAR(r.fit.camera.T_colour_depth.translation().norm(), 0.025, 0.008);
  EXPECT_NEAR(r.fit.camera.intrinsics.fx, 525.0, 15.0);
}

}  // namespace
}  // namespace aoscan::colour_registration
