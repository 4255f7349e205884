/// @file trajectory_eval.h
/// @brief Absolute and relative trajectory error against a ground truth (TUM RGB-D benchmark
/// definitions): association by timestamp, rigid (rotation + translation, no scale) alignment.
#pragma once

#include <cstddef>
#include <vector>

#include "core/pose.h"
#include "io/tum.h"

namespace aoscan::eval {

/// Estimated and ground-truth poses of the same frames (matched by timestamp).
struct AssociatedPoses {
  std::vector<Pose> estimate;
  std::vector<Pose> truth;
};

/// Pairs every estimated pose with the ground-truth pose nearest in time (within max_dt_s).
AssociatedPoses associate_poses(const std::vector<StampedPose>& truth,
                                const std::vector<StampedPose>& estimate, double max_dt_s = 0.02);

struct AteResult {
  std::size_t pairs = 0;
  double rmse_m = 0, mean_m = 0, median_m = 0, max_m = 0;
  Pose T_truth_estimate;  ///< the rigid alignment applied to the estimate
};

/// The map of the first pose pair, T_truth[0] * T_estimate[0]^-1. aoscan's world frame is the
/// first tracked frame's camera frame (the contract), so this maps its mesh into the truth's frame
/// exactly, with nothing fitted; drift after that frame stays visible. Identity when `poses` is
/// empty.
Pose first_pose_alignment(const AssociatedPoses& poses);

/// Absolute trajectory error of camera positions after the least-squares rigid alignment
/// (Horn / Umeyama without scale) of the estimate onto the truth.
AteResult compute_ate(const AssociatedPoses& poses);

struct RpeResult {
  std::size_t pairs = 0;
  double translation_rmse_m = 0;
  double rotation_rmse_deg = 0;
};

/// Relative pose error over steps of `delta` frames: drift per step, independent of alignment.
RpeResult compute_rpe(const AssociatedPoses& poses, std::size_t delta = 1);

}  // namespace aoscan::eval
