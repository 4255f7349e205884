/// @file colour_volume.cpp
/// @brief Colour integration over the blocks of a depth frame, and trilinear colour sampling.
#include "fusion/tsdf/colour_volume.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"

static_assert(aoscan::kBlockSize == 8, "colour sampling finds blocks by shifts of 3 bits");

namespace aoscan {
namespace {

/// Bilinear colour at (u, v) (pixel centres at integers); false outside the image.
bool bilinear(const Image<Rgb8>& image, float u, float v, float rgb[3]) {
  if (!(u >= 0.0f && v >= 0.0f && u <= static_cast<float>(image.width() - 1) &&
        v <= static_cast<float>(image.height() - 1)))
    return false;
  const int x0 = std::min(static_cast<int>(u), image.width() - 2 < 0 ? 0 : image.width() - 2);
  const int y0 = std::min(static_cast<int>(v), image.height() - 2 < 0 ? 0 : image.height() - 2);
  const int x1 = std::min(x0 + 1, image.width() - 1);
  const int y1 = std::min(y0 + 1, image.height() - 1);
  const float fx = u - static_cast<float>(x0), fy = v - static_cast<float>(y0);
  const Rgb8 &a = image(x0, y0), &b = image(x1, y0), &c = image(x0, y1), &d = image(x1, y1);
  const float wa = (1 - fx) * (1 - fy), wb = fx * (1 - fy), wc = (1 - fx) * fy, wd = fx * fy;
  rgb[0] = wa * a.r + wb * b.r + wc * c.r + wd * d.r;
  rgb[1] = wa * a.g + wb * b.g + wc * c.g + wd * d.g;
  rgb[2] = wa * a.b + wb * b.b + wc * c.b + wd * d.b;
  return true;
}

std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::clamp(std::lrint(v), 0L, 255L));
}

}  // namespace

ColourBlock& ColourVolume::allocate(int index) {
  if (index < 0) throw usage_error("ColourVolume: negative block index");
  if (static_cast<std::size_t>(index) >= blocks_.size())
    blocks_.resize(static_cast<std::size_t>(index) + 1);
  std::unique_ptr<ColourBlock>& b = blocks_[static_cast<std::size_t>(index)];
  if (!b) {
    b = std::make_unique<ColourBlock>();
    ++allocated_;
  }
  return *b;
}

ColourIntegrateStats ColourVolume::integrate(const TsdfVolume& volume,
                                             const std::vector<int>& blocks,
                                             const Image<float>& depth_m,
                                             const Intrinsics& depth_intrinsics,
                                             const Pose& T_world_camera,
                                             const Image<Rgb8>& colour, const ColourCamera& camera,
                                             float shell_m, float band_m, int max_weight) {
  ColourIntegrateStats stats;
  if (depth_m.width() != depth_intrinsics.width || depth_m.height() != depth_intrinsics.height)
    throw usage_error("colour integration: the depth differs in size from its intrinsics");
  if (colour.width() != camera.intrinsics.width || colour.height() != camera.intrinsics.height)
    throw usage_error("colour integration: the colour image differs in size from its camera");
  if (camera.registered &&
      (colour.width() != depth_m.width() || colour.height() != depth_m.height()))
    throw usage_error("colour integration: registered colour differs in size from the depth");
  if (!T_world_camera.finite() || blocks.empty() || colour.empty()) return stats;
  if (blocks_.size() < static_cast<std::size_t>(volume.block_count()))
    blocks_.resize(static_cast<std::size_t>(volume.block_count()));

  const Pose T_camera_world = T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  const Eigen::Matrix3f Rc = camera.T_colour_depth.rotation().cast<float>();
  const Eigen::Vector3f tc = camera.T_colour_depth.translation().cast<float>();
  const float fx = static_cast<float>(depth_intrinsics.fx), fy = static_cast<float>(depth_intrinsics.fy);
  const float cx = static_cast<float>(depth_intrinsics.cx), cy = static_cast<float>(depth_intrinsics.cy);
  const Intrinsics& kc = camera.intrinsics;
  const float cfx = static_cast<float>(kc.fx), cfy = static_cast<float>(kc.fy);
  const float ccx = static_cast<float>(kc.cx), ccy = static_cast<float>(kc.cy);
  const float vs = volume.voxel_size_m();
  // Voxels whose fused TSDF puts them outside the shell are not looked at.
  const float shell_tsdf = shell_m / volume.truncation_m();
  const float cap = static_cast<float>(std::clamp(max_weight, 1, 255));
  const int width = depth_m.width(), height = depth_m.height();

  coloured_.assign(blocks.size(), 0);
  fresh_.assign(blocks.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks.size(), 8),
                    [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const int index = blocks[k];
      const VoxelBlock& tsdf = volume.block(index);
      ColourBlock* cb = blocks_[static_cast<std::size_t>(index)].get();
      const Eigen::Vector3i origin = volume.block_coord(index) * kBlockSize;
      int n = 0;
      for (int z = 0; z < kBlockSize; ++z)
        for (int y = 0; y < kBlockSize; ++y)
          for (int x = 0; x < kBlockSize; ++x) {
            const int vi = voxel_index(x, y, z);
            const Voxel& voxel = tsdf.voxels[static_cast<std::size_t>(vi)];
            if (voxel.count == 0 || std::abs(voxel.tsdf()) > shell_tsdf) continue;
            const Eigen::Vector3f world =
                (origin + Eigen::Vector3i(x, y, z)).cast<float>() * vs;
            const Eigen::Vector3f p = R * world + t;
            if (!(p.z() > 0.0f)) continue;
            const int u = floor_to_int(fx * p.x() / p.z() + cx + 0.5f);
            const int v = floor_to_int(fy * p.y() / p.z() + cy + 0.5f);
            if (u < 0 || v < 0 || u >= width || v >= height) continue;
            const float d = depth_m(u, v);
            if (!(d > 0.0f) || std::abs(d - p.z()) > band_m) continue;
            float rgb[3];
            if (camera.registered) {
              const Rgb8& c = colour(u, v);
              rgb[0] = c.r;
              rgb[1] = c.g;
              rgb[2] = c.b;
            } else {
              const Eigen::Vector3f q = Rc * p + tc;
              if (!(q.z() > 0.0f) ||
                  !bilinear(colour, cfx * q.x() / q.z() + ccx, cfy * q.y() / q.z() + ccy, rgb))
                continue;
            }
            if (cb == nullptr) {
              blocks_[static_cast<std::size_t>(index)] = std::make_unique<ColourBlock>();
              cb = blocks_[static_cast<std::size_t>(index)].get();
              fresh_[k] = 1;
            }
            ColourVoxel& c = cb->voxels[static_cast<std::size_t>(vi)];
            const float w = c.weight;
            c.r = to_byte((c.r * w + rgb[0]) / (w + 1.0f));
            c.g = to_byte((c.g * w + rgb[1]) / (w + 1.0f));
            c.b = to_byte((c.b * w + rgb[2]) / (w + 1.0f));
            c.weight = static_cast<std::uint8_t>(std::min(w + 1.0f, cap));
            ++n;
          }
      coloured_[k] = n;
    }
  });
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    stats.voxels_coloured += coloured_[k];
    stats.blocks_allocated += fresh_[k];
  }
  allocated_ += static_cast<std::size_t>(stats.blocks_allocated);
  return stats;
}

const ColourVoxel* ColourVolume::coloured_voxel(const TsdfVolume& volume,
                                                const Eigen::Vector3i& voxel) const {
  // Shifts and masks are floor division and remainder by kBlockSize for negative voxels too.
  const ColourBlock* cb =
      block(volume.find_block({voxel.x() >> 3, voxel.y() >> 3, voxel.z() >> 3}));
  if (cb == nullptr) return nullptr;
  const ColourVoxel& c =
      cb->voxels[static_cast<std::size_t>(voxel_index(voxel.x() & 7, voxel.y() & 7, voxel.z() & 7))];
  return c.weight > 0 ? &c : nullptr;
}

bool ColourVolume::sample(const TsdfVolume& volume, const Eigen::Vector3f& p, Rgb8& out) const {
  const Eigen::Vector3f g = p / volume.voxel_size_m();
  const int x0 = floor_to_int(g.x()), y0 = floor_to_int(g.y()), z0 = floor_to_int(g.z());
  const float fx = g.x() - static_cast<float>(x0), fy = g.y() - static_cast<float>(y0),
              fz = g.z() - static_cast<float>(z0);
  float sum[3] = {0.0f, 0.0f, 0.0f}, weight = 0.0f;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const ColourVoxel* c = coloured_voxel(volume, {x0 + dx, y0 + dy, z0 + dz});
    if (c == nullptr) continue;
    const float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy) * (dz ? fz : 1.0f - fz);
    sum[0] += w * c->r;
    sum[1] += w * c->g;
    sum[2] += w * c->b;
    weight += w;
  }
  if (weight > 1e-6f) {
    out = {to_byte(sum[0] / weight), to_byte(sum[1] / weight), to_byte(sum[2] / weight)};
    return true;
  }
  // None of the eight is coloured (a vertex of the mesh between two surfaces at a depth edge,
  // whose voxels lie outside both shells): the nearest coloured voxel one voxel further out.
  float best = 3.5f;
  for (int dz = -1; dz <= 2; ++dz)
    for (int dy = -1; dy <= 2; ++dy)
      for (int dx = -1; dx <= 2; ++dx) {
        const Eigen::Vector3i voxel(x0 + dx, y0 + dy, z0 + dz);
        const float d2 = (voxel.cast<float>() - g).squaredNorm();
        if (d2 >= best) continue;
        const ColourVoxel* c = coloured_voxel(volume, voxel);
        if (c == nullptr) continue;
        best = d2;
        out = {c->r, c->g, c->b};
      }
  return best < 3.5f;
}

}  // namespace aoscan
