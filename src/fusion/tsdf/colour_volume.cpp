/// @file colour_volume.cpp
/// @brief Colour integration over the blocks of a depth frame, and trilinear colour sampling.
#include "fusion/tsdf/colour_volume.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#endif

#include "core/status.h"
#include "fusion/tsdf/colour_kernels.h"
#include "geometry/simd.h"

static_assert(aoscan::kBlockSize == 8, "colour sampling finds blocks by shifts of 3 bits");

namespace aoscan {
namespace detail {

AOSCAN_NO_CONTRACT void project_shell_portable(const ColourProjection& c, const int origin[3],
                                               const std::uint16_t* voxel, int n,
                                               ColourHits& hits) {
  const float width = static_cast<float>(c.width), height = static_cast<float>(c.height);
  int count = 0;
  for (int k = 0; k < n; ++k) {
    const int vi = voxel[k];
    const float wx = static_cast<float>(origin[0] + (vi & 7)) * c.voxel_m;
    const float wy = static_cast<float>(origin[1] + ((vi >> 3) & 7)) * c.voxel_m;
    const float wz = static_cast<float>(origin[2] + (vi >> 6)) * c.voxel_m;
    const float x = ((c.R[0][0] * wx + c.R[0][1] * wy) + c.R[0][2] * wz) + c.t[0];
    const float y = ((c.R[1][0] * wx + c.R[1][1] * wy) + c.R[1][2] * wz) + c.t[1];
    const float z = ((c.R[2][0] * wx + c.R[2][1] * wy) + c.R[2][2] * wz) + c.t[2];
    if (!(z > 0.0f)) continue;
    // floor(u) inside [0, width) exactly when u is (NaN is neither).
    const float u = (c.fx * x) / z + c.cx;
    const float v = (c.fy * y) / z + c.cy;
    if (!(u >= 0.0f && u < width && v >= 0.0f && v < height)) continue;
    const int pixel = static_cast<int>(v) * c.width + static_cast<int>(u);
    const float d = c.depth[pixel];
    if (!(d > 0.0f && std::abs(d - z) <= c.band_m)) continue;
    hits.voxel[count] = static_cast<std::uint16_t>(vi);
    hits.pixel[count] = pixel;
    hits.x[count] = x;
    hits.y[count] = y;
    hits.z[count] = z;
    ++count;
  }
  hits.count = count;
}

}  // namespace detail

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

/// v rounded to the nearest integer (ties to even, as std::lrint in the default rounding mode)
/// and clamped to a byte. On x86 one instruction: std::lrint is a library call there.
std::uint8_t to_byte(float v) {
#if defined(__SSE__) || defined(__x86_64__)
  const long rounded = _mm_cvtss_si32(_mm_set_ss(v));
#else
  const long rounded = std::lrint(v);
#endif
  return static_cast<std::uint8_t>(std::clamp(rounded, 0L, 255L));
}

}  // namespace

namespace detail {

AOSCAN_NO_CONTRACT void update_colours_portable(std::uint8_t* voxels, const std::uint16_t* index,
                                                const float* r, const float* g, const float* b,
                                                int n, float cap) {
  for (int k = 0; k < n; ++k) {
    std::uint8_t* c = voxels + 4 * index[k];
    const float w = c[3];
    c[0] = to_byte((static_cast<float>(c[0]) * w + r[k]) / (w + 1.0f));
    c[1] = to_byte((static_cast<float>(c[1]) * w + g[k]) / (w + 1.0f));
    c[2] = to_byte((static_cast<float>(c[2]) * w + b[k]) / (w + 1.0f));
    c[3] = static_cast<std::uint8_t>(std::min(w + 1.0f, cap));
  }
}

}  // namespace detail

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

ColourIntegration::ColourIntegration(ColourVolume& colour, const ColourFrameInput& input)
#if AOSCAN_COLOUR_X86
    : ColourIntegration(colour, input, cpu_has_avx2()) {
}
#else
    : ColourIntegration(colour, input, false) {
}
#endif

ColourIntegration::ColourIntegration(ColourVolume& colour, const ColourFrameInput& input,
                                     bool simd)
    : colour_(colour),
      depth_m_(*input.depth_m),
      image_(*input.colour),
      registered_(input.camera.registered),
      simd_(simd && AOSCAN_COLOUR_X86) {
  const Intrinsics& kd = input.depth_intrinsics;
  const Intrinsics& kc = input.camera.intrinsics;
  if (depth_m_.width() != kd.width || depth_m_.height() != kd.height)
    throw usage_error("colour integration: the depth differs in size from its intrinsics");
  if (image_.width() != kc.width || image_.height() != kc.height)
    throw usage_error("colour integration: the colour image differs in size from its camera");
  if (registered_ && (image_.width() != depth_m_.width() || image_.height() != depth_m_.height()))
    throw usage_error("colour integration: registered colour differs in size from the depth");
  const Pose T_camera_world = input.T_world_camera.inverse();
  const Eigen::Matrix3f R = T_camera_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_camera_world.translation().cast<float>();
  detail::ColourProjection& c = projection_;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) c.R[i][j] = R(i, j);
    c.t[i] = t(i);
  }
  c.fx = static_cast<float>(kd.fx);
  c.fy = static_cast<float>(kd.fy);
  c.cx = static_cast<float>(kd.cx + 0.5);
  c.cy = static_cast<float>(kd.cy + 0.5);
  c.voxel_m = 0.0f;
  c.width = kd.width;
  c.height = kd.height;
  c.depth = depth_m_.data();
  c.band_m = input.band_m;
  Rc_ = input.camera.T_colour_depth.rotation().cast<float>();
  tc_ = input.camera.T_colour_depth.translation().cast<float>();
  cfx_ = static_cast<float>(kc.fx);
  cfy_ = static_cast<float>(kc.fy);
  ccx_ = static_cast<float>(kc.cx);
  ccy_ = static_cast<float>(kc.cy);
  shell_m_ = input.shell_m;
  cap_ = static_cast<float>(std::clamp(input.max_weight, 1, 255));
}

void ColourIntegration::begin(const TsdfVolume& volume, const std::vector<int>& blocks) {
  blocks_ = &blocks;
  projection_.voxel_m = volume.voxel_size_m();
  // Voxels whose fused TSDF puts them outside the shell are not looked at. The test on the
  // quantised TSDF: |tsdf_q| <= shell_q_ exactly when |tsdf()| <= shell_tsdf (tsdf() is tsdf_q
  // times a positive step, monotone in tsdf_q).
  const float shell_tsdf = shell_m_ / volume.truncation_m();
  shell_q_ = -1;
  if (shell_tsdf >= 0.0f) {
    shell_q_ = static_cast<int>(std::min(shell_tsdf, 1.0f) * Voxel::kTsdfScale);
    while (shell_q_ < 32767 && static_cast<float>(shell_q_ + 1) * Voxel::kTsdfStep <= shell_tsdf)
      ++shell_q_;
    while (shell_q_ >= 0 && static_cast<float>(shell_q_) * Voxel::kTsdfStep > shell_tsdf)
      --shell_q_;
  }
  if (colour_.blocks_.size() < static_cast<std::size_t>(volume.block_count()))
    colour_.blocks_.resize(static_cast<std::size_t>(volume.block_count()));
  colour_.coloured_.assign(blocks.size(), 0);
  colour_.fresh_.assign(blocks.size(), 0);
}

void ColourIntegration::visit(const TsdfVolume& volume, std::size_t position) {
  const int index = (*blocks_)[position];
  const VoxelBlock& tsdf = volume.block(index);
  colour_.coloured_[position] = 0;
  // Most voxels of an updated block lie outside the shell (or were never seen): a branch-free
  // first pass flags the shell's voxels, so that only those are projected.
  alignas(8) std::array<std::uint8_t, kBlockVoxels> in_shell;
  for (int vi = 0; vi < kBlockVoxels; ++vi) {
    const Voxel& voxel = tsdf.voxels[static_cast<std::size_t>(vi)];
    in_shell[static_cast<std::size_t>(vi)] = static_cast<std::uint8_t>(
        (voxel.count != 0) & (voxel.tsdf_q >= -shell_q_) & (voxel.tsdf_q <= shell_q_));
  }
  std::array<std::uint16_t, kBlockVoxels> shell;
  int n = 0;
  for (int word = 0; word < kBlockVoxels / 8; ++word) {
    std::uint64_t flags;
    std::memcpy(&flags, in_shell.data() + 8 * word, sizeof(flags));
    for (; flags != 0; flags &= flags - 1)
      shell[static_cast<std::size_t>(n++)] =
          static_cast<std::uint16_t>(8 * word + __builtin_ctzll(flags) / 8);
  }
  if (n == 0) return;
  const Eigen::Vector3i first = volume.block_coord(index) * kBlockSize;
  const int origin[3] = {first.x(), first.y(), first.z()};
  detail::ColourHits hits;
#if AOSCAN_COLOUR_X86
  if (simd_)
    detail::project_shell_avx2(projection_, origin, shell.data(), n, hits);
  else
#endif
    detail::project_shell_portable(projection_, origin, shell.data(), n, hits);
  // Each hit's colour: its depth pixel's (registered) or the colour camera's bilinear sample.
  std::array<std::uint16_t, kBlockVoxels> coloured;
  std::array<float, kBlockVoxels> r, g, b;
  int m = 0;
  for (int k = 0; k < hits.count; ++k) {
    float rgb[3];
    if (registered_) {
      const Rgb8& c = image_.data()[hits.pixel[k]];
      rgb[0] = c.r;
      rgb[1] = c.g;
      rgb[2] = c.b;
    } else {
      const Eigen::Vector3f q = Rc_ * Eigen::Vector3f(hits.x[k], hits.y[k], hits.z[k]) + tc_;
      if (!(q.z() > 0.0f) ||
          !bilinear(image_, cfx_ * q.x() / q.z() + ccx_, cfy_ * q.y() / q.z() + ccy_, rgb))
        continue;
    }
    const auto at = static_cast<std::size_t>(m++);
    coloured[at] = hits.voxel[k];
    r[at] = rgb[0];
    g[at] = rgb[1];
    b[at] = rgb[2];
  }
  if (m == 0) return;
  std::unique_ptr<ColourBlock>& slot = colour_.blocks_[static_cast<std::size_t>(index)];
  if (slot == nullptr) {
    slot = std::make_unique<ColourBlock>();
    colour_.fresh_[position] = 1;
  }
  static_assert(sizeof(ColourVoxel) == 4 && offsetof(ColourVoxel, weight) == 3,
                "a colour voxel is r, g, b, weight");
  auto* bytes = reinterpret_cast<std::uint8_t*>(slot->voxels.data());
#if AOSCAN_COLOUR_X86
  if (simd_)
    detail::update_colours_avx2(bytes, coloured.data(), r.data(), g.data(), b.data(), m, cap_);
  else
#endif
    detail::update_colours_portable(bytes, coloured.data(), r.data(), g.data(), b.data(), m,
                                    cap_);
  colour_.coloured_[position] = m;
}

ColourIntegrateStats ColourIntegration::finish() {
  ColourIntegrateStats stats;
  if (blocks_ == nullptr) return stats;  // no begin(): the depth frame was not integrated
  blocks_ = nullptr;
  for (std::size_t k = 0; k < colour_.coloured_.size(); ++k) {
    stats.voxels_coloured += colour_.coloured_[k];
    stats.blocks_allocated += colour_.fresh_[k];
  }
  colour_.allocated_ += static_cast<std::size_t>(stats.blocks_allocated);
  return stats;
}

namespace {

/// Voxel `voxel` (integer voxel coordinates) of colour block `cb` (the block holding it, or
/// nullptr) when it has a colour, else nullptr. Masks are the remainder by kBlockSize for
/// negative voxels too.
const ColourVoxel* coloured_in(const ColourBlock* cb, const Eigen::Vector3i& voxel) {
  if (cb == nullptr) return nullptr;
  const ColourVoxel& c =
      cb->voxels[static_cast<std::size_t>(voxel_index(voxel.x() & 7, voxel.y() & 7, voxel.z() & 7))];
  return c.weight > 0 ? &c : nullptr;
}

}  // namespace

const ColourVoxel* ColourVolume::coloured_voxel(const TsdfVolume& volume,
                                                const Eigen::Vector3i& voxel) const {
  // Shifts are floor division by kBlockSize for negative voxels too.
  return coloured_in(block(volume.find_block({voxel.x() >> 3, voxel.y() >> 3, voxel.z() >> 3})),
                     voxel);
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
  // whose voxels lie outside both shells, or a surface whose shell the colour frames missed): the
  // nearest coloured voxel within kReachSq, found among the 6^3 voxels around the eight; their
  // blocks (at most two per axis) are looked up once.
  constexpr float kReachSq = 8.5f;  // within sqrt(8.5) = 2.9 voxels
  constexpr int kFrom = -2, kTo = 3;
  const Eigen::Vector3i low(x0 + kFrom, y0 + kFrom, z0 + kFrom);
  const Eigen::Vector3i first_block(low.x() >> 3, low.y() >> 3, low.z() >> 3);
  const ColourBlock* blocks[2][2][2];
  for (int bz = 0; bz < 2; ++bz)
    for (int by = 0; by < 2; ++by)
      for (int bx = 0; bx < 2; ++bx)
        blocks[bz][by][bx] = block(volume.find_block(first_block + Eigen::Vector3i(bx, by, bz)));
  float best = kReachSq;
  for (int dz = kFrom; dz <= kTo; ++dz)
    for (int dy = kFrom; dy <= kTo; ++dy)
      for (int dx = kFrom; dx <= kTo; ++dx) {
        const Eigen::Vector3i voxel(x0 + dx, y0 + dy, z0 + dz);
        const float d2 = (voxel.cast<float>() - g).squaredNorm();
        if (d2 >= best) continue;
        const ColourVoxel* c = coloured_in(
            blocks[(voxel.z() >> 3) - first_block.z()][(voxel.y() >> 3) - first_block.y()]
                  [(voxel.x() >> 3) - first_block.x()],
            voxel);
        if (c == nullptr) continue;
        best = d2;
        out = {c->r, c->g, c->b};
      }
  return best < kReachSq;
}

}  // namespace aoscan
