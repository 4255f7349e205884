/// @file relocalisation_takes.h
/// @brief Synthetic takes that lose tracking and come back: a fast back-and-forth sweep past the
/// corner scene with Kinect v1 noise, through the real preprocessing and Reconstruction, with a
/// stretch of frames blacked out (no depth) or cut out (the camera jumps). Shared by
/// tests/fusion/relocalisation_test.cpp and the aoscan-reloc-bench benchmark; free of GoogleTest.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/pose.h"
#include "fusion/preprocess/preprocess.h"
#include "fusion/reconstruction.h"
#include "fusion/tracking/icp.h"
#include "sim/synth_scene.h"

namespace aoscan::test {

/// The take's camera at time t (s): it sweeps a 1.8 m line past the corner scene and back every
/// 10 s (up to 0.57 m/s), looking at the corner; world = the scene's (z up).
Pose sweep_take_pose(double time_s);

struct TakeOptions {
  int frames = 270;  ///< frames of the take at 30 fps (before any are cut out)
  int width = 320, height = 240;
  /// Frames [gap_begin, gap_end) have no depth (blackout) or, with cut_gap, are not in the take
  /// at all; gap_begin < 0: no gap. The default gap is the 2 s from 6 s to 8 s, while the camera
  /// moves 1.0 m back along the line it came.
  int gap_begin = -1, gap_end = -1;
  bool cut_gap = false;
  /// Every frame_step-th frame is in the take (2: 15 fps, the same path in half the frames).
  int frame_step = 1;
  std::uint64_t seed = 1;  ///< noise key
  ReconstructionConfig config;
};

/// One frame of a take as Reconstruction saw it.
struct TakeFrame {
  int index = 0;  ///< frame index in the uncut take
  TrackingStatus status = TrackingStatus::kLost;
  bool relocalised = false;
  bool integrated = false;
  Pose estimate;       ///< the pose Reconstruction reported (world of the take: its first camera)
  Pose truth;          ///< the true pose in the same frame
  double track_ms = 0;  ///< Reconstruction::process() wall time
};

struct TakeResult {
  std::vector<TakeFrame> frames;
  std::size_t losses = 0, relocalisations = 0, frames_lost = 0, keyframes = 0;
  /// RMS translation error over the frames that were not lost (m).
  double ate_m = 0.0;
  /// The first relocalised frame's index, -1 when none.
  int first_relocalised = -1;
  /// Largest translation (m) and rotation (deg) error of a relocalised frame.
  double worst_relocalised_m = 0.0, worst_relocalised_deg = 0.0;
};

/// The default gap of TakeOptions: frames 180-239.
inline constexpr int kTakeGapBegin = 180;
inline constexpr int kTakeGapEnd = 240;

/// Frame `index` of the take (noise keyed by it) rendered from `T_world_camera` in `scene`
/// (blank when `blank`) and preprocessed with the options' configuration.
void take_frame(const AnalyticScene& scene, const Pose& T_world_camera, int index, bool blank,
                const TakeOptions& options, PreprocessedFrame& out);

/// Runs the take; the frames are rendered on the fly (seeded: the same options give the same
/// result).
TakeResult run_take(const TakeOptions& options);

/// The kidnapped-camera measure on a real recording (7-Scenes RedKitchen layout, kitchen_fusion.h):
/// frames [0, map_frames) are tracked and fused as a take; each later frame is then relocalised
/// on its own against that map (Reconstruction::relocalise: from the keyframes alone). Its pose
/// is compared with the pose the same frame gets when the whole recording is tracked as one take
/// (the map is that take's first part, so this is the frame's pose in the map's world, within the
/// take's drift since the map), and with the recording's reference pose relative to the first
/// frame's (which differs from the map by the map's own drift against the reference).
struct KidnapOptions {
  std::string dir;
  int map_frames = 250;
  int frames = 500;  ///< frames read in all
  /// A kidnapped frame counts as coverable when its reference pose is this close to the
  /// reference pose of a mapped frame (the 7-Scenes relocalisation measure).
  double near_m = 0.2, near_deg = 20.0;
  ReconstructionConfig config;
};

/// One kidnapped frame.
struct KidnapFrame {
  int index = 0;
  bool coverable = false, accepted = false;
  double error_m = 0, error_deg = 0;  ///< of the accepted pose against the one-take pose
  double reference_error_m = 0, reference_error_deg = 0;  ///< ... against the reference pose
  double nearest_keyframe_m = 0;      ///< the nearest keyframe's distance from the true pose
  double nearest_keyframe_deg = 0;    ///< ... and its angle (the same keyframe)
  const char* rejection = "";
  double ms = 0, raycast_ms = 0, icp_ms = 0;
  int candidates = 0;
  double candidate_m = 0, candidate_deg = 0;  ///< the most similar keyframe from the true pose
  IcpResult first_search;
  IcpResult check;  ///< the check's ICP
};

struct KidnapResult {
  int map_lost = 0;       ///< mapped frames lost while mapping
  double map_ate_m = 0;   ///< the map's own ATE against the reference poses
  std::size_t keyframes = 0;
  int kidnapped = 0;      ///< frames relocalised on their own (tracked in the one take)
  int coverable = 0;      ///< ... within near_m / near_deg of a mapped pose (one-take poses)
  int coverable_right = 0;  ///< ... of those, accepted within 5 cm and 5 degrees
  int accepted = 0;         ///< kidnapped frames accepted at all
  int accepted_wrong = 0;   ///< ... with an error above 10 cm or 10 degrees
  double worst_accepted_m = 0, worst_accepted_deg = 0;
  std::vector<KidnapFrame> frames;
  std::vector<double> attempt_ms;  ///< each kidnapped frame's relocalisation
  std::vector<double> encode_ms;   ///< the fern encoding of each mapped frame
  std::vector<std::string> read_errors;
};

KidnapResult run_kidnapped(const KidnapOptions& options);

}  // namespace aoscan::test
