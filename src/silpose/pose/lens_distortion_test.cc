#include "silpose/pose/lens_distortion.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <vector>

namespace silpose {
namespace {

PinholeCamera DistortedCamera() {
  PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.0);
  camera.focal_y_px = 522.0;
  camera.distortion = {-0.28, 0.11, 0.001, -0.0015, -0.02};
  return camera;
}

TEST(LensDistortion, JacobianMatchesFiniteDifferences) {
  const std::array<double, 5> k = DistortedCamera().distortion;
  for (const Eigen::Vector2d& point : {Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(-0.5, 0.35)}) {
    Eigen::Matrix2d jacobian;
    DistortNormalized(k, point, &jacobian);
    const double h = 1e-6;
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      step[i] = h;
      const Eigen::Vector2d numeric =
          (DistortNormalized(k, point + step) - DistortNormalized(k, point - step)) / (2 * h);
      EXPECT_TRUE(jacobian.col(i).isApprox(numeric, 1e-7)) << jacobian << "\n" << numeric;
    }
  }
}

TEST(LensDistortion, UndistortInvertsDistortAndAgreesWithOpenCV) {
  const PinholeCamera camera = DistortedCamera();
  const cv::Matx33d matrix(camera.focal_x_px, 0, camera.principal_x_px, 0, camera.focal_y_px,
                           camera.principal_y_px, 0, 0, 1);
  const std::vector<double> coefficients(camera.distortion.begin(), camera.distortion.end());
  // OpenCV's own projection with distortion, then both undistortions.
  std::vector<cv::Point3d> points;
  for (double x = -0.6; x <= 0.6; x += 0.2) {
    for (double y = -0.45; y <= 0.45; y += 0.15) points.emplace_back(x, y, 1.0);
  }
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), matrix, coefficients, pixels);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d ours =
        ProjectDistorted(camera, Eigen::Vector3d(points[i].x, points[i].y, 1.0));
    EXPECT_NEAR(ours.x(), pixels[i].x, 1e-9);
    EXPECT_NEAR(ours.y(), pixels[i].y, 1e-9);
    Eigen::Vector2d ideal;
    ASSERT_TRUE(PixelToIdealNormalized(camera, Eigen::Vector2d(pixels[i].x, pixels[i].y), &ideal));
    EXPECT_NEAR(ideal.x(), points[i].x, 1e-10);
    EXPECT_NEAR(ideal.y(), points[i].y, 1e-10);
  }
  // cv::undistortPoints iterates a fixed number of times; ours converges to 1e-12.
  std::vector<cv::Point2d> opencv_ideal;
  cv::undistortPoints(
      pixels, opencv_ideal, matrix, coefficients, cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(opencv_ideal[i].x, points[i].x, 1e-6);
    EXPECT_NEAR(opencv_ideal[i].y, points[i].y, 1e-6);
  }
}

TEST(LensDistortion, NoDistortionIsIdentityAndFoldsAreReported) {
  PinholeCamera camera = PinholeCamera::Centered(100, 100, 80.0);
  EXPECT_FALSE(HasDistortion(camera));
  Eigen::Vector2d ideal;
  ASSERT_TRUE(PixelToIdealNormalized(camera, Eigen::Vector2d(89.5, 9.5), &ideal));
  EXPECT_NEAR(ideal.x(), 0.5, 1e-15);
  EXPECT_NEAR(ideal.y(), -0.5, 1e-15);
  // Strong barrel distortion folds over beyond r^2 = 1 / (3 |k1|): no inverse far out.
  camera.distortion = {-0.5, 0, 0, 0, 0};
  EXPECT_TRUE(HasDistortion(camera));
  EXPECT_FALSE(UndistortNormalized(camera.distortion, Eigen::Vector2d(1.0, 0.0), &ideal));
}

}  // namespace
}  // namespace silpose
