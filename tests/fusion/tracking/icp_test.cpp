// Tests for src/fusion/tracking/icp.cpp: recovery of known motions against a fused analytic scene,
// lost / poor detection, reduction determinism, and a short noisy sequence through
// integrate -> raycast -> icp with its trajectory error; the model normal smoothing that tracking
// reads (src/geometry/normal_smoothing.cpp).
#include "fusion/tracking/icp.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <Eigen/Eigenvalues>

#include "fusion/tsdf/raycast.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "support/geometry_reference.h"
#include "support/test_scenes.h"
#include "support/tracking_reference.h"

namespace aoscan {
namespace {

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};

/// The corner scene fused from pose A and raycast there.
struct Tracked {
  test::Scene scene = test::corner_scene();
  Pose A = test::look_at({0.3, -0.3, 0.3}, {-0.3, 0.6, 2.5});
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  RaycastResult model;

  explicit Tracked(double noise_m = 0.0) {
    Image<float> depth;
    for (unsigned i = 0; i < 3; ++i) {
      test::render(scene, kKinect, A, depth, nullptr, noise_m, 100 + i);
      integrator.integrate(volume, depth, kKinect, A);
    }
    raycast(volume, kKinect, A, FusionConfig{}, model);
  }
};

TEST(Icp, RecoversKnownSmallMotion) {
  const Tracked t;
  const Pose B = t.A * test::motion({1, -2, 0.5}, 3.0, {0.02, -0.015, 0.015});
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, B);
  const IcpResult r = icp(frame, t.model, t.A, TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kGood) << to_string(r.status);
  EXPECT_LT((r.T_world_camera.translation() - B.translation()).norm(), 0.001);
  EXPECT_LT(rotation_between_deg(r.T_world_camera, B), 0.1);
  EXPECT_GT(r.inlier_ratio, 0.8);
  EXPECT_LT(r.rms_residual_m, 0.002);
  EXPECT_FALSE(r.degenerate);
  EXPECT_NEAR(r.rotation_deg, 3.0, 0.1);
}

TEST(Icp, RecoversMotionWithNoisyDepth) {
  const Tracked t(0.004);
  const Pose B = t.A * test::motion({-1, 1, 2}, 3.0, {-0.03, 0.01, 0.0});
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, B, 0.004, 7);
  const IcpResult r = icp(frame, t.model, t.A, TrackingConfig{});
  EXPECT_NE(r.status, TrackingStatus::kLost);
  EXPECT_LT((r.T_world_camera.translation() - B.translation()).norm(), 0.002);
  EXPECT_LT(rotation_between_deg(r.T_world_camera, B), 0.1);
}

TEST(Icp, EmptyFrameOrModelIsLostAndFinite) {
  const Tracked t;
  DepthPyramid empty;
  for (int l = 0; l < kPyramidLevels; ++l) {
    const Intrinsics k = kKinect.scaled(l);
    empty.depth_m[l].resize(k.width, k.height, 0.0f);
    empty.maps[l].intrinsics = k;
    empty.maps[l].vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
    empty.maps[l].normals.resize(k.width, k.height, Eigen::Vector3f::Zero());
  }
  IcpResult r = icp(empty, t.model, t.A, TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kLost);
  EXPECT_TRUE(r.T_world_camera.finite());
  EXPECT_TRUE(r.T_world_camera.matrix().isApprox(t.A.matrix()));
  EXPECT_EQ(r.inliers, 0);

  RaycastResult nothing;
  TsdfVolume volume{FusionConfig{}};
  raycast(volume, kKinect, t.A, FusionConfig{}, nothing);
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, t.A);
  r = icp(frame, nothing, t.A, TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kLost);
  EXPECT_TRUE(r.T_world_camera.finite());

  const Pose nan_pose(Eigen::Matrix3d::Identity(),
                      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  r = icp(frame, t.model, nan_pose, TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kLost);
}

TEST(Icp, ImplausibleMotionIsLost) {
  const Tracked t;
  // The camera really moved 40 cm: whatever ICP converges to is too far for one frame.
  const Pose B = t.A * test::motion({0, 1, 0}, 25.0, {0.4, 0.0, 0.1});
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, B);
  const IcpResult r = icp(frame, t.model, t.A, TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kLost);
  EXPECT_TRUE(r.T_world_camera.matrix().isApprox(t.A.matrix()));
  // With a tighter limit even the small motion of the other test is refused.
  TrackingConfig strict;
  strict.max_translation_m = 0.01;
  const Pose C = t.A * test::motion({1, 0, 0}, 1.0, {0.03, 0.0, 0.0});
  EXPECT_EQ(icp(test::render_pyramid(t.scene, kKinect, C), t.model, t.A, strict).status,
            TrackingStatus::kLost);
}

TEST(Icp, SinglePlaneIsDegenerateButConstrainedPartIsRecovered) {
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 2.0});
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(scene, kKinect, Pose::identity(), depth);
  integrator.integrate(volume, depth, kKinect, Pose::identity());
  RaycastResult model;
  raycast(volume, kKinect, Pose::identity(), FusionConfig{}, model);
  const Pose B(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 0.02));
  const IcpResult r =
      icp(test::render_pyramid(scene, kKinect, B), model, Pose::identity(), TrackingConfig{});
  EXPECT_EQ(r.status, TrackingStatus::kPoor)
      << to_string(r.status) << " inliers " << r.inliers << " ratio " << r.inlier_ratio << " t "
      << r.translation_m << " rms " << r.rms_residual_m;
  EXPECT_TRUE(r.degenerate);
  EXPECT_NEAR(r.T_world_camera.translation().z(), 0.02, 0.001);
  EXPECT_TRUE(r.T_world_camera.finite());
}

/// Exact normal equations of a floor (normal y) and a wall (normal z) seen by the camera: points
/// on both planes, Jacobian (p x n, n) of the left increment, residuals r = -J . xi_true, so that
/// A xi = -b holds for xi_true in every direction the planes constrain. The translation along
/// their edge (x) enters no residual: row and column 3 of A are exactly zero.
IcpSystem two_plane_system(const Eigen::Matrix<double, 6, 1>& xi_true) {
  IcpSystem s;
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    Eigen::Matrix<double, 6, 1> J;
    J.head<3>() = p.cross(n);
    J.tail<3>() = n;
    const double r = -J.dot(xi_true);
    s.A += J * J.transpose();
    s.b += J * r;
    s.residual_sq += r * r;
    ++s.inliers;
  };
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) {
      add({-1.0 + 0.2 * i, 1.0, 1.0 + 0.2 * j}, {0.0, 1.0, 0.0});    // floor y = 1
      add({-1.0 + 0.2 * i, -0.8 + 0.18 * j, 3.0}, {0.0, 0.0, 1.0});  // wall z = 3
    }
  s.valid = s.inliers;
  return s;
}

TEST(IcpSolve, UnconstrainedDirectionTakesThePriorAndTheRestIsSolvedExactly) {
  Eigen::Matrix<double, 6, 1> xi_true, prior;
  xi_true << 0.01, -0.02, 0.015, 0.03, -0.01, 0.02;
  prior << -0.05, 0.04, 0.03, -0.007, 0.02, -0.03;
  const IcpSystem s = two_plane_system(xi_true);
  ASSERT_EQ(s.A.row(3).norm(), 0.0);
  for (const double ratio : {0.0, 0.01}) {
    bool degenerate = false;
    const Eigen::Matrix<double, 6, 1> xi = solve_icp_system(s.A, s.b, prior, ratio, degenerate);
    EXPECT_TRUE(degenerate);
    EXPECT_NEAR(xi[3], prior[3], 1e-12) << "ratio " << ratio;  // along the edge: the prior
    for (const int i : {0, 1, 2, 4, 5}) EXPECT_NEAR(xi[i], xi_true[i], 1e-12) << i;
  }
}

TEST(IcpSolve, WeakDirectionBlendsDataAndPriorUpToTheInformationFloor) {
  Eigen::Matrix<double, 6, 1> xi_true, prior;
  xi_true << 0.01, -0.02, 0.015, 0.03, -0.01, 0.02;
  prior << -0.05, 0.04, 0.03, -0.007, 0.02, -0.03;
  const IcpSystem planes = two_plane_system(xi_true);
  const double largest =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(planes.A).eigenvalues()[5];
  const double ratio = 0.01;
  const double floor = ratio * largest;
  // A weak constraint along the edge (e.g. a far wall): information w = eigenvalue of e_x.
  for (const double w : {0.25 * floor, 0.75 * floor, 2.0 * floor}) {
    IcpSystem s = planes;
    s.A(3, 3) += w;
    s.b[3] += -w * xi_true[3];
    bool degenerate = true;
    const Eigen::Matrix<double, 6, 1> xi = solve_icp_system(s.A, s.b, prior, ratio, degenerate);
    // Below the floor the prior supplies the missing information floor - w; above it the data
    // alone decides.
    const double expected =
        w < floor ? (w * xi_true[3] + (floor - w) * prior[3]) / floor : xi_true[3];
    EXPECT_NEAR(xi[3], expected, 1e-12) << "w / floor " << w / floor;
    EXPECT_EQ(degenerate, w < floor);
    for (const int i : {0, 1, 2, 4, 5}) EXPECT_NEAR(xi[i], xi_true[i], 1e-12) << i;
  }
}

TEST(Icp, WallAndFloorTakeTheMotionAlongTheirEdgeFromThePrior) {
  // A floor and a wall only: the data fixes five degrees of freedom, not the translation along
  // their edge (the camera's x axis). icp() takes that component from the prior pose and the
  // others from the data, whichever prior it is given.
  test::Scene scene;
  scene.planes.push_back({Eigen::Vector3d(0, 1, 0), 1.0});
  scene.planes.push_back({Eigen::Vector3d(0, 0, 1), 3.0});
  const Pose A = test::look_at({0.0, 0.0, 0.0}, {0.0, 0.4, 3.0});
  ASSERT_GT(std::abs(A.rotation().col(0).x()), 0.999);  // camera x along the edge
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(scene, kKinect, A, depth);
  integrator.integrate(volume, depth, kKinect, A);
  RaycastResult model;
  raycast(volume, kKinect, A, FusionConfig{}, model);
  const Pose B = test::motion({0, 1, 0}, 0.5, {0.012, 0.006, -0.008}) * A;
  const DepthPyramid frame = test::render_pyramid(scene, kKinect, B);
  IcpWorkspace workspace;
  for (const Pose& prior : {A, B}) {
    const IcpResult r = icp(frame, model, A, prior, TrackingConfig{}, workspace);
    ASSERT_NE(r.status, TrackingStatus::kLost);
    EXPECT_TRUE(r.degenerate);
    const Eigen::Vector3d t = r.T_world_camera.translation();
    EXPECT_NEAR(t.x(), prior.translation().x(), 0.001);
    EXPECT_NEAR(t.y(), B.translation().y(), 0.001);
    EXPECT_NEAR(t.z(), B.translation().z(), 0.001);
    EXPECT_LT(rotation_between_deg(r.T_world_camera, B), 0.05);
  }
}

TEST(Icp, ParallelSystemMatchesReferenceAndIgnoresThreadCount) {
  const Tracked t;
  const Pose B = t.A * test::motion({0, 1, 1}, 2.0, {0.01, 0.02, -0.01});
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, B);
  const Pose T_model_camera = t.A.inverse() * t.A;
  const IcpSystem ref = icp_system_reference(frame.maps[0], t.model.maps, T_model_camera, {});
  IcpSystem one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = icp_system(frame.maps[0], t.model.maps, T_model_camera, {});
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = icp_system(frame.maps[0], t.model.maps, T_model_camera, {});
  }
  EXPECT_EQ(one.A, two.A);
  EXPECT_EQ(one.b, two.b);
  EXPECT_EQ(one.residual_sq, two.residual_sq);
  EXPECT_EQ(one.inliers, ref.inliers);
  EXPECT_EQ(one.valid, ref.valid);
  EXPECT_GT(ref.inliers, 100000);
  // Rows are summed in float: relative agreement ~1e-6. b may nearly cancel at the true pose, so
  // its scale is the Cauchy-Schwarz bound sqrt(trace(A) * sum r^2) of its terms.
  EXPECT_LT((one.A - ref.A).norm(), 1e-5 * ref.A.norm());
  EXPECT_LT((one.b - ref.b).norm(), 1e-5 * std::sqrt(ref.A.trace() * ref.residual_sq) + 1e-12);
  EXPECT_NEAR(one.residual_sq, ref.residual_sq, 1e-5 * ref.residual_sq);

  // Every 2nd pixel, staggered: the checkerboard, half the pixels, same sums as its reference.
  const IcpSystem half = icp_system(frame.maps[0], t.model.maps, T_model_camera, {}, 2);
  const IcpSystem half_ref =
      icp_system_reference(frame.maps[0], t.model.maps, T_model_camera, {}, 2);
  EXPECT_EQ(half.valid, half_ref.valid);
  EXPECT_EQ(half.inliers, half_ref.inliers);
  EXPECT_NEAR(half.valid, ref.valid / 2, ref.valid / 100);
  EXPECT_NEAR(half.inliers, ref.inliers / 2, ref.inliers / 100);
  EXPECT_LT((half.A - half_ref.A).norm(), 1e-5 * half_ref.A.norm());
  EXPECT_LT((half.A - 0.5 * ref.A).norm(), 0.05 * ref.A.norm());
}

TEST(Icp, FastAndPortableSystemsMatchReferenceUnderMotionNoiseAndEveryStep) {
  // A noisy frame 2 cm / 2 degrees off the model pose: many pixels are rejected by distance,
  // normal angle or bounds and the Huber weight is active, so every branch of the association is
  // exercised. The AVX2 and scalar paths must pick exactly the reference's correspondences.
  const Tracked t(0.003);
  const Pose B = t.A * test::motion({1, 1, 0}, 2.0, {0.02, -0.01, 0.01});
  const DepthPyramid frame = test::render_pyramid(t.scene, kKinect, B, 0.006, 5);
  const Pose T_model_camera = t.A.inverse() * B;
  TrackingConfig config;
  config.huber_delta_m = 0.002;
  config.max_normal_angle_deg = 10.0;
  for (const double noise_depth : {0.0, 1.0})
    for (int level = 0; level < kPyramidLevels; ++level) {
      for (int step = 1; step <= 3; ++step) {
        config.noise_reference_depth_m = noise_depth;
        SCOPED_TRACE("level " + std::to_string(level) + " step " + std::to_string(step) +
                     " noise depth " + std::to_string(noise_depth));
        const PointMaps& maps = frame.maps[level];
        const IcpSystem ref =
            icp_system_reference(maps, t.model.maps, T_model_camera, config, step);
        const IcpSystem fast = icp_system(maps, t.model.maps, T_model_camera, config, step);
        const IcpSystem portable =
            icp_system_portable(maps, t.model.maps, T_model_camera, config, step);
        EXPECT_GT(ref.inliers, 500);
        EXPECT_LT(ref.inliers, ref.valid * 9 / 10);  // a real share of the pixels is rejected
        for (const IcpSystem* s : {&fast, &portable}) {
          SCOPED_TRACE(s == &fast ? "fast" : "portable");
          EXPECT_EQ(s->valid, ref.valid);
          EXPECT_EQ(s->inliers, ref.inliers);
          EXPECT_LT((s->A - ref.A).norm(), 1e-5 * ref.A.norm());
          EXPECT_LT((s->b - ref.b).norm(), 1e-5 * std::sqrt(ref.A.trace() * ref.residual_sq));
          EXPECT_NEAR(s->residual_sq, ref.residual_sq, 1e-5 * ref.residual_sq);
        }
      }
    }
}

/// Point maps of the plane z = depth_m facing the camera (normal (0, 0, -1)) at `k`.
PointMaps plane_maps(const Intrinsics& k, float depth_m) {
  PointMaps m;
  m.intrinsics = k;
  m.vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
  m.normals.resize(k.width, k.height, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x)
      m.vertices(x, y) = k.unproject(static_cast<float>(x), static_cast<float>(y), depth_m);
  return m;
}

TEST(Icp, DepthNoiseWeightScalesHuberAndWeightBySquaredDepth) {
  const Intrinsics k = kKinect.scaled(2);
  const PointMaps model = plane_maps(k, 2.0f);
  TrackingConfig config;
  config.huber_delta_m = 0.005;
  // At the model's own pose every residual is 0: the weight is 1 / s^2, s = (2 m / 1 m)^2 = 4.
  config.noise_reference_depth_m = 0.0;
  const IcpSystem flat = icp_system_reference(model, model, Pose(), config);
  config.noise_reference_depth_m = 1.0;
  const IcpSystem weighted = icp_system_reference(model, model, Pose(), config);
  ASSERT_GT(flat.inliers, 1000);
  EXPECT_EQ(weighted.inliers, flat.inliers);
  EXPECT_LT((weighted.A - flat.A / 16.0).norm(), 1e-9 * flat.A.norm());
  // Nearer than the reference depth nothing changes.
  config.noise_reference_depth_m = 2.5;
  EXPECT_EQ(icp_system_reference(model, model, Pose(), config).A, flat.A);
  // A frame 1 cm behind the model: |r| = 1 cm is above huber_delta_m (weight 0.5) but below
  // huber_delta_m * s (s = 2.01^2 at the frame's depth), so the weight is 1 / s^2 alone.
  const PointMaps frame = plane_maps(k, 2.01f);
  config.noise_reference_depth_m = 0.0;
  const IcpSystem huber = icp_system_reference(frame, model, Pose(), config);
  config.noise_reference_depth_m = 1.0;
  const IcpSystem scaled = icp_system_reference(frame, model, Pose(), config);
  const double s = 2.01 * 2.01;
  EXPECT_NEAR(huber.b[5], 0.5 * 0.01 * huber.inliers,
              1e-4 * huber.inliers * 0.01);  // r = -1 cm, J_z = -1
  EXPECT_NEAR(scaled.b[5] / huber.b[5], 2.0 / (s * s), 1e-4);
  for (const IcpSystem& fast : {icp_system(frame, model, Pose(), config),
                                icp_system_portable(frame, model, Pose(), config)}) {
    EXPECT_EQ(fast.inliers, scaled.inliers);
    EXPECT_LT((fast.A - scaled.A).norm(), 1e-5 * scaled.A.norm());
    EXPECT_LT((fast.b - scaled.b).norm(), 1e-5 * scaled.b.norm());
  }
}

TEST(Icp, SmoothModelNormalsAveragesOneSurfaceOnly) {
  // Left half: the plane z = 1 with normals alternating between two tilts of 20 degrees about
  // the y axis, whose normalised sum is (0, 0, -1); right half: z = 2 with a third normal.
  const Intrinsics k{16, 8, 100.0, 100.0, 7.5, 3.5};  // 1-2 cm between pixels
  PointMaps in;
  in.intrinsics = k;
  in.vertices.resize(16, 8, Eigen::Vector3f::Zero());
  in.normals.resize(16, 8, Eigen::Vector3f::Zero());
  const float a = static_cast<float>(20.0 * M_PI / 180.0);
  const Eigen::Vector3f left_a(std::sin(a), 0.0f, -std::cos(a)),
      left_b(-std::sin(a), 0.0f, -std::cos(a));
  const Eigen::Vector3f right = Eigen::Vector3f(0.3f, 0.1f, -1.0f).normalized();
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      const float z = x < 8 ? 1.0f : 2.0f;
      in.vertices(x, y) = k.unproject(static_cast<float>(x), static_cast<float>(y), z);
      in.normals(x, y) = x >= 8 ? right : ((x + y) % 2 == 0 ? left_a : left_b);
    }
  in.vertices(12, 4).setZero();  // no vertex: stays without a normal, is no neighbour
  in.normals(12, 4).setZero();
  PointMaps out;
  std::vector<float> scratch;
  smooth_model_normals(in, 1, 0.05f, out, scratch);
  EXPECT_EQ(out.intrinsics, k);
  EXPECT_EQ(out.vertices, in.vertices);
  // An interior left pixel sums 5 of one tilt and 4 of the other: the x components leave one
  // tilt's sin(a) over a length of sqrt(sin^2 a + 81 cos^2 a).
  const float len = std::sqrt(std::sin(a) * std::sin(a) + 81.0f * std::cos(a) * std::cos(a));
  const Eigen::Vector3f interior(std::sin(a) / len, 0.0f, -9.0f * std::cos(a) / len);
  EXPECT_LT((out.normals(4, 4) - interior).norm(), 1e-6f);  // (4 + 4) even: 5 of left_a
  // Next to the 1 m depth jump (x = 7) the right half's normals are not averaged in: the
  // window holds 3 x 2 pixels of the left half, 3 of each tilt, whose sum is straight back.
  EXPECT_LT((out.normals(7, 4) - Eigen::Vector3f(0.0f, 0.0f, -1.0f)).norm(), 1e-6f);
  EXPECT_LT((out.normals(8, 4) - right).norm(), 1e-6f);
  EXPECT_LT((out.normals(11, 4) - right).norm(), 1e-6f);
  EXPECT_EQ(out.normals(12, 4), Eigen::Vector3f::Zero());
}

TEST(Icp, SmoothedModelNormalsMatchTheReferenceBitForBit) {
  // A noisy corner fused from three views and raycast at 640x480 (depth jumps, holes, grazing
  // walls), then a 45x13 crop of it whose rows end inside an eight-pixel block: every radius the
  // configuration allows agrees with the plain serial loop exactly.
  const Tracked t(0.004);
  const PointMaps& full = t.model.maps;
  PointMaps crop;
  crop.intrinsics = full.intrinsics;
  crop.vertices.resize(45, 13, Eigen::Vector3f::Zero());
  crop.normals.resize(45, 13, Eigen::Vector3f::Zero());
  for (int y = 0; y < 13; ++y)
    for (int x = 0; x < 45; ++x) {
      crop.vertices(x, y) = full.vertices(300 + x, 200 + y);
      crop.normals(x, y) = full.normals(300 + x, 200 + y);
    }
  std::vector<float> scratch;
  for (const PointMaps* in : std::vector<const PointMaps*>{&full, &crop}) {
    for (int radius = 0; radius <= 4; ++radius) {
      PointMaps fast, ref;
      smooth_model_normals(*in, radius, 0.05f, fast, scratch);
      smooth_model_normals_reference(*in, radius, 0.05f, ref);
      ASSERT_EQ(fast.normals.width(), ref.normals.width());
      int differing = 0, smoothed = 0;
      for (int y = 0; y < ref.normals.height(); ++y)
        for (int x = 0; x < ref.normals.width(); ++x) {
          differing += fast.normals(x, y) != ref.normals(x, y) ? 1 : 0;
          smoothed += radius > 0 && ref.normals(x, y) != in->normals(x, y) ? 1 : 0;
        }
      EXPECT_EQ(differing, 0) << "radius " << radius << ", width " << in->vertices.width();
      if (radius > 0) {
        EXPECT_GT(smoothed, static_cast<int>(in->vertices.size() / 4)) << "radius " << radius;
      }
      EXPECT_EQ(fast.vertices, in->vertices);
    }
  }
}

TEST(Icp, SmallMapsMatchTheirLastPixelInsideAFastBlock) {
  // A 20x10 plane at 1 m against itself shifted by 4 pixels: frame pixel (x, y) meets model pixel
  // (x + 4, y), so frame pixel (15, 9), inside an eight-pixel block, meets the model's very last
  // pixel (the fast path's special case); frame pixels x >= 16 fall outside the model.
  PointMaps maps;
  maps.intrinsics = Intrinsics{20, 10, 10.0, 10.0, 9.5, 4.5};
  maps.vertices.resize(20, 10, Eigen::Vector3f::Zero());
  maps.normals.resize(20, 10, Eigen::Vector3f(0.0f, 0.0f, -1.0f));
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x)
      maps.vertices(x, y) = Eigen::Vector3f((x - 9.5f) / 10.0f, (y - 4.5f) / 10.0f, 1.0f);
  const Pose T_model_camera(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.4, 0.0, 0.0));
  const IcpSystem ref = icp_system_reference(maps, maps, T_model_camera, {});
  const IcpSystem fast = icp_system(maps, maps, T_model_camera, {});
  EXPECT_EQ(ref.valid, 200);
  EXPECT_EQ(ref.inliers, 160);
  EXPECT_EQ(fast.valid, ref.valid);
  EXPECT_EQ(fast.inliers, ref.inliers);
  EXPECT_LT((fast.A - ref.A).norm(), 1e-5 * ref.A.norm());
}

TEST(Icp, NoisySequenceTrajectoryErrorWithinThreeMillimetres) {
#if defined(AOSCAN_SANITIZED)
  GTEST_SKIP() << "an accuracy measurement over a fused sequence; too slow under the sanitizers, "
                  "which see the same code in this suite's shorter tests";
#endif
  // 12 frames sweeping 12 cm and 6 degrees past the corner, depth noise 3 mm: track every frame
  // against the raycast at the previous estimate, fuse it, raycast again (the KinectFusion loop).
  const test::Scene scene = test::corner_scene();
  const Intrinsics k = kKinect;
  TsdfVolume volume{FusionConfig{}};
  TsdfIntegrator integrator;
  RaycastResult model;
  const int frames = 12;
  double sum_sq = 0.0;
  Pose estimate;
  for (int i = 0; i < frames; ++i) {
    const double s = static_cast<double>(i) / (frames - 1);
    const Pose truth = test::look_at({0.3 - 0.12 * s, -0.3 + 0.03 * s, 0.3 + 0.02 * s},
                                     {-0.3 + 0.2 * s, 0.6, 2.5});
    const DepthPyramid frame = test::render_pyramid(scene, k, truth, 0.003, 11 + 3 * i);
    if (i == 0) {
      estimate = truth;  // the world frame is anchored at the first frame's true pose
    } else {
      const IcpResult r = icp(frame, model, estimate, TrackingConfig{});
      ASSERT_EQ(r.status, TrackingStatus::kGood) << "frame " << i << " " << to_string(r.status);
      estimate = r.T_world_camera;
    }
    sum_sq += (estimate.translation() - truth.translation()).squaredNorm();
    integrator.integrate(volume, frame.depth_m[0], k, estimate);
    raycast(volume, k, estimate, FusionConfig{}, model);
  }
  const double ate = std::sqrt(sum_sq / frames);
  std::printf("noisy corner sequence: ATE %.3f mm over %d frames\n", 1000 * ate, frames);
  EXPECT_LT(ate, 0.003) << "ATE " << ate;
}

}  // namespace
}  // namespace aoscan
