/// @file synth_camera.cpp
/// @brief The synthetic depth camera: `synth:` spec parsing, handheld trajectories, depth
/// rendering with an optional Kinect v1 noise model.
#include "sim/synth_camera.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/status.h"
#include "sim/counter_rng.h"

namespace aoscan {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
/// Depths beyond this are invalid in every synthetic frame (metres; fits uint16 at 5000/m).
constexpr double kMaxSynthDepthM = 13.0;
/// Stream keys that separate the trajectory's random phases from the per-pixel noise.
constexpr std::uint64_t kTrajectoryStream = 0x7472616a65637479ULL;

// ---------------------------------------------------------------------------------------------
// Spec parsing

/// The text with control characters replaced, so messages stay on one line.
std::string printable(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  return out;
}

const char* const kParameterList = "frames, width, height, noise, seed, trajectory, fps, colour";

[[noreturn]] void bad_value(const std::string& spec, const std::string& key,
                            const std::string& value, const std::string& expected) {
  throw usage_error("synth spec '" + printable(spec) + "': bad value '" + printable(value) +
                    "' for parameter '" + key + "' (expected " + expected + ")");
}

template <class T>
T parse_integer(const std::string& spec, const std::string& key, const std::string& value, T lo,
                T hi) {
  const std::string expected =
      "an integer from " + std::to_string(lo) + " to " + std::to_string(hi);
  T out{};
  const char* end = value.data() + value.size();
  const auto [ptr, ec] = std::from_chars(value.data(), end, out);
  if (value.empty() || ec != std::errc() || ptr != end || out < lo || out > hi) {
    bad_value(spec, key, value, expected);
  }
  return out;
}

double parse_fps(const std::string& spec, const std::string& value) {
  double out = 0.0;
  const char* end = value.data() + value.size();
  const auto [ptr, ec] = std::from_chars(value.data(), end, out);
  if (value.empty() || ec != std::errc() || ptr != end || !std::isfinite(out) || out <= 0.0 ||
      out > 1000.0) {
    bad_value(spec, "fps", value, "a number in (0, 1000]");
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Trajectories

/// A smooth, seed-dependent wobble of roughly unit amplitude (|w| < 1.9): three sinusoids of
/// 0.16-1.12 Hz times `frequency_scale`, whose phases and exact frequencies come from
/// (seed, channel).
double wobble(std::uint64_t seed, int channel, double time_s, double frequency_scale) {
  static constexpr double kAmplitudes[3] = {1.0, 0.6, 0.3};
  static constexpr double kFrequenciesHz[3] = {0.19, 0.43, 0.97};
  CounterRng rng(seed, kTrajectoryStream, static_cast<std::uint64_t>(channel));
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double phase = 2.0 * kPi * rng.uniform();
    const double f = kFrequenciesHz[k] * frequency_scale * (0.85 + 0.3 * rng.uniform());
    sum += kAmplitudes[k] * std::sin(2.0 * kPi * f * time_s + phase);
  }
  return sum;
}

/// Camera on a circle around `centre` (x, y) at azimuth phi(t) = azimuth0 + rate t - amplitude
/// cos(2 pi t / period), looking at the point `target_radius` beyond the centre, opposite the
/// camera.
struct OrbitRig {
  Eigen::Vector2d centre;
  double camera_radius_m, camera_height_m;
  double target_radius_m, target_height_m;
  double azimuth0_deg, azimuth_amplitude_deg, azimuth_period_s, azimuth_rate_deg_s;
  double radius_swing_m, height_swing_m;
};

/// Camera and target moving back and forth along parallel lines, both at
/// centre - axis * cos(2 pi t / period).
struct SweepRig {
  Eigen::Vector3d camera_centre, camera_axis;
  Eigen::Vector3d target_centre, target_axis;
  double period_s;
};

struct Rig {
  OrbitRig orbit;
  SweepRig sweep;
};

Rig rig_for(const std::string& scene) {
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1.0, -1.0, 0.0).normalized();
  if (scene == "corner") {
    return {{{0.9, 0.9}, 2.0, 1.45, 0.0, 0.45, 45.0, 30.0, 24.0, 0.0, 0.15, 0.1},
            {{2.1, 2.1, 1.45}, 0.9 * diagonal, {0.85, 0.85, 0.45}, 0.4 * diagonal, 24.0}};
  }
  if (scene == "room") {
    return {{{2.0, 2.0}, 0.6, 1.45, 1.6, 0.7, 0.0, 0.0, 24.0, 15.0, 0.1, 0.1},
            {{2.0, 2.6, 1.5}, {0.9, 0.0, 0.0}, {2.0, 0.3, 0.7}, {0.5, 0.0, 0.0}, 24.0}};
  }
  if (scene == "plane") {
    return {{{0.0, 0.0}, 2.0, 1.4, 0.0, 1.2, -90.0, 35.0, 24.0, 0.0, 0.15, 0.1},
            {{0.0, -1.5, 1.3}, {1.0, 0.0, 0.0}, {0.0, 0.0, 1.1}, {0.7, 0.0, 0.0}, 24.0}};
  }
  AnalyticScene::make(scene);  // throws the unknown-scene usage_error
  throw usage_error("no trajectory for synthetic scene '" + printable(scene) + "'");
}

// ---------------------------------------------------------------------------------------------
// Rendering

/// Rendering works on square tiles of pixels; each tile ray-casts only the primitives its frustum
/// can reach.
constexpr int kTileSize = 16;
/// Culling capacity per tile; scenes with more primitives render tiles without culling.
constexpr int kMaxTilePrimitives = 64;
/// Largest lateral jitter in pixels: CounterRng::normal_pair never exceeds 12.1 sigma, i.e.
/// 6.05 px at sigma 0.5 px.
constexpr double kMaxJitterPx = 6.5;
/// A primitive is culled only when it lies this far (metres) outside a tile's frustum plane.
constexpr double kCullMarginM = 1e-6;

/// Per-frame constants of the renderer.
struct RenderSetup {
  const AnalyticScene* scene;
  Eigen::Matrix3d R_world_camera;
  Eigen::Vector3d t_world_camera;
  double fx, inv_fx, inv_fy, cx, cy;
  int width, height;
  double cos_dropout_start, cos_dropout_full;
  SynthRenderOptions options;
};

RenderSetup make_setup(const AnalyticScene& scene, const Intrinsics& k, const Pose& T_world_camera,
                       const SynthRenderOptions& options) {
  return {&scene,
          T_world_camera.rotation(),
          T_world_camera.translation(),
          k.fx,
          1.0 / k.fx,
          1.0 / k.fy,
          k.cx,
          k.cy,
          k.width,
          k.height,
          std::cos(kKinectDropoutStartDeg * kDegToRad),
          std::cos(kKinectDropoutFullDeg * kDegToRad),
          options};
}

/// Nearest integer of a value in [0, 2^62), halves rounded up (no libm call).
inline std::int64_t round_non_negative(double x) {
  return static_cast<std::int64_t>(x + 0.5);
}

/// Raw units of depth z (metres), round to nearest; 0 when it does not fit in 1..65535.
inline std::uint16_t to_raw(double z_m, double depth_scale) {
  const double scaled = z_m * depth_scale;
  if (!(scaled >= 0.5 && scaled < 65535.5)) return 0;
  return static_cast<std::uint16_t>(round_non_negative(scaled));
}

/// Casts the ray through pixel coordinates (pu, pv); on a hit within 13 m returns its depth z
/// along the optical axis (m) and |cos| of the angle between the ray and the surface normal.
/// `subset` (null: all primitives) must hold every primitive the ray can reach.
inline bool cast_pixel(const RenderSetup& s, const PrimitiveSubset* subset, double pu, double pv,
                       double* z, double* cos_incidence) {
  const Eigen::Vector3d dir_camera((pu - s.cx) * s.inv_fx, (pv - s.cy) * s.inv_fy, 1.0);
  const double length = dir_camera.norm();  // metres of ray per metre of depth
  const double inv_length = 1.0 / length;
  const Ray ray{s.t_world_camera, s.R_world_camera * (dir_camera * inv_length)};
  Hit hit;
  const double t_max = kMaxSynthDepthM * length;
  const bool found = subset != nullptr ? s.scene->intersect(ray, 0.0, t_max, *subset, &hit)
                                       : s.scene->intersect(ray, 0.0, t_max, &hit);
  if (!found) return false;
  *z = hit.t * inv_length;
  *cos_incidence = std::min(1.0, std::abs(ray.direction.dot(hit.normal)));
  return *z > 0.0;
}

/// Raw depth of pixel (u, v): a pure function of the set-up and the pixel (see cast_pixel).
std::uint16_t render_pixel(const RenderSetup& s, const PrimitiveSubset* subset, int u, int v) {
  double z, cos_incidence;
  if (s.options.noise == SynthNoise::kNone) {
    if (!cast_pixel(s, subset, u, v, &z, &cos_incidence)) return 0;
    return to_raw(z, s.options.depth_scale);
  }
  // Kinect v1. Draw order per pixel: jitter pair, dropout uniform, axial pair.
  CounterRng rng(s.options.seed, s.options.frame_index,
                 static_cast<std::uint64_t>(v) * static_cast<std::uint64_t>(s.width) +
                     static_cast<std::uint64_t>(u));
  double n0, n1;
  rng.normal_pair(&n0, &n1);
  if (!cast_pixel(s, subset, u + kKinectLateralSigmaPx * n0, v + kKinectLateralSigmaPx * n1, &z,
                  &cos_incidence)) {
    return 0;
  }
  // Dropouts: certain beyond 80 deg incidence, ramping linearly in angle from 70 deg.
  const double dropout_draw = rng.uniform();
  if (cos_incidence < s.cos_dropout_full) return 0;
  if (cos_incidence < s.cos_dropout_start) {
    const double incidence_deg = std::acos(cos_incidence) / kDegToRad;
    if (dropout_draw < (incidence_deg - kKinectDropoutStartDeg) /
                           (kKinectDropoutFullDeg - kKinectDropoutStartDeg)) {
      return 0;
    }
  }
  double n2, n3;
  rng.normal_pair(&n2, &n3);
  const double z_noisy = z + kinect_axial_sigma_m(z) * n2;
  // Disparity d = fx b / z in pixels, quantised to 1/8 px.
  const double fb = s.fx * kKinectBaselineM;
  const double disparity_steps = fb / (z_noisy * kKinectDisparityStepPx);
  if (!(disparity_steps >= 0.5 && disparity_steps < 1e15)) return 0;
  const double z_measured =
      fb / (static_cast<double>(round_non_negative(disparity_steps)) * kKinectDisparityStepPx);
  if (z_measured < kKinectMinDepthM || z_measured > kKinectMaxDepthM) return 0;
  return to_raw(z_measured, s.options.depth_scale);
}

/// Primitives that rays through pixel coordinates [u_lo, u_hi] x [v_lo, v_hi] can reach: those not
/// entirely outside one of the four side planes of that frustum (world frame). Returns false when
/// the scene has too many primitives to list.
bool cull_tile(const RenderSetup& s, double u_lo, double u_hi, double v_lo, double v_hi,
               std::array<int, kMaxTilePrimitives>& boxes,
               std::array<int, kMaxTilePrimitives>& spheres, PrimitiveSubset* subset) {
  const auto& scene_boxes = s.scene->boxes();
  const auto& scene_spheres = s.scene->spheres();
  if (scene_boxes.size() > boxes.size() || scene_spheres.size() > spheres.size()) return false;
  auto world_ray = [&](double pu, double pv) {
    return Eigen::Vector3d(s.R_world_camera *
                           Eigen::Vector3d((pu - s.cx) * s.inv_fx, (pv - s.cy) * s.inv_fy, 1.0));
  };
  const std::array<Eigen::Vector3d, 4> corners = {world_ray(u_lo, v_lo), world_ray(u_hi, v_lo),
                                                  world_ray(u_hi, v_hi), world_ray(u_lo, v_hi)};
  const Eigen::Vector3d middle = world_ray(0.5 * (u_lo + u_hi), 0.5 * (v_lo + v_hi));
  std::array<Eigen::Vector3d, 4> planes;
  for (int k = 0; k < 4; ++k) {
    Eigen::Vector3d n = corners[k].cross(corners[(k + 1) % 4]).normalized();
    planes[k] = n.dot(middle) < 0.0 ? Eigen::Vector3d(-n) : n;  // inward
  }
  const Eigen::Vector3d& eye = s.t_world_camera;
  int box_count = 0;
  for (int i = 0; i < static_cast<int>(scene_boxes.size()); ++i) {
    const SceneBox& b = scene_boxes[i];
    bool outside = false;
    for (int k = 0; k < 4 && !outside; ++k) {
      // The box corner farthest along the plane normal decides.
      Eigen::Vector3d far;
      for (int a = 0; a < 3; ++a) far[a] = planes[k][a] >= 0.0 ? b.max[a] : b.min[a];
      outside = planes[k].dot(far - eye) < -kCullMarginM;
    }
    if (!outside) boxes[box_count++] = i;
  }
  int sphere_count = 0;
  for (int i = 0; i < static_cast<int>(scene_spheres.size()); ++i) {
    const SceneSphere& sp = scene_spheres[i];
    bool outside = false;
    for (int k = 0; k < 4 && !outside; ++k) {
      outside = planes[k].dot(sp.centre - eye) < -sp.radius - kCullMarginM;
    }
    if (!outside) spheres[sphere_count++] = i;
  }
  *subset = {boxes.data(), box_count, spheres.data(), sphere_count};
  return true;
}

/// Renders tile row `tile_row` (kTileSize image rows), tile by tile with frustum culling.
void render_tile_row(const RenderSetup& s, int tile_row, Image<std::uint16_t>& depth) {
  const double margin = s.options.noise == SynthNoise::kKinect ? kMaxJitterPx : 0.5;
  const int v0 = tile_row * kTileSize;
  const int v1 = std::min(v0 + kTileSize, s.height);
  std::array<int, kMaxTilePrimitives> boxes;
  std::array<int, kMaxTilePrimitives> spheres;
  for (int u0 = 0; u0 < s.width; u0 += kTileSize) {
    const int u1 = std::min(u0 + kTileSize, s.width);
    PrimitiveSubset subset;
    const bool culled = cull_tile(s, u0 - margin, u1 - 1 + margin, v0 - margin, v1 - 1 + margin,
                                  boxes, spheres, &subset);
    for (int v = v0; v < v1; ++v) {
      std::uint16_t* row = depth.row(v);
      for (int u = u0; u < u1; ++u) row[u] = render_pixel(s, culled ? &subset : nullptr, u, v);
    }
  }
}

}  // namespace

Pose look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
             double roll_rad) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x0 = z.cross(up).normalized();
  const Eigen::Vector3d y0 = z.cross(x0);
  const double c = std::cos(roll_rad);
  const double s = std::sin(roll_rad);
  Eigen::Matrix3d R;
  R.col(0) = c * x0 + s * y0;
  R.col(1) = -s * x0 + c * y0;
  R.col(2) = z;
  return Pose(R, eye);
}

Intrinsics SynthParams::intrinsics() const {
  return synth_intrinsics(width, height);
}

Intrinsics synth_intrinsics(int width, int height) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = 525.0 * width / 640.0;
  k.fy = k.fx;
  k.cx = (width - 1) / 2.0;
  k.cy = (height - 1) / 2.0;
  return k;
}

SynthParams parse_synth_spec(const std::string& spec) {
  static const std::string kPrefix = "synth:";
  if (spec.compare(0, kPrefix.size(), kPrefix) != 0) {
    throw usage_error("synth spec '" + printable(spec) + "' does not start with 'synth:'");
  }
  const std::size_t query = spec.find('?');
  SynthParams params;
  params.scene = spec.substr(
      kPrefix.size(), query == std::string::npos ? std::string::npos : query - kPrefix.size());
  const std::vector<std::string> scenes = AnalyticScene::names();
  if (std::find(scenes.begin(), scenes.end(), params.scene) == scenes.end()) {
    std::string valid;
    for (const auto& n : scenes) valid += (valid.empty() ? "" : ", ") + n;
    throw usage_error("synth spec '" + printable(spec) + "': unknown scene '" +
                      printable(params.scene) + "' (valid: " + valid + ")");
  }
  if (query == std::string::npos) return params;

  std::set<std::string> seen;
  std::size_t begin = query + 1;
  while (begin <= spec.size()) {
    std::size_t end = spec.find('&', begin);
    if (end == std::string::npos) end = spec.size();
    const std::string item = spec.substr(begin, end - begin);
    begin = end + 1;
    if (item.empty() && end == spec.size() && seen.empty()) break;  // "synth:NAME?"
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw usage_error("synth spec '" + printable(spec) + "': parameter '" + printable(item) +
                        "' is not key=value (valid keys: " + kParameterList + ")");
    }
    const std::string key = item.substr(0, eq);
    const std::string value = item.substr(eq + 1);
    if (!seen.insert(key).second) {
      throw usage_error("synth spec '" + printable(spec) + "': parameter '" + printable(key) +
                        "' is given twice");
    }
    if (key == "frames") {
      params.frames = parse_integer<int>(spec, key, value, 1, 100000000);
    } else if (key == "width") {
      params.width = parse_integer<int>(spec, key, value, 1, 4096);
    } else if (key == "height") {
      params.height = parse_integer<int>(spec, key, value, 1, 4096);
    } else if (key == "seed") {
      params.seed = parse_integer<std::uint64_t>(spec, key, value, 0,
                                                 std::numeric_limits<std::uint64_t>::max());
    } else if (key == "fps") {
      params.fps = parse_fps(spec, value);
    } else if (key == "noise") {
      if (value == "none") {
        params.noise = SynthNoise::kNone;
      } else if (value == "kinect") {
        params.noise = SynthNoise::kKinect;
      } else {
        bad_value(spec, key, value, "none or kinect");
      }
    } else if (key == "colour") {
      if (value == "on") {
        params.colour = true;
      } else if (value == "off") {
        params.colour = false;
      } else {
        bad_value(spec, key, value, "on or off");
      }
    } else if (key == "trajectory") {
      if (value == "orbit") {
        params.trajectory = SynthTrajectory::kOrbit;
      } else if (value == "sweep") {
        params.trajectory = SynthTrajectory::kSweep;
      } else {
        bad_value(spec, key, value, "orbit or sweep");
      }
    } else {
      throw usage_error("synth spec '" + printable(spec) + "': unknown parameter '" +
                        printable(key) + "' (valid: " + kParameterList + ")");
    }
  }
  return params;
}

Pose synth_camera_pose(const std::string& scene, SynthTrajectory trajectory, std::uint64_t seed,
                       double time_s) {
  const Rig rig = rig_for(scene);
  const double t = time_s;
  Eigen::Vector3d eye;
  Eigen::Vector3d target;
  if (trajectory == SynthTrajectory::kOrbit) {
    const OrbitRig& o = rig.orbit;
    const double azimuth =
        kDegToRad * (o.azimuth0_deg + o.azimuth_rate_deg_s * t -
                     o.azimuth_amplitude_deg * std::cos(2.0 * kPi * t / o.azimuth_period_s));
    const double radius = o.camera_radius_m + o.radius_swing_m * std::sin(2.0 * kPi * t / 17.0);
    const double height = o.camera_height_m + o.height_swing_m * std::sin(2.0 * kPi * t / 11.0);
    const Eigen::Vector3d radial(std::cos(azimuth), std::sin(azimuth), 0.0);
    const Eigen::Vector3d centre(o.centre.x(), o.centre.y(), 0.0);
    eye = centre + radius * radial + Eigen::Vector3d(0.0, 0.0, height);
    target = centre - o.target_radius_m * radial + Eigen::Vector3d(0.0, 0.0, o.target_height_m);
  } else {
    const SweepRig& w = rig.sweep;
    const double s = -std::cos(2.0 * kPi * t / w.period_s);
    eye = w.camera_centre + s * w.camera_axis;
    target = w.target_centre + s * w.target_axis;
  }
  // Hand tremor (about 1 cm, up to 1.3 Hz), a slowly drifting look-at point (about 4 cm) and roll.
  for (int axis = 0; axis < 3; ++axis) {
    eye[axis] += 0.01 * wobble(seed, axis, t, 1.0);
    target[axis] += 0.04 * wobble(seed, 3 + axis, t, 0.3);
  }
  const double roll_rad = kDegToRad * 1.5 * wobble(seed, 6, t, 0.5);
  return look_at(eye, target, Eigen::Vector3d::UnitZ(), roll_rad);
}

void render_synth_depth(const AnalyticScene& scene, const Intrinsics& intrinsics,
                        const Pose& T_world_camera, const SynthRenderOptions& options,
                        Image<std::uint16_t>& depth) {
  depth.resize(intrinsics.width, intrinsics.height);
  const RenderSetup setup = make_setup(scene, intrinsics, T_world_camera, options);
  const int tile_rows = (intrinsics.height + kTileSize - 1) / kTileSize;
  tbb::parallel_for(tbb::blocked_range<int>(0, tile_rows), [&](const tbb::blocked_range<int>& r) {
    for (int tile_row = r.begin(); tile_row < r.end(); ++tile_row) {
      render_tile_row(setup, tile_row, depth);
    }
  });
}

std::uint16_t render_synth_depth_pixel(const AnalyticScene& scene, const Intrinsics& intrinsics,
                                       const Pose& T_world_camera,
                                       const SynthRenderOptions& options, int u, int v) {
  return render_pixel(make_setup(scene, intrinsics, T_world_camera, options), nullptr, u, v);
}

void render_synth_colour(const AnalyticScene& scene, const Intrinsics& intrinsics,
                         const Pose& T_world_camera, Image<Rgb8>& colour) {
  colour.resize(intrinsics.width, intrinsics.height);
  const RenderSetup setup = make_setup(scene, intrinsics, T_world_camera, SynthRenderOptions{});
  tbb::parallel_for(tbb::blocked_range<int>(0, intrinsics.height),
                    [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v)
      for (int u = 0; u < intrinsics.width; ++u) {
        const Eigen::Vector3d dir((u - setup.cx) * setup.inv_fx, (v - setup.cy) * setup.inv_fy, 1.0);
        const double length = dir.norm();
        const Ray ray{setup.t_world_camera, setup.R_world_camera * (dir / length)};
        Hit hit;
        colour(u, v) = scene.intersect(ray, 0.0, kMaxSynthDepthM * length, &hit)
                           ? scene.colour(hit.primitive)
                           : Rgb8{};
      }
  });
}

void render_synth_frame(const AnalyticScene& scene, const SynthParams& params, std::uint64_t index,
                        DepthFrame& frame) {
  const double time_s = static_cast<double>(index) / params.fps;
  const Pose T_world_camera = synth_camera_pose(params.scene, params.trajectory, params.seed, time_s);
  SynthRenderOptions options;
  options.noise = params.noise;
  options.seed = params.seed;
  options.frame_index = index;
  options.depth_scale = kSynthDepthScale;
  frame.intrinsics = params.intrinsics();
  render_synth_depth(scene, frame.intrinsics, T_world_camera, options, frame.depth);
  frame.depth_scale = kSynthDepthScale;
  frame.timestamp_s = time_s;
  frame.sequence = index;
  frame.T_world_camera_gt = T_world_camera;
  frame.colour_error.clear();
  if (params.colour) {
    render_synth_colour(scene, frame.intrinsics, T_world_camera, frame.colour);
    frame.colour_camera = ColourCamera::registered_to(frame.intrinsics);
    frame.colour_timestamp_s = time_s;
  } else {
    frame.colour.resize(0, 0);
    frame.colour_camera.reset();
  }
}

}  // namespace aoscan
