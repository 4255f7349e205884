// Tests for src/fusion/tsdf/colour_volume.cpp: colour fused from registered and unregistered
// colour cameras against the exact colour of the scene, the running mean and its cap, sampling,
// thread independence, bad input.
#include "fusion/tsdf/colour_volume.h"

#include <cmath>
#include <cstring>
#include <limits>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "geometry/simd.h"
#include "support/test_scenes.h"
#include "support/tsdf_reference.h"

namespace aoscan {
namespace {

const Intrinsics kDepth{640, 480, 585.0, 585.0, 320.0, 240.0};
constexpr double kPlaneZ = 1.5;
constexpr Rgb8 kLeft{200, 30, 40}, kRight{20, 60, 220};

/// The scene's colour at a point of the plane: red left of x = 0, blue right of it.
Rgb8 scene_colour(double x_world) {
  return x_world < 0.0 ? kLeft : kRight;
}

/// The colour image `camera` sees of the plane z = kPlaneZ (depth camera = world frame). The
/// camera is only translated from the depth camera, so its rays meet the plane at depth
/// kPlaneZ + t.z in its own frame.
Image<Rgb8> render_colour(const ColourCamera& camera) {
  const Intrinsics& k = camera.intrinsics;
  const Eigen::Vector3d centre = camera.T_colour_depth.inverse().translation();
  const double depth = kPlaneZ - centre.z();
  Image<Rgb8> image(k.width, k.height);
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u)
      image(u, v) = scene_colour(centre.x() + (u - k.cx) / k.fx * depth);
  return image;
}

/// An unregistered colour camera beside the depth camera: 2.5 cm to the side, turned 0.01 rad.
ColourCamera offset_colour_camera() {
  ColourCamera camera;
  camera.intrinsics = Intrinsics{640, 480, 525.0, 525.0, 319.5, 239.5};
  camera.T_colour_depth = Pose(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                               Eigen::Vector3d(-0.025, 0.001, 0.002));
  return camera;
}

/// A colour image whose every pixel differs from its neighbours.
Image<Rgb8> textured_image() {
  Image<Rgb8> image(640, 480);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u)
      image(u, v) = Rgb8{static_cast<std::uint8_t>((u * 7 + v * 3) % 256),
                         static_cast<std::uint8_t>((u * v) % 251),
                         static_cast<std::uint8_t>((u ^ v) & 255)};
  return image;
}

struct Fused {
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  ColourVolume colour;
  Image<float> depth;
};

void fuse(Fused& f, const ColourCamera& camera, const Image<Rgb8>& image, int max_weight = 16) {
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), kPlaneZ});
  test::render(scene, kDepth, Pose::identity(), f.depth);
  ColourIntegration visitor(f.colour, {&f.depth, kDepth, Pose::identity(), &image, camera,
                                      2.0f * f.volume.voxel_size_m(), f.volume.truncation_m(),
                                      max_weight});
  f.integrator.integrate(f.volume, f.depth, kDepth, Pose::identity(), &visitor);
  visitor.finish();
}

/// Every coloured voxel more than `margin` from the colour boundary x = 0 has the scene's colour.
void expect_exact_away_from_boundary(const Fused& f, double margin) {
  int checked = 0;
  for (int i = 0; i < f.volume.block_count(); ++i) {
    const ColourBlock* cb = f.colour.block(i);
    if (cb == nullptr) continue;
    const Eigen::Vector3i base = f.volume.block_coord(i) * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x) {
          const ColourVoxel& c = cb->voxels[static_cast<std::size_t>(voxel_index(x, y, z))];
          if (c.weight == 0) continue;
          const double xw = (base.x() + x) * static_cast<double>(f.volume.voxel_size_m());
          if (std::abs(xw) < margin) continue;
          const Rgb8 want = scene_colour(xw);
          ASSERT_EQ((Rgb8{c.r, c.g, c.b}), want) << "voxel at x = " << xw;
          ++checked;
        }
  }
  EXPECT_GT(checked, 10000);
}

TEST(ColourVolume, RegisteredColourIsExactOnTheSurface) {
  Fused f;
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  fuse(f, camera, render_colour(camera));
  EXPECT_GT(f.colour.block_count(), 0u);
  // A voxel's depth pixel sees the plane's colour at the voxel's own x up to half a pixel.
  expect_exact_away_from_boundary(f, 2.0 * kPlaneZ / kDepth.fx);
  Rgb8 out;
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(-0.2f, 0.1f, kPlaneZ), out));
  EXPECT_EQ(out, kLeft);
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(0.3f, -0.1f, kPlaneZ), out));
  EXPECT_EQ(out, kRight);
  // Far from every coloured voxel there is no colour.
  EXPECT_FALSE(f.colour.sample(f.volume, Eigen::Vector3f(0.0f, 0.0f, 0.5f), out));
}

/// Whether voxel `v` (integer voxel coordinates) of the fused volume has a colour.
bool coloured(const Fused& f, const Eigen::Vector3i& v) {
  const ColourBlock* cb = f.colour.block(f.volume.find_block({v.x() >> 3, v.y() >> 3, v.z() >> 3}));
  return cb != nullptr &&
         cb->voxels[static_cast<std::size_t>(voxel_index(v.x() & 7, v.y() & 7, v.z() & 7))].weight >
             0;
}

TEST(ColourVolume, APointOffTheShellTakesTheNearestColourWithinReach) {
  // A mesh vertex whose eight voxels have no colour (between two surfaces at a depth edge, or on
  // a surface the colour frames missed) takes the nearest coloured voxel within sqrt(8.5) voxels.
  Fused f;
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  fuse(f, camera, render_colour(camera));
  const float vs = f.volume.voxel_size_m();
  const int x = -26, y = 13;  // a voxel column left of the colour boundary, x = -0.2 m
  int last = static_cast<int>(std::lround(kPlaneZ / vs));
  while (coloured(f, {x, y, last + 1})) ++last;  // the shell's last coloured voxel behind the plane
  ASSERT_TRUE(coloured(f, {x, y, last}));
  Rgb8 out;
  // 2.5 voxels beyond it (beyond the sqrt(3.5) voxels of the search before): its colour.
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(x * vs, y * vs, (last + 2.5f) * vs), out));
  EXPECT_EQ(out, kLeft);
  // 3 voxels beyond it: none within reach.
  EXPECT_FALSE(f.colour.sample(f.volume, Eigen::Vector3f(x * vs, y * vs, (last + 3.0f) * vs), out));
  // Right of the boundary (x = +0.2 m) the same: its colour. The 6^3 voxels searched around
  // x = -26 and x = 26 span two blocks along x (-32..-25 and -24..-17; 24..31 and 16..23).
  ASSERT_TRUE(coloured(f, {-x, y, last}));
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(-x * vs, y * vs, (last + 2.5f) * vs), out));
  EXPECT_EQ(out, kRight);
}

TEST(ColourVolume, UnregisteredColourCameraIsProjectedThroughItsCalibration) {
  Fused f;
  ColourCamera camera;
  camera.intrinsics = Intrinsics{1280, 960, 1050.0, 1050.0, 640.0, 480.0};
  // The colour camera 5 cm right of and 1 cm behind the depth camera.
  camera.T_colour_depth = Pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.05, 0.0, 0.01));
  fuse(f, camera, render_colour(camera));
  // Bilinear samples blend within a colour pixel of the boundary.
  expect_exact_away_from_boundary(f, 0.01);
  Rgb8 out;
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(-0.25f, 0.0f, kPlaneZ), out));
  EXPECT_EQ(out, kLeft);
  // Taking the colour camera's image as registered instead puts the boundary 4.5 cm left of
  // where it is: a red voxel 3 cm left of it comes out blue.
  Fused wrong;
  const ColourCamera as_registered = ColourCamera::registered_to(kDepth);
  Image<Rgb8> shifted(kDepth.width, kDepth.height);
  const Image<Rgb8> image = render_colour(camera);
  for (int v = 0; v < kDepth.height; ++v)
    for (int u = 0; u < kDepth.width; ++u) shifted(u, v) = image(2 * u, 2 * v);
  fuse(wrong, as_registered, shifted);
  ASSERT_TRUE(wrong.colour.sample(wrong.volume, Eigen::Vector3f(-0.03f, 0.0f, kPlaneZ), out));
  EXPECT_EQ(out, kRight);
}

TEST(ColourVolume, RunningMeanWithCappedWeight) {
  Fused f;
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  Image<Rgb8> grey(kDepth.width, kDepth.height, Rgb8{100, 100, 100});
  Image<Rgb8> white(kDepth.width, kDepth.height, Rgb8{200, 200, 200});
  fuse(f, camera, grey, 2);
  Rgb8 out;
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(0.1f, 0.1f, kPlaneZ), out));
  EXPECT_EQ(out, (Rgb8{100, 100, 100}));
  // Weight 1 and one more frame (of the same depth): the mean of the two.
  fuse(f, camera, white, 2);
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(0.1f, 0.1f, kPlaneZ), out));
  EXPECT_EQ(out, (Rgb8{150, 150, 150}));
  // The cap of 2: (150 * 2 + 200) / 3.
  fuse(f, camera, white, 2);
  ASSERT_TRUE(f.colour.sample(f.volume, Eigen::Vector3f(0.1f, 0.1f, kPlaneZ), out));
  EXPECT_EQ(out, (Rgb8{167, 167, 167}));
}

TEST(ColourVolume, OnlyTheShellOfTheSurfaceIsColoured) {
  Fused f;
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  fuse(f, camera, render_colour(camera));
  // The shell: 2 voxels either side of the plane (the fused TSDF of a frontal plane is exact).
  const float band = 2.0f * f.volume.voxel_size_m();
  for (int i = 0; i < f.volume.block_count(); ++i) {
    const ColourBlock* cb = f.colour.block(i);
    if (cb == nullptr) continue;
    const Eigen::Vector3i base = f.volume.block_coord(i) * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x)
          if (cb->voxels[static_cast<std::size_t>(voxel_index(x, y, z))].weight > 0) {
            ASSERT_LE(std::abs((base.z() + z) * f.volume.voxel_size_m() - kPlaneZ), band + 1e-6);
          }
  }
}

TEST(ColourVolume, SameColourForOneAndTwoThreads) {
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  Fused one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    fuse(one, camera, render_colour(camera));
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    fuse(two, camera, render_colour(camera));
  }
  ASSERT_EQ(one.colour.block_count(), two.colour.block_count());
  for (int i = 0; i < one.volume.block_count(); ++i) {
    ASSERT_EQ(one.colour.block(i) == nullptr, two.colour.block(i) == nullptr);
    if (one.colour.block(i) != nullptr) {
      ASSERT_EQ(0, std::memcmp(one.colour.block(i), two.colour.block(i), sizeof(ColourBlock)));
    }
  }
}

// The colour fused inside the depth integration (ColourIntegration as the integrator's block
// visitor, what Reconstruction does) against the plain pass over the updated blocks afterwards,
// one block after another (test::colour_pass_after):
// the same colour blocks byte for byte, frame after frame, for a camera that moves over a sphere
// in front of a wall and an unregistered colour camera with a textured image.
TEST(ColourVolume, FusedInsideTheDepthIntegrationEqualsThePassAfterIt) {
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 2.0});
  scene.spheres.push_back({Eigen::Vector3d(0.1, 0.0, 1.4), 0.25});
  const ColourCamera camera = offset_colour_camera();
  const Image<Rgb8> image = textured_image();
  TsdfVolume fused_volume{FusionConfig{}}, plain_volume{FusionConfig{}};
  TsdfIntegrator fused_integrator, plain_integrator;
  ColourVolume fused, plain;
  Image<float> depth;
  for (int frame = 0; frame < 4; ++frame) {
    const Pose T_world_camera(
        Eigen::AngleAxisd(0.04 * frame, Eigen::Vector3d::UnitY()).toRotationMatrix(),
        Eigen::Vector3d(0.03 * frame, -0.01 * frame, 0.0));
    test::render(scene, kDepth, T_world_camera, depth);
    const float shell = 2.0f * fused_volume.voxel_size_m();
    ColourIntegration visitor(fused, {&depth, kDepth, T_world_camera, &image, camera, shell,
                                      fused_volume.truncation_m(), 8});
    fused_integrator.integrate(fused_volume, depth, kDepth, T_world_camera, &visitor);
    const ColourIntegrateStats a = visitor.finish();
    plain_integrator.integrate(plain_volume, depth, kDepth, T_world_camera);
    const ColourIntegrateStats b = test::colour_pass_after(
        plain, plain_volume, plain_integrator.updated_blocks(),
        {&depth, kDepth, T_world_camera, &image, camera, shell, plain_volume.truncation_m(), 8});
    ASSERT_GT(a.voxels_coloured, 1000) << "frame " << frame;
    EXPECT_EQ(a.voxels_coloured, b.voxels_coloured) << "frame " << frame;
    EXPECT_EQ(a.blocks_allocated, b.blocks_allocated) << "frame " << frame;
    ASSERT_EQ(fused.block_count(), plain.block_count()) << "frame " << frame;
    ASSERT_EQ(fused_volume.block_count(), plain_volume.block_count());
    for (int i = 0; i < fused_volume.block_count(); ++i) {
      ASSERT_EQ(fused.block(i) == nullptr, plain.block(i) == nullptr) << "block " << i;
      if (fused.block(i) != nullptr) {
        ASSERT_EQ(0, std::memcmp(fused.block(i), plain.block(i), sizeof(ColourBlock)))
            << "frame " << frame << ", block " << i;
      }
    }
  }
  // A frame whose pose is not finite is not integrated: the visitor reports nothing.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Pose bad(Eigen::Matrix3d::Identity(), Eigen::Vector3d(nan, 0.0, 0.0));
  ColourIntegration visitor(fused, {&depth, kDepth, bad, &image, camera, 0.01f, 0.02f, 8});
  fused_integrator.integrate(fused_volume, depth, kDepth, bad, &visitor);
  EXPECT_EQ(visitor.finish().voxels_coloured, 0);
}

// The AVX2 kernels (the projection of the shell's voxels, the running mean) against the portable
// code: the same colour blocks byte for byte, frame after frame, for a registered and an
// unregistered colour camera, a textured image and a weight cap the frames reach.
TEST(ColourVolume, TheAvx2KernelsColourLikeThePortableCode) {
#if defined(__x86_64__)
  if (!cpu_has_avx2()) GTEST_SKIP() << "this CPU has no AVX2: only the portable code runs";
#else
  GTEST_SKIP() << "no AVX2 kernels on this architecture";
#endif
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 2.0});
  scene.spheres.push_back({Eigen::Vector3d(0.1, 0.0, 1.4), 0.25});
  const Image<Rgb8> image = textured_image();
  for (const ColourCamera& camera : {ColourCamera::registered_to(kDepth), offset_colour_camera()}) {
    TsdfVolume volume{FusionConfig{}};
    TsdfIntegrator integrator;
    ColourVolume fast, portable;
    Image<float> depth;
    for (int frame = 0; frame < 6; ++frame) {
      const Pose T_world_camera(
          Eigen::AngleAxisd(0.03 * frame, Eigen::Vector3d::UnitY()).toRotationMatrix(),
          Eigen::Vector3d(0.02 * frame, -0.01 * frame, 0.01 * frame));
      test::render(scene, kDepth, T_world_camera, depth);
      integrator.integrate(volume, depth, kDepth, T_world_camera);
      const ColourFrameInput input{&depth, kDepth, T_world_camera, &image, camera,
                                   2.0f * volume.voxel_size_m(), volume.truncation_m(), 4};
      ColourIntegration a(fast, input, true), b(portable, input, false);
      const std::vector<int>& blocks = integrator.updated_blocks();
      a.begin(volume, blocks);
      b.begin(volume, blocks);
      for (std::size_t k = 0; k < blocks.size(); ++k) {
        a.visit(volume, k);
        b.visit(volume, k);
      }
      const ColourIntegrateStats sa = a.finish(), sb = b.finish();
      ASSERT_GT(sa.voxels_coloured, 1000) << "frame " << frame;
      EXPECT_EQ(sa.voxels_coloured, sb.voxels_coloured) << "frame " << frame;
      EXPECT_EQ(sa.blocks_allocated, sb.blocks_allocated) << "frame " << frame;
      ASSERT_EQ(fast.block_count(), portable.block_count()) << "frame " << frame;
      for (int i = 0; i < volume.block_count(); ++i) {
        ASSERT_EQ(fast.block(i) == nullptr, portable.block(i) == nullptr) << "block " << i;
        if (fast.block(i) != nullptr) {
          ASSERT_EQ(0, std::memcmp(fast.block(i), portable.block(i), sizeof(ColourBlock)))
              << "frame " << frame << ", block " << i;
        }
      }
    }
  }
}

TEST(ColourVolume, BadInputIsRefusedOrIgnored) {
  Fused f;
  const ColourCamera camera = ColourCamera::registered_to(kDepth);
  const Image<Rgb8> image = render_colour(camera);
  fuse(f, camera, image);
  const std::size_t blocks = f.colour.block_count();
  const Image<Rgb8> small(320, 240);
  EXPECT_THROW(ColourIntegration(f.colour, {&f.depth, kDepth, Pose::identity(), &small, camera,
                                            0.01f, 0.02f, 16}),
               Error);
  const Image<float> small_depth(320, 240, 1.0f);
  EXPECT_THROW(ColourIntegration(f.colour, {&small_depth, kDepth, Pose::identity(), &image, camera,
                                            0.01f, 0.02f, 16}),
               Error);
  // A pose that is not finite is not integrated, and changes no colour.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Pose bad(Eigen::Matrix3d::Identity(), Eigen::Vector3d(nan, 0.0, 0.0));
  ColourIntegration visitor(f.colour, {&f.depth, kDepth, bad, &image, camera, 0.01f, 0.02f, 16});
  f.integrator.integrate(f.volume, f.depth, kDepth, bad, &visitor);
  EXPECT_EQ(visitor.finish().voxels_coloured, 0);
  EXPECT_EQ(f.colour.block_count(), blocks);
  f.colour.reset();
  EXPECT_EQ(f.colour.block_count(), 0u);
  Rgb8 out;
  EXPECT_FALSE(f.colour.sample(f.volume, Eigen::Vector3f(0.1f, 0.1f, kPlaneZ), out));
}

}  // namespace
}  // namespace aoscan
