/// @file relocaliser.cpp
/// @brief Candidates, ICP from each, and the check of the best.
#include "fusion/relocaliser.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "fusion/tsdf/raycast.h"

namespace aoscan {
namespace {

/// Candidates closer than this to one already in the list are the same start for ICP.
constexpr double kSameStartTranslationM = 0.05;
constexpr double kSameStartRotationDeg = 5.0;
/// A verified pose is a converged one: ICP started from it moves less than this.
constexpr double kConvergedTranslationM = 0.01;
constexpr double kConvergedRotationDeg = 1.0;
/// Candidates that pass ICP are checked best first, at most this many per frame.
constexpr int kMaxChecks = 1;
/// A frame with depth on fewer of its pixels than this is not tried (a covered camera).
constexpr double kMinValidFraction = 0.05;
/// The see-through test's unhinted rays: this many pixels across at most.
constexpr int kSeeThroughWidth = 40;

/// `intrinsics` halved until at most kSeeThroughWidth pixels across.
Intrinsics see_through_intrinsics(const Intrinsics& intrinsics) {
  int level = 0;
  while (intrinsics.scaled(level).width > kSeeThroughWidth) ++level;
  return intrinsics.scaled(level);
}

/// `in` at width x height, each pixel the one nearest its centre.
Image<float> resample_nearest(const Image<float>& in, int width, int height) {
  Image<float> out(width, height, 0.0f);
  if (in.empty()) return out;
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(in.height() - 1, (2 * y + 1) * in.height() / (2 * height));
    for (int x = 0; x < width; ++x)
      out(x, y) = in(std::min(in.width() - 1, (2 * x + 1) * in.width() / (2 * width)), sy);
  }
  return out;
}

using Clock = std::chrono::steady_clock;

/// Adds the time since `start` to `ms`.
void add_ms(double& ms, Clock::time_point start) {
  ms += std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

DepthAgreement compare_depth(const Image<float>& frame_depth_m, const Image<float>& model_depth_m,
                             double tolerance_m, double noise_reference_depth_m) {
  DepthAgreement a;
  if (frame_depth_m.width() != model_depth_m.width() ||
      frame_depth_m.height() != model_depth_m.height())
    return a;
  for (std::size_t i = 0; i < frame_depth_m.size(); ++i) {
    const float f = frame_depth_m.data()[i];
    if (!(f > 0.0f)) continue;
    ++a.frame_pixels;
    const float m = model_depth_m.data()[i];
    if (!(m > 0.0f)) continue;
    ++a.both;
    const double s = noise_reference_depth_m > 0.0 && m > noise_reference_depth_m
                         ? (m / noise_reference_depth_m) * (m / noise_reference_depth_m)
                         : 1.0;
    const double tol = tolerance_m * s;
    if (std::abs(f - m) <= tol)
      ++a.agree;
    else if (f > m + tol)
      ++a.see_through;
  }
  return a;
}

Relocaliser::Relocaliser(const ReconstructionConfig& config)
    : config_(config), search_(config.tracking), database_(config.relocalisation) {
  search_.max_translation_m = config.relocalisation.search_translation_m;
  search_.max_rotation_deg = config.relocalisation.search_rotation_deg;
  // The search raycasts at the frame's coarsest level: full resolution adds nothing there.
  search_.iterations_level0 = 0;
}

void Relocaliser::observe(const DepthPyramid& frame, const Pose& T_world_camera,
                          int model_level) {
  if (!enabled() || database_.full()) return;
  const bool first = database_.keyframes().empty();
  database_.add_if_novel(database_.encode(frame), T_world_camera, frame);
  if (!first || database_.keyframes().empty()) return;
  // Sized once here, the buffers cost nothing when the camera is lost (allocating and touching
  // them then added about 5 ms to the first attempt on RedKitchen).
  const auto size = [](RaycastResult& r, const Intrinsics& in) {
    r.depth_m.resize(in.width, in.height, 0.0f);
    r.maps.vertices.resize(in.width, in.height, Eigen::Vector3f::Zero());
    r.maps.normals.resize(in.width, in.height, Eigen::Vector3f::Zero());
  };
  const Intrinsics& search = frame.maps[kPyramidLevels - 1].intrinsics;
  size(search_model_, search);
  hint_.resize(search.width, search.height, 0.0f);
  size(check_model_, frame.maps[model_level].intrinsics);
  size(see_through_model_, see_through_intrinsics(frame.maps[model_level].intrinsics));
}

bool Relocaliser::verify(const DepthPyramid& frame, const Intrinsics& model_intrinsics,
                         int model_level, const TsdfVolume& volume, const Pose& T_world_camera,
                         IcpWorkspace& workspace, RelocalisationResult& result) {
  // The model at the candidate pose, each ray searched next to the frame's depth: where the pose
  // is right, the model's surface is there.
  auto start = Clock::now();
  const Image<float>& frame_depth = frame.depth_m[model_level];
  raycast(volume, model_intrinsics, T_world_camera, config_.fusion, check_model_, &frame_depth,
          RaycastRays::kHintedOnly);
  add_ms(result.raycast_ms, start);
  start = Clock::now();
  result.icp = icp(frame, check_model_, T_world_camera, config_.tracking, workspace);
  add_ms(result.icp_ms, start);
  const RelocalisationConfig& rc = config_.relocalisation;
  const auto reject = [&](const char* why) {
    result.rejection = why;
    return false;
  };
  // Poor is enough (a Kinect's residual at 3 m is about poor_rms_residual_m): the inliers, the
  // convergence and the depth comparisons decide.
  if (result.icp.status == TrackingStatus::kLost) return reject("ICP lost");
  if (result.icp.translation_m > kConvergedTranslationM ||
      result.icp.rotation_deg > kConvergedRotationDeg)
    return reject("not converged");
  if (result.icp.inlier_ratio < rc.accept_inlier_ratio) return reject("inliers");
  result.agreement = compare_depth(frame_depth, check_model_.depth_m, rc.accept_depth_tolerance_m,
                                   config_.tracking.noise_reference_depth_m);
  if (result.agreement.overlap() < rc.accept_overlap) return reject("overlap");
  if (result.agreement.agreement() < rc.accept_agreement) return reject("agreement");
  // The hinted rays look only next to the frame's depth: whether the frame sees through a surface
  // of the model in front of it is asked of unhinted rays, on a coarse grid.
  start = Clock::now();
  raycast(volume, see_through_intrinsics(model_intrinsics), result.icp.T_world_camera,
          config_.fusion, see_through_model_);
  add_ms(result.raycast_ms, start);
  result.see_through = compare_depth(resample_nearest(frame.depth_m[kPyramidLevels - 1],
                                                      see_through_model_.depth_m.width(),
                                                      see_through_model_.depth_m.height()),
                                     see_through_model_.depth_m, rc.accept_depth_tolerance_m,
                                     config_.tracking.noise_reference_depth_m);
  if (result.see_through.see_through_ratio() > rc.accept_max_see_through)
    return reject("see-through");
  result.rejection = "";
  result.T_world_camera = result.icp.T_world_camera;
  return true;
}

RelocalisationResult Relocaliser::relocalise(const DepthPyramid& frame,
                                             const Intrinsics& model_intrinsics, int model_level,
                                             const TsdfVolume& volume,
                                             const std::shared_ptr<const RaycastResult>& last_model,
                                             IcpWorkspace& workspace) {
  RelocalisationResult result;
  const Image<float>& coarse = frame.depth_m[kPyramidLevels - 1];
  const auto valid = std::count_if(coarse.data(), coarse.data() + coarse.size(),
                                   [](float d) { return d > 0.0f; });
  result.rejection = "too little depth";
  if (static_cast<double>(valid) < kMinValidFraction * static_cast<double>(coarse.size()))
    return result;
  std::vector<Candidate> candidates;
  if (last_model) candidates.push_back({last_model->T_world_camera, -1});
  if (enabled()) {
    for (const KeyframeMatch& m :
         database_.nearest(database_.encode(frame), config_.relocalisation.candidates)) {
      const Pose& T = database_.keyframes()[static_cast<std::size_t>(m.keyframe)].T_world_camera;
      const bool seen = std::any_of(candidates.begin(), candidates.end(), [&](const Candidate& c) {
        return translation_between(c.T_world_camera, T) < kSameStartTranslationM &&
               rotation_between_deg(c.T_world_camera, T) < kSameStartRotationDeg;
      });
      if (!seen) {
        candidates.push_back({T, m.keyframe});
        result.keyframes.push_back(m.keyframe);
      }
    }
  }
  // ICP from each candidate; the ones it does not lose, best matched first.
  struct Tracked {
    Pose T_world_camera;
    double inlier_ratio;
    int keyframe;
  };
  std::vector<Tracked> tracked;
  // Keyframe candidates are raycast at the frame's coarsest level: ICP from them only has to come
  // near enough for the check's ICP at the model's resolution.
  const Intrinsics& search_intrinsics = frame.maps[kPyramidLevels - 1].intrinsics;
  for (const Candidate& c : candidates) {
    const RaycastResult* reference = nullptr;
    if (c.keyframe < 0) {
      reference = last_model.get();
    } else {
      // The keyframe was fused at its pose: its depth is the hint of the raycast there.
      const auto start = Clock::now();
      const Keyframe& k = database_.keyframes()[static_cast<std::size_t>(c.keyframe)];
      depth_from_mm(k.depth_mm, hint_);
      const bool hinted =
          hint_.width() == search_intrinsics.width && hint_.height() == search_intrinsics.height;
      raycast(volume, search_intrinsics, c.T_world_camera, config_.fusion, search_model_,
              hinted ? &hint_ : nullptr, RaycastRays::kHintedOnly);
      add_ms(result.raycast_ms, start);
      reference = &search_model_;
    }
    ++result.candidates_tried;
    if (reference->hits == 0) continue;
    const auto start = Clock::now();
    const IcpResult r = icp(frame, *reference, c.T_world_camera, search_, workspace);
    add_ms(result.icp_ms, start);
    if (result.candidates_tried == 1) result.first_search = r;
    // A candidate that matches too little already will not pass the check: not worth a raycast.
    if (r.status != TrackingStatus::kLost && r.T_world_camera.finite() &&
        r.inlier_ratio >= config_.relocalisation.accept_inlier_ratio)
      tracked.push_back({r.T_world_camera, r.inlier_ratio, c.keyframe});
  }
  result.rejection = tracked.empty() ? (candidates.empty() ? "no candidate" : "ICP") : "";
  std::stable_sort(tracked.begin(), tracked.end(), [](const Tracked& a, const Tracked& b) {
    return a.inlier_ratio > b.inlier_ratio;
  });
  for (std::size_t i = 0; i < tracked.size() && i < static_cast<std::size_t>(kMaxChecks); ++i) {
    if (verify(frame, model_intrinsics, model_level, volume, tracked[i].T_world_camera, workspace,
               result)) {
      result.accepted = true;
      result.candidate_keyframe = tracked[i].keyframe;
      return result;
    }
  }
  return result;
}

}  // namespace aoscan
