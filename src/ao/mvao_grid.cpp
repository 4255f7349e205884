/// @file mvao_grid.cpp
/// @brief Sparse Morton-keyed MVAO grid: bricks of 4^3 cells in a pool, frame integration in the
/// three modes, trilinear sampling and nearest-observed-cell search.
#include "ao/mvao_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace aoscan {
namespace {

/// floor(v) as a cell coordinate, or nullopt outside the Morton range / not finite.
std::optional<std::int32_t> to_cell(double v) {
  const double f = std::floor(v);
  if (!(f >= kMortonMin && f <= kMortonMax)) return std::nullopt;
  return static_cast<std::int32_t>(f);
}

/// to_cell() without a libm call, for the per-pixel loop: the same result for every double (the
/// range test runs on the truncation first, so only values that fit in int64 are converted).
inline bool to_cell_fast(double v, std::int32_t& cell) {
  if (!(v >= static_cast<double>(kMortonMin) && v < static_cast<double>(kMortonMax) + 1.0))
    return false;
  const std::int32_t t = static_cast<std::int32_t>(v);
  cell = t - (v < static_cast<double>(t) ? 1 : 0);
  return true;
}

}  // namespace

MvaoGrid::MvaoGrid(const AoConfig& config)
    : MvaoGrid(config.grid_extent_m / config.grid_resolution, config.integration) {}

MvaoGrid::MvaoGrid(double cell_size_m, AoIntegration mode)
    : cell_size_m_(cell_size_m), inv_cell_size_(1.0 / cell_size_m), mode_(mode) {
  if (!(cell_size_m_ > 0.0) || !std::isfinite(cell_size_m_))
    throw usage_error("ao.grid_extent_m / ao.grid_resolution must give a positive cell size");
  clear();
}

MvaoGrid MvaoGrid::coarsened(int factor) const {
  const int f = std::max(factor, 1);
  MvaoGrid out(cell_size_m_ * f, mode_);
  out.frames_ = frames_;
  out.points_integrated_ = points_integrated_;
  out.points_out_of_range_ = points_out_of_range_;
  out.points_invalid_ = points_invalid_;
  const auto floor_div = [f](std::int32_t v) {
    return static_cast<std::int32_t>(v >= 0 ? v / f
                                            : -((-static_cast<std::int64_t>(v) + f - 1) / f));
  };
  // Serial in brick order, which is deterministic, so the float sums are too.
  for_each_cell([&](const CellIndex& c, const MvaoCell& fine) {
    const auto code = morton_encode(floor_div(c[0]), floor_div(c[1]), floor_div(c[2]));
    if (!code) return;  // cannot happen: coarse indices lie inside the fine range
    // The coarse grid has at most as many bricks as this one, so make_brick() succeeds.
    const std::int64_t b = out.make_brick(*code >> kBrickBits);
    if (b < 0) return;
    out.mark_dirty(static_cast<std::uint32_t>(b));
    MvaoCell& cell = out.brick(static_cast<std::uint32_t>(b)).cells[*code & (kBrickCells - 1)];
    if (cell.last_frame == 0) ++out.size_;
    cell.ao_weight_sum += fine.ao_weight_sum;
    cell.weight_sum += fine.weight_sum;
    cell.last_frame = std::max(cell.last_frame, fine.last_frame);
  });
  return out;
}

void MvaoGrid::clear() {
  index_.clear();
  chunks_.clear();
  chunks_.shrink_to_fit();
  brick_codes_.clear();
  brick_codes_.shrink_to_fit();
  brick_sums_.clear();
  brick_sums_.shrink_to_fit();
  brick_dirty_.clear();
  brick_dirty_.shrink_to_fit();
  dirty_bricks_.clear();
  dirty_bricks_.shrink_to_fit();
  size_ = 0;
  frames_ = 0;
  points_integrated_ = points_out_of_range_ = points_invalid_ = 0;
}

std::size_t MvaoGrid::memory_bytes() const {
  return index_.memory_bytes() + chunks_.size() * (kChunkMask + 1) * sizeof(Brick) +
         chunks_.capacity() * sizeof(chunks_[0]) + brick_codes_.capacity() * sizeof(std::uint64_t) +
         brick_sums_.capacity() * sizeof(BrickSum) + brick_dirty_.capacity() +
         dirty_bricks_.capacity() * sizeof(std::uint32_t);
}

bool MvaoGrid::restore_cell(const CellIndex& cell, const MvaoCell& value) {
  const auto code = morton_encode(cell[0], cell[1], cell[2]);
  if (!code || value.last_frame == 0) return false;
  const std::int64_t b = make_brick(*code >> kBrickBits);
  if (b < 0) return false;
  mark_dirty(static_cast<std::uint32_t>(b));
  MvaoCell& c = brick(static_cast<std::uint32_t>(b)).cells[*code & (kBrickCells - 1)];
  if (c.last_frame == 0) ++size_;
  c = value;
  return true;
}

std::int64_t MvaoGrid::make_brick(std::uint64_t brick_code) {
  const int found = index_.find(brick_code);
  if (found >= 0) return found;
  const std::uint32_t b = static_cast<std::uint32_t>(brick_codes_.size());
  if (b >= kMaxBricks) return -1;
  if ((b & kChunkMask) == 0) chunks_.push_back(std::make_unique<Brick[]>(kChunkMask + 1));
  brick_codes_.push_back(brick_code);
  brick_sums_.emplace_back();
  brick_dirty_.push_back(0);
  index_.insert(brick_code, static_cast<int>(b));
  return b;
}

const MvaoCell* MvaoGrid::find_code(std::uint64_t code) const {
  const int b = index_.find(code >> kBrickBits);
  if (b < 0) return nullptr;
  const MvaoCell& c = brick(static_cast<std::uint32_t>(b)).cells[code & (kBrickCells - 1)];
  return c.weight_sum > 0.0f ? &c : nullptr;
}

Status MvaoGrid::integrate(const Image<float>& ao, const Image<float>& weights,
                           const PointMaps& maps, const Pose& T_world_camera,
                           Image<std::uint32_t>* slots, float frame_weight) {
  const int w = maps.vertices.width();
  const int h = maps.vertices.height();
  if (ao.width() != w || ao.height() != h || weights.width() != w || weights.height() != h)
    return Status::internal("MvaoGrid::integrate: AO, weight and vertex images differ in size");
  if (!(frame_weight > 0.0f) || !std::isfinite(frame_weight))
    return Status::internal("MvaoGrid::integrate: the frame weight must be positive and finite");
  ++frames_;
  const std::uint32_t stamp = static_cast<std::uint32_t>(frames_);
  const Eigen::Matrix3d R = T_world_camera.rotation();
  const Eigen::Vector3d t = T_world_camera.translation();
  const double inv_cell = inv_cell_size_;
  std::uint32_t* slot_out = nullptr;
  if (slots != nullptr) {
    slots->resize(w, h, kNoSlot);
    slots->fill(kNoSlot);
    slot_out = slots->data();
  }
  const float* ao_data = ao.data();
  const float* w_data = weights.data();
  const Eigen::Vector3f* verts = maps.vertices.data();
  // Pixels go in batches of three passes, so that the cache misses of a batch overlap: the
  // first turns the accepted pixels into cell codes and prefetches the index slots of their
  // bricks, the second finds (or makes, in pixel order) the bricks and prefetches the cells, the
  // third accumulates in pixel order, so the result is the same as one pixel at a time.
  constexpr std::size_t kBatch = 64;
  std::uint64_t codes[kBatch];
  MvaoCell* batch_cell[kBatch];
  std::uint32_t batch_slot[kBatch];
  float batch_ao[kBatch];
  float batch_w[kBatch];
  std::size_t batch_pixel[kBatch];
  constexpr std::uint64_t kNone = ~std::uint64_t{0};  // never a brick code
  std::uint64_t brick_code = kNone;                   // the brick of the last cell
  std::int64_t brick_number = -1;
  const std::size_t n = ao.size();
  for (std::size_t begin = 0; begin < n;) {
    std::size_t count = 0;
    std::size_t i = begin;
    std::uint64_t prefetched = kNone;
    for (; i < n && count < kBatch; ++i) {
      const float wi = w_data[i];
      if (wi == 0.0f) continue;
      const float ai = ao_data[i];
      const Eigen::Vector3f& v = verts[i];
      if (!(wi > 0.0f) || !std::isfinite(wi) || !std::isfinite(ai) || !v.allFinite()) {
        ++points_invalid_;
        continue;
      }
      const Eigen::Vector3d p = (R * v.cast<double>() + t) * inv_cell;
      if (!p.allFinite()) {
        ++points_invalid_;
        continue;
      }
      std::int32_t cx, cy, cz;
      if (!to_cell_fast(p.x(), cx) || !to_cell_fast(p.y(), cy) || !to_cell_fast(p.z(), cz)) {
        ++points_out_of_range_;
        continue;
      }
      codes[count] = *morton_encode(cx, cy, cz);
      if ((codes[count] >> kBrickBits) != prefetched) {
        prefetched = codes[count] >> kBrickBits;
        index_.prefetch(prefetched);
      }
      batch_pixel[count] = i;
      batch_ao[count] = std::min(std::max(ai, 0.0f), 1.0f);
      batch_w[count] = (mode_ == AoIntegration::kMvao ? wi : 1.0f) * frame_weight;
      ++count;
    }
    begin = i;
    for (std::size_t k = 0; k < count; ++k) {
      if ((codes[k] >> kBrickBits) != brick_code) {
        brick_code = codes[k] >> kBrickBits;
        brick_number = make_brick(brick_code);
        if (brick_number >= 0) mark_dirty(static_cast<std::uint32_t>(brick_number));
      }
      batch_cell[k] = nullptr;
      if (brick_number < 0) continue;
      const std::uint32_t local = static_cast<std::uint32_t>(codes[k] & (kBrickCells - 1));
      batch_cell[k] = &brick(static_cast<std::uint32_t>(brick_number)).cells[local];
      batch_slot[k] = (static_cast<std::uint32_t>(brick_number) << kBrickBits) | local;
      __builtin_prefetch(batch_cell[k], 1);
    }
    for (std::size_t k = 0; k < count; ++k) {
      if (batch_cell[k] == nullptr) {  // no brick left for it
        ++points_out_of_range_;
        continue;
      }
      MvaoCell& cell = *batch_cell[k];
      if (cell.last_frame != stamp) {
        if (cell.last_frame == 0)
          ++size_;
        else if (mode_ == AoIntegration::kLast)
          cell.ao_weight_sum = cell.weight_sum = 0.0f;
        cell.last_frame = stamp;
      }
      cell.ao_weight_sum += batch_w[k] * batch_ao[k];
      cell.weight_sum += batch_w[k];
      if (slot_out != nullptr) slot_out[batch_pixel[k]] = batch_slot[k];
      ++points_integrated_;
    }
  }
  return Status::ok();
}

std::optional<CellIndex> MvaoGrid::cell_of(const Eigen::Vector3d& p_world) const {
  const Eigen::Vector3d p = p_world * inv_cell_size_;
  const auto cx = to_cell(p.x()), cy = to_cell(p.y()), cz = to_cell(p.z());
  if (!cx || !cy || !cz) return std::nullopt;
  return CellIndex{*cx, *cy, *cz};
}

void MvaoGrid::lookup_ao(const Eigen::Vector3f* vertices, std::size_t n, const Pose& T_world_camera,
                         float* out) const {
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  const Eigen::Vector3d& t = T_world_camera.translation();
  constexpr std::uint64_t kNone = ~std::uint64_t{0};  // never a Morton or brick code
  std::uint64_t brick_code = kNone;
  const Brick* cells = nullptr;  // the brick of brick_code, nullptr when there is none
  // In batches of three passes, as integrate(): cell codes (brick index slots prefetched), cells
  // (prefetched), AO.
  constexpr std::size_t kBatch = 64;
  std::uint64_t codes[kBatch];
  const MvaoCell* batch_cell[kBatch];
  for (std::size_t begin = 0; begin < n; begin += kBatch) {
    const std::size_t count = std::min(kBatch, n - begin);
    std::uint64_t prefetched = kNone;
    for (std::size_t k = 0; k < count; ++k) {
      codes[k] = kNone;
      const Eigen::Vector3f& v = vertices[begin + k];
      if (v.isZero()) continue;
      const Eigen::Vector3d p = (R * v.cast<double>() + t) * inv_cell_size_;  // as cell_of()
      std::int32_t cx, cy, cz;
      if (!to_cell_fast(p.x(), cx) || !to_cell_fast(p.y(), cy) || !to_cell_fast(p.z(), cz))
        continue;
      codes[k] = *morton_encode(cx, cy, cz);
      if ((codes[k] >> kBrickBits) != prefetched) {
        prefetched = codes[k] >> kBrickBits;
        index_.prefetch(prefetched);
      }
    }
    for (std::size_t k = 0; k < count; ++k) {
      batch_cell[k] = nullptr;
      if (codes[k] == kNone) continue;
      if ((codes[k] >> kBrickBits) != brick_code) {
        brick_code = codes[k] >> kBrickBits;
        const int b = index_.find(brick_code);
        cells = b >= 0 ? &brick(static_cast<std::uint32_t>(b)) : nullptr;
      }
      if (cells == nullptr) continue;
      batch_cell[k] = &cells->cells[codes[k] & (kBrickCells - 1)];
      __builtin_prefetch(batch_cell[k]);
    }
    for (std::size_t k = 0; k < count; ++k) {
      const MvaoCell* c = batch_cell[k];
      out[begin + k] =
          c != nullptr && c->weight_sum > 0.0f ? c->ao() : std::numeric_limits<float>::quiet_NaN();
    }
  }
}

const MvaoCell* MvaoGrid::find(const CellIndex& c) const {
  const auto code = morton_encode(c[0], c[1], c[2]);
  return code ? find_code(*code) : nullptr;
}

std::optional<float> MvaoGrid::cell_ao(const CellIndex& cell) const {
  const MvaoCell* c = find(cell);
  if (!c) return std::nullopt;
  return c->ao();
}

Eigen::Vector3d MvaoGrid::cell_centre(const CellIndex& c) const {
  return (Eigen::Vector3d(c[0], c[1], c[2]) + Eigen::Vector3d::Constant(0.5)) * cell_size_m_;
}

std::optional<float> MvaoGrid::sample(const Eigen::Vector3d& p_world) const {
  const Eigen::Vector3d g = p_world * inv_cell_size_ - Eigen::Vector3d::Constant(0.5);
  if (!g.allFinite()) return std::nullopt;
  const Eigen::Vector3d base = g.array().floor();
  if ((base.array() < kMortonMin).any() || (base.array() > kMortonMax).any()) return std::nullopt;
  const Eigen::Vector3d f = g - base;
  double sum = 0.0, total = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const double tw =
        (dx ? f.x() : 1.0 - f.x()) * (dy ? f.y() : 1.0 - f.y()) * (dz ? f.z() : 1.0 - f.z());
    if (!(tw > 0.0)) continue;
    const std::int64_t cx = static_cast<std::int64_t>(base.x()) + dx;
    const std::int64_t cy = static_cast<std::int64_t>(base.y()) + dy;
    const std::int64_t cz = static_cast<std::int64_t>(base.z()) + dz;
    if (cx > kMortonMax || cy > kMortonMax || cz > kMortonMax) continue;
    const MvaoCell* c = find({static_cast<std::int32_t>(cx), static_cast<std::int32_t>(cy),
                              static_cast<std::int32_t>(cz)});
    if (!c) continue;
    sum += tw * c->ao();
    total += tw;
  }
  if (!(total > 0.0)) return std::nullopt;
  return static_cast<float>(std::min(std::max(sum / total, 0.0), 1.0));
}

void MvaoGrid::refresh_brick_sums() {
  for (const std::uint32_t b : dirty_bricks_) {
    // The order of coarsened(): the brick's observed cells in Morton order, from zero.
    BrickSum sum;
    for (const MvaoCell& c : brick(b).cells) {
      if (c.last_frame == 0) continue;
      sum.ao_weight_sum += c.ao_weight_sum;
      sum.weight_sum += c.weight_sum;
    }
    brick_sums_[b] = sum;
    brick_dirty_[b] = 0;
  }
  dirty_bricks_.clear();
}

void MvaoGrid::lookup_ao_coarse(const Eigen::Vector3f* vertices, std::size_t n,
                                const Pose& T_world_camera, float* out) const {
  const Eigen::Matrix3d& R = T_world_camera.rotation();
  const Eigen::Vector3d& t = T_world_camera.translation();
  // As coarsened(kBrickSide).sample(): the coarse grid's cell size and its reciprocal.
  const double inv_coarse = 1.0 / (cell_size_m_ * kBrickSide);
  // The mean AO of coarse cells (NaN: unobserved) in a direct-mapped cache: the pixels of a view
  // share most of their coarse cells, and a lookup in a large grid's index is a cache miss. Keys
  // pack the offset coordinates (within the Morton range).
  constexpr int kCacheBits = 11;
  struct Entry {
    std::uint64_t key = ~std::uint64_t{0};  // never a packed coordinate
    float ao = 0.0f;
  };
  std::array<Entry, std::size_t{1} << kCacheBits> cache{};
  const auto pack = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    const auto offset = [](std::int64_t v) { return static_cast<std::uint64_t>(v - kMortonMin); };
    return offset(x) | offset(y) << 21 | offset(z) << 42;
  };
  const auto brick_mean = [&](std::int64_t cx, std::int64_t cy, std::int64_t cz) {
    constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
    if (cx > kMortonMax || cy > kMortonMax || cz > kMortonMax) return kNan;  // as sample()
    const std::uint64_t key = pack(cx, cy, cz);
    Entry& e = cache[(key * 0x9E3779B97F4A7C15ull) >> (64 - kCacheBits)];
    if (e.key == key) return e.ao;
    e.key = key;
    e.ao = kNan;
    // Coarse cell c holds the fine cells kBrickSide * c + [0, kBrickSide) per axis: one brick.
    const std::int64_t x = cx * kBrickSide, y = cy * kBrickSide, z = cz * kBrickSide;
    if (x >= kMortonMin && x <= kMortonMax && y >= kMortonMin && y <= kMortonMax &&
        z >= kMortonMin && z <= kMortonMax) {
      const int b =
          index_.find(*morton_encode(static_cast<std::int32_t>(x), static_cast<std::int32_t>(y),
                                     static_cast<std::int32_t>(z)) >>
                      kBrickBits);
      if (b >= 0) {
        const BrickSum& sum = brick_sums_[static_cast<std::size_t>(b)];
        if (sum.weight_sum > 0.0f) e.ao = sum.ao_weight_sum / sum.weight_sum;
      }
    }
    return e.ao;
  };
  // sample()'s arithmetic on the coarse cells (its test holds the two to the same bits), with
  // the 8 corners' AO kept while the base cell stays the same (neighbouring pixels mostly share
  // it), and without a branch: an unobserved corner adds 0 * 0, which leaves both sums' bits as
  // skipping it does (so does a zero weight).
  std::uint64_t base_key = ~std::uint64_t{0};
  double corner_ao[8], corner_seen[8];
  for (std::size_t i = 0; i < n; ++i) {
    out[i] = std::numeric_limits<float>::quiet_NaN();
    const Eigen::Vector3f& v = vertices[i];
    if (v.isZero()) continue;
    const Eigen::Vector3d g =
        (R * v.cast<double>() + t) * inv_coarse - Eigen::Vector3d::Constant(0.5);
    // floor(g) within the Morton range (which also rules out NaN), without a libm call.
    std::int32_t bx, by, bz;
    if (!to_cell_fast(g.x(), bx) || !to_cell_fast(g.y(), by) || !to_cell_fast(g.z(), bz)) continue;
    const Eigen::Vector3d base(bx, by, bz);
    const std::uint64_t key = pack(bx, by, bz);
    if (key != base_key) {
      base_key = key;
      for (int corner = 0; corner < 8; ++corner) {
        const float ao =
            brick_mean(bx + (corner & 1), by + ((corner >> 1) & 1), bz + ((corner >> 2) & 1));
        corner_seen[corner] = std::isnan(ao) ? 0.0 : 1.0;
        corner_ao[corner] = std::isnan(ao) ? 0.0 : ao;
      }
    }
    const Eigen::Vector3d f = g - base;
    const double wx[2] = {1.0 - f.x(), f.x()}, wy[2] = {1.0 - f.y(), f.y()},
                 wz[2] = {1.0 - f.z(), f.z()};
    double sum = 0.0, total = 0.0;
    for (int corner = 0; corner < 8; ++corner) {
      const double tw =
          wx[corner & 1] * wy[(corner >> 1) & 1] * wz[(corner >> 2) & 1] * corner_seen[corner];
      sum += tw * corner_ao[corner];
      total += tw;
    }
    if (total > 0.0) out[i] = static_cast<float>(std::min(std::max(sum / total, 0.0), 1.0));
  }
}

std::optional<float> MvaoGrid::nearest_observed(const Eigen::Vector3d& p_world,
                                                int max_cells) const {
  const auto home = cell_of(p_world);
  if (!home || size_ == 0) return std::nullopt;
  double best_d2 = std::numeric_limits<double>::infinity();
  std::optional<float> best;
  // Shell r holds cells at Chebyshev distance r; a cell there is at least (r - 1) cells from p.
  for (int r = 0; r <= std::max(max_cells, 0); ++r) {
    const double min_dist = std::max(r - 1, 0) * cell_size_m_;
    if (best && min_dist * min_dist > best_d2) break;
    for (int dz = -r; dz <= r; ++dz)
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
          const std::int64_t c[3] = {std::int64_t{(*home)[0]} + dx, std::int64_t{(*home)[1]} + dy,
                                     std::int64_t{(*home)[2]} + dz};
          if (!morton_in_range(static_cast<std::int32_t>(
                                   std::clamp<std::int64_t>(c[0], kMortonMin - 1, kMortonMax + 1)),
                               static_cast<std::int32_t>(
                                   std::clamp<std::int64_t>(c[1], kMortonMin - 1, kMortonMax + 1)),
                               static_cast<std::int32_t>(
                                   std::clamp<std::int64_t>(c[2], kMortonMin - 1, kMortonMax + 1))))
            continue;
          const CellIndex ci{static_cast<std::int32_t>(c[0]), static_cast<std::int32_t>(c[1]),
                             static_cast<std::int32_t>(c[2])};
          const MvaoCell* cell = find(ci);
          if (!cell) continue;
          const double d2 = (cell_centre(ci) - p_world).squaredNorm();
          if (d2 < best_d2) {
            best_d2 = d2;
            best = cell->ao();
          }
        }
  }
  return best;
}

}  // namespace aoscan
