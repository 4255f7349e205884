/// @file image_eval.h
/// @brief The AO aoscan shows, measured in image space from a replay's `--snapshot` views: per
/// pixel against ray-traced obscurance on a synthetic scene (the frame's SSAO, the MVAO grid as
/// shown at that frame, and the final grid), split by image region; and its temporal stability
/// (the spread over frames of the AO shown for the same world cell), which needs no reference.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "ao/mvao_grid.h"
#include "core/colour.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "io/camera_json.h"
#include "io/session_files.h"
#include "io/tum.h"
#include "sim/synth_scene.h"

namespace aoscan::eval {

/// AO shown by a grey view (`ssao_*.png`, `mvao_*.png`) at a pixel: grey / 255; NaN for any colour
/// that is not a grey (the views' background, RGB 24, 24, 32: no surface, no SSAO, an unobserved
/// cell).
float shown_ao(const Rgb8& pixel);
Image<float> shown_ao(const Image<Rgb8>& view);

/// Path of a snapshot view, as `--snapshot` names it: DIR/<view>_<sequence, 6 digits>.png.
std::string snapshot_path(const std::string& dir, const std::string& view, std::uint64_t sequence);
/// The frames of a snapshot folder that have both an `ssao` and an `mvao` view, ascending. Throws
/// input_error naming the folder when it cannot be listed.
std::vector<std::uint64_t> snapshot_frames(const std::string& dir);
/// shown_ao() of the snapshot view `view` of frame `sequence`; throws input_error naming the file
/// when it cannot be read.
Image<float> read_shown_ao(const std::string& dir, const std::string& view, std::uint64_t sequence);

/// Pixels within `border_px` of the image border: x < border_px, y < border_px,
/// x >= width - border_px or y >= height - border_px (1 = inside the region).
Image<std::uint8_t> border_mask(int width, int height, int border_px);

/// Pixels within `radius_px` (Euclidean, the discontinuity itself included) of a depth
/// discontinuity of `depth_m` (0 = no surface). A pixel is a discontinuity when one of its four
/// neighbours differs from it in having a surface, or both have one and their depths differ by
/// more than `relative_jump` times the nearer one. Both sides of a jump are discontinuities.
Image<std::uint8_t> discontinuity_mask(const Image<float>& depth_m, int radius_px,
                                       double relative_jump = 0.05);

/// The image regions the measures are split by.
enum class Region { kAll = 0, kBorder = 1, kDiscontinuity = 2 };
inline constexpr int kRegionCount = 3;
const char* region_name(Region region);  ///< "all", "border", "discontinuity"

/// The AO shown for a pixel that is compared with the reference.
enum class Shown { kSsao = 0, kMvao = 1, kFinal = 2 };
inline constexpr int kShownCount = 3;
const char* shown_name(Shown shown);  ///< "ssao", "mvao", "final"

/// Pearson r of the three shown AOs of each pixel against its reference, per region. A pixel goes
/// to `all` and to each region it lies in.
class RegionCorrelation {
 public:
  void add(const std::array<double, kShownCount>& shown, double reference, bool border,
           bool discontinuity);
  /// Adds every pixel of `other`.
  void merge(const RegionCorrelation& other);
  std::size_t count(Region region) const;
  /// sim's pearson_r() of the shown AO against the reference over the region's pixels (0 with
  /// fewer than two or a constant one).
  double r(Region region, Shown shown) const;
  /// Mean of the shown AO (or of the reference) over the region's pixels; 0 when empty.
  double mean(Region region, Shown shown) const;
  double mean_reference(Region region) const;

 private:
  std::array<std::vector<double>, kRegionCount> reference_;
  std::array<std::array<std::vector<double>, kShownCount>, kRegionCount> shown_;
};

/// A run's final MVAO grid read at a world point as the views read it (ao.view_read): the AO of
/// the observed cell holding the point, or, coarse, MvaoGrid::sample() of the grid coarsened by
/// MvaoGrid::kBrickSide (what MvaoGrid::lookup_ao_coarse() gives the views, bit for bit).
class FinalGrid {
 public:
  /// `grid` must outlive this.
  FinalGrid(const MvaoGrid& grid, AoViewRead read = AoViewRead::kCells);
  std::optional<float> ao(const Eigen::Vector3d& p_world) const;
  /// The grid's own cells (the cell ceiling's).
  const MvaoGrid& cells() const { return *grid_; }

 private:
  const MvaoGrid* grid_;
  std::optional<MvaoGrid> coarse_;
};

struct ImageEvalOptions {
  int raycast_level = 1;  ///< the model raycast's pyramid level (fusion.raycast_level)
  int step = 2;           ///< evaluate every step-th raycast pixel along x and y
  double t_max_m = 0.2;   ///< reference obscurance falloff (ao.t_max_m)
  int strata = 16;        ///< reference rays: strata^2
  int border_px = 40;
  int discontinuity_px = 5;
  double relative_jump = 0.05;  ///< discontinuity_mask()'s threshold
};

/// One snapshot frame of a replay of a synthetic scene.
struct ImageEvalFrame {
  Intrinsics intrinsics;  ///< the depth camera's, full resolution (the snapshots' size)
  Pose T_scene_camera;    ///< the estimated pose mapped into the scene's frame
  Pose T_world_camera;    ///< the estimated pose (the grid's world frame)
  Image<float> ssao, mvao;  ///< shown_ao() of the frame's ssao and mvao views
};

/// Pixels of a frame looked at and why some were not compared.
struct ImageEvalCounts {
  std::size_t sampled = 0;   ///< raycast pixels looked at
  std::size_t no_scene = 0;  ///< the ray through the pixel misses the scene
  std::size_t no_ssao = 0;   ///< the ssao view shows no SSAO there
  std::size_t no_mvao = 0;   ///< the mvao view shows no grid value (unobserved cell)
  std::size_t no_final = 0;  ///< the final grid has no observed cell at the surface point
  std::size_t compared = 0;  ///< pixels added to the correlation
  void merge(const ImageEvalCounts& o);
};

/// A compared pixel's reference and the final grid's cell at its surface point.
struct CellSample {
  std::uint64_t cell;  ///< the cell's index, packed
  double reference;
  bool border, discontinuity;
};

/// The ceiling of any AO that is constant over each grid cell: per region, the correlation ratio
/// of the reference by cell (Pearson r of each sample's reference with the mean reference of the
/// samples in its cell, over all samples; the largest r a function of the cell alone can reach
/// on these samples).
std::array<double, kRegionCount> cell_constant_ceiling(const std::vector<CellSample>& samples);

/// Evaluates one frame: every `step`-th pixel (u, v) of the raycast at `raycast_level` (scale
/// s = 2^level) shows at frame pixel (s u, s v) of the views (they enlarge the raycast by pixel
/// replication). The ray through the raycast pixel's centre meets the exact scene at the surface
/// point whose ray-traced obscurance is the reference; there the frame's SSAO and the MVAO shown
/// are read from the views, and the final grid's value is the AO of its cell containing that point
/// (mapped into the world frame by the estimated pose). Region masks are those of frame pixel
/// (s u, s v): border_mask() of the frame and discontinuity_mask() of the exact scene's depth
/// through every frame pixel. Only pixels with all three values are compared; `cells` (optional)
/// gets each compared pixel's CellSample.
void evaluate_frame(const AnalyticScene& scene, const FinalGrid& final_grid,
                    const ImageEvalFrame& frame, const ImageEvalOptions& options,
                    RegionCorrelation& out, ImageEvalCounts& counts,
                    std::vector<CellSample>* cells = nullptr);

/// The exact scene's depth (along the optical axis, m; 0 = no hit within 100 m) through the
/// centre of every pixel of `intrinsics`, seen from T_scene_camera.
Image<float> scene_depth(const AnalyticScene& scene, const Intrinsics& intrinsics,
                         const Pose& T_scene_camera);

/// The spread over frames of the AO shown for the same world cell. Each frame's pixels with a
/// depth and both an SSAO and an MVAO value (and, with a final grid, an observed cell of it at the
/// pixel's point) go to the cell (cubes of cell_m) containing their point (depth unprojected,
/// mapped by the frame's pose); a cell's value in a frame is the mean over its pixels in that
/// frame. The standard deviation (population) over the frames that saw a cell is taken for cells
/// seen in at least min_frames frames. The final grid's AO does not change between frames: its
/// spread is what the binning alone contributes (which pixels of a cell a frame sees).
class TemporalStability {
 public:
  explicit TemporalStability(double cell_m);
  /// `depth_m` at the views' resolution or at a pyramid level of it (the model raycast's: its
  /// pixel (x, y) is view pixel (x << level, y << level), unprojected with the level's
  /// intrinsics; 0 = invalid); `ssao`, `mvao` as shown_ao(); `final_grid` (optional): the run's
  /// final grid, in the world frame of the poses. Throws input_error for other sizes.
  void add(const Intrinsics& intrinsics, const Pose& T_world_camera, const Image<float>& depth_m,
           const Image<float>& ssao, const Image<float>& mvao,
           const FinalGrid* final_grid = nullptr);

  /// The same spread at fixed surface points instead of cells: `points_world` (e.g. the run's mesh
  /// vertices, in the poses' world frame) keep their index as their key across frames. A frame
  /// sees a point when the four pixels of `raycast_depth_m` (the model raycast, at the views' size
  /// or a pyramid level of it, as in add()) around the point's projection all lie within
  /// kTrackedDepthToleranceM of its depth and show both AOs; the point then gets the bilinear mix
  /// of the SSAO and the MVAO the views show at those pixels, and (with a final grid) the same mix
  /// of the final grid's AO at their points, so that an AO field that does not change spreads only
  /// by that interpolation. Each point also keeps the mean of the SSAO of every frame added that
  /// saw it so far (the views so far: what a merge of exactly those views, unweighted and at the
  /// point itself, would show); a frame that is not `measured` only adds its SSAO to that mean.
  /// A measure takes either add() or add_tracked(): throws usage_error when they are mixed,
  /// input_error for sizes as add().
  void add_tracked(const Intrinsics& intrinsics, const Pose& T_world_camera,
                   const Image<float>& raycast_depth_m, const Image<float>& ssao,
                   const Image<float>& mvao, const std::vector<Eigen::Vector3f>& points_world,
                   const FinalGrid* final_grid = nullptr, bool measured = true);
  static constexpr double kTrackedDepthToleranceM = 0.02;

  /// Cells whose final-grid AO (mean over their frames) is below this are the occluded ones.
  static constexpr double kOccludedBelow = 0.9;

  /// The values whose spread is measured: the three Shown, then (tracked points only) the mean of
  /// the SSAO of the views so far.
  static constexpr int kViewsSoFar = kShownCount;
  static constexpr int kValues = kShownCount + 1;
  struct Spread {
    std::size_t cells = 0;  ///< cells (or tracked points) seen in at least min_frames frames
    double frames_per_cell_mean = 0;
    /// Per value (ssao, mvao, final, views so far; final 0 without a grid, views so far 0 for
    /// cells): mean and median over the cells of the standard deviation over frames.
    std::array<double, kValues> std_mean{}, std_median{};
  };
  struct Result {
    Spread all;
    Spread occluded;  ///< the cells with final-grid AO below kOccludedBelow (with a grid only)
  };
  Result result(std::size_t min_frames) const;
  std::size_t frames() const { return frames_; }
  /// Where the frames' surface points came from: the model raycast the views show
  /// (raycast_depth_*.png; the caller counts those frames) or the recording's own depth images
  /// (the other frames added).
  void count_raycast_points() { ++frames_raycast_; }
  std::size_t frames_with_raycast_points() const { return frames_raycast_; }
  std::size_t frames_with_depth_points() const { return frames_ - frames_raycast_; }

  /// Per frame added with a final grid: how far the MVAO shown is from the final grid's AO at the
  /// same pixels. At the run's last frame the grid is the final one, so what remains there is the
  /// difference between the view's cell (of the model raycast's point) and the cell of the depth's
  /// point.
  struct FinalDifference {
    std::size_t pixels = 0;
    double mean_abs = 0;        ///< mean |MVAO shown - final|
    double share_differing = 0; ///< share of pixels with |MVAO shown - final| > 2 / 255
  };
  const std::vector<FinalDifference>& final_differences() const { return final_differences_; }

 private:
  struct Sums {
    std::size_t n = 0;
    std::array<double, kValues> sum{}, sum_sq{};
  };
  /// A tracked point's SSAO over every frame added that saw it.
  struct ViewsSoFar {
    std::size_t n = 0;
    double sum = 0;
  };
  /// The raycast pixel level of a depth image for views of `intrinsics`; throws input_error.
  static int depth_level(const Intrinsics& intrinsics, const Image<float>& depth_m,
                         const Image<float>& ssao, const Image<float>& mvao);
  /// Adds one frame's value of each key seen, as the next frame of that key.
  template <typename FrameMap>
  void add_frame(const FrameMap& frame);
  enum class Keys { kNone, kCells, kPoints };
  void use_keys(Keys keys);

  double cell_m_;
  Keys keys_ = Keys::kNone;
  std::size_t frames_ = 0;
  std::size_t frames_raycast_ = 0;
  bool with_final_ = false;  ///< a final grid was given
  std::unordered_map<std::uint64_t, Sums> cells_;
  std::unordered_map<std::uint64_t, ViewsSoFar> views_so_far_;
  std::vector<FinalDifference> final_differences_;
};

/// A saved session's MVAO grid (io's neutral records: `OUT/session/mvao.grid`) as the ao module's
/// grid, cell for cell; throws input_error when a cell lies outside the grid's range.
MvaoGrid grid_from_saved(const SavedGrid& saved);

/// What a replay's evaluation reads of its recording folder: the depth camera (`camera.json`;
/// without a size in it, `width` x `height`, the views' size) and the frames (`depth.txt`; frame
/// i of a replay, as snapshots number it, is line i).
struct RecordingFrames {
  std::string dir;
  CameraInfo camera;
  std::vector<TumListEntry> depth;
};
RecordingFrames read_recording(const std::string& dir, int width, int height);

/// The estimated pose of frame `sequence` of `recording`: the pose of `estimate` (aoscan's
/// trajectory.txt, sorted by time) within 5 ms of the frame's timestamp, or nullopt (a lost frame,
/// or a frame beyond depth.txt).
std::optional<Pose> frame_pose(const RecordingFrames& recording,
                               const std::vector<StampedPose>& estimate, std::uint64_t sequence);

/// The image-space evaluation of a replay of a synthetic scene over its snapshot frames.
struct ImageEvalReport {
  RegionCorrelation pooled;  ///< every compared pixel of every frame
  ImageEvalCounts counts;
  std::size_t frames = 0;           ///< snapshot frames evaluated
  std::size_t frames_untracked = 0; ///< snapshot frames without an estimated pose
  /// cell_constant_ceiling() of the compared pixels of every frame.
  std::array<double, kRegionCount> cell_ceiling_r{};
  /// Per evaluated frame: its number and r over all its pixels of the SSAO and of the MVAO shown.
  struct Frame {
    std::uint64_t sequence;
    std::size_t pixels;
    double r_ssao, r_mvao;
  };
  std::vector<Frame> per_frame;
};

/// evaluate_frame() over every frame of `snapshot_dir` (snapshot_frames()). Poses: frame_pose()
/// of `estimate`, mapped into the scene's frame by `T_scene_world` (e.g. the first pose pair's
/// map: aoscan's world frame is its first frame's camera frame).
ImageEvalReport evaluate_snapshots(const std::string& snapshot_dir,
                                   const RecordingFrames& recording,
                                   const std::vector<StampedPose>& estimate,
                                   const Pose& T_scene_world, const AnalyticScene& scene,
                                   const FinalGrid& final_grid, const ImageEvalOptions& options);

/// Which points and frames stability_of_snapshots() measures.
struct StabilityOptions {
  double cell_m = 0.01;
  /// The surface points the views show (the model raycast's depth, raycast_depth_*.png) where a
  /// frame has it; false: the recording's own depth in every frame.
  bool raycast_points = true;
  /// Tracked points instead of cells (TemporalStability::add_tracked()); null: cells.
  const std::vector<Eigen::Vector3f>* tracked_points = nullptr;
  /// The frames measured: snapshot frames from `measure_from` on whose number is a multiple of
  /// `measure_every`. With tracked points the other frames still add their SSAO to each point's
  /// views so far; with cells they are skipped.
  std::uint64_t measure_every = 1;
  std::uint64_t measure_from = 0;
};

/// TemporalStability over every frame of `snapshot_dir` with an estimated pose, the surface points
/// mapped by the estimated pose being those the views show, the model raycast's
/// (`raycast_depth_*.png` of the snapshots), or, for a frame without it or without
/// `raycast_points`, the recording's own depth at each pixel (depth.txt's PNG of the frame,
/// depth_scale of camera.json). With `tracked_points`, TemporalStability::add_tracked() of those
/// points instead, which needs the model raycast's depth of every frame (input_error naming the
/// first file missing). Returns the accumulated measure; frames without a pose are skipped.
TemporalStability stability_of_snapshots(const std::string& snapshot_dir,
                                         const RecordingFrames& recording,
                                         const std::vector<StampedPose>& estimate,
                                         const StabilityOptions& options,
                                         const FinalGrid* final_grid = nullptr);

}  // namespace aoscan::eval
