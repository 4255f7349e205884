/// @file kitchen_fusion.cpp
/// @brief The RedKitchen fusion loop of kitchen_fusion.h.
#include "support/kitchen_fusion.h"

#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "core/status.h"
#include "fusion/tracking/icp.h"
#include "fusion/tsdf/marching_cubes.h"
#include "fusion/tsdf/raycast.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"
#include "io/png_read.h"

namespace aoscan::test {
namespace {

void point_maps(const Image<float>& depth, const Intrinsics& k, PointMaps& maps) {
  maps.intrinsics = k;
  maps.vertices.resize(k.width, k.height, Eigen::Vector3f::Zero());
  maps.normals.resize(k.width, k.height, Eigen::Vector3f::Zero());
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x)
      if (depth(x, y) > 0)
        maps.vertices(x, y) =
            k.unproject(static_cast<float>(x), static_cast<float>(y), depth(x, y));
  for (int y = 1; y + 1 < k.height; ++y) {
    for (int x = 1; x + 1 < k.width; ++x) {
      const float z = depth(x, y);
      if (z <= 0) continue;
      const float d[4] = {depth(x - 1, y), depth(x + 1, y), depth(x, y - 1), depth(x, y + 1)};
      bool ok = true;
      for (float n : d) ok &= n > 0 && std::abs(n - z) < 0.05f * z;
      if (!ok) continue;
      const Eigen::Vector3f dx = maps.vertices(x + 1, y) - maps.vertices(x - 1, y);
      const Eigen::Vector3f dy = maps.vertices(x, y + 1) - maps.vertices(x, y - 1);
      Eigen::Vector3f n = dx.cross(dy);
      if (n.squaredNorm() <= 0) continue;
      n.normalize();
      if (n.dot(maps.vertices(x, y)) > 0) n = -n;
      maps.normals(x, y) = n;
    }
  }
}

/// Stand-in preprocessing: millimetres to metres, 5x5 bilateral filter, 2x2 pyramid, maps.
/// Returns the unfiltered metric depth in `raw_m` (what gets integrated).
void preprocess(const Image<std::uint16_t>& raw, const Intrinsics& k, Image<float>& raw_m,
                DepthPyramid& pyramid) {
  raw_m.resize(k.width, k.height, 0.0f);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const std::uint16_t v = raw(x, y);
      raw_m(x, y) = (v == 0 || v == 65535) ? 0.0f : v * 0.001f;
    }
  // Border outliers (Sabbadin et al. 2016 Sec. 6): drop a pixel when an 8-neighbour differs by
  // more than 2 cm.
  Image<float>& level0 = pyramid.depth_m[0];
  level0 = raw_m;
  for (int y = 1; y + 1 < k.height; ++y)
    for (int x = 1; x + 1 < k.width; ++x) {
      const float c = level0(x, y);
      for (int i = 0; i < 9 && c > 0; ++i) {
        const float n = level0(x + i % 3 - 1, y + i / 3 - 1);
        if (n > 0 && std::abs(n - c) > 0.02f) raw_m(x, y) = 0.0f;
      }
    }
  level0.resize(k.width, k.height, 0.0f);
  constexpr float kSpace = 1.0f / (2 * 2.0f * 2.0f), kRange = 1.0f / (2 * 0.03f * 0.03f);
  for (int y = 0; y < k.height; ++y) {
    for (int x = 0; x < k.width; ++x) {
      const float c = raw_m(x, y);
      if (c <= 0) continue;
      float sum = 0, wsum = 0;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          if (!raw_m.contains(x + dx, y + dy)) continue;
          const float d = raw_m(x + dx, y + dy);
          if (d <= 0) continue;
          const float w = std::exp(-(dx * dx + dy * dy) * kSpace - (d - c) * (d - c) * kRange);
          sum += w * d;
          wsum += w;
        }
      level0(x, y) = sum / wsum;
    }
  }
  for (int l = 1; l < kPyramidLevels; ++l) {
    const Image<float>& fine = pyramid.depth_m[l - 1];
    Image<float>& coarse = pyramid.depth_m[l];
    coarse.resize(fine.width() / 2, fine.height() / 2, 0.0f);
    for (int y = 0; y < coarse.height(); ++y)
      for (int x = 0; x < coarse.width(); ++x) {
        const float c = fine(2 * x, 2 * y);
        if (c <= 0) continue;
        float sum = 0;
        int n = 0;
        for (int i = 0; i < 4; ++i) {
          const float d = fine(2 * x + (i & 1), 2 * y + (i >> 1));
          if (d > 0 && std::abs(d - c) < 0.03f) sum += d, ++n;
        }
        coarse(x, y) = sum / n;
      }
  }
  for (int l = 0; l < kPyramidLevels; ++l)
    point_maps(pyramid.depth_m[l], k.scaled(l), pyramid.maps[l]);
}

using Clock = std::chrono::steady_clock;
/// CPU time of the whole process (all threads), ms.
double cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace

bool kitchen_present(const std::string& dir) {
  return std::ifstream(dir + "/depth.txt").good();
}

std::vector<KitchenFrame> read_kitchen(const std::string& dir, int max_frames) {
  std::vector<KitchenFrame> frames;
  std::ifstream depth(dir + "/depth.txt"), gt(dir + "/groundtruth.txt");
  std::string dline, gline;
  while (static_cast<int>(frames.size()) < max_frames && std::getline(depth, dline)) {
    if (dline.empty() || dline[0] == '#') continue;
    do {
      if (!std::getline(gt, gline)) return frames;
    } while (gline.empty() || gline[0] == '#');
    std::istringstream ds(dline), gs(gline);
    double ts = 0, tx, ty, tz, qx, qy, qz, qw;
    std::string file;
    ds >> ts >> file;
    gs >> ts >> tx >> ty >> tz >> qx >> qy >> qz >> qw;
    frames.push_back(
        {dir + "/" + file, Pose::from_quaternion({tx, ty, tz}, {qw, qx, qy, qz})});
  }
  return frames;
}

KitchenRunStats run_kitchen(const std::string& dir, const KitchenRunOptions& options) {
  KitchenRunStats stats;
  const std::vector<KitchenFrame> frames = read_kitchen(dir, options.max_frames);
  const int kernel_loops = options.kernel_loops;
  const FusionConfig fusion;
  const TrackingConfig tracking;
  TsdfVolume volume(fusion);
  TsdfIntegrator integrator;
  RaycastResult model;
  IcpWorkspace workspace;
  Image<std::uint16_t> raw;
  Image<float> raw_m;
  DepthPyramid pyramid;
  Pose pose;
  double sum_sq = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (const Status read = read_grey16_png(frames[i].path, raw); !read.is_ok())
      stats.read_errors.push_back(read.message());
    auto t0 = Clock::now();
    preprocess(raw, kKitchenIntrinsics, raw_m, pyramid);
    stats.ms_preprocess.push_back(ms_since(t0));
    bool lost_now = false;
    if (i == 0) {
      pose = frames[0].T_world_camera_gt;
      ++stats.good;
    } else {
      t0 = Clock::now();
      const IcpResult r = icp(
          pyramid, model, options.fuse_at_reference ? frames[i - 1].T_world_camera_gt : pose,
          tracking, workspace);
      stats.ms_icp.push_back(ms_since(t0));
      if (options.verbose) {
        const IcpSystem sys =
            icp_system(pyramid.maps[0], model.maps,
                       model.T_world_camera.inverse() * r.T_world_camera, tracking);
        Eigen::Matrix<double, 6, 6> A = sys.A;
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(A);
        std::printf(
            "  eig %.3g %.3g %.3g %.3g %.3g %.3g; weakest dir %.2f %.2f %.2f | %.2f %.2f %.2f\n",
            eig.eigenvalues()[0], eig.eigenvalues()[1], eig.eigenvalues()[2], eig.eigenvalues()[3],
            eig.eigenvalues()[4], eig.eigenvalues()[5], eig.eigenvectors()(0, 0),
            eig.eigenvectors()(1, 0), eig.eigenvectors()(2, 0), eig.eigenvectors()(3, 0),
            eig.eigenvectors()(4, 0), eig.eigenvectors()(5, 0));
        const Pose gt_step =
            frames[i - 1].T_world_camera_gt.inverse() * frames[i].T_world_camera_gt;
        std::printf(
            "frame %zu %s inliers %d ratio %.3f rms %.4f moved %.4f m %.2f deg (gt %.4f m) "
            "err %.4f m iters %d\n",
            i, to_string(r.status), r.inliers, r.inlier_ratio, r.rms_residual_m, r.translation_m,
            r.rotation_deg, gt_step.translation().norm(),
            (r.T_world_camera.translation() - frames[i].T_world_camera_gt.translation()).norm(),
            r.iterations);
      }
      pose = options.fuse_at_reference ? frames[i].T_world_camera_gt : r.T_world_camera;
      stats.good += r.status == TrackingStatus::kGood;
      stats.poor += r.status == TrackingStatus::kPoor;
      stats.lost += r.status == TrackingStatus::kLost;
      lost_now = r.status == TrackingStatus::kLost && !options.fuse_at_reference;
    }
    sum_sq += (pose.translation() - frames[i].T_world_camera_gt.translation()).squaredNorm();
    if (lost_now) continue;
    t0 = Clock::now();
    integrator.integrate(volume, raw_m, kKitchenIntrinsics, pose);
    stats.ms_integrate.push_back(ms_since(t0));
    t0 = Clock::now();
    raycast(volume, kKitchenIntrinsics, pose, fusion, model,
            options.no_hint ? nullptr : &raw_m);
    stats.ms_raycast.push_back(ms_since(t0));
  }
  stats.ate_m = frames.empty() ? 0 : std::sqrt(sum_sq / frames.size());
  stats.blocks = volume.block_count();
  stats.volume_mb = volume.memory_bytes() / 1048576.0;
  if (kernel_loops > 0 && !frames.empty()) {
    // Each kernel alone on the last frame, repeated.
    RaycastResult scratch;
    auto loop = [&](const char* name, auto&& kernel) {
      const auto t0 = Clock::now();
      const double cpu0 = cpu_ms();
      for (int i = 0; i < kernel_loops; ++i) kernel();
      std::printf("%-22s wall %7.2f ms  cpu %7.2f ms\n", name, ms_since(t0) / kernel_loops,
                  (cpu_ms() - cpu0) / kernel_loops);
    };
    loop("raycast (hint)",
         [&] { raycast(volume, kKitchenIntrinsics, pose, fusion, scratch, &raw_m); });
    loop("raycast (no hint)", [&] { raycast(volume, kKitchenIntrinsics, pose, fusion, scratch); });
    loop("icp", [&] { icp(pyramid, model, pose, tracking, workspace); });
    loop("integrate", [&] { integrator.integrate(volume, raw_m, kKitchenIntrinsics, pose); });
  }
  if (options.mesh) {
    const auto t0 = Clock::now();
    const TriangleMesh m = extract_mesh(volume, static_cast<float>(fusion.mesh_min_weight));
    stats.ms_mesh = ms_since(t0);
    stats.mesh_vertices = m.vertices.size();
    stats.mesh_faces = m.faces.size();
  }
  return stats;
}

}  // namespace aoscan::test
