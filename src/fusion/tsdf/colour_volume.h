/// @file colour_volume.h
/// @brief The fused colour of the TSDF's voxels, kept beside the volume: a colour block per TSDF
/// block that has seen colour (the same block index), so a run without colour holds none.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "core/colour.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/tsdf/colour_kernels.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

/// One voxel's colour: the running mean of its observations (8-bit RGB) and their number
/// (capped; 0 = never coloured).
struct ColourVoxel {
  std::uint8_t r = 0, g = 0, b = 0;
  std::uint8_t weight = 0;
};
static_assert(sizeof(ColourVoxel) == 4, "a colour voxel is 4 bytes");

/// The colours of one TSDF block's voxels, in the block's voxel order (voxel_index()).
struct ColourBlock {
  std::array<ColourVoxel, kBlockVoxels> voxels;
};

/// What one frame's colour integration did.
struct ColourIntegrateStats {
  int voxels_coloured = 0;   ///< voxels that took a colour sample
  int blocks_allocated = 0;  ///< colour blocks newly allocated
};

class ColourVolume;

/// What a colour frame is fused with: the colour image seen by `camera` (the colour camera of
/// the depth camera at T_world_camera), the depth frame (size = depth_intrinsics), the shell and
/// band (ColourIntegration) and the weight cap.
struct ColourFrameInput {
  const Image<float>* depth_m = nullptr;
  Intrinsics depth_intrinsics;
  Pose T_world_camera;
  const Image<Rgb8>* colour = nullptr;
  ColourCamera camera;
  float shell_m = 0.0f;
  float band_m = 0.0f;
  int max_weight = 1;
};

/// One frame's colour integration into a ColourVolume, block by block, as the BlockVisitor of
/// TsdfIntegrator::integrate(): it colours each block right after the block's depth update, while
/// its voxels and the depth pixels they project to are still in the cache. A voxel of the fused
/// surface's shell (|fused TSDF| <= shell_m: the voxels a mesh vertex samples) takes the colour at
/// its projection when the depth frame saw a surface within band_m of it along its ray
/// (|depth(pixel) - z| <= band_m at its depth pixel), and its colour becomes the running mean, its
/// weight capped at max_weight. The colour is sampled bilinearly (a registered camera: the voxel's
/// depth pixel itself). Blocks are visited on the integrator's threads; the result does not depend
/// on the thread count or the order of the blocks. The projection of the shell's voxels and the
/// running mean run eight voxels per AVX2 vector where the CPU has AVX2, with the same result bit
/// for bit as the portable code.
class ColourIntegration final : public BlockVisitor {
 public:
  /// Throws usage_error when the colour image's size differs from the camera's or the depth's
  /// from its intrinsics (before any block is touched). The inputs must outlive the object.
  ColourIntegration(ColourVolume& colour, const ColourFrameInput& input);
  /// The same with the AVX2 kernels (`simd`: the caller checked the CPU) or the portable code.
  ColourIntegration(ColourVolume& colour, const ColourFrameInput& input, bool simd);

  void begin(const TsdfVolume& volume, const std::vector<int>& blocks) override;
  void visit(const TsdfVolume& volume, std::size_t position) override;
  /// What the blocks visited since begin() did (nothing when begin() was not called: the
  /// depth frame was not integrated); call after the last visit().
  ColourIntegrateStats finish();

 private:
  ColourVolume& colour_;
  const Image<float>& depth_m_;
  const Image<Rgb8>& image_;
  bool registered_;
  bool simd_;
  const std::vector<int>* blocks_ = nullptr;
  detail::ColourProjection projection_;  ///< into the depth camera; voxel_m set by begin()
  Eigen::Matrix3f Rc_;
  Eigen::Vector3f tc_;
  float cfx_, cfy_, ccx_, ccy_;
  float shell_m_, cap_;
  int shell_q_ = -1;  ///< |tsdf_q| <= shell_q_: the voxel lies in the shell
};

/// Colour of a TsdfVolume's voxels. One writer (a ColourIntegration, reset()), any number of readers
/// between writes, like the volume.
class ColourVolume {
 public:
  /// The colour at world point `p` (metres): the mean of the coloured voxels among the eight
  /// around it, each weighted by its trilinear weight; when none of them is coloured, the nearest
  /// coloured voxel within sqrt(8.5) voxels (2.9); false when there is none.
  bool sample(const TsdfVolume& volume, const Eigen::Vector3f& p, Rgb8& out) const;

  /// The colour block of TSDF block `index`, or nullptr when it has none.
  const ColourBlock* block(int index) const {
    return index >= 0 && static_cast<std::size_t>(index) < blocks_.size()
               ? blocks_[static_cast<std::size_t>(index)].get()
               : nullptr;
  }
  /// Gives TSDF block `index` a colour block (restoring a saved model); returns it.
  ColourBlock& allocate(int index);
  /// Colour blocks held.
  std::size_t block_count() const { return allocated_; }
  /// Bytes held by the colour blocks and the index.
  std::size_t memory_bytes() const {
    return allocated_ * sizeof(ColourBlock) + blocks_.capacity() * sizeof(blocks_[0]);
  }
  /// Drops every colour (with TsdfVolume::reset()).
  void reset() {
    blocks_.clear();
    allocated_ = 0;
  }

 private:
  friend class ColourIntegration;
  /// The coloured voxel at global voxel coordinates, or nullptr (no colour block, weight 0).
  const ColourVoxel* coloured_voxel(const TsdfVolume& volume, const Eigen::Vector3i& voxel) const;

  std::vector<std::unique_ptr<ColourBlock>> blocks_;  ///< by TSDF block index
  std::size_t allocated_ = 0;
  // Per-frame scratch of ColourIntegration, reused: voxels coloured and new colour blocks per
  // block.
  std::vector<int> coloured_;
  std::vector<unsigned char> fresh_;
};

}  // namespace aoscan
