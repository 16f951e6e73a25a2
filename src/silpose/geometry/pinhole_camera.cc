#include "silpose/geometry/pinhole_camera.h"

#include <cmath>

namespace silpose {

bool PinholeCamera::Check(std::string* error) const {
  auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (width_px <= 0 || height_px <= 0) return fail("image size must be positive");
  if (width_px > 32768 || height_px > 32768) return fail("image size larger than 32768 pixels");
  if (!std::isfinite(focal_x_px) || !std::isfinite(focal_y_px) || focal_x_px <= 0.0 ||
      focal_y_px <= 0.0) {
    return fail("focal lengths must be positive and finite");
  }
  if (!std::isfinite(principal_x_px) || !std::isfinite(principal_y_px)) {
    return fail("principal point must be finite");
  }
  for (double k : distortion) {
    if (!std::isfinite(k)) return fail("distortion coefficients must be finite");
  }
  return true;
}

PinholeCamera PinholeCamera::Centered(int width_px, int height_px, double focal_px) {
  PinholeCamera camera;
  camera.width_px = width_px;
  camera.height_px = height_px;
  camera.focal_x_px = focal_px;
  camera.focal_y_px = focal_px;
  camera.principal_x_px = 0.5 * (width_px - 1);
  camera.principal_y_px = 0.5 * (height_px - 1);
  return camera;
}

}  // namespace silpose
