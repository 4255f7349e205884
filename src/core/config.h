/// @file config.h
/// @brief Every tunable of aoscan: one struct per module, every field defaulted, units in the
/// names.
///
/// Each struct lists its fields once in `visit()`; loading (`--config`, `--set`), validation and
/// printing are all driven by that list, so a new field needs one line. Defaults are the values of
/// paper 000 Sec. 7 for a Kinect-class camera.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace aoscan {

/// Depth preprocessing: raw units to metres, range clip, border-outlier removal (paper 000 Sec. 6).
struct PreprocessConfig {
  double min_depth_m = 0.4;           ///< nearer depths are invalid
  double max_depth_m = 4.5;           ///< farther depths are invalid
  double outlier_threshold_m = 0.02;  ///< drop a pixel when any 8-neighbour differs by more
  /// ... than outlier_threshold_m + outlier_threshold_per_m2 * depth^2 (the depth resolution of
  /// a triangulating sensor falls with depth^2; 0 gives the paper's fixed threshold). This is the
  /// fused (and SSAO raw) depth's threshold.
  double outlier_threshold_per_m2 = 0.002;
  /// The same growth for the depth that tracking reads (outlier_threshold_m +
  /// tracking_outlier_threshold_per_m2 * depth^2). A Kinect v1's disparity step is about
  /// 0.0029-0.0032 m * depth^2 (f = 525-585 px) and its axial noise 0.0019 m * depth^2, so a
  /// fixed threshold removes most of every surface beyond about 2.5 m from the tracking depth.
  double tracking_outlier_threshold_per_m2 = 0.004;
  /// Bilateral filter before tracking. Sigmas are PCL KinFu's (4.5 px, 0.03 m); KinFu's radius is
  /// 6 px (13x13 window), here 2 px (5x5) by default: about 5 ms per VGA frame on one core, and
  /// RedKitchen tracks as well as with 7x7. 0 disables the filter.
  int bilateral_radius_px = 2;
  double bilateral_sigma_space_px = 4.5;  ///< spatial Gaussian sigma (pixels)
  double bilateral_sigma_depth_m = 0.03;  ///< depth Gaussian sigma (m); |dz| > 3 sigma is ignored
  /// Pyramid downsampling averages a 2x2 block's depths within this of the block's first valid
  /// depth (KinectFusion uses 3 sigma_depth).
  double pyramid_max_depth_diff_m = 0.09;
  /// Normal map: no normal where a right/down neighbour's depth differs by more than this (m) at
  /// level 0; doubled at each pyramid level because neighbours are twice as far apart.
  double normal_max_depth_jump_m = 0.05;

  template <class V>
  void visit(V& v) {
    v.number("min_depth_m", min_depth_m, "nearest depth kept (m)", 0.0, 100.0);
    v.number("max_depth_m", max_depth_m, "farthest depth kept (m)", 0.0, 100.0);
    v.number("outlier_threshold_m", outlier_threshold_m,
             "border-outlier removal: a pixel goes when an 8-neighbour differs in depth by more "
             "than this (m) plus outlier_threshold_per_m2 * depth^2; 0 disables",
             0.0, 10.0);
    v.number(
        "outlier_threshold_per_m2", outlier_threshold_per_m2,
        "border-outlier removal of the fused depth: growth of the threshold with the square of "
        "the pixel's depth (1/m); 0 keeps it fixed as in the paper",
        0.0, 1.0);
    v.number("tracking_outlier_threshold_per_m2", tracking_outlier_threshold_per_m2,
             "border-outlier removal of the tracking depth: the same growth with depth^2 (1/m); 0 "
             "keeps it fixed as in the paper",
             0.0, 1.0);
    v.integer("bilateral_radius_px", bilateral_radius_px,
              "bilateral filter half-window (px); 0 disables the filter", 0, 16);
    v.number("bilateral_sigma_space_px", bilateral_sigma_space_px,
             "bilateral filter spatial sigma (px)", 0.1, 100.0);
    v.number("bilateral_sigma_depth_m", bilateral_sigma_depth_m,
             "bilateral filter depth sigma (m); neighbours beyond 3 sigma are ignored", 1e-4, 1.0);
    v.number("pyramid_max_depth_diff_m", pyramid_max_depth_diff_m,
             "pyramid 2x2 downsampling averages depths within this of the block's first valid "
             "depth (m)",
             1e-4, 10.0);
    v.number("normal_max_depth_jump_m", normal_max_depth_jump_m,
             "normal map: no normal across a depth jump larger than this at level 0 (m)", 1e-4,
             10.0);
  }
};

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
  }
};

/// Frame-to-model projective point-to-plane ICP and the per-frame tracking status.
struct TrackingConfig {
  int iterations_level0 = 2;   ///< Gauss-Newton iterations at full resolution
  int iterations_level1 = 5;   ///< ... at half resolution
  int iterations_level2 = 10;  ///< ... at quarter resolution (done first)
  /// Full resolution associates every n-th pixel of each row, staggered row to row (2 = a
  /// checkerboard, half the pixels); coarser levels use every pixel.
  int level0_pixel_step = 2;
  double max_distance_m = 0.1;         ///< correspondences farther apart are rejected (m)
  double max_normal_angle_deg = 30.0;  ///< correspondences whose normals differ more are rejected
  double huber_delta_m = 0.005;        ///< Huber robust weight: residuals above are down-weighted
  /// Depth-dependent noise of the ICP residuals: beyond this depth a correspondence's residual
  /// is scaled by s = (z / noise_reference_depth_m)^2 (the axial noise of a triangulating sensor
  /// grows with z^2): Huber threshold huber_delta_m * s and weight 1 / s^2. 0 weighs all depths
  /// alike.
  double noise_reference_depth_m = 1.0;
  double lost_inlier_ratio = 0.1;     ///< inliers / valid frame pixels below this: lost
  double poor_inlier_ratio = 0.3;     ///< inliers / valid frame pixels below this: poor
  double poor_rms_residual_m = 0.01;  ///< point-to-plane RMS residual above this: poor
  double max_translation_m = 0.15;    ///< motion from the initial pose above this: lost (m)
  double max_rotation_deg = 20.0;     ///< rotation from the initial pose above this: lost (deg)
  /// ICP uses the model raycast's normals averaged over (2 r + 1)^2 pixels of the raycast (points
  /// within model_normal_max_distance_m of the pixel's): TSDF-gradient normals of a model fused
  /// from few noisy frames scatter by tens of degrees at 2-3 m, which both rejects most
  /// correspondences at the normal-angle test and biases the point-to-plane solution along the
  /// weakly constrained directions of a room (walls and floor). 0 uses the raw normals.
  int model_normal_radius_px = 2;
  double model_normal_max_distance_m = 0.05;  ///< neighbours farther away (m) are not averaged
  /// Degeneracy-aware update (Zhang, Kaess & Singh 2016): a direction of the ICP system whose
  /// eigenvalue is below this fraction of the largest is hardly measured (a wall and the floor
  /// alone leave the translation along their edge to depth noise, at about 0.02 % in the room
  /// scenes, against 1 % for the weakest direction of a well-constrained view). Such a direction
  /// gets the information missing up to the floor from the motion prior (velocity_smoothing):
  /// far below it the estimate follows the prior, near it mostly the data. 0 keeps only the
  /// numerically unconstrained directions (below 1e-6) at the prior.
  double weak_direction_ratio = 0.0005;
  /// The motion prior of the weak directions is the previous pose moved on by the camera's
  /// frame-to-frame motion, smoothed exponentially with this weight of the newest motion (1: the
  /// last motion alone). 0: no velocity, the prior is the previous pose.
  double velocity_smoothing = 0.3;

  template <class V>
  void visit(V& v) {
    v.integer("iterations_level0", iterations_level0, "ICP iterations at full resolution", 0, 100);
    v.integer("iterations_level1", iterations_level1, "ICP iterations at half resolution", 0, 100);
    v.integer("iterations_level2", iterations_level2, "ICP iterations at quarter resolution", 0,
              100);
    v.integer("level0_pixel_step", level0_pixel_step,
              "ICP at full resolution uses every n-th pixel, staggered by row (checkerboard at 2)",
              1, 8);
    v.number("max_distance_m", max_distance_m, "ICP correspondence distance rejection (m)", 1e-4,
             10.0);
    v.integer("model_normal_radius_px", model_normal_radius_px,
              "ICP averages the model raycast's normals over this radius (pixels of the raycast); "
              "0 uses them as they are",
              0, 8);
    v.number(
        "model_normal_max_distance_m", model_normal_max_distance_m,
        "model normal averaging: only neighbours within this distance of the pixel's point (m)",
        1e-3, 1.0);
    v.number("noise_reference_depth_m", noise_reference_depth_m,
             "ICP: beyond this depth (m) residuals count as noisier by (z / this)^2 (Huber "
             "threshold times that, weight over its square); 0 weighs all depths alike",
             0.0, 100.0);
    v.number("weak_direction_ratio", weak_direction_ratio,
             "ICP directions with an eigenvalue below this fraction of the largest take the "
             "missing information from the motion prior; 0: only unconstrained ones",
             0.0, 1.0);
    v.number("velocity_smoothing", velocity_smoothing,
             "motion prior of the weak ICP directions: weight of the newest frame-to-frame "
             "motion in the smoothed camera velocity; 0: the previous pose",
             0.0, 1.0);
    v.number("max_normal_angle_deg", max_normal_angle_deg,
             "ICP correspondence normal-angle rejection (degrees)", 0.0, 180.0);
    v.number("huber_delta_m", huber_delta_m, "ICP Huber threshold of the residual (m)", 1e-5, 1.0);
    v.number("lost_inlier_ratio", lost_inlier_ratio,
             "tracking lost below this fraction of valid pixels matched", 0.0, 1.0);
    v.number("poor_inlier_ratio", poor_inlier_ratio,
             "tracking poor below this fraction of valid pixels matched", 0.0, 1.0);
    v.number("poor_rms_residual_m", poor_rms_residual_m,
             "tracking poor above this point-to-plane RMS residual (m)", 0.0, 1.0);
    v.number("max_translation_m", max_translation_m,
             "tracking lost when a frame moves farther than this from its initial pose (m)", 0.0,
             100.0);
    v.number("max_rotation_deg", max_rotation_deg,
             "tracking lost when a frame turns more than this from its initial pose (deg)", 0.0,
             180.0);
  }
};

/// How SSAO values from several frames are merged per MVAO grid cell (contract key ao.integration).
enum class AoIntegration { kMvao, kMean, kLast };
/// Which depth the SSAO runs on (contract key ao.input).
enum class AoInput { kRaycast, kRaw };
/// Per-sample SSAO estimator (see src/ao/ssao.h): paper 000 Eq. 3-5 as printed; obscurance form
/// (only samples above the tangent plane occlude, weighted by elevation and 1 - rho); Alchemy
/// (McGuire et al. 2011); horizon-based (GTAO-like cosine-weighted slice integral with rho);
/// heightfield (Eq. 1 integrated exactly on each slice's height profile up to t_max).
enum class AoEstimator { kPaper, kObscurance, kAlchemy, kHorizon, kHeightfield };

/// Screen-space AO and the multi-view AO grid (paper 000 Sec. 4 and 6).
struct AoConfig {
  double radius_m = 0.1;  ///< r_s: radius of the sampling sphere (m)
  double t_max_m = 0.2;   ///< t_max: falloff distance of rho (m)
  /// N: samples per pixel. 16 (not the paper's 32): with stride 2 and MVAO the accumulated AO
  /// correlates equally with the ray-traced reference (exact corner, Pearson r 0.920 vs 0.921; 8
  /// gives 0.921, but a single frame's r drops 0.911 -> 0.908 -> 0.905; noisy corner through the
  /// whole pipeline 0.861 vs 0.862), at half the SSAO cost.
  int samples = 16;
  double d_min_m = 0.4;        ///< w_d: minimum normalisation depth (m)
  double d_max_m = 3.0;        ///< w_d: maximum normalisation depth (m)
  int grid_resolution = 512;   ///< MVAO grid cells per axis over grid_extent_m
  double grid_extent_m = 4.0;  ///< MVAO grid: cell size = grid_extent_m / grid_resolution
  AoIntegration integration = AoIntegration::kMvao;
  AoInput input = AoInput::kRaycast;
  /// SSAO estimator; alchemy correlates best with the ray-traced Eq. 1 reference (tests/ao/
  /// ao_accuracy_test.cpp).
  AoEstimator estimator = AoEstimator::kAlchemy;
  /// SSAO pixel stride: 1 evaluates every pixel; 2 evaluates one pixel per 2x2 block per frame
  /// (the block's pixel rotates with the frame index) and copies it to the block's other pixels
  /// with weight 0, so the MVAO grid only integrates evaluated pixels.
  int ssao_stride_px = 2;
  /// Alchemy, obscurance and heightfield estimators: a sample occludes only by its height above the
  /// tangent plane beyond bias * depth (McGuire et al. 2011's beta, scaled with the point's depth
  /// like their z_C beta), so the residual bumps of a fused noisy surface do not read as occluders.
  /// 0.0035: with the whole normal map smoothed (normal_radius_px), the tangent planes are flat
  /// enough for a lower bias than the 0.005 of raw normals: noisy corner r +0.003 to +0.004 (3
  /// seeds), room +0.000, exact-depth corner +0.005 (0.0025: room -0.002; 0.0065: all lower); see
  /// BENCHMARKS.md.
  double bias = 0.0035;
  /// Coverage weight (in the spirit of the paper's border weight w_b, Eq. 12): in mvao mode a
  /// pixel's weight w_d * w_n is multiplied by coverage^coverage_power, coverage = the share of
  /// its SSAO samples that fell inside the image on valid pixels (samples off the image or in
  /// holes count as open, so such a pixel's AO is too light). 0 = off. 4: noisy corner through the
  /// pipeline r 0.862 -> 0.865 (1: 0.864); see BENCHMARKS.md.
  double coverage_power = 4.0;
  /// The mesh export reads the grid through cells of mesh_cell_factor^3 grid cells (their sums
  /// added, i.e. the AO averaged over mesh_cell_factor * cell size) with trilinear interpolation
  /// between those; the live view keeps the grid's own cells. 1 = the grid's cells. 4 (3.1 cm
  /// with the default grid, a third of r_s): noisy corner r 0.865 -> 0.890 (3: 0.886), the fused
  /// surface's small bumps average out; see BENCHMARKS.md.
  int mesh_cell_factor = 4;
  /// SSAO takes at each evaluated pixel the normalised sum of the raycast normals within
  /// normal_radius_px pixels whose vertices lie within normal_max_distance_m of the pixel's own
  /// (the same surface, not the one behind a depth jump); 0 = the raycast's own normal. The
  /// raycast normal is the TSDF gradient at the nearest voxel, whose few-degree noise on a fused
  /// noisy surface tilts the tangent plane, so that samples a few centimetres away rise above or
  /// sink below it by more than the bias. 2 px within 4 cm: noisy room r 0.790 -> 0.922, noisy
  /// corner +0.009 to +0.011 (3 seeds); see BENCHMARKS.md. The whole normal map is smoothed
  /// once per frame (smooth_model_normals()), so the samples' area factor (area_min_cos) reads
  /// the smoothed normals too: noisy corner +0.001 (3 seeds), room +0.005, exact corner +0.002.
  int normal_radius_px = 2;
  double normal_max_distance_m = 0.04;
  /// Alchemy: each sample's term is divided by max(cos theta_q, area_min_cos), theta_q the angle
  /// between the sample's SSAO normal (smoothed as above) and its ray to the camera. A screen-space
  /// sample stands for the surface area its pixel covers, which grows as 1 / cos theta_q, so an
  /// occluder seen at a grazing angle (a few pixels wide) would otherwise count far less than the
  /// same occluder seen face-on; the floor keeps single grazing pixels from dominating. 1 = off
  /// (McGuire et al.'s plain screen-area mean). 0.5, on top of the smoothed normal: noisy corner r
  /// +0.002 to +0.005 (3 seeds), noisy room +0.012 (0.2: worse, 0.7: alike); see BENCHMARKS.md.
  double area_min_cos = 0.5;
  /// Live only (a camera or `--realtime`): while frames are dropped in front of tracking, SSAO runs
  /// on every 3rd, 5th, ... tracked frame, up to this interval (odd; 1 = every frame always); see
  /// pipeline/ao_load_shedder.h. 3: RedKitchen paced at 30 Hz on 2 cores (`--realtime`), frames
  /// dropped in front of tracking 18 / 20 against 20 / 37 with 1 (two alternating pairs); see
  /// BENCHMARKS.md.
  int live_max_interval = 3;

  template <class V>
  void visit(V& v) {
    v.number("radius_m", radius_m, "SSAO sampling sphere radius r_s (m)", 1e-3, 10.0);
    v.number("t_max_m", t_max_m, "SSAO distance falloff t_max (m)", 1e-3, 10.0);
    v.integer("samples", samples, "SSAO samples per pixel N", 1, 1024);
    v.number("d_min_m", d_min_m, "view weight w_d: minimum normalisation depth (m)", 0.0, 100.0);
    v.number("d_max_m", d_max_m, "view weight w_d: maximum normalisation depth (m)", 1e-3, 100.0);
    v.integer("grid_resolution", grid_resolution, "MVAO grid cells per grid_extent_m", 1, 1 << 20);
    v.number("grid_extent_m", grid_extent_m,
             "MVAO grid: length covered by grid_resolution cells (m)", 1e-3, 1e4);
    v.choice("integration", integration, "merge of SSAO over frames: mvao (w_d*w_n), mean, last",
             {{"mvao", AoIntegration::kMvao},
              {"mean", AoIntegration::kMean},
              {"last", AoIntegration::kLast}});
    v.choice("input", input, "SSAO input: raycast of the model or raw filtered depth",
             {{"raycast", AoInput::kRaycast}, {"raw", AoInput::kRaw}});
    v.choice("estimator", estimator,
             "SSAO estimator: paper (Eq. 3-5 as printed), obscurance, alchemy, horizon, "
             "heightfield",
             {{"paper", AoEstimator::kPaper},
              {"obscurance", AoEstimator::kObscurance},
              {"alchemy", AoEstimator::kAlchemy},
              {"horizon", AoEstimator::kHorizon},
              {"heightfield", AoEstimator::kHeightfield}});
    v.number("bias", bias,
             "SSAO alchemy/obscurance/heightfield: a sample occludes only above the tangent plane "
             "by more than bias * depth (m per m of depth)",
             0.0, 1.0);
    v.number("coverage_power", coverage_power,
             "mvao weight *= (share of SSAO samples inside the image on valid pixels)^power; "
             "0 = off",
             0.0, 16.0);
    v.integer("mesh_cell_factor", mesh_cell_factor,
              "mesh AO reads the grid through cells of factor^3 grid cells (1 = the grid's cells)",
              1, 64);
    v.integer("normal_radius_px", normal_radius_px,
              "SSAO normal (evaluated pixels and samples): sum of the raycast normals within this "
              "many pixels (0 = the pixel's own)",
              0, 16);
    v.number("normal_max_distance_m", normal_max_distance_m,
             "SSAO normal: only neighbours whose vertices lie within this distance (m)", 0.0, 10.0);
    v.number("area_min_cos", area_min_cos,
             "SSAO alchemy: a sample's term / max(cos of its surface to its camera ray, this); "
             "1 = off",
             0.01, 1.0);
    v.integer("ssao_stride_px", ssao_stride_px,
              "SSAO evaluates one pixel per stride x stride block per frame (1 or 2)", 1, 2);
    v.integer("live_max_interval", live_max_interval,
              "live: while frames are dropped in front of tracking, SSAO runs on every 3rd, "
              "5th, ... tracked frame up to this (1 = every frame)",
              1, 15);
  }
};

/// The stage thread chain.
struct PipelineConfig {
  int queue_capacity = 4;  ///< frames buffered between two stages

  template <class V>
  void visit(V& v) {
    v.integer("queue_capacity", queue_capacity, "frames buffered between two stages", 1, 1024);
  }
};

/// The whole configuration; keys are `SECTION.FIELD`, e.g. `ao.radius_m`.
struct Config {
  PreprocessConfig preprocess;
  FusionConfig fusion;
  TrackingConfig tracking;
  AoConfig ao;
  PipelineConfig pipeline;

  template <class V>
  void visit_sections(V& v) {
    v.section("preprocess", preprocess);
    v.section("fusion", fusion);
    v.section("tracking", tracking);
    v.section("ao", ao);
    v.section("pipeline", pipeline);
  }
};

/// Applies `KEY=VALUE` to `config`; throws usage_error naming the key on an unknown key or a value
/// that does not parse or is out of range. `origin` names where it came from (a file, `--set`).
void set_config_value(Config& config, const std::string& key, const std::string& value,
                      const std::string& origin);

/// Reads a YAML or JSON file (nested sections or dotted keys) into `config`; throws usage_error
/// naming the file on a missing file, a syntax error, an unknown key or a bad value.
void load_config_file(Config& config, const std::string& path);

/// Checks relations between fields (e.g. min < max); throws usage_error.
void validate_config(const Config& config);

/// Defaults, then `file` (if not empty), then each `KEY=VALUE` of `sets`, then validation.
Config load_config(const std::string& file, const std::vector<std::string>& sets);

/// The configuration as YAML with one comment per key (what `aoscan config` prints).
std::string dump_config(const Config& config);

}  // namespace aoscan
