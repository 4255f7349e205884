/// @file image_eval.cpp
/// @brief Image-space AO measures from snapshot views.
#include "image_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>
#include <system_error>

#include "ao/ao_config.h"
#include "ao_eval.h"
#include "core/status.h"
#include "io/colour_image.h"
#include "io/png_read.h"
#include "io/snapshot_files.h"
#include "sim/reference_ao.h"

namespace aoscan::eval {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
/// Rays of the exact scene's depth and surface points look this far at most (m).
constexpr double kMaxRayM = 100.0;

double mean_of(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  if (v.size() % 2 == 1) return v[mid];
  const double upper = v[mid];
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
}

/// Unit ray direction through pixel (u, v) of `k`, scene frame.
Eigen::Vector3d pixel_ray(const Intrinsics& k, const Pose& T_scene_camera, double u, double v) {
  const Eigen::Vector3d d_camera((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  return (T_scene_camera.rotation() * d_camera).normalized();
}

/// A cell index of the grid's signed 21-bit range per axis as one 64-bit key (offset to be
/// non-negative); the cells of TemporalStability likewise.
std::uint64_t pack(const CellIndex& c) {
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;  // the grid's Morton range per axis
  std::uint64_t key = 0;
  for (int i = 0; i < 3; ++i) key = (key << 21) | static_cast<std::uint64_t>(c[i] + kHalf);
  return key;
}

std::optional<std::uint64_t> cell_key(const Eigen::Vector3d& p, double cell_m) {
  constexpr double kHalf = static_cast<double>(std::int64_t{1} << 20);
  CellIndex c;
  for (int i = 0; i < 3; ++i) {
    const double f = std::floor(p[i] / cell_m);
    if (!(f >= -kHalf && f < kHalf)) return std::nullopt;
    c[i] = static_cast<std::int32_t>(f);
  }
  return pack(c);
}

}  // namespace

float shown_ao(const Rgb8& pixel) {
  if (pixel.r != pixel.g || pixel.g != pixel.b) return kNaN;
  return static_cast<float>(pixel.r) / 255.0f;
}

Image<float> shown_ao(const Image<Rgb8>& view) {
  Image<float> out(view.width(), view.height());
  for (std::size_t i = 0; i < view.size(); ++i) out.data()[i] = shown_ao(view.data()[i]);
  return out;
}

std::string snapshot_path(const std::string& dir, const std::string& view, std::uint64_t sequence) {
  char name[64];
  std::snprintf(name, sizeof name, "_%06llu.png", static_cast<unsigned long long>(sequence));
  return (std::filesystem::path(dir) / (view + name)).string();
}

std::vector<std::uint64_t> snapshot_frames(const std::string& dir) {
  std::set<std::uint64_t> ssao, mvao;
  std::error_code ec;
  std::filesystem::directory_iterator it(dir, ec);
  if (ec) throw input_error(dir + ": cannot list the snapshot folder (" + ec.message() + ")");
  for (const auto& entry : it) {
    const std::string name = entry.path().filename().string();
    unsigned long long sequence = 0;
    char tail[8] = {};
    // "ssao_000123.png" / "mvao_000123.png": a view name, '_', the frame, ".png" and nothing more.
    for (auto [prefix, set] : {std::pair{"ssao_%llu%7s", &ssao}, std::pair{"mvao_%llu%7s", &mvao}})
      if (std::sscanf(name.c_str(), prefix, &sequence, tail) == 2 &&
          std::string(tail) == ".png" && name.size() == 15)
        set->insert(sequence);
  }
  std::vector<std::uint64_t> both;
  std::set_intersection(ssao.begin(), ssao.end(), mvao.begin(), mvao.end(),
                        std::back_inserter(both));
  return both;
}

Image<float> read_shown_ao(const std::string& dir, const std::string& view, std::uint64_t sequence) {
  Image<Rgb8> rgb;
  const Status status = read_colour_image(snapshot_path(dir, view, sequence), rgb);
  if (!status.is_ok()) throw input_error(status.message());
  return shown_ao(rgb);
}

Image<std::uint8_t> border_mask(int width, int height, int border_px) {
  Image<std::uint8_t> mask(width, height, 0);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      mask(x, y) = x < border_px || y < border_px || x >= width - border_px ||
                   y >= height - border_px;
  return mask;
}

Image<std::uint8_t> discontinuity_mask(const Image<float>& depth_m, int radius_px,
                                       double relative_jump) {
  const int w = depth_m.width(), h = depth_m.height();
  Image<std::uint8_t> edge(w, h, 0);
  const auto jump = [&](int x0, int y0, int x1, int y1) {
    const float a = depth_m(x0, y0), b = depth_m(x1, y1);
    const bool sa = a > 0.0f, sb = b > 0.0f;
    if (sa != sb) return true;
    return sa && std::abs(a - b) > relative_jump * std::min(a, b);
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (x + 1 < w && jump(x, y, x + 1, y)) edge(x, y) = edge(x + 1, y) = 1;
      if (y + 1 < h && jump(x, y, x, y + 1)) edge(x, y) = edge(x, y + 1) = 1;
    }
  Image<std::uint8_t> mask(w, h, 0);
  const int r2 = radius_px * radius_px;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!edge(x, y)) continue;
      for (int dy = -radius_px; dy <= radius_px; ++dy)
        for (int dx = -radius_px; dx <= radius_px; ++dx)
          if (dx * dx + dy * dy <= r2 && mask.contains(x + dx, y + dy)) mask(x + dx, y + dy) = 1;
    }
  return mask;
}

const char* region_name(Region region) {
  static constexpr const char* kNames[kRegionCount] = {"all", "border", "discontinuity"};
  return kNames[static_cast<int>(region)];
}

const char* shown_name(Shown shown) {
  static constexpr const char* kNames[kShownCount] = {"ssao", "mvao", "final"};
  return kNames[static_cast<int>(shown)];
}

void RegionCorrelation::add(const std::array<double, kShownCount>& shown, double reference,
                            bool border, bool discontinuity) {
  const bool in[kRegionCount] = {true, border, discontinuity};
  for (int g = 0; g < kRegionCount; ++g) {
    if (!in[g]) continue;
    reference_[g].push_back(reference);
    for (int s = 0; s < kShownCount; ++s) shown_[g][s].push_back(shown[s]);
  }
}

void RegionCorrelation::merge(const RegionCorrelation& other) {
  for (int g = 0; g < kRegionCount; ++g) {
    reference_[g].insert(reference_[g].end(), other.reference_[g].begin(),
                         other.reference_[g].end());
    for (int s = 0; s < kShownCount; ++s)
      shown_[g][s].insert(shown_[g][s].end(), other.shown_[g][s].begin(),
                          other.shown_[g][s].end());
  }
}

std::size_t RegionCorrelation::count(Region region) const {
  return reference_[static_cast<int>(region)].size();
}

double RegionCorrelation::r(Region region, Shown shown) const {
  const int g = static_cast<int>(region);
  return pearson_r(shown_[g][static_cast<int>(shown)], reference_[g]);
}

double RegionCorrelation::mean(Region region, Shown shown) const {
  return mean_of(shown_[static_cast<int>(region)][static_cast<int>(shown)]);
}

double RegionCorrelation::mean_reference(Region region) const {
  return mean_of(reference_[static_cast<int>(region)]);
}

void ImageEvalCounts::merge(const ImageEvalCounts& o) {
  sampled += o.sampled;
  no_scene += o.no_scene;
  no_ssao += o.no_ssao;
  no_mvao += o.no_mvao;
  no_final += o.no_final;
  compared += o.compared;
}

Image<float> scene_depth(const AnalyticScene& scene, const Intrinsics& k,
                         const Pose& T_scene_camera) {
  Image<float> depth(k.width, k.height, 0.0f);
  const Eigen::Vector3d optical_axis = T_scene_camera.rotation().col(2);
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const Eigen::Vector3d d = pixel_ray(k, T_scene_camera, x, y);
      Hit hit;
      if (scene.intersect(Ray{T_scene_camera.translation(), d}, 0.0, kMaxRayM, &hit))
        depth(x, y) = static_cast<float>(hit.t * d.dot(optical_axis));
    }
  return depth;
}

std::array<double, kRegionCount> cell_constant_ceiling(const std::vector<CellSample>& samples) {
  std::unordered_map<std::uint64_t, std::pair<double, std::size_t>> cells;  // sum, count
  for (const CellSample& s : samples) {
    auto& c = cells[s.cell];
    c.first += s.reference;
    ++c.second;
  }
  std::array<double, kRegionCount> r{};
  for (int g = 0; g < kRegionCount; ++g) {
    std::vector<double> reference, cell_mean;
    for (const CellSample& s : samples) {
      if ((g == 1 && !s.border) || (g == 2 && !s.discontinuity)) continue;
      const auto& c = cells.at(s.cell);
      reference.push_back(s.reference);
      cell_mean.push_back(c.first / static_cast<double>(c.second));
    }
    r[g] = pearson_r(cell_mean, reference);
  }
  return r;
}

FinalGrid::FinalGrid(const MvaoGrid& grid, AoViewRead read) : grid_(&grid) {
  if (read == AoViewRead::kCoarse) coarse_.emplace(grid.coarsened(MvaoGrid::kBrickSide));
}

std::optional<float> FinalGrid::ao(const Eigen::Vector3d& p_world) const {
  if (coarse_) return coarse_->sample(p_world);
  const std::optional<CellIndex> cell = grid_->cell_of(p_world);
  return cell ? grid_->cell_ao(*cell) : std::nullopt;
}

void evaluate_frame(const AnalyticScene& scene, const FinalGrid& final_grid,
                    const ImageEvalFrame& frame, const ImageEvalOptions& options,
                    RegionCorrelation& out, ImageEvalCounts& counts,
                    std::vector<CellSample>* cells) {
  const Intrinsics& k = frame.intrinsics;
  if (frame.ssao.width() != k.width || frame.ssao.height() != k.height ||
      frame.mvao.width() != k.width || frame.mvao.height() != k.height)
    throw input_error("the snapshot views are not the camera's " + std::to_string(k.width) + "x" +
                      std::to_string(k.height));
  const int scale = 1 << options.raycast_level;
  const Intrinsics level = k.scaled(options.raycast_level);
  const Image<std::uint8_t> border = border_mask(k.width, k.height, options.border_px);
  const Image<std::uint8_t> discontinuity =
      discontinuity_mask(scene_depth(scene, k, frame.T_scene_camera), options.discontinuity_px,
                         options.relative_jump);
  const RayCaster cast = scene_ray_caster(scene);
  const Pose T_world_scene = frame.T_world_camera * frame.T_scene_camera.inverse();
  const int step = std::max(1, options.step);
  for (int v = 0; v < level.height; v += step)
    for (int u = 0; u < level.width; u += step) {
      ++counts.sampled;
      const int x = u * scale, y = v * scale;
      const Eigen::Vector3d d = pixel_ray(level, frame.T_scene_camera, u, v);
      Hit hit;
      if (!scene.intersect(Ray{frame.T_scene_camera.translation(), d}, 0.0, kMaxRayM, &hit)) {
        ++counts.no_scene;
        continue;
      }
      const float ssao = frame.ssao(x, y), mvao = frame.mvao(x, y);
      if (!(ssao >= 0.0f)) {
        ++counts.no_ssao;
        continue;
      }
      if (!(mvao >= 0.0f)) {
        ++counts.no_mvao;
        continue;
      }
      SurfacePoint s;
      s.p = frame.T_scene_camera.translation() + hit.t * d;
      s.normal = hit.normal;
      s.primitive = hit.primitive;
      const std::optional<CellIndex> cell = final_grid.cells().cell_of(T_world_scene * s.p);
      const std::optional<float> final_ao =
          cell ? final_grid.ao(T_world_scene * s.p) : std::nullopt;
      if (!final_ao) {
        ++counts.no_final;
        continue;
      }
      const double reference = scene_obscurance(scene, cast, s, options.t_max_m, options.strata);
      const bool in_border = border(x, y) != 0, in_discontinuity = discontinuity(x, y) != 0;
      out.add({ssao, mvao, *final_ao}, reference, in_border, in_discontinuity);
      if (cells) cells->push_back({pack(*cell), reference, in_border, in_discontinuity});
      ++counts.compared;
    }
}

TemporalStability::TemporalStability(double cell_m) : cell_m_(cell_m) {
  if (!(cell_m > 0.0) || !std::isfinite(cell_m))
    throw usage_error("the stability cell size must be a positive number of metres");
}

int TemporalStability::depth_level(const Intrinsics& k, const Image<float>& depth_m,
                                   const Image<float>& ssao, const Image<float>& mvao) {
  if (mvao.width() != ssao.width() || mvao.height() != ssao.height() ||
      ssao.width() != k.width || ssao.height() != k.height)
    throw input_error("the snapshot views differ in size from the camera");
  // The depth at the views' resolution or at pyramid level `level` of it (the model raycast's):
  // its pixel (x, y) is view pixel (x << level, y << level).
  int level = 0;
  while (level < 4 && (depth_m.width() << level) < k.width) ++level;
  if ((depth_m.width() << level) != k.width || (depth_m.height() << level) != k.height)
    throw input_error("the depth image is neither the snapshot views' size nor a pyramid level of it");
  return level;
}

void TemporalStability::use_keys(Keys keys) {
  if (keys_ != Keys::kNone && keys_ != keys)
    throw usage_error("a stability measure takes either cells or tracked points, not both");
  keys_ = keys;
}

template <typename FrameMap>
void TemporalStability::add_frame(const FrameMap& frame) {
  for (const auto& [key, f] : frame) {
    Sums& c = cells_[key];
    ++c.n;
    for (int i = 0; i < kValues; ++i) {
      const double mean = f.sum[i] / static_cast<double>(f.n);
      c.sum[i] += mean;
      c.sum_sq[i] += mean * mean;
    }
  }
  ++frames_;
}

namespace {
/// A key's values in one frame: the sum of each value over the frame's pixels of the key.
struct FrameSums {
  std::size_t n = 0;
  std::array<double, TemporalStability::kValues> sum{};
};
}  // namespace

void TemporalStability::add(const Intrinsics& k, const Pose& T_world_camera,
                            const Image<float>& depth_m, const Image<float>& ssao,
                            const Image<float>& mvao, const FinalGrid* final_grid) {
  const int level = depth_level(k, depth_m, ssao, mvao);
  use_keys(Keys::kCells);
  const Intrinsics kd = k.scaled(level);
  std::unordered_map<std::uint64_t, FrameSums> frame;
  FinalDifference difference;
  for (int y = 0; y < kd.height; ++y)
    for (int x = 0; x < kd.width; ++x) {
      const float z = depth_m(x, y), s = ssao(x << level, y << level), m = mvao(x << level, y << level);
      if (!(z > 0.0f) || !(s >= 0.0f) || !(m >= 0.0f)) continue;
      const Eigen::Vector3d p = T_world_camera * kd.unproject(double(x), double(y), double(z));
      std::optional<float> final_ao = 0.0f;
      if (final_grid) {
        final_ao = final_grid->ao(p);
        if (!final_ao) continue;
        const double d = std::abs(static_cast<double>(m) - *final_ao);
        ++difference.pixels;
        difference.mean_abs += d;
        difference.share_differing += d > 2.0 / 255.0;
      }
      const std::optional<std::uint64_t> key = cell_key(p, cell_m_);
      if (!key) continue;
      FrameSums& f = frame[*key];
      ++f.n;
      f.sum[0] += s;
      f.sum[1] += m;
      f.sum[2] += *final_ao;
    }
  with_final_ = with_final_ || final_grid != nullptr;
  if (final_grid) {
    if (difference.pixels > 0) {
      difference.mean_abs /= static_cast<double>(difference.pixels);
      difference.share_differing /= static_cast<double>(difference.pixels);
    }
    final_differences_.push_back(difference);
  }
  add_frame(frame);
}

void TemporalStability::add_tracked(const Intrinsics& k, const Pose& T_world_camera,
                                    const Image<float>& raycast_depth_m, const Image<float>& ssao,
                                    const Image<float>& mvao,
                                    const std::vector<Eigen::Vector3f>& points_world,
                                    const FinalGrid* final_grid, bool measured) {
  const int level = depth_level(k, raycast_depth_m, ssao, mvao);
  use_keys(Keys::kPoints);
  const Intrinsics kd = k.scaled(level);
  const Pose T_camera_world = T_world_camera.inverse();
  std::vector<std::pair<std::uint64_t, FrameSums>> frame;
  for (std::size_t i = 0; i < points_world.size(); ++i) {
    const Eigen::Vector3d q = T_camera_world * points_world[i].cast<double>();
    if (!(q.z() > 0.0)) continue;
    const Eigen::Vector2d uv = kd.project(q);
    const double fx = std::floor(uv.x()), fy = std::floor(uv.y());
    if (!(fx >= 0.0 && fy >= 0.0 && fx + 1.0 < kd.width && fy + 1.0 < kd.height)) continue;
    const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
    const double ax = uv.x() - fx, ay = uv.y() - fy;
    FrameSums f;
    f.n = 1;
    bool seen = true;
    for (int c = 0; c < 4 && seen; ++c) {
      const int x = x0 + (c & 1), y = y0 + (c >> 1);
      const double w = ((c & 1) ? ax : 1.0 - ax) * ((c >> 1) ? ay : 1.0 - ay);
      const float z = raycast_depth_m(x, y), s = ssao(x << level, y << level),
                  m = mvao(x << level, y << level);
      seen = z > 0.0f && std::abs(z - q.z()) <= kTrackedDepthToleranceM && s >= 0.0f && m >= 0.0f;
      if (!seen) break;
      if (final_grid) {
        const std::optional<float> final_ao =
            final_grid->ao(T_world_camera * kd.unproject(double(x), double(y), double(z)));
        seen = final_ao.has_value();
        if (!seen) break;
        f.sum[2] += w * *final_ao;
      }
      f.sum[0] += w * s;
      f.sum[1] += w * m;
    }
    if (!seen) continue;
    ViewsSoFar& views = views_so_far_[i];
    ++views.n;
    views.sum += f.sum[0];
    f.sum[kViewsSoFar] = views.sum / static_cast<double>(views.n);
    if (measured) frame.emplace_back(i, f);
  }
  with_final_ = with_final_ || final_grid != nullptr;
  if (measured) add_frame(frame);
}

TemporalStability::Result TemporalStability::result(std::size_t min_frames) const {
  std::array<std::array<std::vector<double>, kValues>, 2> stds;  // all, occluded
  std::array<double, 2> frames{};
  for (const auto& [key, c] : cells_) {
    if (c.n < std::max<std::size_t>(min_frames, 1)) continue;
    const auto n = static_cast<double>(c.n);
    const bool occluded = with_final_ && c.sum[2] / n < kOccludedBelow;
    for (int g = 0; g < 2; ++g) {
      if (g == 1 && !occluded) continue;
      frames[g] += n;
      for (int i = 0; i < kValues; ++i) {
        const double mean = c.sum[i] / n;
        stds[g][i].push_back(std::sqrt(std::max(0.0, c.sum_sq[i] / n - mean * mean)));
      }
    }
  }
  Result r;
  for (int g = 0; g < 2; ++g) {
    Spread& s = g == 0 ? r.all : r.occluded;
    s.cells = stds[g][0].size();
    if (s.cells == 0) continue;
    s.frames_per_cell_mean = frames[g] / static_cast<double>(s.cells);
    for (int i = 0; i < kValues; ++i) {
      s.std_mean[i] = mean_of(stds[g][i]);
      s.std_median[i] = median_of(stds[g][i]);
    }
  }
  return r;
}

MvaoGrid grid_from_saved(const SavedGrid& saved) {
  if (saved.integration > static_cast<std::uint32_t>(AoIntegration::kLast))
    throw input_error("the saved grid has an unknown merge mode " +
                      std::to_string(saved.integration));
  AoConfig config;
  config.grid_resolution = 1;
  config.grid_extent_m = saved.cell_size_m;
  config.integration = static_cast<AoIntegration>(saved.integration);
  MvaoGrid grid(config);
  for (const SavedCell& c : saved.cells)
    if (!grid.restore_cell({c.x, c.y, c.z}, {c.ao_weight_sum, c.weight_sum, c.last_frame}))
      throw input_error("the saved grid has a cell outside the grid's range");
  grid.set_frames_integrated(saved.frames);
  return grid;
}

RecordingFrames read_recording(const std::string& dir, int width, int height) {
  const std::filesystem::path d(dir);
  RecordingFrames r;
  r.dir = dir;
  r.camera = read_camera_json((d / "camera.json").string(), width, height);
  r.depth = read_tum_list((d / "depth.txt").string());
  return r;
}

std::optional<Pose> frame_pose(const RecordingFrames& recording,
                               const std::vector<StampedPose>& estimate, std::uint64_t sequence) {
  if (sequence >= recording.depth.size()) return std::nullopt;
  return associate(estimate, recording.depth[sequence].timestamp_s, 0.005);
}

ImageEvalReport evaluate_snapshots(const std::string& snapshot_dir,
                                   const RecordingFrames& recording,
                                   const std::vector<StampedPose>& estimate,
                                   const Pose& T_scene_world, const AnalyticScene& scene,
                                   const FinalGrid& final_grid, const ImageEvalOptions& options) {
  ImageEvalReport report;
  std::vector<CellSample> cells;
  for (const std::uint64_t sequence : snapshot_frames(snapshot_dir)) {
    const std::optional<Pose> pose = frame_pose(recording, estimate, sequence);
    if (!pose) {
      ++report.frames_untracked;
      continue;
    }
    ImageEvalFrame frame;
    frame.intrinsics = recording.camera.intrinsics;
    frame.T_world_camera = *pose;
    frame.T_scene_camera = T_scene_world * *pose;
    frame.ssao = read_shown_ao(snapshot_dir, "ssao", sequence);
    frame.mvao = read_shown_ao(snapshot_dir, "mvao", sequence);
    RegionCorrelation correlation;
    ImageEvalCounts counts;
    evaluate_frame(scene, final_grid, frame, options, correlation, counts, &cells);
    report.per_frame.push_back({sequence, correlation.count(Region::kAll),
                                correlation.r(Region::kAll, Shown::kSsao),
                                correlation.r(Region::kAll, Shown::kMvao)});
    report.pooled.merge(correlation);
    report.counts.merge(counts);
    ++report.frames;
  }
  report.cell_ceiling_r = cell_constant_ceiling(cells);
  return report;
}

TemporalStability stability_of_snapshots(const std::string& snapshot_dir,
                                         const RecordingFrames& recording,
                                         const std::vector<StampedPose>& estimate,
                                         const StabilityOptions& options,
                                         const FinalGrid* final_grid) {
  if (options.measure_every == 0) throw usage_error("frames are measured every 1 or more");
  TemporalStability stability(options.cell_m);
  const std::vector<Eigen::Vector3f>* tracked = options.tracked_points;
  Image<std::uint16_t> raw;
  Image<float> depth_m;
  for (const std::uint64_t sequence : snapshot_frames(snapshot_dir)) {
    const bool measured = sequence >= options.measure_from && sequence % options.measure_every == 0;
    if (!measured && !tracked) continue;
    const std::optional<Pose> pose = frame_pose(recording, estimate, sequence);
    if (!pose) continue;
    std::string path = snapshot_path(snapshot_dir, kRaycastDepthView, sequence);
    double metres_per_unit = 1.0 / kRaycastDepthUnitsPerMetre;
    const bool raycast = (options.raycast_points || tracked) && std::filesystem::exists(path);
    if (tracked && !raycast)
      throw input_error(path +
                        ": tracked points need the model raycast's depth of every "
                        "snapshot frame");
    if (!raycast) {
      path = (std::filesystem::path(recording.dir) / recording.depth[sequence].path).string();
      metres_per_unit = 1.0 / recording.camera.depth_scale;
    }
    const Status status = read_grey16_png(path, raw, sequence);
    if (!status.is_ok()) throw input_error(status.message());
    depth_m.resize(raw.width(), raw.height());
    for (std::size_t i = 0; i < raw.size(); ++i)
      depth_m.data()[i] = raw.data()[i] == 0 || raw.data()[i] == 0xFFFF
                              ? 0.0f
                              : static_cast<float>(raw.data()[i] * metres_per_unit);
    const Image<float> ssao = read_shown_ao(snapshot_dir, "ssao", sequence);
    const Image<float> mvao = read_shown_ao(snapshot_dir, "mvao", sequence);
    if (tracked)
      stability.add_tracked(recording.camera.intrinsics, *pose, depth_m, ssao, mvao, *tracked,
                            final_grid, measured);
    else
      stability.add(recording.camera.intrinsics, *pose, depth_m, ssao, mvao, final_grid);
    if (raycast && measured) stability.count_raycast_points();
  }
  return stability;
}

}  // namespace aoscan::eval
