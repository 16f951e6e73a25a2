#pragma once
// Rigid transforms. Convention, stated once for the whole project:
//   b_from_a = (R, t) maps a point given in frame a to frame b:  x_in_b = R * x_in_a + t.
// The `object_to_camera` pose of the output files (r00..r22, tx..tz) is camera_from_object here.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace silpose {

struct Rigid3 {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return rotation * x + translation; }
  /// (this * other)(x) = this(other(x)).
  Rigid3 operator*(const Rigid3& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
  Rigid3 Inverse() const { return {rotation.transpose(), -(rotation.transpose() * translation)}; }
};

/// Angle of the rotation a^T b in degrees, [0, 180]. The matrices should be rotations. From the
/// quaternion by atan2: acos of (trace - 1) / 2 loses precision near 0.
inline double RotationAngleBetweenDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::Quaterniond relative(Eigen::Matrix3d(a.transpose() * b));
  const double angle = 2.0 * std::atan2(relative.vec().norm(), std::abs(relative.w()));
  return angle * 180.0 / std::numbers::pi;
}

}  // namespace silpose
