#include "silpose/geometry/pinhole_camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

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

bool PinholeCamera::CheckCalibration(std::string* error) const {
  if (!Check(error)) return false;
  std::ostringstream message;
  const double side = std::max(width_px, height_px);
  const double focal_min = kMinFocalPerSide * side;
  const double focal_max = kMaxFocalPerSide * side;
  auto principal_ok = [](double c, int size) {
    return c >= -static_cast<double>(size) && c <= 2.0 * size;
  };
  if (focal_x_px < focal_min || focal_y_px < focal_min || focal_x_px > focal_max ||
      focal_y_px > focal_max) {
    message << "focal lengths fx " << focal_x_px << " fy " << focal_y_px << " px are outside ["
            << focal_min << ", " << focal_max << "] px (" << kMinFocalPerSide << " to "
            << kMaxFocalPerSide << " times the longer image side, " << side << " px)";
  } else if (!principal_ok(principal_x_px, width_px) || !principal_ok(principal_y_px, height_px)) {
    message << "principal point (" << principal_x_px << ", " << principal_y_px
            << ") px is more than one image size away from the " << width_px << "x" << height_px
            << " image";
  } else {
    static const char* kNames[] = {"k1", "k2", "p1", "p2", "k3"};
    for (size_t i = 0; i < distortion.size(); ++i) {
      const bool tangential = i == 2 || i == 3;
      const double bound = tangential ? kMaxTangentialDistortion : kMaxRadialDistortion;
      if (std::abs(distortion[i]) > bound) {
        message << "distortion coefficient " << kNames[i] << " = " << distortion[i]
                << " is outside [-" << bound << ", " << bound << "]";
        break;
      }
    }
  }
  if (message.str().empty()) return true;
  if (error != nullptr) *error = message.str();
  return false;
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
