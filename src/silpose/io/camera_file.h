#pragma once
// Camera intrinsics files in the YAML (or XML/JSON) layout that OpenCV's calibration writes:
// camera_matrix (3x3), distortion_coefficients (1xN or Nx1), image_width, image_height.

#include <filesystem>

#include "silpose/geometry/pinhole_camera.h"

namespace silpose {

/// Reads a camera file. Throws silpose::Error naming the file and the problem (missing file, not
/// OpenCV YAML, a missing or malformed field, an invalid camera). Distortion models with more than
/// the 5 standard coefficients (k1 k2 p1 p2 k3) are refused if the extra ones are non-zero.
PinholeCamera ReadCameraFile(const std::filesystem::path& path);

/// Writes a camera file that ReadCameraFile (and OpenCV) read back.
void WriteCameraFile(const std::filesystem::path& path, const PinholeCamera& camera);

}  // namespace silpose
