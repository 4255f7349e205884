/// @file relocalisation_takes.cpp
/// @brief The sweep take, rendered and fused frame by frame.
#include "support/relocalisation_takes.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "io/png_read.h"
#include "sim/synth_camera.h"
#include "support/kitchen_fusion.h"

namespace aoscan::test {
namespace {

constexpr double kFps = 30.0;
constexpr double kSweepPeriodS = 10.0;

}  // namespace

Pose sweep_take_pose(double time_s) {
  // The corner scene's sweep rig (sim), ten seconds a period instead of 24.
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1.0, -1.0, 0.0).normalized();
  const double s = -std::cos(2.0 * M_PI * time_s / kSweepPeriodS);
  const Eigen::Vector3d eye = Eigen::Vector3d(2.1, 2.1, 1.45) + 0.9 * s * diagonal;
  const Eigen::Vector3d target = Eigen::Vector3d(0.85, 0.85, 0.45) + 0.4 * s * diagonal;
  return look_at(eye, target, Eigen::Vector3d::UnitZ());
}

void take_frame(const AnalyticScene& scene, const Pose& T_world_camera, int index, bool blank,
                const TakeOptions& options, PreprocessedFrame& out) {
  DepthFrame raw;
  raw.intrinsics = synth_intrinsics(options.width, options.height);
  raw.depth_scale = kSynthDepthScale;
  raw.sequence = static_cast<std::uint64_t>(index);
  raw.timestamp_s = index / kFps;
  SynthRenderOptions render;
  render.noise = SynthNoise::kKinect;
  render.seed = options.seed;
  render.frame_index = static_cast<std::uint64_t>(index);
  render_synth_depth(scene, raw.intrinsics, T_world_camera, render, raw.depth);
  if (blank) raw.depth.fill(0);
  preprocess_frame(raw, options.config.preprocess, out);
}

TakeResult run_take(const TakeOptions& options) {
  static const AnalyticScene scene = AnalyticScene::make("corner");
  Reconstruction rec(options.config);
  const Intrinsics k = synth_intrinsics(options.width, options.height);
  TakeResult result;
  Pose T_world0_inverse;
  bool have_first = false;
  double sum_sq = 0.0;
  int tracked = 0;
  PreprocessedFrame frame;
  for (int i = 0; i < options.frames; i += std::max(1, options.frame_step)) {
    const bool in_gap = options.gap_begin >= 0 && i >= options.gap_begin && i < options.gap_end;
    if (in_gap && options.cut_gap) continue;
    const Pose truth = sweep_take_pose(i / kFps);
    take_frame(scene, truth, i, in_gap, options, frame);
    const auto start = std::chrono::steady_clock::now();
    const FusionStep step = rec.process(frame, k, std::make_shared<RaycastResult>());
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!have_first) {
      T_world0_inverse = truth.inverse();
      have_first = true;
    }
    TakeFrame f;
    f.index = i;
    f.status = step.status;
    f.relocalised = step.relocalised;
    f.integrated = step.integrated;
    f.estimate = step.T_world_camera;
    f.truth = T_world0_inverse * truth;
    f.track_ms = ms;
    if (step.status != TrackingStatus::kLost) {
      sum_sq += (f.estimate.translation() - f.truth.translation()).squaredNorm();
      ++tracked;
    }
    if (step.relocalised) {
      if (result.first_relocalised < 0) result.first_relocalised = i;
      result.worst_relocalised_m =
          std::max(result.worst_relocalised_m, translation_between(f.estimate, f.truth));
      result.worst_relocalised_deg =
          std::max(result.worst_relocalised_deg, rotation_between_deg(f.estimate, f.truth));
    }
    result.frames.push_back(f);
  }
  result.ate_m = tracked > 0 ? std::sqrt(sum_sq / tracked) : 0.0;
  result.losses = rec.losses();
  result.relocalisations = rec.relocalisations();
  result.frames_lost = rec.frames_lost();
  result.keyframes = rec.relocaliser().database().keyframes().size();
  return result;
}

KidnapResult run_kidnapped(const KidnapOptions& options) {
  using Clock = std::chrono::steady_clock;
  const auto ms_since = [](Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  };
  KidnapResult result;
  const std::vector<KitchenFrame> frames = read_kitchen(options.dir, options.frames);
  const int map_frames = std::min<int>(options.map_frames, static_cast<int>(frames.size()));
  if (map_frames == 0) return result;
  Reconstruction rec(options.config);
  const Pose T_gt0_inverse = frames[0].T_world_camera_gt.inverse();
  DepthFrame raw;
  raw.intrinsics = kKitchenIntrinsics;
  raw.depth_scale = 1000.0;
  PreprocessedFrame frame;
  const auto load = [&](std::size_t i) {
    if (const Status read = read_grey16_png(frames[i].path, raw.depth); !read.is_ok()) {
      result.read_errors.push_back(read.message());
      return false;
    }
    raw.sequence = i;
    preprocess_frame(raw, options.config.preprocess, frame);
    return true;
  };
  // The whole recording as one take: the reference of the kidnapped frames in the map's world.
  std::vector<std::optional<Pose>> one_take(frames.size());
  {
    Reconstruction whole(options.config);
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (!load(i)) continue;
      const FusionStep step =
          whole.process(frame, raw.intrinsics, std::make_shared<RaycastResult>());
      if (step.status != TrackingStatus::kLost) one_take[i] = step.T_world_camera;
    }
  }
  result.read_errors.clear();
  std::vector<Pose> mapped;
  double sum_sq = 0.0;
  for (int i = 0; i < map_frames; ++i) {
    if (!load(static_cast<std::size_t>(i))) continue;
    const FusionStep step = rec.process(frame, raw.intrinsics, std::make_shared<RaycastResult>());
    if (step.status == TrackingStatus::kLost) {
      ++result.map_lost;
      continue;
    }
    mapped.push_back(step.T_world_camera);
    const Pose truth = T_gt0_inverse * frames[static_cast<std::size_t>(i)].T_world_camera_gt;
    sum_sq += (step.T_world_camera.translation() - truth.translation()).squaredNorm();
    const auto t0 = Clock::now();
    (void)rec.relocaliser().database().encode(frame.pyramid);
    result.encode_ms.push_back(ms_since(t0));
  }
  result.map_ate_m = mapped.empty() ? 0.0 : std::sqrt(sum_sq / mapped.size());
  const std::vector<Keyframe>& keyframes = rec.relocaliser().database().keyframes();
  result.keyframes = keyframes.size();
  for (std::size_t i = static_cast<std::size_t>(map_frames); i < frames.size(); ++i) {
    if (!one_take[i] || !load(i)) continue;
    const Pose& truth = *one_take[i];
    KidnapFrame f;
    f.index = static_cast<int>(i);
    f.coverable = std::any_of(mapped.begin(), mapped.end(), [&](const Pose& m) {
      return translation_between(m, truth) <= options.near_m &&
             rotation_between_deg(m, truth) <= options.near_deg;
    });
    f.nearest_keyframe_m = 1e9;
    for (const Keyframe& k : keyframes)
      if (translation_between(k.T_world_camera, truth) < f.nearest_keyframe_m) {
        f.nearest_keyframe_m = translation_between(k.T_world_camera, truth);
        f.nearest_keyframe_deg = rotation_between_deg(k.T_world_camera, truth);
      }
    const auto t0 = Clock::now();
    const RelocalisationResult r = rec.relocalise(frame, raw.intrinsics);
    f.ms = ms_since(t0);
    result.attempt_ms.push_back(f.ms);
    f.accepted = r.accepted;
    f.rejection = r.rejection;
    f.raycast_ms = r.raycast_ms;
    f.icp_ms = r.icp_ms;
    f.candidates = r.candidates_tried;
    f.first_search = r.first_search;
    f.check = r.icp;
    if (!r.keyframes.empty()) {
      const Pose& k = keyframes[static_cast<std::size_t>(r.keyframes.front())].T_world_camera;
      f.candidate_m = translation_between(k, truth);
      f.candidate_deg = rotation_between_deg(k, truth);
    }
    ++result.kidnapped;
    result.coverable += f.coverable;
    if (r.accepted) {
      ++result.accepted;
      f.error_m = translation_between(r.T_world_camera, truth);
      f.error_deg = rotation_between_deg(r.T_world_camera, truth);
      const Pose reference = T_gt0_inverse * frames[i].T_world_camera_gt;
      f.reference_error_m = translation_between(r.T_world_camera, reference);
      f.reference_error_deg = rotation_between_deg(r.T_world_camera, reference);
      result.worst_accepted_m = std::max(result.worst_accepted_m, f.error_m);
      result.worst_accepted_deg = std::max(result.worst_accepted_deg, f.error_deg);
      if (f.error_m > 0.10 || f.error_deg > 10.0) ++result.accepted_wrong;
      if (f.coverable && f.error_m <= 0.05 && f.error_deg <= 5.0) ++result.coverable_right;
    }
    result.frames.push_back(f);
  }
  return result;
}

}  // namespace aoscan::test
