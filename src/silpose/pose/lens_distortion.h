#pragma once
// OpenCV's five-coefficient lens distortion (k1, k2, p1, p2, k3) on normalised image coordinates
// (x, y) = (X / Z, Y / Z) of a point in the camera frame (geometry/pinhole_camera.h):
//   r^2 = x^2 + y^2,  radial = 1 + k1 r^2 + k2 r^4 + k3 r^6,
//   x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2),
//   y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y,
// and pixel (u, v) = (fx x_d + cx, fy y_d + cy). The pose layer uses it to move the silhouette's
// centre and scale, measured in the distorted image, into the ideal pinhole image the database
// was rendered with.

#include <Eigen/Core>
#include <array>

#include "silpose/geometry/pinhole_camera.h"

namespace silpose {

/// True if any distortion coefficient is non-zero.
bool HasDistortion(const PinholeCamera& camera);

/// Distorts ideal normalised coordinates (see above). `jacobian` (may be null) receives
/// d(distorted) / d(ideal).
Eigen::Vector2d DistortNormalized(const std::array<double, 5>& distortion,
                                  const Eigen::Vector2d& ideal,
                                  Eigen::Matrix2d* jacobian = nullptr);

/// Inverse of DistortNormalized by Newton's method (at most 20 steps, to 1e-12). Returns false
/// (and the last iterate) if it does not converge, e.g. beyond the region where the distortion is
/// monotonic.
bool UndistortNormalized(const std::array<double, 5>& distortion, const Eigen::Vector2d& distorted,
                         Eigen::Vector2d* ideal);

/// Pixel of a point in the camera frame (Z > 0) with lens distortion.
Eigen::Vector2d ProjectDistorted(const PinholeCamera& camera,
                                 const Eigen::Vector3d& point_in_camera);

/// Ideal (undistorted) normalised coordinates of a pixel of the distorted image; false if the
/// undistortion does not converge.
bool PixelToIdealNormalized(const PinholeCamera& camera, const Eigen::Vector2d& pixel,
                            Eigen::Vector2d* ideal);

}  // namespace silpose
