/// @file tsdf_config.h
/// @brief Configuration of the TSDF volume, its raycast and mesh extraction (section `fusion`).
///
/// The struct lists its fields once in `visit()`: loading (`--config`, `--set`), validation,
/// `aoscan config` and the README's table are all driven by that list (pipeline/config.h).
#pragma once

namespace aoscan {

/// Whether the colour of a source that has colour is fused (ColourVolume).
enum class ColourFusion { kOn, kOff };

/// KinectFusion-style TSDF fusion.
struct FusionConfig {
  double voxel_size_m = 4.0 / 512.0;        ///< TSDF voxel edge (m)
  double truncation_m = 4.5 * 4.0 / 512.0;  ///< TSDF truncation band (m)
  double max_weight = 100.0;         ///< cap of the per-voxel running-average weight (observations)
  int max_blocks = 131072;           ///< capacity of the sparse volume in 8^3 blocks (2 KiB each)
  double raycast_min_depth_m = 0.2;  ///< raycast: nearest depth searched along a ray (m)
  double raycast_max_depth_m = 5.0;  ///< raycast: farthest depth searched along a ray (m)
  double mesh_min_weight = 1.0;      ///< mesh: cubes with a corner of lower weight are not meshed
  /// Resolution of the model raycast (the ICP reference and SSAO input) as a pyramid level of the
  /// depth frame: 0 = full, 1 = half (a quarter of the rays), 2 = quarter; never coarser than 320
  /// pixels across (Reconstruction keeps small frames' raycast fine enough to track).
  int raycast_level = 1;
  /// Colour: fused when the source has colour (`on`), or ignored (`off`: no memory, no time).
  ColourFusion colour = ColourFusion::kOn;
  /// Cap of the per-voxel colour weight: the colour is the running mean of the last this many
  /// observations, roughly (a lower cap follows lighting changes sooner).
  int colour_max_weight = 16;
  /// Colour is fused from every this many-th frame (the frames whose sequence is a multiple of
  /// it; a recording decodes only their colour). Every frame's colour costs RedKitchen's replay
  /// about a quarter of its wall time on two cores, every second frame's 5 %, with the same colour
  /// error on the synthetic scenes (BENCHMARKS.md, Colour fusion).
  int colour_every = 2;

  template <class V>
  void visit(V& v) {
    v.number("voxel_size_m", voxel_size_m, "TSDF voxel edge (m)", 1e-4, 1.0);
    v.number("truncation_m", truncation_m, "TSDF truncation distance (m)", 1e-4, 10.0);
    v.number("max_weight", max_weight, "cap of the per-voxel TSDF weight (observations, 1-65535)",
             1.0, 65535.0);
    v.integer("max_blocks", max_blocks,
              "TSDF capacity in 8^3 voxel blocks of 2 KiB; reaching it is reported", 1, 1 << 24);
    v.number("raycast_min_depth_m", raycast_min_depth_m, "raycast: nearest depth searched (m)", 0.0,
             100.0);
    v.number("raycast_max_depth_m", raycast_max_depth_m, "raycast: farthest depth searched (m)",
             0.01, 100.0);
    v.number("mesh_min_weight", mesh_min_weight,
             "mesh: cubes with a corner voxel of lower TSDF weight are dropped", 0.0, 1e6);
    v.integer("raycast_level", raycast_level,
              "model raycast resolution as a pyramid level: 0 full, 1 half, 2 quarter; never "
              "coarser than 320 pixels across",
              0, 2);
    v.choice("colour", colour, "fuse the source's colour when it has colour: on, off",
             {{"on", ColourFusion::kOn}, {"off", ColourFusion::kOff}});
    v.integer("colour_max_weight", colour_max_weight,
              "cap of the per-voxel colour weight (observations averaged, roughly)", 1, 255);
    v.integer("colour_every", colour_every,
              "fuse the colour of every N-th frame (1: every frame)", 1, 1000);
  }
};

}  // namespace aoscan
