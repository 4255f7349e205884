/// @file pose.h
/// @brief Rigid transforms named by their frames: `T_world_camera` maps camera coordinates to world.
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace aoscan {

/// A rigid transform T_a_b (maps points in frame b to frame a), double precision.
class Pose {
 public:
  Pose() = default;
  Pose(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
      : R_(rotation), t_(translation) {}
  /// From a TUM trajectory line's translation and (x, y, z, w) quaternion; the quaternion is
  /// normalised.
  static Pose from_quaternion(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
    return Pose(q.normalized().toRotationMatrix(), t);
  }
  static Pose from_matrix(const Eigen::Matrix4d& m) {
    return Pose(m.topLeftCorner<3, 3>(), m.topRightCorner<3, 1>());
  }
  static Pose identity() { return Pose(); }

  const Eigen::Matrix3d& rotation() const { return R_; }
  const Eigen::Vector3d& translation() const { return t_; }
  Eigen::Quaterniond quaternion() const { return Eigen::Quaterniond(R_).normalized(); }
  Eigen::Matrix4d matrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = R_;
    m.topRightCorner<3, 1>() = t_;
    return m;
  }

  Pose inverse() const { return Pose(R_.transpose(), -(R_.transpose() * t_)); }
  /// T_a_c = T_a_b * T_b_c.
  Pose operator*(const Pose& other) const { return Pose(R_ * other.R_, R_ * other.t_ + t_); }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return R_ * p + t_; }

  /// The same transform with its rotation made exactly orthonormal again. inverse() transposes the
  /// rotation, so a chain of compositions (tracking multiplies poses frame after frame) must not
  /// let rounding drift accumulate: R^T R = I + E grows to I + 3E per frame-to-model step.
  Pose normalized() const { return Pose(Eigen::Quaterniond(R_).normalized().toRotationMatrix(), t_); }

  /// True when every entry is finite.
  bool finite() const { return R_.allFinite() && t_.allFinite(); }

 private:
  Eigen::Matrix3d R_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_ = Eigen::Vector3d::Zero();
};

/// The distance between two poses' positions (their translations' units).
inline double translation_between(const Pose& a, const Pose& b) {
  return (a.translation() - b.translation()).norm();
}

/// The angle of the rotation that takes pose a's orientation to pose b's (degrees, in [0, 180]).
inline double rotation_between_deg(const Pose& a, const Pose& b) {
  return std::abs(Eigen::AngleAxisd(a.rotation().transpose() * b.rotation()).angle()) * 180.0 /
         M_PI;
}

}  // namespace aoscan
