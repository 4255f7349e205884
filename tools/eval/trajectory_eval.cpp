/// @file trajectory_eval.cpp
/// @brief ATE and RPE.
#include "trajectory_eval.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace aoscan::eval {

AssociatedPoses associate_poses(const std::vector<StampedPose>& truth,
                                const std::vector<StampedPose>& estimate, double max_dt_s) {
  AssociatedPoses out;
  for (const StampedPose& e : estimate) {
    if (const auto t = associate(truth, e.timestamp_s, max_dt_s)) {
      out.estimate.push_back(e.T_world_camera);
      out.truth.push_back(*t);
    }
  }
  return out;
}

Pose first_pose_alignment(const AssociatedPoses& poses) {
  if (poses.estimate.empty()) return Pose();
  return poses.truth[0] * poses.estimate[0].inverse();
}

AteResult compute_ate(const AssociatedPoses& poses) {
  AteResult r;
  r.pairs = poses.estimate.size();
  if (r.pairs == 0) return r;
  Eigen::Matrix3Xd est(3, r.pairs), gt(3, r.pairs);
  for (std::size_t i = 0; i < r.pairs; ++i) {
    est.col(static_cast<Eigen::Index>(i)) = poses.estimate[i].translation();
    gt.col(static_cast<Eigen::Index>(i)) = poses.truth[i].translation();
  }
  if (r.pairs >= 3) {
    r.T_truth_estimate = Pose::from_matrix(Eigen::umeyama(est, gt, /*with_scaling=*/false));
  } else {  // too few points to fix a rotation
    r.T_truth_estimate = first_pose_alignment(poses);
  }
  std::vector<double> errors(r.pairs);
  double sum_sq = 0, sum = 0;
  for (std::size_t i = 0; i < r.pairs; ++i) {
    errors[i] = (r.T_truth_estimate * poses.estimate[i].translation() - poses.truth[i].translation()).norm();
    sum_sq += errors[i] * errors[i];
    sum += errors[i];
  }
  r.rmse_m = std::sqrt(sum_sq / static_cast<double>(r.pairs));
  r.mean_m = sum / static_cast<double>(r.pairs);
  r.max_m = *std::max_element(errors.begin(), errors.end());
  std::nth_element(errors.begin(), errors.begin() + static_cast<std::ptrdiff_t>(r.pairs / 2), errors.end());
  r.median_m = errors[r.pairs / 2];
  return r;
}

RpeResult compute_rpe(const AssociatedPoses& poses, std::size_t delta) {
  RpeResult r;
  const std::size_t n = poses.estimate.size();
  if (delta == 0 || n <= delta) return r;
  double t_sq = 0, r_sq = 0;
  for (std::size_t i = 0; i + delta < n; ++i) {
    const Pose gt_step = poses.truth[i].inverse() * poses.truth[i + delta];
    const Pose est_step = poses.estimate[i].inverse() * poses.estimate[i + delta];
    const Pose error = gt_step.inverse() * est_step;
    t_sq += error.translation().squaredNorm();
    const double angle = Eigen::AngleAxisd(error.rotation()).angle();
    r_sq += angle * angle;
    ++r.pairs;
  }
  r.translation_rmse_m = std::sqrt(t_sq / static_cast<double>(r.pairs));
  r.rotation_rmse_deg = std::sqrt(r_sq / static_cast<double>(r.pairs)) * 180.0 / M_PI;
  return r;
}

}  // namespace aoscan::eval
