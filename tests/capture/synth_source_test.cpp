/// @file synth_source_test.cpp
/// @brief Tests for src/capture/synth_source.h: spec parsing, exact depth, the Kinect v1 noise
/// model, trajectories and determinism of the `synth:` source.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include <tbb/global_control.h>

#include "capture/synth_source.h"
#include "core/status.h"
#include "support/sim_reference.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// T_world_camera at `eye` looking along the world direction `forward` (world z up, no roll).
Pose looking(const Eigen::Vector3d& eye, const Eigen::Vector3d& forward) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  Eigen::Matrix3d R;
  R << x, z.cross(x), z;
  return Pose(R, eye);
}

SynthParams vga() {
  return parse_synth_spec("synth:plane");
}

// ---------------------------------------------------------------------------------------------
// Spec parsing

TEST(SynthSpec, DefaultsAndAllParameters) {
  const SynthParams d = parse_synth_spec("synth:corner");
  EXPECT_EQ(d.scene, "corner");
  EXPECT_EQ(d.frames, 300);
  EXPECT_EQ(d.width, 640);
  EXPECT_EQ(d.height, 480);
  EXPECT_EQ(d.noise, SynthNoise::kNone);
  EXPECT_EQ(d.seed, 1u);
  EXPECT_EQ(d.trajectory, SynthTrajectory::kOrbit);
  EXPECT_EQ(d.fps, 30.0);
  const Intrinsics k = d.intrinsics();
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_EQ(k.fy, 525.0);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);

  const SynthParams p = parse_synth_spec(
      "synth:room?frames=10&noise=kinect&seed=18446744073709551615&trajectory=sweep&width=320&"
      "height=200&fps=15.5");
  EXPECT_EQ(p.scene, "room");
  EXPECT_EQ(p.frames, 10);
  EXPECT_EQ(p.noise, SynthNoise::kKinect);
  EXPECT_EQ(p.seed, 18446744073709551615ULL);
  EXPECT_EQ(p.trajectory, SynthTrajectory::kSweep);
  EXPECT_EQ(p.fps, 15.5);
  const Intrinsics k2 = p.intrinsics();
  EXPECT_EQ(k2.width, 320);
  EXPECT_EQ(k2.height, 200);
  EXPECT_EQ(k2.fx, 262.5);
  EXPECT_EQ(k2.cx, 159.5);
  EXPECT_EQ(k2.cy, 99.5);
  EXPECT_EQ(parse_synth_spec("synth:plane?noise=none&trajectory=orbit&seed=0").seed, 0u);
}

TEST(SynthSpec, BadSpecsAreUsageErrorsNamingTheCulprit) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"synth:kitchen", "kitchen"},
      {"synth:", "unknown scene"},
      {"synth:corner?foo=1", "foo"},
      {"synth:corner?frames=0", "frames"},
      {"synth:corner?frames=abc", "frames"},
      {"synth:corner?frames=12x", "frames"},
      {"synth:corner?frames=", "frames"},
      {"synth:corner?noise=loud", "noise"},
      {"synth:corner?width=-3", "width"},
      {"synth:corner?height=0", "height"},
      {"synth:corner?seed=-1", "seed"},
      {"synth:corner?fps=0", "fps"},
      {"synth:corner?fps=nan", "fps"},
      {"synth:corner?trajectory=spiral", "trajectory"},
      {"synth:corner?frames=3&frames=4", "frames"},
      {"synth:corner?frames", "frames"},
      {"synth:corner?frames=3&", "not key=value"},
      {"corner?frames=3", "synth:"},
      {"synth:corner?noise=\nkinect", "noise"},
  };
  for (const auto& [spec, culprit] : cases) {
    SCOPED_TRACE(spec);
    for (int opener = 0; opener < 2; ++opener) {
      try {
        if (opener == 0) {
          parse_synth_spec(spec);
        } else {
          open_synth_source(spec);
        }
        ADD_FAILURE() << "no exception";
      } catch (const Error& e) {
        EXPECT_EQ(e.code(), ExitCode::kUsage);
        const std::string message = e.what();
        EXPECT_NE(message.find(culprit), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      }
    }
  }
  // Unknown parameters and scenes list the valid ones.
  try {
    parse_synth_spec("synth:corner?foo=1");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frames, width, height, noise, seed, trajectory, fps"),
              std::string::npos)
        << e.what();
  }
  try {
    parse_synth_spec("synth:kitchen");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("corner, room, plane"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// The Source interface

TEST(SynthSource, ReadsFramesWithExactPosesThenEnds) {
  const std::string spec = "synth:corner?frames=3&width=160&height=120&fps=20&seed=5";
  const std::unique_ptr<Source> source = open_synth_source(spec);
  EXPECT_EQ(source->name(), spec);
  ASSERT_TRUE(source->size().has_value());
  EXPECT_EQ(*source->size(), 3u);
  EXPECT_FALSE(source->live());
  EXPECT_EQ(source->depth_scale(), 5000.0);
  EXPECT_EQ(source->intrinsics().width, 160);
  EXPECT_EQ(source->intrinsics().fx, 525.0 / 4.0);
  ASSERT_NE(source->scene_mesh(), nullptr);
  EXPECT_EQ(source->scene_mesh()->faces.size(),
            AnalyticScene::make("corner").to_mesh().faces.size());

  const AnalyticScene scene = AnalyticScene::make("corner");
  DepthFrame frame;
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(source->read(frame).is_ok());
    EXPECT_EQ(frame.sequence, static_cast<std::uint64_t>(i));
    EXPECT_DOUBLE_EQ(frame.timestamp_s, i / 20.0);
    EXPECT_EQ(frame.origin, spec + " frame " + std::to_string(i));
    EXPECT_EQ(frame.depth_scale, 5000.0);
    EXPECT_EQ(frame.intrinsics, source->intrinsics());
    ASSERT_TRUE(frame.T_world_camera_gt.has_value());
    const Pose expected = synth_camera_pose("corner", SynthTrajectory::kOrbit, 5, i / 20.0);
    EXPECT_EQ(frame.T_world_camera_gt->matrix(), expected.matrix());
    Image<std::uint16_t> direct;
    SynthRenderOptions options;
    options.seed = 5;
    options.frame_index = i;
    render_synth_depth_reference(scene, source->intrinsics(), expected, options, direct);
    EXPECT_TRUE(frame.depth == direct);
  }
  EXPECT_EQ(source->read(frame).code(), Status::Code::kEndOfStream);
  EXPECT_EQ(source->read(frame).code(), Status::Code::kEndOfStream);
}

// ---------------------------------------------------------------------------------------------
// Exact depth (noise=none)

TEST(SynthRender, HeadOnPlaneGivesTheExactDepthEverywhere) {
  const AnalyticScene plane = AnalyticScene::make("plane");
  const Intrinsics k = vga().intrinsics();
  for (const double distance : {0.5, 1.23456, 2.0, 3.7}) {
    SCOPED_TRACE(distance);
    // The wall's front face is y = 0; the camera looks along +y.
    const Pose T_world_camera = looking({0.3, -distance, 1.0}, {0, 1, 0});
    Image<std::uint16_t> depth;
    render_synth_depth(plane, k, T_world_camera, SynthRenderOptions{}, depth);
    const int expected = static_cast<int>(std::lround(distance * 5000.0));
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) ASSERT_NEAR(depth(u, v), expected, 1) << u << "," << v;
    }
  }
  // Nothing hit (looking away) and beyond 13 m are invalid.
  Image<std::uint16_t> depth;
  render_synth_depth(plane, k, looking({0, -1, 1}, {0, -1, 0}), SynthRenderOptions{}, depth);
  EXPECT_EQ(std::count(depth.data(), depth.data() + depth.size(), 0),
            static_cast<long>(depth.size()));
  render_synth_depth(plane, k, looking({0, -13.5, 1}, {0, 1, 0}), SynthRenderOptions{}, depth);
  EXPECT_EQ(std::count(depth.data(), depth.data() + depth.size(), 0),
            static_cast<long>(depth.size()));
}

/// Fraction of valid pixels and, per valid pixel, checks that the back-projected point lies on the
/// scene surface within the 0.1 mm rounding of the depth (stretched along the pixel's ray).
double check_frame_on_surface(const AnalyticScene& scene, const DepthFrame& frame) {
  const Intrinsics& k = frame.intrinsics;
  const Pose& T = *frame.T_world_camera_gt;
  long valid = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const std::uint16_t raw = frame.depth(u, v);
      if (raw == 0) continue;
      ++valid;
      const Eigen::Vector3d ray = k.unproject(static_cast<double>(u), static_cast<double>(v), 1.0);
      const double bound = 0.5 / frame.depth_scale * ray.norm() + 1e-9;
      const Eigen::Vector3d p_world = T * (ray * (raw / frame.depth_scale));
      const double d = scene.distance(p_world);
      if (d >= bound) {
        ADD_FAILURE() << frame.origin << " pixel " << u << "," << v << ": " << d << " m off";
        return 0.0;
      }
    }
  }
  return static_cast<double>(valid) / static_cast<double>(k.width * k.height);
}

TEST(SynthRender, ExactFramesBackProjectOntoTheSurfaceAndCoverTheCorner) {
  const AnalyticScene scene = AnalyticScene::make("corner");
  const SynthParams params = parse_synth_spec("synth:corner");
  for (const SynthTrajectory trajectory : {SynthTrajectory::kOrbit, SynthTrajectory::kSweep}) {
    SCOPED_TRACE(trajectory == SynthTrajectory::kOrbit ? "orbit" : "sweep");
    double worst_valid = 1.0;
    long in_range = 0;
    long total_valid = 0;
    DepthFrame frame;
    frame.intrinsics = params.intrinsics();
    frame.depth_scale = kSynthDepthScale;
    // Frames 0, 60, ..., 299 of the default 300-frame stream (what the source renders there);
    // every pixel of the first and last is checked against the surface.
    for (int i = 0; i <= 300; i += 60) {
      const int index = std::min(i, 299);
      frame.T_world_camera_gt = synth_camera_pose("corner", trajectory, 1, index / 30.0);
      frame.origin = "frame " + std::to_string(index);
      render_synth_depth(scene, frame.intrinsics, *frame.T_world_camera_gt, SynthRenderOptions{},
                         frame.depth);
      long valid = 0;
      for (std::size_t j = 0; j < frame.depth.size(); ++j) {
        const double z = frame.depth.data()[j] / frame.depth_scale;
        if (z == 0.0) continue;
        ++valid;
        in_range += (z >= 0.5 && z <= 3.5);
      }
      total_valid += valid;
      worst_valid = std::min(worst_valid, static_cast<double>(valid) / frame.depth.size());
      if (index == 0 || index == 299) {
        EXPECT_EQ(check_frame_on_surface(scene, frame),
                  static_cast<double>(valid) / frame.depth.size());
      }
    }
    const double in_range_fraction = static_cast<double>(in_range) / total_valid;
    std::printf("worst valid fraction %.3f, depths in [0.5, 3.5] m: %.3f\n", worst_valid,
                in_range_fraction);
    EXPECT_GE(worst_valid, 0.9);
    EXPECT_GE(in_range_fraction, 0.9);
  }
}

TEST(SynthRender, ColourIsThePrimitiveEachPixelSees) {
  const AnalyticScene scene = AnalyticScene::make("corner");
  const Intrinsics k = synth_intrinsics(160, 120);
  const Pose pose = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 3.0);
  Image<std::uint16_t> depth;
  Image<Rgb8> colour;
  render_synth_depth(scene, k, pose, SynthRenderOptions{}, depth);
  render_synth_colour(scene, k, pose, colour);
  ASSERT_EQ(colour.width(), 160);
  int checked = 0, other = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const double z = depth(u, v) / kSynthDepthScale;
      if (z == 0.0) {
        EXPECT_EQ(colour(u, v), Rgb8{});
        continue;
      }
      const Eigen::Vector3d p = pose.rotation() * k.unproject(u, v, z) + pose.translation();
      const auto s = scene.nearest_surface_point(p, 0.001);
      ASSERT_TRUE(s.has_value());
      ++checked;
      // At an edge the nearest point may be the touching primitive's.
      other += colour(u, v) != scene.colour(s->primitive);
    }
  EXPECT_GT(checked, 15000);
  EXPECT_LE(other, checked / 200);
  // Neighbouring primitives differ in colour, and colour=on delivers it registered.
  EXPECT_NE(scene.colour(0), scene.colour(1));
  DepthFrame frame;
  render_synth_frame(scene, parse_synth_spec("synth:corner?colour=on&width=160&height=120"), 90,
                     frame);
  ASSERT_TRUE(frame.colour_camera.has_value());
  EXPECT_TRUE(frame.colour_camera->registered);
  EXPECT_EQ(frame.colour(40, 50), colour(40, 50));
  render_synth_frame(scene, parse_synth_spec("synth:corner?colour=off&width=160&height=120"), 90,
                     frame);
  EXPECT_TRUE(frame.colour.empty());
  EXPECT_FALSE(frame.colour_camera.has_value());
  EXPECT_THROW(parse_synth_spec("synth:corner?colour=yes"), Error);
}

// ---------------------------------------------------------------------------------------------
// Kinect v1 noise

TEST(SynthRender, KinectNoiseOnAPlaneMatchesTheAxialModelAndQuantisation) {
  const AnalyticScene plane = AnalyticScene::make("plane");
  const Intrinsics k = vga().intrinsics();
  for (const double z : {1.0, 2.0, 3.0}) {
    SCOPED_TRACE(z);
    SynthRenderOptions options;
    options.noise = SynthNoise::kKinect;
    options.seed = 3;
    Image<std::uint16_t> depth;
    render_synth_depth(plane, k, looking({0.0, -z, 1.0}, {0, 1, 0}), options, depth);
    double sum = 0.0;
    double sum_sq = 0.0;
    long n = 0;
    for (std::size_t j = 0; j < depth.size(); ++j) {
      if (depth.data()[j] == 0) continue;
      const double error = depth.data()[j] / 5000.0 - z;
      sum += error;
      sum_sq += error * error;
      ++n;
    }
    // Head-on at 1-3 m: no dropouts (incidence < 38 deg), nothing out of range.
    EXPECT_EQ(n, static_cast<long>(depth.size()));
    const double mean = sum / n;
    const double std_dev = std::sqrt(sum_sq / n - mean * mean);
    // Quantising z + N(0, sigma) with a step q adds q^2 / 12 to the variance (Sheppard; accurate
    // to < 2 % for sigma > q / 2, which holds here); the raw 0.2 mm step adds its own.
    const double q = z * z / (k.fx * kKinectBaselineM) * kKinectDisparityStepPx;
    const double sigma = kinect_axial_sigma_m(z);
    const double expected = std::sqrt(sigma * sigma + q * q / 12.0 + 0.0002 * 0.0002 / 12.0);
    std::printf("z %.1f m: std %.3f mm, model %.3f mm (sigma %.3f, step %.3f), mean %+.3f mm\n", z,
                std_dev * 1e3, expected * 1e3, sigma * 1e3, q * 1e3, mean * 1e3);
    EXPECT_NEAR(std_dev, expected, 0.05 * expected);
    EXPECT_LT(std::abs(mean), 0.1 * expected);
  }
}

TEST(SynthRender, KinectDropsOutAtGrazingIncidence) {
  const AnalyticScene plane = AnalyticScene::make("plane");
  const Intrinsics k = vga().intrinsics();
  // 0.6 m from the wall, looking 65 deg away from its normal: incidence spans ~35-95 deg.
  const double yaw = 65.0 * kPi / 180.0;
  const Pose T = looking({0.0, -0.6, 1.0}, {std::sin(yaw), std::cos(yaw), 0.0});
  SynthRenderOptions options;
  options.noise = SynthNoise::kKinect;
  Image<std::uint16_t> depth;
  render_synth_depth(plane, k, T, options, depth);
  long low = 0, low_valid = 0, ramp = 0, ramp_valid = 0, grazing = 0, grazing_valid = 0;
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray_camera = k.unproject(double(u), double(v), 1.0);
      const Eigen::Vector3d d = T.rotation() * ray_camera.normalized();
      if (d.y() <= 0.0) continue;  // parallel to or away from the wall
      const double incidence = std::acos(d.y()) * 180.0 / kPi;
      const double z = 0.6 / d.y() / ray_camera.norm();  // exact depth along the optical axis
      const bool valid = depth(u, v) != 0;
      if (incidence > 80.5) {
        ++grazing;
        grazing_valid += valid;
      } else if (incidence > 72.0 && incidence < 78.0) {
        ++ramp;
        ramp_valid += valid;
      } else if (incidence < 69.5 && z > 0.5 && z < 4.2) {
        ++low;
        low_valid += valid;
      }
    }
  }
  std::printf("valid: %ld/%ld below 69.5 deg, %ld/%ld in 72-78 deg, %ld/%ld above 80.5 deg\n",
              low_valid, low, ramp_valid, ramp, grazing_valid, grazing);
  ASSERT_GT(low, 10000);
  ASSERT_GT(ramp, 10000);
  ASSERT_GT(grazing, 10000);
  EXPECT_EQ(low_valid, low);
  EXPECT_EQ(grazing_valid, 0);
  // The dropout probability ramps linearly from 70 to 80 deg: about half survive at 72-78 deg.
  const double survived = static_cast<double>(ramp_valid) / ramp;
  EXPECT_GT(survived, 0.35);
  EXPECT_LT(survived, 0.65);
}

TEST(SynthRender, KinectRangeLimits) {
  const AnalyticScene plane = AnalyticScene::make("plane");
  const Intrinsics k = vga().intrinsics();
  SynthRenderOptions options;
  options.noise = SynthNoise::kKinect;
  Image<std::uint16_t> depth;
  for (const double z : {0.3, 5.0}) {
    render_synth_depth(plane, k, looking({0.0, -z, 1.0}, {0, 1, 0}), options, depth);
    EXPECT_EQ(std::count(depth.data(), depth.data() + depth.size(), 0),
              static_cast<long>(depth.size()))
        << z;
  }
}

TEST(SynthRender, SeedsAndFramesKeyTheNoise) {
  const std::string base = "synth:corner?frames=2&width=320&height=240&noise=kinect";
  auto read = [](const std::string& spec, int index) {
    const std::unique_ptr<Source> source = open_synth_source(spec);
    DepthFrame frame;
    for (int i = 0; i <= index; ++i) EXPECT_TRUE(source->read(frame).is_ok());
    return frame;
  };
  const DepthFrame a = read(base + "&seed=9", 1);
  const DepthFrame b = read(base + "&seed=9", 1);
  const DepthFrame c = read(base + "&seed=10", 1);
  EXPECT_TRUE(a.depth == b.depth);
  EXPECT_EQ(a.T_world_camera_gt->matrix(), b.T_world_camera_gt->matrix());
  EXPECT_FALSE(a.depth == c.depth);
  long differing = 0;
  for (std::size_t j = 0; j < a.depth.size(); ++j)
    differing += a.depth.data()[j] != c.depth.data()[j];
  EXPECT_GT(differing, static_cast<long>(a.depth.size() / 2));
  // Another frame index at the same pose draws different noise.
  const AnalyticScene scene = AnalyticScene::make("corner");
  SynthRenderOptions options;
  options.noise = SynthNoise::kKinect;
  options.seed = 9;
  options.frame_index = 7;
  Image<std::uint16_t> other;
  render_synth_depth(scene, a.intrinsics, *a.T_world_camera_gt, options, other);
  EXPECT_FALSE(other == a.depth);
}

TEST(SynthRender, TiledParallelRendererMatchesTheReferenceExactly) {
  // A size that is not a multiple of the tile size, so partial tiles are covered too.
  const Intrinsics k = parse_synth_spec("synth:plane?width=330&height=250").intrinsics();
  for (const std::string& name : AnalyticScene::names()) {
    const AnalyticScene scene = AnalyticScene::make(name);
    for (const SynthTrajectory trajectory : {SynthTrajectory::kOrbit, SynthTrajectory::kSweep}) {
      for (const double time_s : {0.0, 11.3}) {
        SCOPED_TRACE(name + " t=" + std::to_string(time_s));
        const Pose T = synth_camera_pose(name, trajectory, 4, time_s);
        for (const SynthNoise noise : {SynthNoise::kNone, SynthNoise::kKinect}) {
          SynthRenderOptions options;
          options.noise = noise;
          options.frame_index = static_cast<std::uint64_t>(time_s * 30);
          Image<std::uint16_t> reference, fast;
          render_synth_depth_reference(scene, k, T, options, reference);
          render_synth_depth(scene, k, T, options, fast);
          ASSERT_TRUE(fast == reference);
        }
      }
    }
  }
}

TEST(SynthRender, ManyPrimitivesRenderWithoutCullingAndStillMatch) {
  // More primitives than a tile can list: tiles fall back to testing everything.
  AnalyticScene scene("crowd");
  scene.add_box({-5, -5, -0.1}, {5, 5, 0});
  for (int i = 0; i < 70; ++i) {
    const double x = -2.0 + 0.5 * (i % 10);
    const double y = 1.0 + 0.5 * (i / 10);
    scene.add_box({x, y, 0}, {x + 0.2, y + 0.2, 0.1 + 0.01 * i});
    scene.add_sphere({x + 0.25, y + 0.3, 0.1}, 0.1);
  }
  const Intrinsics k = parse_synth_spec("synth:plane?width=200&height=150").intrinsics();
  const Pose T = looking({0.1, -1.5, 1.5}, {0, 1, -0.8});
  Image<std::uint16_t> reference, fast;
  render_synth_depth_reference(scene, k, T, SynthRenderOptions{}, reference);
  render_synth_depth(scene, k, T, SynthRenderOptions{}, fast);
  EXPECT_TRUE(fast == reference);
  EXPECT_EQ(std::count(fast.data(), fast.data() + fast.size(), 0), 0);
}

TEST(SynthRender, IdenticalForAnyThreadCount) {
  const AnalyticScene scene = AnalyticScene::make("corner");
  const Intrinsics k = vga().intrinsics();
  const Pose T = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 3.0);
  for (const SynthNoise noise : {SynthNoise::kNone, SynthNoise::kKinect}) {
    SynthRenderOptions options;
    options.noise = noise;
    options.frame_index = 90;
    Image<std::uint16_t> reference, one, two;
    render_synth_depth_reference(scene, k, T, options, reference);
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      render_synth_depth(scene, k, T, options, one);
    }
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
      render_synth_depth(scene, k, T, options, two);
    }
    EXPECT_TRUE(one == reference);
    EXPECT_TRUE(two == reference);
  }
}


// ---------------------------------------------------------------------------------------------
// Trajectories

TEST(SynthTrajectory, SmoothHandheldStepsAndNeverInsideGeometry) {
  for (const std::string& name : AnalyticScene::names()) {
    const AnalyticScene scene = AnalyticScene::make(name);
    for (const SynthTrajectory trajectory : {SynthTrajectory::kOrbit, SynthTrajectory::kSweep}) {
      for (const std::uint64_t seed : {1ull, 2ull, 12345ull}) {
        SCOPED_TRACE(name + (trajectory == SynthTrajectory::kOrbit ? " orbit" : " sweep") +
                     " seed " + std::to_string(seed));
        double max_step_m = 0.0;
        double max_turn_deg = 0.0;
        double min_clearance_m = 1e9;
        Pose previous = synth_camera_pose(name, trajectory, seed, 0.0);
        // Two full periods of every path at 30 Hz.
        for (int i = 1; i <= 1440; ++i) {
          const Pose pose = synth_camera_pose(name, trajectory, seed, i / 30.0);
          const Pose delta = previous.inverse() * pose;
          max_step_m = std::max(max_step_m, delta.translation().norm());
          max_turn_deg =
              std::max(max_turn_deg, Eigen::AngleAxisd(delta.rotation()).angle() * 180.0 / kPi);
          min_clearance_m = std::min(min_clearance_m, scene.signed_distance(pose.translation()));
          ASSERT_NEAR(
              (pose.rotation().transpose() * pose.rotation() - Eigen::Matrix3d::Identity()).norm(),
              0.0, 1e-12);
          ASSERT_NEAR(pose.rotation().determinant(), 1.0, 1e-12);
          previous = pose;
        }
        std::printf("%s: max step %.2f cm, max turn %.3f deg, min clearance %.2f m\n",
                    testing::UnitTest::GetInstance()->current_test_info()->name(), max_step_m * 100,
                    max_turn_deg, min_clearance_m);
        EXPECT_LE(max_step_m, 0.015);
        EXPECT_LE(max_turn_deg, 1.5);
        EXPECT_GT(max_step_m, 0.001);  // it does move
        EXPECT_GT(min_clearance_m, 0.3);
      }
    }
  }
}

TEST(SynthTrajectory, SeedChangesOnlyTheWobble) {
  const Pose a = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 4.0);
  const Pose b = synth_camera_pose("corner", SynthTrajectory::kOrbit, 1, 4.0);
  const Pose c = synth_camera_pose("corner", SynthTrajectory::kOrbit, 2, 4.0);
  EXPECT_EQ(a.matrix(), b.matrix());
  const double shift = (a.translation() - c.translation()).norm();
  EXPECT_GT(shift, 1e-4);
  EXPECT_LT(shift, 0.06);
  EXPECT_THROW(synth_camera_pose("kitchen", SynthTrajectory::kOrbit, 1, 0.0), Error);
}

TEST(SynthTrajectory, EveryBuiltInPathSeesPlentyOfSurface) {
  SynthParams params = parse_synth_spec("synth:plane?width=160&height=120");
  const Intrinsics k = params.intrinsics();
  for (const std::string& name : AnalyticScene::names()) {
    const AnalyticScene scene = AnalyticScene::make(name);
    for (const SynthTrajectory trajectory : {SynthTrajectory::kOrbit, SynthTrajectory::kSweep}) {
      SCOPED_TRACE(name + (trajectory == SynthTrajectory::kOrbit ? " orbit" : " sweep"));
      double worst = 1.0;
      Image<std::uint16_t> depth;
      // Every 0.8 s over one full period (24 s).
      for (int i = 0; i < 720; i += 24) {
        const Pose T = synth_camera_pose(name, trajectory, 1, i / 30.0);
        render_synth_depth(scene, k, T, SynthRenderOptions{}, depth);
        const long valid = static_cast<long>(depth.size()) -
                           std::count(depth.data(), depth.data() + depth.size(), 0);
        worst = std::min(worst, static_cast<double>(valid) / depth.size());
      }
      EXPECT_GE(worst, 0.9);
    }
  }
}

}  // namespace
}  // namespace aoscan
