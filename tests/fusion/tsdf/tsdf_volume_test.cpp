// Tests for src/fusion/tsdf/tsdf_volume.cpp and tsdf_integrator.cpp: band allocation, projective
// TSDF values, weight cap, multi-threaded vs reference integration, capacity, bad input.
#include "fusion/tsdf/tsdf_volume.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "core/status.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_sampler.h"
#include "support/test_scenes.h"
#include "support/tsdf_reference.h"

namespace aoscan {
namespace {

const Intrinsics kKinect{640, 480, 585.0, 585.0, 320.0, 240.0};

FusionConfig default_fusion() {
  return FusionConfig{};
}

test::Scene plane_scene(double z) {
  test::Scene s;
  s.planes.push_back({Eigen::Vector3d(0, 0, 1), z});
  return s;
}

/// Calls f(voxel, world centre) for every observed voxel.
template <class F>
void for_each_observed(const TsdfVolume& volume, F f) {
  for (int i = 0; i < volume.block_count(); ++i) {
    const Eigen::Vector3i base = volume.block_coord(i) * kBlockSize;
    for (int z = 0; z < kBlockSize; ++z)
      for (int y = 0; y < kBlockSize; ++y)
        for (int x = 0; x < kBlockSize; ++x) {
          const Voxel& v = volume.block(i).voxels[voxel_index(x, y, z)];
          if (v.count == 0) continue;
          f(v, (base + Eigen::Vector3i(x, y, z)).cast<double>() * volume.voxel_size_m());
        }
  }
}

TEST(Voxel, FixedPointStoreRoundsClampsAndRejectsNaN) {
  Voxel v;
  EXPECT_EQ(v.tsdf(), 1.0f);  // unobserved voxels read as free space
  EXPECT_EQ(v.count, 0);
  v.store(0.5f, 3.0f);
  EXPECT_EQ(v.tsdf_q, 16384);  // 0.5 * 32767 = 16383.5: to nearest even
  EXPECT_EQ(v.weight(), 3.0f);
  v.store(-0.25f, 2.9f);
  EXPECT_EQ(v.tsdf_q, -8192);  // -8191.75
  EXPECT_EQ(v.count, 2);       // the count truncates
  v.store(-7.0f, 1e9f);
  EXPECT_EQ(v.tsdf_q, -32767);
  EXPECT_EQ(v.count, 65535);
  v.store(std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN());
  EXPECT_EQ(v.tsdf_q, 32767);  // NaN: free and unobserved
  EXPECT_EQ(v.count, 0);
  v.store(0.1f, -std::numeric_limits<float>::infinity());
  EXPECT_EQ(v.count, 0);
  // Every fixed-point value survives tsdf() -> store() (the volume.vdb round trip).
  for (int q = -32767; q <= 32767; ++q) {
    Voxel a;
    a.tsdf_q = static_cast<std::int16_t>(q);
    Voxel b;
    b.store(a.tsdf(), 1.0f);
    ASSERT_EQ(b.tsdf_q, q);
  }
}

TEST(Voxel, RunningAverageOfObservations) {
  // Observations 0.6, 0.0, -0.3 average to 0.1; each step within half a fixed-point step of the
  // exact running mean, the count stopping at the cap.
  Voxel v;
  v.add_observation(0.6f, 2.0f);
  EXPECT_EQ(v.tsdf_q, std::lrint(0.6 * 32767));
  v.add_observation(0.0f, 2.0f);
  EXPECT_NEAR(v.tsdf(), 0.3f, 1.0f / 32767);
  EXPECT_EQ(v.count, 2);
  v.add_observation(-0.3f, 2.0f);  // capped: (0.3 * 2 - 0.3) / 3, the count stays 2
  EXPECT_NEAR(v.tsdf(), 0.1f, 1.0f / 32767);
  EXPECT_EQ(v.count, 2);
}

TEST(TsdfVolume, FrontalPlaneGivesExactSignedDistance) {
  TsdfVolume volume(default_fusion());
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(plane_scene(1.5), kKinect, Pose::identity(), depth);
  const IntegrateStats stats = integrator.integrate(volume, depth, kKinect, Pose::identity());
  EXPECT_EQ(stats.rays, 640 * 480);
  EXPECT_EQ(stats.blocks_allocated, volume.block_count());
  EXPECT_EQ(stats.blocks_updated, volume.block_count());
  const double trunc = volume.truncation_m();
  int checked = 0;
  for_each_observed(volume, [&](const Voxel& v, const Eigen::Vector3d& p) {
    const double expected = std::min(1.0, (1.5 - p.z()) / trunc);
    EXPECT_NEAR(v.tsdf(), expected, 1e-4) << p.transpose();
    EXPECT_LE(p.z(), 1.5 + trunc + 1e-6);  // nothing observed behind the band
    ++checked;
  });
  EXPECT_GT(checked, 100000);
}

TEST(TsdfVolume, AllocatesOnlyBlocksNearTheSurface) {
  TsdfVolume volume(default_fusion());
  TsdfIntegrator integrator;
  Image<float> depth;
  const double z = 1.5;
  test::render(plane_scene(z), kKinect, Pose::identity(), depth);
  integrator.integrate(volume, depth, kKinect, Pose::identity());
  const double block = volume.block_size_m();
  const double voxel = volume.voxel_size_m();
  // Every block's voxel-centre box lies within the truncation band of the plane.
  for (int i = 0; i < volume.block_count(); ++i) {
    const double z_lo = (volume.block_coord(i).z() * kBlockSize - 0.5) * voxel;
    const double z_hi = z_lo + block;
    EXPECT_LT(z_lo, z + volume.truncation_m() + 1e-6);
    EXPECT_GT(z_hi, z - volume.truncation_m() - 1e-6);
  }
  // The plane seen in the image covers w x h metres; the band is at most 3 blocks thick.
  const double w = 640.0 / 585.0 * (z + volume.truncation_m());
  const double h = 480.0 / 585.0 * (z + volume.truncation_m());
  const int max_blocks = 3 * (static_cast<int>(w / block) + 2) * (static_cast<int>(h / block) + 2);
  const int min_blocks = static_cast<int>(640.0 / 585.0 * z * 480.0 / 585.0 * z / (block * block));
  EXPECT_LE(volume.block_count(), max_blocks);
  EXPECT_GE(volume.block_count(), min_blocks);
}

TEST(TsdfVolume, SphereSignedDistanceWithinAVoxel) {
  TsdfVolume volume(default_fusion());
  TsdfIntegrator integrator;
  test::Scene scene;
  const Eigen::Vector3d centre(0.1, -0.05, 1.6);
  const double radius = 0.4;
  scene.spheres.push_back({centre, radius});
  Image<float> depth;
  test::render(scene, kKinect, Pose::identity(), depth);
  integrator.integrate(volume, depth, kKinect, Pose::identity());
  const double trunc = volume.truncation_m();
  int checked = 0;
  for_each_observed(volume, [&](const Voxel& v, const Eigen::Vector3d& p) {
    const double sd = (p - centre).norm() - radius;
    // Near the surface, on the cap facing the camera (within 30 degrees of the view ray).
    const Eigen::Vector3d n = (p - centre).normalized();
    if (std::abs(sd) > 0.5 * trunc || n.dot(-p.normalized()) < std::cos(M_PI / 6)) return;
    EXPECT_NEAR(v.tsdf() * trunc, sd, volume.voxel_size_m()) << p.transpose();
    ++checked;
  });
  EXPECT_GT(checked, 1000);
}

TEST(TsdfVolume, WeightsAreCappedAndAveragesStay) {
  FusionConfig config = default_fusion();
  config.max_weight = 3.0;
  TsdfVolume volume(config);
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(plane_scene(1.2), kKinect, Pose::identity(), depth);
  for (int i = 0; i < 5; ++i) integrator.integrate(volume, depth, kKinect, Pose::identity());
  float max_weight = 0;
  const double trunc = volume.truncation_m();
  for_each_observed(volume, [&](const Voxel& v, const Eigen::Vector3d& p) {
    max_weight = std::max(max_weight, v.weight());
    EXPECT_NEAR(v.tsdf(), std::min(1.0, (1.2 - p.z()) / trunc), 1e-4);
  });
  EXPECT_EQ(max_weight, 3.0f);
}

TEST(TsdfVolume, FastParallelIntegrationMatchesReference) {
  const test::Scene scene = test::corner_scene();
  const Pose poses[] = {test::look_at({0.4, -0.2, 0.2}, {-0.3, 0.6, 2.6}),
                        test::look_at({0.0, -0.3, 0.4}, {-0.2, 0.5, 2.5}),
                        test::look_at({0.6, 0.0, 0.6}, {-0.4, 0.7, 2.7})};
  TsdfVolume fast(default_fusion()), reference(default_fusion());
  TsdfIntegrator fast_integrator;
  Image<float> depth;
  unsigned seed = 3;
  for (const Pose& pose : poses) {
    test::render(scene, kKinect, pose, depth, nullptr, 0.004, seed++);
    const IntegrateStats a = fast_integrator.integrate(fast, depth, kKinect, pose);
    const IntegrateStats b = test::integrate_reference(reference, depth, kKinect, pose);
    EXPECT_EQ(a.blocks_allocated, b.blocks_allocated);
    EXPECT_EQ(a.blocks_updated, b.blocks_updated);
  }
  // The fast update steps voxel positions affinely: its voxel depths differ from the reference's
  // by float rounding (about 1e-6 m, i.e. a few 1e-5 of the truncation in tsdf), and a voxel
  // projecting within rounding of a pixel border may read the neighbouring pixel. So: weights
  // equal and tsdf within 2e-4 everywhere except at most 1e-4 of the voxels (59 in 2.25M here).
  ASSERT_EQ(fast.block_count(), reference.block_count());
  long long voxels = 0, different = 0, not_exact = 0;
  for (int i = 0; i < fast.block_count(); ++i) {
    ASSERT_EQ(fast.block_coord(i), reference.block_coord(i));
    for (int j = 0; j < kBlockVoxels; ++j) {
      const Voxel& a = fast.block(i).voxels[j];
      const Voxel& b = reference.block(i).voxels[j];
      ++voxels;
      if (a.count != b.count || std::abs(a.tsdf() - b.tsdf()) > 2e-4f) ++different;
      if (a.count != b.count || a.tsdf_q != b.tsdf_q) ++not_exact;
    }
  }
  std::printf("fast vs reference integration: %lld of %lld voxels beyond 2e-4, %lld not exact\n",
              different, voxels, not_exact);
  EXPECT_GT(voxels, 100000);
  EXPECT_LE(different, voxels / 10000);
}

TEST(TsdfVolume, SimdIntegrationEqualsPortableBitForBit) {
  // integrate() updates one voxel row per AVX2 vector (when the CPU has AVX2) with the same float
  // operations as integrate_portable(): the volumes must be identical, also with noise, grazing
  // surfaces, voxels behind the camera and at the image border.
  const test::Scene scene = test::corner_scene();
  const Pose poses[] = {test::look_at({0.4, -0.2, 0.2}, {-0.3, 0.6, 2.6}),
                        test::look_at({-0.2, 0.1, 1.2}, {-0.5, 0.6, 2.7}),
                        test::look_at({0.6, 0.0, 0.6}, {-0.4, 0.7, 2.7})};
  TsdfVolume simd(default_fusion()), portable(default_fusion());
  TsdfIntegrator simd_integrator, portable_integrator;
  Image<float> depth;
  unsigned seed = 21;
  for (const Pose& pose : poses) {
    test::render(scene, kKinect, pose, depth, nullptr, 0.004, seed++);
    const IntegrateStats a = simd_integrator.integrate(simd, depth, kKinect, pose);
    const IntegrateStats b = portable_integrator.integrate_portable(portable, depth, kKinect, pose);
    EXPECT_EQ(a.blocks_allocated, b.blocks_allocated);
    EXPECT_EQ(a.blocks_updated, b.blocks_updated);
  }
  ASSERT_EQ(simd.block_count(), portable.block_count());
  ASSERT_GT(simd.block_count(), 1000);
  long long observed = 0;
  for (int i = 0; i < simd.block_count(); ++i) {
    ASSERT_EQ(simd.block_coord(i), portable.block_coord(i));
    ASSERT_EQ(0, std::memcmp(&simd.block(i), &portable.block(i), sizeof(VoxelBlock))) << i;
    for (const Voxel& v : simd.block(i).voxels) observed += v.count > 0;
  }
  EXPECT_GT(observed, 100000);
}

TEST(TsdfVolume, SimdEqualsPortableOnARowWidthThatIsNoMultipleOfEight) {
  // The band allocation sets up eight pixels per AVX2 vector and the rest of a row one by one;
  // a 637-pixel row has a 5-pixel tail, and a dropout pattern leaves lanes without depth.
  Intrinsics k;
  k.width = 637;
  k.height = 203;
  k.cx = 300.0;
  k.cy = 101.0;
  const Pose pose = test::look_at({0.4, -0.2, 0.2}, {-0.3, 0.6, 2.6});
  Image<float> depth;
  test::render(test::corner_scene(), k, pose, depth, nullptr, 0.004, 5);
  for (int y = 0; y < depth.height(); ++y)
    for (int x = 0; x < depth.width(); ++x)
      if ((x * 7 + y * 3) % 11 == 0) depth(x, y) = 0.0f;
  TsdfVolume simd(default_fusion()), portable(default_fusion());
  TsdfIntegrator simd_integrator, portable_integrator;
  const IntegrateStats a = simd_integrator.integrate(simd, depth, k, pose);
  const IntegrateStats b = portable_integrator.integrate_portable(portable, depth, k, pose);
  EXPECT_EQ(a.rays, b.rays);
  EXPECT_GT(a.rays, 100000);
  EXPECT_EQ(a.blocks_allocated, b.blocks_allocated);
  ASSERT_EQ(simd.block_count(), portable.block_count());
  for (int i = 0; i < simd.block_count(); ++i) {
    ASSERT_EQ(simd.block_coord(i), portable.block_coord(i));
    ASSERT_EQ(0, std::memcmp(&simd.block(i), &portable.block(i), sizeof(VoxelBlock))) << i;
  }
}

TEST(TsdfVolume, SameVolumeForOneAndTwoThreads) {
  const test::Scene scene = test::corner_scene();
  const Pose pose = test::look_at({0.4, -0.2, 0.2}, {-0.3, 0.6, 2.6});
  Image<float> depth;
  test::render(scene, kKinect, pose, depth, nullptr, 0.004, 9);
  TsdfVolume one(default_fusion()), two(default_fusion());
  TsdfIntegrator one_integrator, two_integrator;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one_integrator.integrate(one, depth, kKinect, pose);
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two_integrator.integrate(two, depth, kKinect, pose);
  }
  ASSERT_EQ(one.block_count(), two.block_count());
  for (int i = 0; i < one.block_count(); ++i)
    ASSERT_EQ(0, std::memcmp(&one.block(i), &two.block(i), sizeof(VoxelBlock)));
}

TEST(TsdfVolume, CapacityLimitIsReported) {
  FusionConfig config = default_fusion();
  config.max_blocks = 10;
  TsdfVolume volume(config);
  TsdfIntegrator integrator;
  Image<float> depth;
  test::render(plane_scene(1.5), kKinect, Pose::identity(), depth);
  const IntegrateStats stats = integrator.integrate(volume, depth, kKinect, Pose::identity());
  EXPECT_EQ(volume.block_count(), 10);
  EXPECT_EQ(stats.blocks_allocated, 10);
  EXPECT_GT(stats.blocks_dropped, 0);
  EXPECT_TRUE(volume.capacity_reached());
  volume.reset();
  EXPECT_EQ(volume.block_count(), 0);
  EXPECT_FALSE(volume.capacity_reached());
}

TEST(TsdfVolume, BadInputNeverCrashes) {
  TsdfVolume volume(default_fusion());
  TsdfIntegrator integrator;
  Image<float> depth(640, 480, 1.0f);
  depth(3, 3) = std::numeric_limits<float>::quiet_NaN();
  depth(4, 3) = std::numeric_limits<float>::infinity();
  depth(5, 3) = -2.0f;
  EXPECT_THROW(
      integrator.integrate(volume, Image<float>(320, 240, 1.0f), kKinect, Pose::identity()), Error);
  Pose bad(Eigen::Matrix3d::Identity(),
           Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0, 0));
  EXPECT_TRUE(integrator.integrate(volume, depth, kKinect, bad).skipped);
  EXPECT_EQ(volume.block_count(), 0);
  const IntegrateStats stats = integrator.integrate(volume, depth, kKinect, Pose::identity());
  EXPECT_EQ(stats.rays, 640 * 480 - 3);
  // Far away from the origin: block coordinates beyond the packable range are dropped, not
  // wrapped.
  const Pose far(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1e9, 0, 0));
  integrator.integrate(volume, depth, kKinect, far);
  for (int i = 0; i < volume.block_count(); ++i)
    EXPECT_LE(volume.block_coord(i).cwiseAbs().maxCoeff(), TsdfVolume::kMaxBlockCoord);
  FusionConfig config = default_fusion();
  config.truncation_m = config.voxel_size_m / 2;
  EXPECT_THROW(TsdfVolume{config}, Error);
}

TEST(TsdfVolume, RegionsTrackTheAllocatedBlocks) {
  // Region r holds blocks 4r .. 4r + 3 per axis (floor division for negative coordinates).
  TsdfVolume volume(default_fusion());
  EXPECT_FALSE(volume.region_allocated({0, 0, 0}));
  ASSERT_GE(volume.allocate_block({5, -3, 9}), 0);
  ASSERT_GE(volume.allocate_block({-1, -4, -5}), 0);
  EXPECT_TRUE(volume.region_allocated({1, -1, 2}));
  EXPECT_TRUE(volume.region_allocated({-1, -1, -2}));
  for (const Eigen::Vector3i& empty :
       {Eigen::Vector3i(0, 0, 0), Eigen::Vector3i(1, -1, 1), Eigen::Vector3i(2, -1, 2),
        Eigen::Vector3i(1, 0, 2), Eigen::Vector3i(-1, -2, -2), Eigen::Vector3i(0, -1, -2)})
    EXPECT_FALSE(volume.region_allocated(empty)) << empty.transpose();
  // The sampler's answer, cached or not, is the volume's.
  TsdfSampler sampler(volume);
  EXPECT_FALSE(sampler.region_empty(1, -1, 2));
  EXPECT_FALSE(sampler.region_empty(1, -1, 2));
  EXPECT_TRUE(sampler.region_empty(1, -1, 1));
  EXPECT_FALSE(sampler.region_empty(-1, -1, -2));
  EXPECT_TRUE(sampler.region_empty(TsdfVolume::kMaxBlockCoord + 1, 0, 0));
  volume.reset();
  EXPECT_FALSE(volume.region_allocated({1, -1, 2}));
  EXPECT_EQ(volume.block_count(), 0);
}

/// trilinear() and nearest_gradient() computed voxel by voxel through find_voxel(): the plain
/// reference of the sampler's block-cached reads.
bool reference_trilinear(const TsdfVolume& volume, const Eigen::Vector3f& g, float& tsdf,
                         float min_weight = 1e-6f) {
  const Eigen::Vector3i base(static_cast<int>(std::floor(g.x())),
                             static_cast<int>(std::floor(g.y())),
                             static_cast<int>(std::floor(g.z())));
  float c[8];
  for (int i = 0; i < 8; ++i) {
    const Voxel* v = volume.find_voxel(base + Eigen::Vector3i(i & 1, (i >> 1) & 1, i >> 2));
    if (v == nullptr || !(v->weight() >= min_weight)) return false;
    c[i] = v->tsdf();
  }
  const Eigen::Vector3f a = g - base.cast<float>();
  const float c00 = c[0] + a[0] * (c[1] - c[0]), c10 = c[2] + a[0] * (c[3] - c[2]);
  const float c01 = c[4] + a[0] * (c[5] - c[4]), c11 = c[6] + a[0] * (c[7] - c[6]);
  const float c0 = c00 + a[1] * (c10 - c00), c1 = c01 + a[1] * (c11 - c01);
  tsdf = c0 + a[2] * (c1 - c0);
  return true;
}

bool reference_nearest_gradient(const TsdfVolume& volume, const Eigen::Vector3f& g,
                                Eigen::Vector3f& grad) {
  const Eigen::Vector3i v(static_cast<int>(std::floor(g.x() + 0.5f)),
                          static_cast<int>(std::floor(g.y() + 0.5f)),
                          static_cast<int>(std::floor(g.z() + 0.5f)));
  for (int axis = 0; axis < 3; ++axis) {
    const Voxel* p = volume.find_voxel(v + Eigen::Vector3i::Unit(axis));
    const Voxel* m = volume.find_voxel(v - Eigen::Vector3i::Unit(axis));
    if (p == nullptr || m == nullptr || p->count == 0 || m->count == 0) return false;
    grad[axis] = 0.5f * (p->tsdf() - m->tsdf());
  }
  return true;
}

TEST(TsdfVolume, SamplerAgreesWithVoxelByVoxelReads) {
  // 3x3x3 blocks around the origin minus two (a hole at a corner and one at an edge), pseudo-
  // random values and every 7th voxel unobserved: samples anywhere, across block borders and
  // next to missing blocks, must read exactly what voxel-by-voxel lookups read.
  TsdfVolume volume(default_fusion());
  std::uint32_t state = 12345;
  auto next = [&state] { return state = state * 1664525u + 1013904223u; };
  for (int bz = -1; bz <= 1; ++bz)
    for (int by = -1; by <= 1; ++by)
      for (int bx = -1; bx <= 1; ++bx) {
        if ((bx == 1 && by == 1 && bz == 1) || (bx == -1 && by == 0 && bz == 1)) continue;
        const int index = volume.allocate_block({bx, by, bz});
        ASSERT_GE(index, 0);
        for (Voxel& v : volume.block(index).voxels) {
          const std::uint32_t r = next();
          v.tsdf_q = static_cast<std::int16_t>(static_cast<int>(r >> 16) - 32768);
          v.count = r % 7 == 0 ? 0 : 1 + r % 5;
        }
      }
  TsdfSampler sampler(volume);
  int found = 0, gradients = 0;
  int scalar_found[2] = {0, 0};  // min_weight 0, 3
  for (int i = 0; i < 200000; ++i) {
    const Eigen::Vector3f g(static_cast<float>(next() % 2600) / 100.0f - 10.0f,
                            static_cast<float>(next() % 2600) / 100.0f - 10.0f,
                            static_cast<float>(next() % 2600) / 100.0f - 10.0f);
    float f = 0, f_ref = 0;
    const bool ok = sampler.trilinear(g, f);
    ASSERT_EQ(ok, reference_trilinear(volume, g, f_ref)) << g.transpose();
    if (ok) {
      ASSERT_EQ(f, f_ref) << g.transpose();
      ++found;
    }
    // Thresholds outside (0, 1] take the scalar eight-voxel read on every build.
    for (const float min_weight : {0.0f, 3.0f}) {
      const bool scalar_ok = sampler.trilinear(g, f, min_weight);
      ASSERT_EQ(scalar_ok, reference_trilinear(volume, g, f_ref, min_weight))
          << g.transpose() << " min_weight " << min_weight;
      if (scalar_ok) {
        ASSERT_EQ(f, f_ref) << g.transpose() << " min_weight " << min_weight;
        ++scalar_found[min_weight > 0.0f];
      }
    }
    Eigen::Vector3f grad, grad_ref;
    const bool has = sampler.nearest_gradient(g, grad);
    ASSERT_EQ(has, reference_nearest_gradient(volume, g, grad_ref)) << g.transpose();
    if (has) {
      ASSERT_EQ(grad, grad_ref) << g.transpose();
      ++gradients;
    }
  }
  // Enough of both answers to mean something (about (6/7)^8 and (6/7)^6 of the covered cells).
  EXPECT_GT(found, 20000);
  EXPECT_GT(gradients, 30000);
  // Weight 0 accepts every allocated voxel (about 25/27 of the samples fall in covered cells);
  // weight 3 about (18/35)^8 of them (counts 3-5 of 1-5 on the 6/7 observed).
  EXPECT_GT(scalar_found[0], found);
  EXPECT_GT(scalar_found[1], 200);
}

TEST(TsdfVolume, SamplerReadsVoxelsAcrossBlocks) {
  TsdfVolume volume(default_fusion());
  // Write a linear field tsdf = kSlope * x, exact in the voxels' fixed point (320 steps per
  // voxel), into 2x2x2 blocks around the origin.
  constexpr int kSteps = 320;
  const float kSlope = kSteps * Voxel::kTsdfStep;
  for (int bz = -1; bz <= 0; ++bz)
    for (int by = -1; by <= 0; ++by)
      for (int bx = -1; bx <= 0; ++bx) {
        const int i = volume.allocate_block({bx, by, bz});
        ASSERT_GE(i, 0);
        for (int z = 0; z < 8; ++z)
          for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 8; ++x) {
              Voxel& v = volume.block(i).voxels[voxel_index(x, y, z)];
              v.tsdf_q = static_cast<std::int16_t>(kSteps * (bx * 8 + x));
              v.count = 1;
            }
      }
  TsdfSampler sampler(volume);
  float f = 0;
  ASSERT_TRUE(sampler.trilinear(Eigen::Vector3f(-0.25f, 0.5f, -0.5f), f));
  EXPECT_NEAR(f, -0.25f * kSlope, 1e-6f);
  ASSERT_TRUE(sampler.trilinear(Eigen::Vector3f(3.5f, 3.5f, 3.5f), f));
  EXPECT_NEAR(f, 3.5f * kSlope, 1e-6f);
  EXPECT_FALSE(sampler.trilinear(Eigen::Vector3f(7.5f, 0.0f, 0.0f), f));  // needs block x = 1
  Eigen::Vector3f grad;
  ASSERT_TRUE(sampler.gradient(Eigen::Vector3f(-1.0f, 0.2f, -0.3f), grad));
  EXPECT_NEAR(grad.x(), kSlope, 1e-6f);
  EXPECT_NEAR(grad.y(), 0.0f, 1e-6f);
  // Nearest-voxel central differences: inside a block (one lookup, direct offsets) and at a
  // block border (neighbours in other blocks) give the same exact slope; a missing neighbour
  // block gives none.
  for (const Eigen::Vector3f& g :
       {Eigen::Vector3f(-4.2f, -3.9f, -5.1f), Eigen::Vector3f(-0.4f, -0.3f, -1.0f),
        Eigen::Vector3f(-1.0f, -7.2f, -4.0f)}) {
    ASSERT_TRUE(sampler.nearest_gradient(g, grad)) << g.transpose();
    EXPECT_NEAR(grad.x(), kSlope, 1e-6f) << g.transpose();
    EXPECT_EQ(grad.y(), 0.0f);
    EXPECT_EQ(grad.z(), 0.0f);
  }
  EXPECT_FALSE(sampler.nearest_gradient(Eigen::Vector3f(7.2f, 0.0f, 0.0f), grad));
  EXPECT_FALSE(sampler.nearest_gradient(Eigen::Vector3f(-8.4f, -4.0f, -4.0f), grad));
  ASSERT_NE(volume.find_voxel({-8, -8, -8}), nullptr);
  EXPECT_EQ(volume.find_voxel({8, 0, 0}), nullptr);
}

}  // namespace
}  // namespace aoscan
