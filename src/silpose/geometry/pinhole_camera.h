#pragma once
// Pinhole camera in OpenCV's convention: camera frame x right, y down, z forward; pixel (u, v) has
// its centre at integer coordinates, u = fx * X / Z + cx, v = fy * Y / Z + cy. Units: pixels.
// Lens distortion is carried for the real-video pipeline; the renderer ignores it (ideal pinhole).

#include <Eigen/Core>
#include <array>
#include <string>

namespace silpose {

struct PinholeCamera {
  int width_px = 0;
  int height_px = 0;
  double focal_x_px = 0.0;
  double focal_y_px = 0.0;
  double principal_x_px = 0.0;
  double principal_y_px = 0.0;
  /// OpenCV distortion coefficients (k1, k2, p1, p2, k3); all zero = none.
  std::array<double, 5> distortion = {0, 0, 0, 0, 0};

  /// True if the parameters describe a usable camera; otherwise `error` says what is wrong.
  bool Check(std::string* error = nullptr) const;

  /// Bounds of a real camera's calibration (docs/limits.md): focal lengths between
  /// kMinFocalPerSide and kMaxFocalPerSide times the longer image side; the principal point within
  /// one image size of the image (-width..2 width, -height..2 height); |k1|, |k2|, |k3| <=
  /// kMaxRadialDistortion and |p1|, |p2| <= kMaxTangentialDistortion. Beyond them poses are not
  /// meaningful numbers.
  static constexpr double kMinFocalPerSide = 0.01;
  static constexpr double kMaxFocalPerSide = 1000.0;
  static constexpr double kMaxRadialDistortion = 1000.0;
  static constexpr double kMaxTangentialDistortion = 10.0;
  /// Check() and the calibration bounds above (calibration files are checked with this).
  bool CheckCalibration(std::string* error = nullptr) const;

  /// Projects a point in the camera frame (Z > 0) to pixel coordinates.
  Eigen::Vector2d Project(const Eigen::Vector3d& point_in_camera) const {
    return {focal_x_px * point_in_camera.x() / point_in_camera.z() + principal_x_px,
            focal_y_px * point_in_camera.y() / point_in_camera.z() + principal_y_px};
  }

  /// Square image, principal point at the image centre, square pixels.
  static PinholeCamera Centered(int width_px, int height_px, double focal_px);
};

}  // namespace silpose
