#pragma once
// The frame silhouette as the database would have rendered it: seen by a virtual, distortion-free
// camera that looks straight at the object.
//
// The database renders every view with the object centre on the optical axis of an ideal pinhole
// camera. In a real frame the object can be anywhere in the image and the lens distorts: an object
// seen theta away from the optical axis is stretched by about 1 / cos^2(theta) radially and
// 1 / cos(theta) across (the homography of the camera rotation that would centre it), and radial
// distortion bends its outline further. Matching that outline against the database biases the
// view and the roll. Here the outline (not the image) is mapped into the virtual camera instead:
//  1. every outline pixel is undistorted to ideal normalised coordinates n (lens_distortion.h);
//  2. the virtual camera has the real camera's centre, focal length f = sqrt(fx fy), no
//     distortion, and is turned by Q, the minimal rotation taking the optical axis to the ray u
//     towards the silhouette's centre (RotationFromOpticalAxisTo): a point on ray (n, 1) is seen
//     at f (x / z, y / z) with (x, y, z) = Q^T (n, 1);
//  3. u starts at the ray through the undistorted centroid and is moved to the ray through the
//     mapped outline's area centroid until that centroid is on the virtual axis (two or three
//     iterations; the centroid of a projected shape is not the projection of its centroid);
//  4. the mapped outline is described like a database silhouette (star-convex radii around its
//     centroid, half a pixel added, divided by their mean: shape/polar_signature.h).
// Q is the same minimal rotation that EstimatePoseFromSilhouette (pose_from_silhouette.h) puts
// between the virtual and the real camera, so the roll matched here is the roll it expects.
// The apparent size, mean radius / f, tells the distance (ViewDatabase::ChooseShell).

#include <Eigen/Core>
#include <span>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/shape/polar_signature.h"

namespace silpose {

struct OnAxisSilhouette {
  /// The descriptor in the virtual image (radii for matching). centroid_px is the virtual image's
  /// principal point (0, 0) up to the iteration's tolerance; mean_radius_px and area_px are in
  /// virtual pixels.
  PolarSignature signature;
  /// Q: the virtual camera's axes in the real camera frame (x_camera = Q x_virtual).
  Eigen::Matrix3d camera_from_virtual = Eigen::Matrix3d::Identity();
  /// The virtual camera's focal length, pixels (sqrt(fx fy)).
  double focal_px = 0.0;
  /// signature.mean_radius_px / focal_px: the silhouette's apparent size (a tangent).
  double apparent_radius = 0.0;
  /// Angle between the real optical axis and the virtual one, degrees.
  double off_axis_deg = 0.0;
};

/// Describes `outline_px` (SignatureResult::outline_px of a frame of `camera`) in the on-axis
/// virtual camera, as above, with `options.length` radii. Returns false, leaving `result`
/// unspecified, if a point cannot be undistorted or the outline reaches 80 degrees off the axis.
bool DescribeOnAxis(std::span<const Eigen::Vector2d> outline_px, const PinholeCamera& camera,
                    const SignatureOptions& options, OnAxisSilhouette* result);

}  // namespace silpose
