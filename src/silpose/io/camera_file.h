#pragma once
// Camera intrinsics files in the YAML (or XML/JSON) layout that OpenCV's calibration writes:
// camera_matrix (3x3), distortion_coefficients (1xN or Nx1), image_width, image_height.

#include <filesystem>

#include "silpose/geometry/pinhole_camera.h"

namespace silpose {

/// Reads a camera file: the YAML, XML or JSON that cv::FileStorage writes (recognised by its
/// beginning, %YAML:1.0, <?xml or {), read by silpose's own strict reader of that layout, not by
/// OpenCV's parsers. Other keys (what OpenCV's calibration sample writes around the camera) are
/// skipped. Throws silpose::Error, one line naming the file, the line and the problem: a missing
/// file, more than 1 MiB or binary content, not that layout, a key that appears twice, a missing
/// or malformed field (a matrix of more than 16 elements or more than one channel, a count of
/// values other than rows x cols, a value that is not a finite number, base64 data), an invalid
/// camera. Distortion models with more than the 5 standard coefficients (k1 k2 p1 p2 k3) are
/// refused if the extra ones are non-zero.
PinholeCamera ReadCameraFile(const std::filesystem::path& path);

/// Writes a camera file (with cv::FileStorage; YAML, XML or JSON by the extension) that
/// ReadCameraFile and OpenCV read back.
void WriteCameraFile(const std::filesystem::path& path, const PinholeCamera& camera);

}  // namespace silpose
