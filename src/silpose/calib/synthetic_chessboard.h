#pragma once
// Synthetic chessboard images for testing calibration: a planar board seen by a known camera,
// lens distortion included, at a known pose. Each output pixel is mapped back through the camera
// model (undistortion, then the ray's intersection with the board plane) and the board's colour
// there is averaged over a grid of sub-pixel samples (anti-aliasing by supersampling).
//
// Board frame as in calibration.h: inner corner (i, j) (column i, row j) at (i, j, 0) *
// square_size; the board's squares cover [-1, board_cols] x [-1, board_rows] squares, with a white
// border around them. The square touching the first inner corner diagonally is dark.
//
// Header-only (OpenCV core, Eigen and the lens model of pose/lens_distortion.h), so that tests of
// other layers and of the command line can make calibration images without linking the calib
// layer.

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/pose/lens_distortion.h"

namespace silpose {

struct SyntheticChessboardOptions {
  /// Inner corners along a row and along a column (as CalibrationOptions).
  int board_cols = 9;
  int board_rows = 6;
  /// Side of one square, in the unit of the pose's translation.
  double square_size = 1.0;
  /// Width of the white border around the squares, in squares.
  double border_squares = 1.0;
  /// Sub-pixel samples per pixel along each axis (n * n samples per pixel).
  int supersampling = 3;
  uint8_t dark = 25;
  uint8_t light = 230;
  /// Grey level where a pixel's ray misses the board.
  uint8_t background = 120;
};

/// The board's inner corners in the board frame, row-major (board_cols per row).
inline std::vector<Eigen::Vector3d> ChessboardCornersInBoard(
    const SyntheticChessboardOptions& options) {
  std::vector<Eigen::Vector3d> corners;
  for (int j = 0; j < options.board_rows; ++j) {
    for (int i = 0; i < options.board_cols; ++i) {
      corners.emplace_back(i * options.square_size, j * options.square_size, 0.0);
    }
  }
  return corners;
}

/// Renders the board seen by `camera` with pose `camera_from_board` (x_in_camera = R x_in_board
/// + t) as an 8-bit grey image of the camera's size.
inline cv::Mat RenderSyntheticChessboard(const PinholeCamera& camera,
                                         const Rigid3& camera_from_board,
                                         const SyntheticChessboardOptions& options) {
  // A ray (x, y, 1) meets the plane z_board = 0 where (x, y, 1) ~ [r1 r2 t] (X, Y, 1).
  Eigen::Matrix3d plane_to_ray;
  plane_to_ray.col(0) = camera_from_board.rotation.col(0);
  plane_to_ray.col(1) = camera_from_board.rotation.col(1);
  plane_to_ray.col(2) = camera_from_board.translation;
  const Eigen::Matrix3d ray_to_plane = plane_to_ray.inverse();
  const double s = options.square_size;
  const double border = options.border_squares * s;
  const double min_x = -s - border;
  const double max_x = options.board_cols * s + border;
  const double min_y = -s - border;
  const double max_y = options.board_rows * s + border;
  const int n = options.supersampling < 1 ? 1 : options.supersampling;

  cv::Mat image(camera.height_px, camera.width_px, CV_8UC1);
  for (int v = 0; v < camera.height_px; ++v) {
    for (int u = 0; u < camera.width_px; ++u) {
      double sum = 0.0;
      for (int a = 0; a < n; ++a) {
        for (int b = 0; b < n; ++b) {
          const double su = u + (b + 0.5) / n - 0.5;
          const double sv = v + (a + 0.5) / n - 0.5;
          Eigen::Vector2d ray;
          if (!PixelToIdealNormalized(camera, {su, sv}, &ray)) {
            sum += options.background;  // beyond the lens model's valid range
            continue;
          }
          const Eigen::Vector3d plane = ray_to_plane * Eigen::Vector3d(ray.x(), ray.y(), 1.0);
          double level = options.background;
          if (plane.z() > 0.0) {  // in front of the camera
            const double x = plane.x() / plane.z();
            const double y = plane.y() / plane.z();
            if (x >= min_x && x < max_x && y >= min_y && y < max_y) {
              level = options.light;
              if (x >= -s && x < options.board_cols * s && y >= -s && y < options.board_rows * s) {
                const auto i = static_cast<int64_t>(std::floor(x / s));
                const auto j = static_cast<int64_t>(std::floor(y / s));
                if (((i + j) & 1) == 0) level = options.dark;
              }
            }
          }
          sum += level;
        }
      }
      image.at<uint8_t>(v, u) = static_cast<uint8_t>(std::lround(sum / (n * n)));
    }
  }
  return image;
}

}  // namespace silpose
