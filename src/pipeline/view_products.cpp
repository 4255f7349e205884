/// @file view_products.cpp
/// @brief Per-pixel MVAO image and the orbit view's sparse AO point cloud.
#include "pipeline/view_products.h"

#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace aoscan {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();

}  // namespace

void mvao_image(const MvaoGrid& grid, const PointMaps& maps, const Pose& T_world_camera,
                Image<float>& out, const Image<std::uint32_t>* slots) {
  const int w = maps.vertices.width();
  out.resize(w, maps.vertices.height());
  if (slots != nullptr && (slots->width() != w || slots->height() != out.height())) slots = nullptr;
  tbb::parallel_for(
      tbb::blocked_range<int>(0, out.height()), [&](const tbb::blocked_range<int>& r) {
        // The pixels without a slot are looked up in batches gathered on the stack.
        constexpr int kBatch = 64;
        Eigen::Vector3f rest[kBatch];
        int rest_x[kBatch];
        float rest_ao[kBatch];
        for (int y = r.begin(); y < r.end(); ++y) {
          const Eigen::Vector3f* vertices = maps.vertices.row(y);
          float* ao = out.row(y);
          if (slots == nullptr) {
            grid.lookup_ao(vertices, static_cast<std::size_t>(w), T_world_camera, ao);
            continue;
          }
          const std::uint32_t* slot = slots->row(y);
          int count = 0;
          const auto flush = [&] {
            grid.lookup_ao(rest, static_cast<std::size_t>(count), T_world_camera, rest_ao);
            for (int i = 0; i < count; ++i) ao[rest_x[i]] = rest_ao[i];
            count = 0;
          };
          for (int x = 0; x < w; ++x) {
            if (slot[x] != MvaoGrid::kNoSlot) {
              ao[x] = grid.slot_ao(slot[x]);
              continue;
            }
            rest[count] = vertices[x];
            rest_x[count] = x;
            if (++count == kBatch) flush();
          }
          flush();
        }
      });
}

void mvao_image(MvaoGrid& grid, AoViewRead read, const PointMaps& maps, const Pose& T_world_camera,
                Image<float>& out, const Image<std::uint32_t>* slots) {
  if (read == AoViewRead::kCells) {
    mvao_image(grid, maps, T_world_camera, out, slots);
    return;
  }
  grid.refresh_brick_sums();
  const int w = maps.vertices.width();
  out.resize(w, maps.vertices.height());
  // Runs of whole rows (contiguous in both images): the coarse read's cache serves a run.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, out.height()), [&](const tbb::blocked_range<int>& r) {
        grid.lookup_ao_coarse(maps.vertices.row(r.begin()),
                              static_cast<std::size_t>(w) * static_cast<std::size_t>(r.size()),
                              T_world_camera, out.row(r.begin()));
      });
}

SurfaceCloud::SurfaceCloud(SurfaceCloudOptions options) : options_(options) {
  if (options_.pixel_step < 1) options_.pixel_step = 1;
}

void SurfaceCloud::clear() {
  mesh_ = TriangleMesh{};
  index_.clear();
  refused_ = 0;
}

void SurfaceCloud::add(const PointMaps& maps, const Image<float>& mvao,
                       const Pose& T_world_camera) {
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  const Eigen::Vector3d& t = T_world_camera.translation();
  const Eigen::Matrix3f R_f = R.cast<float>();
  const bool has_ao =
      mvao.width() == maps.vertices.width() && mvao.height() == maps.vertices.height();
  const double inv_voxel = 1.0 / options_.voxel_m;
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;  // 21 bits per axis, signed range
  for (int y = 0; y < maps.vertices.height(); y += options_.pixel_step) {
    for (int x = 0; x < maps.vertices.width(); x += options_.pixel_step) {
      const Eigen::Vector3f& v = maps.vertices(x, y);
      const Eigen::Vector3f& n = maps.normals(x, y);
      if (v.isZero() || n.isZero()) continue;
      const Eigen::Vector3d p = R * v.cast<double>() + t;
      if (!p.allFinite()) continue;
      std::uint64_t key = 0;
      bool in_range = true;
      for (int a = 0; a < 3; ++a) {
        const double c = std::floor(p[a] * inv_voxel);
        if (c < -kHalf || c >= kHalf) {
          in_range = false;
          break;
        }
        key |= static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + kHalf) << (21 * a);
      }
      if (!in_range) continue;
      const float ao = has_ao ? mvao(x, y) : kNan;
      const auto found = index_.find(key);
      if (found == index_.end()) {
        if (mesh_.vertices.size() >= options_.max_points) {
          ++refused_;
          continue;
        }
        index_.emplace(key, static_cast<std::uint32_t>(mesh_.vertices.size()));
        mesh_.vertices.push_back(p.cast<float>());
        mesh_.normals.push_back(R_f * n);
        mesh_.quality.push_back(ao);
      } else if (!std::isnan(ao)) {
        mesh_.normals[found->second] = R_f * n;
        mesh_.quality[found->second] = ao;
      }
    }
  }
}

std::shared_ptr<const TriangleMesh> SurfaceCloud::to_mesh() const {
  return std::make_shared<const TriangleMesh>(mesh_);
}

}  // namespace aoscan
