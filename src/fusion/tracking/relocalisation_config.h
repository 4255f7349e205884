/// @file relocalisation_config.h
/// @brief Configuration of relocalisation after tracking loss (section `relocalisation`).
///
/// The struct lists its fields once in `visit()`: loading (`--config`, `--set`), validation,
/// `aoscan config` and the README's table are all driven by that list (pipeline/config.h).
#pragma once

namespace aoscan {

/// The keyframe database of randomised ferns (Glocker et al. 2015) and the check a candidate pose
/// must pass before fusing starts again.
struct RelocalisationConfig {
  /// Ferns encoding a frame; 0 turns relocalisation off (a lost take then only retries from the
  /// last good pose, still checked before fusing resumes).
  int ferns = 500;
  int fern_decisions = 4;  ///< binary tests per fern (a fern's code has this many bits)
  /// A well-tracked frame becomes a keyframe when its codes differ from every keyframe's in more
  /// than this fraction of the ferns.
  double keyframe_dissimilarity = 0.2;
  /// The database stops growing here (a keyframe holds 40 KiB at 640 x 480: its depth at the
  /// coarsest level, and its codes).
  int max_keyframes = 4000;
  int candidates = 3;         ///< most similar keyframes whose poses a lost frame is tried from
  /// ICP from a keyframe's pose may move this far (m, degrees) before the candidate is dropped:
  /// the keyframe was taken near, not at, the frame's pose.
  double search_translation_m = 0.3;
  double search_rotation_deg = 30.0;
  /// The check: ICP from the candidate converges (a second ICP from its result moves less than
  /// 1 cm and 1 degree) with at least this fraction of the frame's pixels matched ...
  double accept_inlier_ratio = 0.4;
  /// ... the frame's depth agrees with the model raycast at the pose within this distance (m,
  /// growing with the square of the depth beyond tracking.noise_reference_depth_m) on at least
  /// accept_agreement of the pixels where both have depth ...
  double accept_depth_tolerance_m = 0.03;
  double accept_agreement = 0.7;
  /// ... on no more than accept_max_see_through of them the frame sees beyond the model's
  /// surface (through a place the model holds as solid) ...
  double accept_max_see_through = 0.1;
  /// ... and at least this fraction of the frame's valid pixels see mapped geometry.
  double accept_overlap = 0.3;

  template <class V>
  void visit(V& v) {
    v.integer("ferns", ferns,
              "randomised ferns encoding a frame for relocalisation; 0 turns relocalisation off", 0,
              4096);
    v.integer("fern_decisions", fern_decisions, "binary tests per fern", 1, 8);
    v.number("keyframe_dissimilarity", keyframe_dissimilarity,
             "a tracked frame becomes a keyframe when it differs from every keyframe in more than "
             "this fraction of ferns",
             0.0, 1.0);
    v.integer("max_keyframes", max_keyframes, "the keyframe database stops growing here", 1,
              10000000);
    v.integer("candidates", candidates, "keyframes a lost frame is tried from, most similar first",
              1, 32);
    v.number("search_translation_m", search_translation_m,
             "relocalisation: ICP from a keyframe's pose may move this far (m)", 0.0, 10.0);
    v.number("search_rotation_deg", search_rotation_deg,
             "relocalisation: ICP from a keyframe's pose may turn this far (degrees)", 0.0, 180.0);
    v.number("accept_inlier_ratio", accept_inlier_ratio,
             "relocalisation check: least fraction of the frame's pixels matched by ICP", 0.0, 1.0);
    v.number("accept_depth_tolerance_m", accept_depth_tolerance_m,
             "relocalisation check: frame and model depth agree within this (m, grows with depth "
             "squared)",
             1e-4, 1.0);
    v.number("accept_agreement", accept_agreement,
             "relocalisation check: least fraction of pixels where frame and model depth agree",
             0.0, 1.0);
    v.number("accept_max_see_through", accept_max_see_through,
             "relocalisation check: most fraction of pixels where the frame sees through the model",
             0.0, 1.0);
    v.number("accept_overlap", accept_overlap,
             "relocalisation check: least fraction of the frame's pixels on mapped geometry", 0.0,
             1.0);
  }
};

}  // namespace aoscan
