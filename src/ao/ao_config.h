/// @file ao_config.h
/// @brief Configuration of screen-space AO and the MVAO grid (section `ao`).
///
/// The struct lists its fields once in `visit()`: loading (`--config`, `--set`), validation,
/// `aoscan config` and the README's table are all driven by that list (pipeline/config.h).
#pragma once

namespace aoscan {

/// How SSAO values from several frames are merged per MVAO grid cell (contract key ao.integration).
enum class AoIntegration { kMvao, kMean, kLast };
/// Which depth the SSAO runs on (contract key ao.input).
enum class AoInput { kRaycast, kRaw };
/// Per-sample SSAO estimator (see src/ao/ssao.h): Sabbadin et al. 2016 Eq. 3-5 as printed;
/// obscurance form (only samples above the tangent plane occlude, weighted by elevation and
/// 1 - rho); Alchemy (McGuire et al. 2011); horizon-based (GTAO-like cosine-weighted slice
/// integral with rho); heightfield (Eq. 1 integrated exactly on each slice's height profile up to
/// t_max); statvo (Hendrickx et al. 2015: statistical volumetric obscurance in adaptive depth
/// layers from summed-area tables, ao/statvo.h).
enum class AoEstimator { kPaper, kObscurance, kAlchemy, kHorizon, kHeightfield, kStatVo };
/// Weight of a pixel's SSAO in the MVAO grid (contract key ao.integration = mvao): the paper's
/// w_d * w_n (Sabbadin et al. 2016 Eq. 9-11, w_d from the distance to the camera), or Vardis et
/// al. 2013's b * w_d + (1 - b) * w_n (Eq. 3-5, w_d from the mean distance of the pixel's SSAO
/// samples to it: views whose samples land on other surfaces count less).
enum class AoViewWeight { kPaper, kVardis };
/// How the views read the MVAO grid at a pixel (contract key ao.view_read): the cell holding the
/// pixel's surface point, or trilinear between the grid's coarse cells of 4^3 cells (its bricks),
/// as the mesh export reads it by default (mesh_cell_factor 4).
enum class AoViewRead { kCells, kCoarse };

/// Screen-space AO and the multi-view AO grid (Sabbadin et al. 2016 Sec. 4 and 6).
struct AoConfig {
  double radius_m = 0.1;  ///< r_s: radius of the sampling sphere (m)
  double t_max_m = 0.2;   ///< t_max: falloff distance of rho (m)
  /// N: samples per pixel. 16 (not the paper's 32): with stride 2 and MVAO the accumulated AO
  /// correlates with the ray-traced reference as well as with 32, exact or through the whole
  /// pipeline, at half the SSAO cost (8 does too once accumulated, but a single frame's
  /// correlation drops with every halving); see BENCHMARKS.md.
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
  /// enough for a lower bias than the 0.005 of raw normals: the noisy and the exact-depth corner
  /// correlate better with the reference and the room no worse (lower: the room loses; higher:
  /// every scene loses); see BENCHMARKS.md.
  double bias = 0.0035;
  /// Coverage weight (in the spirit of the paper's border weight w_b, Eq. 12): in mvao mode a
  /// pixel's weight w_d * w_n is multiplied by coverage^coverage_power, coverage = the share of
  /// its SSAO samples that fell inside the image on valid pixels (samples off the image or in
  /// holes count as open, so such a pixel's AO is too light). 0 = off. 4: the noisy corner through
  /// the pipeline correlates better than without it, and slightly better than with 1; see
  /// BENCHMARKS.md.
  double coverage_power = 4.0;
  /// The mesh export reads the grid through cells of mesh_cell_factor^3 grid cells (their sums
  /// added, i.e. the AO averaged over mesh_cell_factor * cell size) with trilinear interpolation
  /// between those; the live view keeps the grid's own cells. 1 = the grid's cells. 4 (3.1 cm
  /// with the default grid, a third of r_s): the fused surface's small bumps average out, so the
  /// noisy corner's mesh AO correlates clearly better than with 1 (and a little better than with
  /// 3); see BENCHMARKS.md.
  int mesh_cell_factor = 4;
  /// What the views (window, snapshots, service) show of the grid at each pixel: the AO of the
  /// cell holding its surface point, or (coarse) the grid read as the export reads it, trilinear
  /// between the means of its 4^3-cell bricks (3.1 cm with the default grid). Coarse: the AO shown
  /// at each frame of the noisy corner and room correlates better with the ray-traced reference,
  /// most at the start of a take, when a cell holds one or two views; see BENCHMARKS.md.
  AoViewRead view_read = AoViewRead::kCoarse;
  /// SSAO takes at each evaluated pixel the normalised sum of the raycast normals within
  /// normal_radius_px pixels whose vertices lie within normal_max_distance_m of the pixel's own
  /// (the same surface, not the one behind a depth jump); 0 = the raycast's own normal. The
  /// raycast normal is the TSDF gradient at the nearest voxel, whose few-degree noise on a fused
  /// noisy surface tilts the tangent plane, so that samples a few centimetres away rise above or
  /// sink below it by more than the bias. 2 px within 4 cm: the noisy room correlates far better
  /// with the reference, the noisy corner somewhat better; see BENCHMARKS.md. The whole normal map
  /// is smoothed once per frame (smooth_model_normals()), so the samples' area factor
  /// (area_min_cos) reads the smoothed normals too, a small gain in every scene.
  int normal_radius_px = 2;
  double normal_max_distance_m = 0.04;
  /// Alchemy: each sample's term is divided by max(cos theta_q, area_min_cos), theta_q the angle
  /// between the sample's SSAO normal (smoothed as above) and its ray to the camera. A screen-space
  /// sample stands for the surface area its pixel covers, which grows as 1 / cos theta_q, so an
  /// occluder seen at a grazing angle (a few pixels wide) would otherwise count far less than the
  /// same occluder seen face-on; the floor keeps single grazing pixels from dominating. 1 = off
  /// (McGuire et al.'s plain screen-area mean). 0.5, on top of the smoothed normal: the noisy
  /// corner and room correlate better with the reference (0.2: worse, 0.7: alike); see
  /// BENCHMARKS.md. `aoscan scans`'s per-scan SSAO (scan_ssao.h) applies it too, reading each
  /// sample's fitted normal: the MVAO of every synthetic scan set correlates better with it.
  double area_min_cos = 0.5;
  /// Live only (a camera or `--realtime`): while frames are dropped in front of tracking, SSAO runs
  /// on every 3rd, 5th, ... tracked frame, up to this interval (odd; 1 = every frame always); see
  /// pipeline/ao_load_shedder.h. 3: RedKitchen paced at 30 Hz on 2 cores (`--realtime`) drops
  /// fewer frames in front of tracking than with 1 (two alternating pairs); see BENCHMARKS.md.
  int live_max_interval = 3;
  /// Repeated views of a still camera (Sabbadin et al. 2016 Sec. 8; ao/still_view.h): the k-th
  /// frame within still_view_distance_m and still_view_angle_deg of the last view that moved away
  /// gets its MVAO weights times still_view_decay^k, so standing still adds at most
  /// decay / (1 - decay) views' weight. 1 = off (every view counts fully); 0 keeps only the first
  /// view of each still period.
  double still_view_decay = 1.0;
  /// The MVAO weight of a pixel (AoViewWeight) and Vardis et al.'s blend b of their distance
  /// weight (b = 1: distance only); their b is 0.8-0.9 for the solid-angle estimators (Alchemy).
  /// vardis needs a point estimator (paper, obscurance, alchemy).
  AoViewWeight view_weight = AoViewWeight::kPaper;
  double vardis_b = 0.85;
  /// Importance sampling (Vardis et al. 2013 Eq. 6): > 0 evaluates this many of the N samples
  /// first, then (N - n) w (1 + O) / 2 more, w the pixel's weight and O = 1 - AO its obscurance
  /// from the first ones: pixels that weigh little in the grid or are open take fewer samples.
  /// 0 = off (every pixel takes N). Point estimators only.
  int importance_samples = 0;
  double still_view_distance_m = 0.01;
  double still_view_angle_deg = 1.0;

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
             "heightfield, statvo (summed-area tables)",
             {{"paper", AoEstimator::kPaper},
              {"obscurance", AoEstimator::kObscurance},
              {"alchemy", AoEstimator::kAlchemy},
              {"horizon", AoEstimator::kHorizon},
              {"heightfield", AoEstimator::kHeightfield},
              {"statvo", AoEstimator::kStatVo}});
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
    v.choice("view_read", view_read,
             "views read the grid per cell (cells) or trilinear between its 4^3-cell bricks "
             "(coarse, as the mesh export with mesh_cell_factor 4)",
             {{"cells", AoViewRead::kCells}, {"coarse", AoViewRead::kCoarse}});
    v.integer("normal_radius_px", normal_radius_px,
              "SSAO normal (evaluated pixels and samples): sum of the raycast normals within this "
              "many pixels (0 = the pixel's own)",
              0, 16);
    v.number("normal_max_distance_m", normal_max_distance_m,
             "SSAO normal: only neighbours whose vertices lie within this distance (m)", 0.0, 10.0);
    v.number("area_min_cos", area_min_cos,
             "SSAO alchemy: a sample's term / max(cos of its surface to its camera ray, this), in "
             "the live SSAO and in `aoscan scans`'s per-scan SSAO; 1 = off",
             0.01, 1.0);
    v.integer("ssao_stride_px", ssao_stride_px,
              "SSAO evaluates one pixel per stride x stride block per frame (1 or 2)", 1, 2);
    v.number("still_view_decay", still_view_decay,
             "repeated views of a still camera: the k-th frame within still_view_distance_m and "
             "still_view_angle_deg of the last view that moved weighs decay^k in the MVAO grid; "
             "1 = off",
             0.0, 1.0);
    v.number("still_view_distance_m", still_view_distance_m,
             "still camera: a frame this close to the last view that moved repeats it (m)", 0.0,
             10.0);
    v.number("still_view_angle_deg", still_view_angle_deg,
             "still camera: ... and its optical axis within this angle of that view's (degrees)",
             0.0, 180.0);
    v.choice("view_weight", view_weight,
             "mvao weight of a pixel: paper (w_d * w_n, w_d from the depth) or vardis "
             "(b * w_d + (1 - b) * w_n, w_d from the mean distance of its SSAO samples)",
             {{"paper", AoViewWeight::kPaper}, {"vardis", AoViewWeight::kVardis}});
    v.number("vardis_b", vardis_b, "view_weight vardis: the blend b of the distance weight", 0.0,
             1.0);
    v.integer("importance_samples", importance_samples,
              "SSAO importance sampling: this many samples first, then (samples - this) * weight "
              "* (2 - AO) / 2 more; 0 = off (point estimators)",
              0, 1024);
    v.integer("live_max_interval", live_max_interval,
              "live: while frames are dropped in front of tracking, SSAO runs on every 3rd, "
              "5th, ... tracked frame up to this (1 = every frame)",
              1, 15);
  }
};

}  // namespace aoscan
