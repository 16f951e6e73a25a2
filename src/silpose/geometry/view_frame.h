#pragma once
// Camera placement on the view sphere (paper 4.1) and the roll convention.
//
// A view is a unit vector `view_dir_in_object`, in the model frame, from the object centre towards
// the camera centre. The camera looks at the object centre: its optical axis (z) is -view_dir.
//
// Roll reference. At roll 0 the camera's "up" (image -y) is the model's +Z axis projected onto the
// image plane, so a Z-up model stands upright in the image. Within 0.5 degrees of the poles
// (view_dir nearly parallel to +-Z), where that projection vanishes, the model's +Y axis is used
// instead; the reference therefore turns quickly near the poles, and code that moves a pose between
// neighbouring views should carry the camera orientation over (TransportRoll), not the roll number.
//
// Roll: rotation of the camera about its optical axis by roll_deg, turning image x towards image y
// (clockwise on screen, as y points down). The image content turns the other way, so a silhouette
// seen at roll r has the polar signature of roll 0 shifted by r: s_r(phi) = s_0(phi + r).

#include <Eigen/Core>

#include "silpose/geometry/rigid3.h"

namespace silpose {

/// The reference "up" direction (in the model frame) for a view, see above.
Eigen::Vector3d ReferenceUpInObject(const Eigen::Vector3d& view_dir_in_object);

/// Rotation camera_from_object (rows: camera x, y, z axes in the model frame) for a camera on
/// `view_dir_in_object` (need not be normalised, must be non-zero) with roll `roll_deg`.
Eigen::Matrix3d CameraFromObjectRotation(const Eigen::Vector3d& view_dir_in_object,
                                         double roll_deg);

/// Full camera_from_object pose: camera centre at object_centre + distance * view_dir, looking at
/// object_centre, rolled by roll_deg. `distance` in model units.
Rigid3 CameraFromObjectAtView(const Eigen::Vector3d& view_dir_in_object, double roll_deg,
                              double distance, const Eigen::Vector3d& object_centre);

/// Inverse of CameraFromObjectRotation: the view direction (unit) and roll (degrees, in
/// (-180, 180]) of a camera rotation whose optical axis points at the object centre.
void ViewAndRollFromRotation(const Eigen::Matrix3d& camera_from_object,
                             Eigen::Vector3d* view_dir_in_object, double* roll_deg);

/// Roll at `to_view_dir` whose camera orientation is closest to the camera at (`from_view_dir`,
/// `from_roll_deg`) moved along the great circle between the two views (parallel transport).
double TransportRoll(const Eigen::Vector3d& from_view_dir, double from_roll_deg,
                     const Eigen::Vector3d& to_view_dir);

/// Wraps an angle in degrees into (-180, 180].
double WrapDegrees(double angle_deg);

}  // namespace silpose
