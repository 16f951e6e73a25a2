#pragma once
// Camera calibration from images of a planar chessboard (Zhang's method, as implemented by
// OpenCV's calib3d): the board's inner corners are detected in each image, refined to sub-pixel
// accuracy, and cv::calibrateCamera fits the pinhole intrinsics and the distortion coefficients
// (k1 k2 p1 p2 [k3]) together with one board pose per image.
//
// Board frame: origin at the first inner corner, x along a row of inner corners, y along a
// column, z = 0 on the board; inner corner (i, j) (column i, row j) is at (i, j, 0) * square_size.
// The camera matrix is in pixels and does not depend on the square size; board poses are in the
// unit of `square_size` (say millimetres if the squares are given in millimetres).
//
// Pixel convention as in PinholeCamera: pixel centres at integer coordinates.

#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"

namespace silpose {

struct CalibrationOptions {
  /// Inner corners of the board (where four squares meet): along a row, and along a column.
  /// A board of 10 x 7 squares has 9 x 6 inner corners. Both must be >= 2.
  int board_cols = 9;
  int board_rows = 6;
  /// Side of one square, in any unit (> 0); the board poses come out in this unit.
  double square_size = 1.0;
  /// Keep fx / fy at 1 (square pixels) instead of fitting both focal lengths.
  bool fix_aspect_ratio = false;
  /// Fit no tangential distortion (p1 = p2 = 0).
  bool zero_tangential = false;
  /// Also fit the sixth-order radial coefficient k3 (off by default: with few or narrow views it
  /// tends to over-fit; turn it on for wide-angle lenses).
  bool estimate_k3 = false;
  /// Half side of the cv::cornerSubPix search window, pixels (window = 2 * n + 1). 0 = no
  /// sub-pixel refinement. Keep it below half a square's size in the images.
  int subpixel_half_window_px = 5;
  /// Use cv::findChessboardCornersSB (sector-based, sub-pixel accurate on its own, more robust to
  /// blur and noise, slower) instead of cv::findChessboardCorners + cv::cornerSubPix.
  bool sector_based_detector = false;
  /// Fewest images with a detected board for a calibration (>= 3 as Zhang's method needs; 10-20
  /// varied views are advisable for a good one).
  int min_boards = 3;

  /// True if the options are usable; otherwise `error` says which one is wrong.
  bool Check(std::string* error = nullptr) const;
};

/// One input image: whether its board was found and, if so, how well the calibrated camera
/// reproduces its corners.
struct CalibrationView {
  /// The image's file path, or the name given with an in-memory image.
  std::string name;
  bool board_found = false;
  /// Detected inner corners, pixels, in the board's row-major order (board_cols per row); empty
  /// if not found.
  std::vector<cv::Point2f> corners_px;
  /// Root-mean-square distance between the detected corners and the corners projected with the
  /// calibrated camera and this view's pose, pixels. NaN if the board was not found.
  double rms_error_px = std::numeric_limits<double>::quiet_NaN();
  /// Board pose: x_in_camera = R * x_in_board + t, t in the unit of square_size. Identity if the
  /// board was not found. OpenCV may number a board's corners from either end, so the origin can
  /// be the last inner corner instead of the first (the pose is then turned 180 deg in-plane).
  Rigid3 camera_from_board;
};

struct CalibrationResult {
  /// The fitted camera: image size, focal lengths and principal point in pixels, distortion
  /// (k1 k2 p1 p2 k3) for normalized image coordinates.
  PinholeCamera camera;
  /// Root-mean-square reprojection error over all corners of all boards used, pixels. Well under
  /// 1 pixel for a good calibration.
  double rms_error_px = 0.0;
  /// One entry per input image, in input order.
  std::vector<CalibrationView> views;

  int NumBoardsFound() const;
};

/// Calibrates from image files (any format cv::imread reads; colour is converted to grey). The
/// images are read one at a time. Throws silpose::Error for invalid options, no images, an
/// unreadable image (named), images of different sizes (both named, with their sizes), or fewer
/// than options.min_boards boards found (the images without one are named).
CalibrationResult CalibrateCamera(const std::vector<std::filesystem::path>& image_paths,
                                  const CalibrationOptions& options);

/// Calibrates from images in memory (8-bit, 1, 3 (BGR) or 4 (BGRA) channels). `names` (one per
/// image, or empty for "image 0", "image 1", ...) are used in CalibrationView::name and in error
/// messages. Throws silpose::Error as the overload above, and for an empty or unsupported image.
CalibrationResult CalibrateCamera(const std::vector<cv::Mat>& images,
                                  const CalibrationOptions& options,
                                  const std::vector<std::string>& names = {});

/// Detects the board's inner corners in one 8-bit image with the detector and refinement chosen in
/// `options`. Returns false (and clears `corners_px`) if the whole board is not found.
bool DetectChessboard(const cv::Mat& image, const CalibrationOptions& options,
                      std::vector<cv::Point2f>* corners_px);

}  // namespace silpose
