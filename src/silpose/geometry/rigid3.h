#pragma once
// Rigid transforms. Convention, stated once for the whole project:
//   b_from_a = (R, t) maps a point given in frame a to frame b:  x_in_b = R * x_in_a + t.
// The `object_to_camera` pose of the output files (r00..r22, tx..tz) is camera_from_object here.

#include <Eigen/Core>
#include <Eigen/Geometry>

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

}  // namespace silpose
