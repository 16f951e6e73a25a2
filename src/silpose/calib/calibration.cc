#include "silpose/calib/calibration.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "silpose/io/image_codec.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// Collects the detections image by image (so that files can be read one at a time), then fits.
class Calibrator {
 public:
  explicit Calibrator(const CalibrationOptions& options) : options_(options) {
    std::string problem;
    if (!options.Check(&problem)) ThrowError("invalid calibration options: ", problem);
  }

  void Add(const cv::Mat& image, const std::string& name) {
    if (image.empty()) ThrowError(name, ": empty image");
    if (image.depth() != CV_8U ||
        (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
      ThrowError(name, ": unsupported image type (need 8-bit grey, BGR or BGRA)");
    }
    if (views_.empty()) {
      size_ = image.size();
      first_name_ = name;
    } else if (image.size() != size_) {
      ThrowError(name, ": image size ", image.cols, "x", image.rows, " differs from ", first_name_,
                 " (", size_.width, "x", size_.height,
                 "); all images must come from the same "
                 "camera at the same resolution");
    }
    CalibrationView view;
    view.name = name;
    view.board_found = DetectChessboard(image, options_, &view.corners_px);
    views_.push_back(std::move(view));
  }

  CalibrationResult Finish() {
    if (views_.empty()) ThrowError("no images to calibrate from");
    std::vector<std::vector<cv::Point3f>> object_points;
    std::vector<std::vector<cv::Point2f>> image_points;
    std::vector<std::string> missing;
    const std::vector<cv::Point3f> board = BoardPoints();
    for (const CalibrationView& view : views_) {
      if (view.board_found) {
        object_points.push_back(board);
        image_points.push_back(view.corners_px);
      } else {
        missing.push_back(view.name);
      }
    }
    if (static_cast<int>(image_points.size()) < options_.min_boards) {
      std::ostringstream message;
      message << "found the " << options_.board_cols << "x" << options_.board_rows
              << " chessboard in only " << image_points.size() << " of " << views_.size()
              << " images (need at least " << options_.min_boards << "); not found in: ";
      for (size_t i = 0; i < missing.size(); ++i) {
        if (i == 8 && missing.size() > 10) {
          message << ", ... (" << missing.size() - i << " more)";
          break;
        }
        message << (i > 0 ? ", " : "") << missing[i];
      }
      message << " (a board size counts inner corners: squares minus one along each side)";
      throw Error(message.str());
    }

    int flags = 0;
    if (options_.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
    if (options_.zero_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
    if (!options_.estimate_k3) flags |= cv::CALIB_FIX_K3;
    // With CALIB_FIX_ASPECT_RATIO OpenCV keeps fx / fy of the initial matrix: start from square
    // pixels.
    cv::Mat camera_matrix(3, 3, CV_64F, cv::Scalar(0));
    camera_matrix.diag().setTo(cv::Scalar(1));
    cv::Mat distortion(1, 5, CV_64F, cv::Scalar(0));
    std::vector<cv::Mat> rotations;
    std::vector<cv::Mat> translations;
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12);
    CalibrationResult result;
    result.rms_error_px = cv::calibrateCamera(object_points, image_points, size_, camera_matrix,
                                              distortion, rotations, translations, flags, criteria);

    PinholeCamera& camera = result.camera;
    camera.width_px = size_.width;
    camera.height_px = size_.height;
    camera.focal_x_px = camera_matrix.at<double>(0, 0);
    camera.focal_y_px = camera_matrix.at<double>(1, 1);
    camera.principal_x_px = camera_matrix.at<double>(0, 2);
    camera.principal_y_px = camera_matrix.at<double>(1, 2);
    distortion = distortion.reshape(1, 1);
    for (int i = 0; i < 5 && i < distortion.cols; ++i) {
      camera.distortion[static_cast<size_t>(i)] = distortion.at<double>(0, i);
    }

    size_t used = 0;
    for (CalibrationView& view : views_) {
      if (!view.board_found) continue;
      std::vector<cv::Point2f> projected;
      cv::projectPoints(board, rotations[used], translations[used], camera_matrix, distortion,
                        projected);
      double sum_squares = 0.0;
      for (size_t k = 0; k < projected.size(); ++k) {
        const cv::Point2f d = projected[k] - view.corners_px[k];
        sum_squares += static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y;
      }
      view.rms_error_px = std::sqrt(sum_squares / static_cast<double>(projected.size()));
      cv::Mat rotation;
      cv::Rodrigues(rotations[used], rotation);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
          view.camera_from_board.rotation(r, c) = rotation.at<double>(r, c);
        view.camera_from_board.translation(r) = translations[used].at<double>(r);
      }
      ++used;
    }
    result.views = std::move(views_);
    return result;
  }

 private:
  std::vector<cv::Point3f> BoardPoints() const {
    std::vector<cv::Point3f> points;
    for (int j = 0; j < options_.board_rows; ++j) {
      for (int i = 0; i < options_.board_cols; ++i) {
        points.emplace_back(static_cast<float>(i * options_.square_size),
                            static_cast<float>(j * options_.square_size), 0.0f);
      }
    }
    return points;
  }

  CalibrationOptions options_;
  cv::Size size_;
  std::string first_name_;
  std::vector<CalibrationView> views_;
};

}  // namespace

bool CalibrationOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (board_cols < 2 || board_rows < 2) {
    return fail("the board needs at least 2x2 inner corners, got " + std::to_string(board_cols) +
                "x" + std::to_string(board_rows));
  }
  if (board_cols > 1000 || board_rows > 1000)
    return fail("the board has more than 1000 corners per side");
  if (!std::isfinite(square_size) || !(square_size > 0.0)) {
    return fail("the square size must be positive and finite");
  }
  if (subpixel_half_window_px < 0 || subpixel_half_window_px > 100) {
    return fail("the sub-pixel half window must be in [0, 100] pixels");
  }
  if (min_boards < 3) return fail("at least 3 boards are needed (min_boards >= 3)");
  return true;
}

int CalibrationResult::NumBoardsFound() const {
  int count = 0;
  for (const CalibrationView& view : views) count += view.board_found ? 1 : 0;
  return count;
}

bool DetectChessboard(const cv::Mat& image, const CalibrationOptions& options,
                      std::vector<cv::Point2f>* corners_px) {
  SILPOSE_ASSERT(corners_px != nullptr);
  corners_px->clear();
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = image;
  }
  const cv::Size pattern(options.board_cols, options.board_rows);
  bool found = false;
  if (options.sector_based_detector) {
    found = cv::findChessboardCornersSB(
        grey, pattern, *corners_px,
        cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
  } else {
    found = cv::findChessboardCorners(grey, pattern, *corners_px,
                                      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (found && options.subpixel_half_window_px > 0) {
      const int half = options.subpixel_half_window_px;
      cv::cornerSubPix(grey, *corners_px, cv::Size(half, half), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-4));
    }
  }
  if (!found || corners_px->size() != static_cast<size_t>(pattern.area())) {
    corners_px->clear();
    return false;
  }
  return true;
}

CalibrationResult CalibrateCamera(const std::vector<std::filesystem::path>& image_paths,
                                  const CalibrationOptions& options) {
  Calibrator calibrator(options);
  for (const std::filesystem::path& path : image_paths) {
    const std::string name = path.string();
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) ThrowError(name, ": no such image file");
    cv::Mat image;
    try {
      image = ReadImage(name, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception& exception) {
      ThrowError(name, ": cannot read image (", exception.msg, ")");
    }
    if (image.empty()) ThrowError(name, ": cannot read as an image");
    calibrator.Add(image, name);
  }
  return calibrator.Finish();
}

CalibrationResult CalibrateCamera(const std::vector<cv::Mat>& images,
                                  const CalibrationOptions& options,
                                  const std::vector<std::string>& names) {
  if (!names.empty() && names.size() != images.size()) {
    ThrowError("CalibrateCamera: ", names.size(), " names for ", images.size(), " images");
  }
  Calibrator calibrator(options);
  for (size_t i = 0; i < images.size(); ++i) {
    calibrator.Add(images[i], names.empty() ? "image " + std::to_string(i) : names[i]);
  }
  return calibrator.Finish();
}

}  // namespace silpose
