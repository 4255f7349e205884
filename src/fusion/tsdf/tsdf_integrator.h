/// @file tsdf_integrator.h
/// @brief Projective TSDF integration of depth frames into a TsdfVolume: band allocation along
/// the depth rays, then the voxel update of the blocks of the band.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

/// What one integrate() call did.
struct IntegrateStats {
  int rays = 0;              ///< valid depth pixels cast
  int blocks_allocated = 0;  ///< blocks newly allocated by this frame
  int blocks_updated = 0;    ///< blocks whose voxels were updated (the band of this frame)
  int blocks_dropped = 0;    ///< blocks the band needed that the capacity did not allow
  bool skipped = false;      ///< true when the pose was not finite: nothing was done
};

/// Work on each block of a frame while its voxels are in the cache: TsdfIntegrator::integrate()
/// calls begin() once the frame's blocks are allocated, then visit() for each block right after
/// its voxels were updated, on the thread that updated them (different blocks concurrently).
class BlockVisitor {
 public:
  virtual ~BlockVisitor() = default;
  /// `blocks`: the blocks that will be updated (TsdfIntegrator::updated_blocks()), none yet.
  virtual void begin(const TsdfVolume& volume, const std::vector<int>& blocks) = 0;
  /// Block blocks[position] (as given to begin()) holds this frame's fused voxels.
  virtual void visit(const TsdfVolume& volume, std::size_t position) = 0;
};

/// Fuses depth frames into a TsdfVolume (its voxel size, truncation and weight cap). Holds only
/// per-frame scratch and per-block bookkeeping, so one integrator can serve any volume; the
/// volume keeps the fused state. Not thread-safe: one integrate() at a time, and the volume's
/// usual single-writer rule applies.
class TsdfIntegrator {
 public:
  /// Fuses one depth image (metres, 0 = invalid, size = intrinsics) seen from T_world_camera
  /// into `volume`: allocates the blocks that the truncation band [d - truncation,
  /// d + truncation] of every valid pixel's ray passes through, then updates every voxel of
  /// those blocks by projective TSDF (sdf = depth(pixel) - z_voxel along the optical axis,
  /// running average, weight capped). Multi-threaded over blocks through TBB; the result does not
  /// depend on the thread count. The voxel update runs one voxel row per AVX2 vector when the CPU
  /// has AVX2. Throws usage_error when the depth size differs from the intrinsics.
  /// `visitor` (optional) sees each updated block right after its update (BlockVisitor).
  IntegrateStats integrate(TsdfVolume& volume, const Image<float>& depth_m,
                           const Intrinsics& intrinsics, const Pose& T_world_camera,
                           BlockVisitor* visitor = nullptr);
  /// integrate() without SIMD (the portable C++ voxel update): bit for bit the same volume as
  /// integrate() on any CPU (the AVX2 update performs the same float operations in the same
  /// order). For tests and CPUs without AVX2.
  IntegrateStats integrate_portable(TsdfVolume& volume, const Image<float>& depth_m,
                                    const Intrinsics& intrinsics, const Pose& T_world_camera);

  /// Frees the scratch and the per-block bookkeeping (e.g. with TsdfVolume::reset()). Never
  /// needed for correctness: integrate() notices a volume that was reset or grew elsewhere.
  void reset();
  /// The blocks the last integrate() updated (indices of its volume), in no particular order.
  const std::vector<int>& updated_blocks() const { return visible_; }
  /// Bytes held by the per-block bookkeeping.
  std::size_t memory_bytes() const { return last_frame_.capacity() * sizeof(std::uint32_t); }

 private:
  /// Allocation pass of integrate(): fills visible_. Runs the chunks of rows in parallel and
  /// skips the traversal of segments whose cells are known (the same blocks in the same order as
  /// the plain per-pixel traversal); `simd` (the caller checked the CPU) sets up eight pixels'
  /// segments per AVX2 vector, the same floats.
  IntegrateStats allocate_band(TsdfVolume& volume, const Image<float>& depth_m,
                               const Intrinsics& intrinsics, const Pose& T_world_camera,
                               bool simd);
  /// Adds the blocks of the chunks' keys to visible_ (each once), allocating them as needed.
  void merge_chunks(TsdfVolume& volume, IntegrateStats& stats);
  /// integrate() with the AVX2 voxel update (`simd`) or the portable one.
  IntegrateStats integrate_fast(TsdfVolume& volume, const Image<float>& depth_m,
                                const Intrinsics& intrinsics, const Pose& T_world_camera,
                                bool simd, BlockVisitor* visitor);

  /// Per block index of the volume: the integrate() call that last listed the block in
  /// visible_. Grown as the volume's blocks appear; entries of a volume that was reset are
  /// below the next frame's number, so they never hide a block.
  std::vector<std::uint32_t> last_frame_;
  std::uint32_t frame_counter_ = 0;

  // Per-frame scratch, reused across calls.
  std::vector<std::vector<std::uint64_t>> chunk_keys_;
  std::vector<int> chunk_rays_;
  std::vector<int> visible_;
};

}  // namespace aoscan
