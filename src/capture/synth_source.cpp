/// @file synth_source.cpp
/// @brief The `synth:` source: spec parsing, handheld trajectories, depth rendering with an optional
/// Kinect v1 noise model.
#include "capture/synth_source.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <exception>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "capture/counter_rng.h"
#include "core/status.h"

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

const char* const kParameterList = "frames, width, height, noise, seed, trajectory, fps";

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
/// 0.2-1.3 Hz whose phases and exact frequencies come from (seed, channel).
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
/// cos(2 pi t / period), looking at the point `target_radius` beyond the centre, opposite the camera.
struct OrbitRig {
  Eigen::Vector2d centre;
  double camera_radius_m, camera_height_m;
  double target_radius_m, target_height_m;
  double azimuth0_deg, azimuth_amplitude_deg, azimuth_period_s, azimuth_rate_deg_s;
  double radius_swing_m, height_swing_m;
};

/// Camera and target moving back and forth along parallel lines: x(t) = centre - axis cos(2 pi t / T).
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

/// T_world_camera looking from `eye` at `target` (world z up), rolled by `roll_rad` about the
/// optical axis.
Pose look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, double roll_rad) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x0 = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y0 = z.cross(x0);
  const double c = std::cos(roll_rad);
  const double s = std::sin(roll_rad);
  Eigen::Matrix3d R;
  R.col(0) = c * x0 + s * y0;
  R.col(1) = -s * x0 + c * y0;
  R.col(2) = z;
  return Pose(R, eye);
}

// ---------------------------------------------------------------------------------------------
// Rendering

/// Per-frame constants of the renderer.
struct RenderSetup {
  const AnalyticScene* scene;
  Eigen::Matrix3d R_world_camera;
  Eigen::Vector3d t_world_camera;
  double fx, fy, cx, cy;
  int width;
  SynthRenderOptions options;
};

inline std::uint16_t to_raw(double z_m, double depth_scale) {
  const double raw = std::floor(z_m * depth_scale + 0.5);
  return raw >= 1.0 && raw <= 65535.0 ? static_cast<std::uint16_t>(raw) : 0;
}

/// Raw depth of pixel (u, v): a pure function of the set-up and the pixel.
std::uint16_t render_pixel(const RenderSetup& s, int u, int v) {
  const bool kinect = s.options.noise == SynthNoise::kKinect;
  CounterRng rng(s.options.seed, s.options.frame_index,
                 static_cast<std::uint64_t>(v) * static_cast<std::uint64_t>(s.width) +
                     static_cast<std::uint64_t>(u));
  double pu = u;
  double pv = v;
  if (kinect) {
    double n0, n1;
    rng.normal_pair(&n0, &n1);
    pu += kKinectLateralSigmaPx * n0;
    pv += kKinectLateralSigmaPx * n1;
  }
  const Eigen::Vector3d dir_camera((pu - s.cx) / s.fx, (pv - s.cy) / s.fy, 1.0);
  const double length = dir_camera.norm();  // metres of ray per metre of depth
  const Ray ray{s.t_world_camera, s.R_world_camera * (dir_camera / length)};
  Hit hit;
  if (!s.scene->intersect(ray, 0.0, kMaxSynthDepthM * length, &hit)) return 0;
  const double z = hit.t / length;
  if (!(z > 0.0)) return 0;
  if (!kinect) return to_raw(z, s.options.depth_scale);

  const double cos_incidence = std::min(1.0, std::abs(ray.direction.dot(hit.normal)));
  const double incidence_deg = std::acos(cos_incidence) / kDegToRad;
  const double dropout_draw = rng.uniform();
  if (incidence_deg > kKinectDropoutFullDeg) return 0;
  if (incidence_deg > kKinectDropoutStartDeg &&
      dropout_draw < (incidence_deg - kKinectDropoutStartDeg) /
                         (kKinectDropoutFullDeg - kKinectDropoutStartDeg)) {
    return 0;
  }
  double n2, n3;
  rng.normal_pair(&n2, &n3);
  const double z_noisy = z + kinect_axial_sigma_m(z) * n2;
  if (!(z_noisy > 0.0)) return 0;
  const double fb = s.fx * kKinectBaselineM;  // disparity (px) times depth (m)
  const double disparity =
      std::round(fb / z_noisy / kKinectDisparityStepPx) * kKinectDisparityStepPx;
  if (!(disparity > 0.0)) return 0;
  const double z_measured = fb / disparity;
  if (z_measured < kKinectMinDepthM || z_measured > kKinectMaxDepthM) return 0;
  return to_raw(z_measured, s.options.depth_scale);
}

RenderSetup make_setup(const AnalyticScene& scene, const Intrinsics& k, const Pose& T_world_camera,
                       const SynthRenderOptions& options) {
  return {&scene, T_world_camera.rotation(), T_world_camera.translation(), k.fx, k.fy, k.cx, k.cy,
          k.width, options};
}

void render_rows(const RenderSetup& s, int row_begin, int row_end, Image<std::uint16_t>& depth) {
  for (int v = row_begin; v < row_end; ++v) {
    std::uint16_t* row = depth.row(v);
    for (int u = 0; u < s.width; ++u) row[u] = render_pixel(s, u, v);
  }
}

// ---------------------------------------------------------------------------------------------
// The source

class SynthSource final : public Source {
 public:
  SynthSource(std::string spec, SynthParams params)
      : spec_(std::move(spec)),
        params_(std::move(params)),
        scene_(AnalyticScene::make(params_.scene)),
        intrinsics_(params_.intrinsics()),
        mesh_(scene_.to_mesh()) {}

  Status read(DepthFrame& frame) override {
    if (next_ >= static_cast<std::uint64_t>(params_.frames)) return Status::end_of_stream();
    try {
      const std::uint64_t index = next_++;
      const double time_s = static_cast<double>(index) / params_.fps;
      const Pose T_world_camera =
          synth_camera_pose(params_.scene, params_.trajectory, params_.seed, time_s);
      SynthRenderOptions options;
      options.noise = params_.noise;
      options.seed = params_.seed;
      options.frame_index = index;
      options.depth_scale = kSynthDepthScale;
      render_synth_depth(scene_, intrinsics_, T_world_camera, options, frame.depth);
      frame.depth_scale = kSynthDepthScale;
      frame.intrinsics = intrinsics_;
      frame.timestamp_s = time_s;
      frame.sequence = index;
      frame.origin = spec_ + " frame " + std::to_string(index);
      frame.T_world_camera_gt = T_world_camera;
      return Status::ok();
    } catch (const std::exception& e) {
      return Status::internal(spec_ + ": rendering failed: " + e.what());
    }
  }

  std::string name() const override { return spec_; }
  const Intrinsics& intrinsics() const override { return intrinsics_; }
  double depth_scale() const override { return kSynthDepthScale; }
  std::optional<std::size_t> size() const override {
    return static_cast<std::size_t>(params_.frames);
  }
  const TriangleMesh* scene_mesh() const override { return &mesh_; }

 private:
  std::string spec_;
  SynthParams params_;
  AnalyticScene scene_;
  Intrinsics intrinsics_;
  TriangleMesh mesh_;
  std::uint64_t next_ = 0;
};

}  // namespace

Intrinsics SynthParams::intrinsics() const {
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
  params.scene = spec.substr(kPrefix.size(), query == std::string::npos ? std::string::npos
                                                                        : query - kPrefix.size());
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
      params.width = parse_integer<int>(spec, key, value, 1, 8192);
    } else if (key == "height") {
      params.height = parse_integer<int>(spec, key, value, 1, 8192);
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
  return look_at(eye, target, roll_rad);
}

void render_synth_depth(const AnalyticScene& scene, const Intrinsics& intrinsics,
                        const Pose& T_world_camera, const SynthRenderOptions& options,
                        Image<std::uint16_t>& depth) {
  depth.resize(intrinsics.width, intrinsics.height);
  const RenderSetup setup = make_setup(scene, intrinsics, T_world_camera, options);
  tbb::parallel_for(tbb::blocked_range<int>(0, intrinsics.height),
                    [&](const tbb::blocked_range<int>& rows) {
                      render_rows(setup, rows.begin(), rows.end(), depth);
                    });
}

void render_synth_depth_reference(const AnalyticScene& scene, const Intrinsics& intrinsics,
                                  const Pose& T_world_camera, const SynthRenderOptions& options,
                                  Image<std::uint16_t>& depth) {
  depth.resize(intrinsics.width, intrinsics.height);
  const RenderSetup setup = make_setup(scene, intrinsics, T_world_camera, options);
  for (int v = 0; v < intrinsics.height; ++v) {
    for (int u = 0; u < intrinsics.width; ++u) depth(u, v) = render_pixel(setup, u, v);
  }
}

std::unique_ptr<Source> open_synth_source(const std::string& spec) {
  SynthParams params = parse_synth_spec(spec);
  return std::make_unique<SynthSource>(spec, std::move(params));
}

}  // namespace aoscan
