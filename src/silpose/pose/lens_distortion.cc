#include "silpose/pose/lens_distortion.h"

#include <Eigen/LU>
#include <cmath>

namespace silpose {

bool HasDistortion(const PinholeCamera& camera) {
  for (double k : camera.distortion) {
    if (k != 0.0) return true;
  }
  return false;
}

Eigen::Vector2d DistortNormalized(const std::array<double, 5>& distortion,
                                  const Eigen::Vector2d& ideal, Eigen::Matrix2d* jacobian) {
  const double k1 = distortion[0], k2 = distortion[1], p1 = distortion[2], p2 = distortion[3],
               k3 = distortion[4];
  const double x = ideal.x(), y = ideal.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const Eigen::Vector2d distorted(x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
                                  y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y);
  if (jacobian != nullptr) {
    // d(radial)/d(r2), and d(r2)/dx = 2x, d(r2)/dy = 2y.
    const double d_radial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
    (*jacobian)(0, 0) = radial + 2.0 * x * x * d_radial + 2.0 * p1 * y + 6.0 * p2 * x;
    (*jacobian)(0, 1) = 2.0 * x * y * d_radial + 2.0 * p1 * x + 2.0 * p2 * y;
    (*jacobian)(1, 0) = 2.0 * x * y * d_radial + 2.0 * p1 * x + 2.0 * p2 * y;
    (*jacobian)(1, 1) = radial + 2.0 * y * y * d_radial + 6.0 * p1 * y + 2.0 * p2 * x;
  }
  return distorted;
}

bool UndistortNormalized(const std::array<double, 5>& distortion, const Eigen::Vector2d& distorted,
                         Eigen::Vector2d* ideal) {
  Eigen::Vector2d estimate = distorted;
  for (int step = 0; step < 20; ++step) {
    Eigen::Matrix2d jacobian;
    const Eigen::Vector2d residual = DistortNormalized(distortion, estimate, &jacobian) - distorted;
    if (!residual.allFinite()) break;
    if (residual.norm() < 1e-12) {
      *ideal = estimate;
      return true;
    }
    const double determinant = jacobian.determinant();
    // A vanishing or negative Jacobian: the distortion folds over here, there is no unique inverse.
    if (!(determinant > 1e-9)) break;
    estimate -= jacobian.inverse() * residual;
  }
  *ideal = estimate;
  return (DistortNormalized(distortion, estimate) - distorted).norm() < 1e-9;
}

Eigen::Vector2d ProjectDistorted(const PinholeCamera& camera,
                                 const Eigen::Vector3d& point_in_camera) {
  const Eigen::Vector2d ideal(point_in_camera.x() / point_in_camera.z(),
                              point_in_camera.y() / point_in_camera.z());
  const Eigen::Vector2d distorted = DistortNormalized(camera.distortion, ideal);
  return {camera.focal_x_px * distorted.x() + camera.principal_x_px,
          camera.focal_y_px * distorted.y() + camera.principal_y_px};
}

bool PixelToIdealNormalized(const PinholeCamera& camera, const Eigen::Vector2d& pixel,
                            Eigen::Vector2d* ideal) {
  const Eigen::Vector2d distorted((pixel.x() - camera.principal_x_px) / camera.focal_x_px,
                                  (pixel.y() - camera.principal_y_px) / camera.focal_y_px);
  return UndistortNormalized(camera.distortion, distorted, ideal);
}

}  // namespace silpose
