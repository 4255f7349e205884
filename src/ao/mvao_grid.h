/// @file mvao_grid.h
/// @brief The sparse multi-view AO grid of Sabbadin et al. 2016 Sec. 6: per world cell {sum AO w,
/// sum w}, keyed by the cell's 64-bit Morton code, accumulated frame by frame.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "ao/ao_config.h"
#include "ao/morton.h"
#include "core/block_hash_map.h"
#include "core/image.h"
#include "core/pose.h"
#include "core/status.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// One observed grid cell.
struct MvaoCell {
  float ao_weight_sum = 0.0f;    ///< sum of AO * w
  float weight_sum = 0.0f;       ///< sum of w (> 0 once observed)
  std::uint32_t last_frame = 0;  ///< 1-based number of the last frame that touched the cell

  float ao() const { return ao_weight_sum / weight_sum; }
};

/// Integer cell coordinates (cell (i, j, k) covers [i, i + 1) * cell_size_m along x, etc.).
using CellIndex = std::array<std::int32_t, 3>;

/// Sparse MVAO grid over the world frame (metres). Cells cover the signed Morton range
/// [-2^20, 2^20 - 1] per axis, so the grid is not bounded by the first frame; memory grows only
/// with observed space. Cells live in bricks of 4^3: the cells whose Morton codes share all but
/// the lowest 6 bits (the low two bits of each axis), stored in Morton order, 768 bytes. Bricks
/// sit in a pool of fixed-size chunks and never move; a hash of brick codes (BlockHashMap, 12
/// bytes per entry) finds them, the layout of the TSDF's voxel blocks. So growing never moves a
/// cell (a flat table of cells moves all of them when it doubles, a frame-long stall), a run of
/// pixels shares one brick lookup, and the memory follows the surface: a brick is made only where
/// a cell of it is observed (BENCHMARKS.md compares the memory with a flat table). Not
/// thread-safe: one writer (the mvao stage).
/// Results are deterministic: pixels are accumulated serially in row-major order, and cells are
/// visited in the order their bricks were made.
class MvaoGrid {
 public:
  /// Cell size = config.grid_extent_m / config.grid_resolution; mode = config.integration. Throws
  /// usage_error when the cell size is not a positive finite number.
  explicit MvaoGrid(const AoConfig& config);

  /// Accumulates one frame: every pixel with weight > 0 and a finite AO, weight and camera-frame
  /// vertex (`maps.vertices`, metres) goes to the cell containing T_world_camera * vertex.
  /// mvao: weight as given (w_d * w_n); mean: weight 1; last: weight 1, and every cell this frame
  /// touches is reset before the frame accumulates into it. AO is clamped to [0, 1]. Pixels whose
  /// cell is outside the Morton range are skipped and counted in points_out_of_range(); pixels
  /// with NaN/inf values (or a negative weight) are skipped and counted in points_invalid().
  /// Returns internal() (and changes nothing) when the image sizes differ.
  /// `slots` (optional): resized to the image and set per pixel to the slot (brick number * 64 +
  /// cell in the brick) of the cell the pixel went to, or kNoSlot (not integrated); valid until
  /// clear(), as cells never move. slot_ao() reads them: the view image of the frame just
  /// integrated, without a second lookup. Beyond kMaxBricks bricks (48 GiB) no new cell is made:
  /// such points are counted in points_out_of_range().
  /// `frame_weight` multiplies every pixel's weight of this frame, in any mode (a still camera's
  /// repeated view, StillViewWeight); it must be positive and finite, else internal() and nothing
  /// changes (a frame that should not count at all is not integrated).
  Status integrate(const Image<float>& ao, const Image<float>& weights, const PointMaps& maps,
                   const Pose& T_world_camera, Image<std::uint32_t>* slots = nullptr,
                   float frame_weight = 1.0f);
  static constexpr std::uint32_t kNoSlot = ~std::uint32_t{0};
  /// Bricks the grid makes at most: slots stay below kNoSlot.
  static constexpr std::uint32_t kMaxBricks = std::uint32_t{1} << 26;
  /// AO of the cell in `slot` (from integrate()'s slots), NaN when it holds no observed cell.
  float slot_ao(std::uint32_t slot) const {
    const std::uint32_t b = slot >> kBrickBits;
    if (b >= brick_codes_.size()) return std::numeric_limits<float>::quiet_NaN();
    const MvaoCell& c = brick(b).cells[slot & (kBrickCells - 1)];
    return c.weight_sum > 0.0f ? c.ao() : std::numeric_limits<float>::quiet_NaN();
  }

  /// Cell containing world point `p_world` (metres), or nullopt when outside the Morton range or
  /// not finite.
  std::optional<CellIndex> cell_of(const Eigen::Vector3d& p_world) const;
  /// The observed cell at `cell`, or nullptr.
  const MvaoCell* find(const CellIndex& cell) const;
  /// AO of an observed cell, or nullopt.
  std::optional<float> cell_ao(const CellIndex& cell) const;
  /// out[i] = AO of the observed cell containing T_world_camera * vertices[i] (camera frame,
  /// metres), NaN where that cell was never observed, the vertex is zero (no surface) or the point
  /// is outside the Morton range: cell_ao(cell_of(...)) for n points, one brick lookup per run of
  /// points in the same brick (the per-pixel lookups of a view image).
  void lookup_ao(const Eigen::Vector3f* vertices, std::size_t n, const Pose& T_world_camera,
                 float* out) const;
  /// World position of a cell's centre (metres).
  Eigen::Vector3d cell_centre(const CellIndex& cell) const;

  /// Trilinear AO at `p_world` from the 8 cell centres around it, renormalised over the observed
  /// ones; nullopt when none of them with a non-zero trilinear weight was observed.
  std::optional<float> sample(const Eigen::Vector3d& p_world) const;
  /// AO of the observed cell whose centre is nearest to `p_world` (Euclidean), searching cells up
  /// to `max_cells` away (Chebyshev) from the cell containing the point; nullopt if none. Ties go
  /// to the cell met first in z, y, x order.
  std::optional<float> nearest_observed(const Eigen::Vector3d& p_world, int max_cells) const;

  /// Side of a brick in cells: the grid keeps the sums of each brick's cells, which are the cells
  /// of coarsened(kBrickSide), for lookup_ao_coarse().
  static constexpr int kBrickSide = 4;
  /// Brings the brick sums up to date with the cells (only the bricks changed since the last
  /// call: integrate(), restore_cell()). Call it on the writer's thread before
  /// lookup_ao_coarse().
  void refresh_brick_sums();
  /// lookup_ao() through the coarse cells of the bricks: out[i] = coarsened(kBrickSide).sample()
  /// at T_world_camera * vertices[i], bit for bit (trilinear between the bricks' mean AO,
  /// renormalised over the observed ones), NaN where the vertex is zero or no brick around it is
  /// observed; without building the coarse grid. The brick sums must be fresh
  /// (refresh_brick_sums()).
  void lookup_ao_coarse(const Eigen::Vector3f* vertices, std::size_t n, const Pose& T_world_camera,
                        float* out) const;
  /// Bricks changed since the last refresh_brick_sums().
  std::size_t stale_bricks() const { return dirty_bricks_.size(); }

  /// A grid of cells factor^3 times larger (cell size * factor, same mode): each of its cells holds
  /// the sums of the observed cells inside it (cell i of this grid goes to floor(i / factor)), so
  /// its AO is their weighted mean. factor < 1 is taken as 1.
  MvaoGrid coarsened(int factor) const;

  /// Calls f(CellIndex, const MvaoCell&) for every observed cell (bricks in the order they were
  /// made, cells in Morton order within each).
  template <class F>
  void for_each_cell(F&& f) const;

  void clear();

  /// Sets the cell at `cell` to `value` (a saved grid read back: `value.last_frame` > 0); returns
  /// false, changing nothing, when the cell is outside the Morton range or the grid is full.
  bool restore_cell(const CellIndex& cell, const MvaoCell& value);
  /// Sets the count of integrated frames (a saved grid read back), which numbers the next frame.
  void set_frames_integrated(std::uint64_t frames) { frames_ = frames; }

  double cell_size_m() const { return cell_size_m_; }
  AoIntegration integration() const { return mode_; }
  std::size_t cell_count() const { return size_; }
  /// Bricks holding the observed cells.
  std::size_t brick_count() const { return brick_codes_.size(); }
  /// Bytes held by the bricks and their index.
  std::size_t memory_bytes() const;
  std::uint64_t frames_integrated() const { return frames_; }
  std::uint64_t points_integrated() const { return points_integrated_; }
  std::uint64_t points_out_of_range() const { return points_out_of_range_; }
  std::uint64_t points_invalid() const { return points_invalid_; }

 private:
  /// Morton code bits inside a brick, and its cells.
  static constexpr int kBrickBits = 6;
  static_assert(kBrickSide * kBrickSide * kBrickSide == 1 << kBrickBits,
                "a brick is kBrickSide^3 cells: the Morton code's low two bits per axis");
  static constexpr std::uint32_t kBrickCells = std::uint32_t{1} << kBrickBits;
  /// Bricks per pool chunk (192 KiB).
  static constexpr int kChunkBits = 8;
  static constexpr std::uint32_t kChunkMask = (std::uint32_t{1} << kChunkBits) - 1;
  struct Brick {
    std::array<MvaoCell, kBrickCells> cells;
  };

  MvaoGrid(double cell_size_m, AoIntegration mode);
  const Brick& brick(std::uint32_t b) const { return chunks_[b >> kChunkBits][b & kChunkMask]; }
  Brick& brick(std::uint32_t b) { return chunks_[b >> kChunkBits][b & kChunkMask]; }
  /// The sums of a brick's observed cells (the coarse cell it forms).
  struct BrickSum {
    float ao_weight_sum = 0.0f;
    float weight_sum = 0.0f;
  };
  void mark_dirty(std::uint32_t b) {
    if (brick_dirty_[b]) return;
    brick_dirty_[b] = 1;
    dirty_bricks_.push_back(b);
  }
  /// Number of the brick with this brick code (Morton code >> kBrickBits), made when needed; -1
  /// when the grid holds kMaxBricks already.
  std::int64_t make_brick(std::uint64_t brick_code);
  /// The observed cell with this Morton code, or nullptr.
  const MvaoCell* find_code(std::uint64_t code) const;

  double cell_size_m_;
  double inv_cell_size_;  ///< 1 / cell_size_m_: every point-to-cell mapping multiplies by it
  AoIntegration mode_;
  BlockHashMap index_;                            ///< brick code -> brick number
  std::vector<std::unique_ptr<Brick[]>> chunks_;  ///< the brick pool
  std::vector<std::uint64_t> brick_codes_;        ///< per brick number: its brick code
  std::vector<BrickSum> brick_sums_;              ///< per brick number: its sums, when not dirty
  std::vector<std::uint8_t> brick_dirty_;         ///< per brick number: changed since refresh
  std::vector<std::uint32_t> dirty_bricks_;       ///< the bricks with brick_dirty_ set
  std::size_t size_ = 0;                          ///< observed cells
  std::uint64_t frames_ = 0;
  std::uint64_t points_integrated_ = 0;
  std::uint64_t points_out_of_range_ = 0;
  std::uint64_t points_invalid_ = 0;
};

template <class F>
void MvaoGrid::for_each_cell(F&& f) const {
  for (std::uint32_t b = 0; b < brick_codes_.size(); ++b) {
    const Brick& cells = brick(b);
    for (std::uint32_t i = 0; i < kBrickCells; ++i) {
      if (cells.cells[i].last_frame == 0) continue;  // never observed
      CellIndex c;
      morton_decode((brick_codes_[b] << kBrickBits) | i, c[0], c[1], c[2]);
      f(static_cast<const CellIndex&>(c), cells.cells[i]);
    }
  }
}

}  // namespace aoscan
