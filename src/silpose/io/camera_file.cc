#include "silpose/io/camera_file.h"

#include <algorithm>
#include <exception>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <string>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// OpenCV allocates rows x cols of a matrix node before it reads its data, so a file announcing a
// huge matrix would take all memory: the size is checked first (a camera's are 3x3 and at most
// 14 distortion coefficients).
void CheckMatrixSize(const cv::FileNode& node, const std::string& name, const char* field) {
  const cv::FileNode rows = node["rows"];
  const cv::FileNode cols = node["cols"];
  if (!node.isMap() || !rows.isInt() || !cols.isInt() || !node["sizes"].empty()) {
    ThrowError(name, ": ", field, " must be an OpenCV matrix with rows and cols");
  }
  const int r = static_cast<int>(rows);
  const int c = static_cast<int>(cols);
  if (r < 0 || c < 0 || r > 16 || c > 16 || r * c > 16) {
    ThrowError(name, ": ", field, " has ", r, "x", c, " elements, more than a camera file holds");
  }
}

}  // namespace

PinholeCamera ReadCameraFile(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) ThrowError(name, ": no such camera file");
  // A camera file is a few hundred bytes of text. OpenCV's parsers are not made for anything else
  // (binary content crashed its XML parser), so that is refused first.
  constexpr std::uintmax_t kMaxBytes = 1 << 20;
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error) ThrowError(name, ": cannot read the camera file: ", error.message());
  if (bytes > kMaxBytes) {
    ThrowError(name, ": ", bytes, " bytes is too large for a camera file (at most ", kMaxBytes,
               ")");
  }
  {
    std::ifstream stream(path, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(stream)),
                           std::istreambuf_iterator<char>());
    if (!stream.eof() && !stream) ThrowError(name, ": cannot read the camera file");
    if (text.find('\0') != std::string::npos) {
      ThrowError(name, ": a binary file, not an OpenCV YAML/XML/JSON camera file");
    }
  }
  cv::FileStorage storage;
  try {
    if (!storage.open(name, cv::FileStorage::READ)) {
      ThrowError(name, ": cannot read as an OpenCV YAML/XML/JSON camera file");
    }
  } catch (const Error&) {
    throw;
  } catch (const cv::Exception& exception) {
    ThrowError(name, ": not an OpenCV YAML/XML/JSON camera file (", exception.err, ")");
  } catch (const std::exception&) {  // OpenCV's parsers also let standard exceptions through
    ThrowError(name, ": not an OpenCV YAML/XML/JSON camera file");
  }
  cv::Mat matrix;
  cv::Mat distortion;
  int width = 0;
  int height = 0;
  try {
    if (storage["camera_matrix"].empty()) ThrowError(name, ": no camera_matrix");
    CheckMatrixSize(storage["camera_matrix"], name, "camera_matrix");
    storage["camera_matrix"] >> matrix;
    if (!storage["distortion_coefficients"].empty()) {
      CheckMatrixSize(storage["distortion_coefficients"], name, "distortion_coefficients");
      storage["distortion_coefficients"] >> distortion;
    }
    if (storage["image_width"].empty() || storage["image_height"].empty()) {
      ThrowError(name, ": no image_width/image_height");
    }
    if (!storage["image_width"].isInt() || !storage["image_height"].isInt()) {
      ThrowError(name, ": image_width and image_height must be whole numbers");
    }
    storage["image_width"] >> width;
    storage["image_height"] >> height;
  } catch (const Error&) {
    throw;
  } catch (const cv::Exception& exception) {
    ThrowError(name, ": malformed camera file (", exception.err, ")");
  } catch (const std::exception&) {
    ThrowError(name, ": malformed camera file");
  }
  if (matrix.rows != 3 || matrix.cols != 3 || matrix.channels() != 1) {
    ThrowError(name, ": camera_matrix must be a 3x3 matrix, got ", matrix.rows, "x", matrix.cols);
  }
  matrix.convertTo(matrix, CV_64F);
  PinholeCamera camera;
  camera.width_px = width;
  camera.height_px = height;
  camera.focal_x_px = matrix.at<double>(0, 0);
  camera.focal_y_px = matrix.at<double>(1, 1);
  camera.principal_x_px = matrix.at<double>(0, 2);
  camera.principal_y_px = matrix.at<double>(1, 2);
  auto near = [](double value, double target) { return std::abs(value - target) <= 1e-9; };
  if (!near(matrix.at<double>(0, 1), 0.0) || !near(matrix.at<double>(1, 0), 0.0) ||
      !near(matrix.at<double>(2, 0), 0.0) || !near(matrix.at<double>(2, 1), 0.0) ||
      !near(matrix.at<double>(2, 2), 1.0)) {
    ThrowError(name, ": camera_matrix must have the form [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (!distortion.empty()) {
    if (distortion.rows != 1 && distortion.cols != 1) {
      ThrowError(name, ": distortion_coefficients must be a vector");
    }
    distortion = distortion.reshape(1, 1);
    distortion.convertTo(distortion, CV_64F);
    for (int i = 0; i < distortion.cols; ++i) {
      const double k = distortion.at<double>(0, i);
      if (i < 5) {
        camera.distortion[static_cast<size_t>(i)] = k;
      } else if (k != 0.0) {
        ThrowError(name, ": distortion coefficient ", i + 1,
                   " is non-zero; only k1 k2 p1 p2 k3 are supported");
      }
    }
  }
  std::string problem;
  if (!camera.CheckCalibration(&problem)) ThrowError(name, ": invalid camera: ", problem);
  return camera;
}

void WriteCameraFile(const std::filesystem::path& path, const PinholeCamera& camera) {
  std::string problem;
  if (!camera.Check(&problem))
    ThrowError(path.string(), ": cannot write an invalid camera: ", problem);
  try {
    cv::FileStorage storage(path.string(), cv::FileStorage::WRITE);
    if (!storage.isOpened()) ThrowError(path.string(), ": cannot open for writing");
    storage << "image_width" << camera.width_px;
    storage << "image_height" << camera.height_px;
    const cv::Mat matrix = (cv::Mat_<double>(3, 3) << camera.focal_x_px, 0.0, camera.principal_x_px,
                            0.0, camera.focal_y_px, camera.principal_y_px, 0.0, 0.0, 1.0);
    storage << "camera_matrix" << matrix;
    cv::Mat distortion(1, 5, CV_64F);
    for (int i = 0; i < 5; ++i)
      distortion.at<double>(0, i) = camera.distortion[static_cast<size_t>(i)];
    storage << "distortion_coefficients" << distortion;
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot write camera file (", exception.err, ")");
  }
}

}  // namespace silpose
