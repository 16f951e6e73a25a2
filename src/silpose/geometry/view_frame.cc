#include "silpose/geometry/view_frame.h"

#include <cmath>
#include <numbers>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
// sin(0.5 deg): below this distance from the Z axis, the +Y fallback is used.
constexpr double kPoleThreshold = 0.0087265;

}  // namespace

Eigen::Vector3d ReferenceUpInObject(const Eigen::Vector3d& view_dir_in_object) {
  const Eigen::Vector3d d = view_dir_in_object.normalized();
  if (std::hypot(d.x(), d.y()) < kPoleThreshold) return Eigen::Vector3d::UnitY();
  return Eigen::Vector3d::UnitZ();
}

Eigen::Matrix3d CameraFromObjectRotation(const Eigen::Vector3d& view_dir_in_object,
                                         double roll_deg) {
  const double norm = view_dir_in_object.norm();
  SILPOSE_ASSERT(norm > 0.0 && std::isfinite(norm));
  const Eigen::Vector3d d = view_dir_in_object / norm;
  const Eigen::Vector3d up = ReferenceUpInObject(d);
  const Eigen::Vector3d z_axis = -d;
  const Eigen::Vector3d y_axis = -(up - up.dot(d) * d).normalized();
  const Eigen::Vector3d x_axis = y_axis.cross(z_axis);
  const double c = std::cos(roll_deg * kDegToRad);
  const double s = std::sin(roll_deg * kDegToRad);
  Eigen::Matrix3d rotation;
  rotation.row(0) = (c * x_axis + s * y_axis).transpose();
  rotation.row(1) = (-s * x_axis + c * y_axis).transpose();
  rotation.row(2) = z_axis.transpose();
  return rotation;
}

Rigid3 CameraFromObjectAtView(const Eigen::Vector3d& view_dir_in_object, double roll_deg,
                              double distance, const Eigen::Vector3d& object_centre) {
  Rigid3 pose;
  pose.rotation = CameraFromObjectRotation(view_dir_in_object, roll_deg);
  const Eigen::Vector3d camera_centre = object_centre + distance * view_dir_in_object.normalized();
  pose.translation = -(pose.rotation * camera_centre);
  return pose;
}

void ViewAndRollFromRotation(const Eigen::Matrix3d& camera_from_object,
                             Eigen::Vector3d* view_dir_in_object, double* roll_deg) {
  const Eigen::Vector3d d = -camera_from_object.row(2).transpose().normalized();
  const Eigen::Matrix3d reference = CameraFromObjectRotation(d, 0.0);
  // Camera x axis expressed in the reference camera's (x, y): (cos r, sin r).
  const Eigen::Vector3d x_axis = camera_from_object.row(0).transpose();
  const double cos_r = x_axis.dot(reference.row(0).transpose());
  const double sin_r = x_axis.dot(reference.row(1).transpose());
  *view_dir_in_object = d;
  *roll_deg = WrapDegrees(std::atan2(sin_r, cos_r) / kDegToRad);
}

double TransportRoll(const Eigen::Vector3d& from_view_dir, double from_roll_deg,
                     const Eigen::Vector3d& to_view_dir) {
  const Eigen::Vector3d a = from_view_dir.normalized();
  const Eigen::Vector3d b = to_view_dir.normalized();
  const Eigen::Matrix3d from = CameraFromObjectRotation(a, from_roll_deg);
  // Minimal rotation taking a to b, applied to the camera (object_from_camera rotates with it).
  const Eigen::Quaterniond a_to_b = Eigen::Quaterniond::FromTwoVectors(a, b);
  const Eigen::Matrix3d moved = from * a_to_b.toRotationMatrix().transpose();
  Eigen::Vector3d unused;
  double roll_deg = 0.0;
  ViewAndRollFromRotation(moved, &unused, &roll_deg);
  return roll_deg;
}

double WrapDegrees(double angle_deg) {
  double wrapped = std::fmod(angle_deg, 360.0);
  if (wrapped <= -180.0) wrapped += 360.0;
  if (wrapped > 180.0) wrapped -= 360.0;
  return wrapped;
}

}  // namespace silpose
