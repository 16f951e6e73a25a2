#include "silpose/pose/pose_error.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

TEST(PoseError, RotationErrorIsTheRelativeAngle) {
  const Eigen::Matrix3d a = CameraFromObjectRotation(Eigen::Vector3d(1, 2, 3), 40.0);
  for (double angle_deg : {0.0, 1e-5, 0.5, 30.0, 179.0}) {
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(angle_deg * M_PI / 180.0, Eigen::Vector3d(1, -1, 2).normalized())
            .toRotationMatrix();
    EXPECT_NEAR(RotationErrorDeg(a, a * turn), angle_deg, 1e-9);
    EXPECT_NEAR(RotationErrorDeg(turn * a, a), angle_deg, 1e-9);
  }
}

TEST(PoseError, TranslationAndViewDirection) {
  const Eigen::Vector3d centre(0.1, -0.2, 0.3);
  const Rigid3 truth = CameraFromObjectAtView(Eigen::Vector3d(0, 0, 1), 0.0, 4.0, centre);
  EXPECT_TRUE(ViewDirectionOfPose(truth, centre).isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  Rigid3 shifted = truth;
  shifted.translation += Eigen::Vector3d(0.3, 0.0, 0.4);
  PoseError error = ComputePoseError(shifted, truth, centre);
  EXPECT_NEAR(error.translation, 0.5, 1e-12);
  EXPECT_NEAR(error.translation_relative, 0.5 / truth.translation.norm(), 1e-12);
  EXPECT_NEAR(error.rotation_deg, 0.0, 1e-9);
  // The opposite view: distance 2 on the unit sphere.
  const Rigid3 opposite = CameraFromObjectAtView(Eigen::Vector3d(0, 0, -1), 0.0, 4.0, centre);
  error = ComputePoseError(opposite, truth, centre);
  EXPECT_NEAR(error.view_direction, 2.0, 1e-12);
  EXPECT_NEAR(ViewDirectionError(Eigen::Vector3d(2, 0, 0), Eigen::Vector3d(0, 3, 0)),
              std::sqrt(2.0), 1e-12);
}

TEST(PoseError, SummaryAndPercentiles) {
  const std::vector<double> values = {5, 1, 4, 2, 3, std::nan(""), INFINITY};
  const ErrorSummary summary = Summarize(values);
  EXPECT_EQ(summary.count, 5);
  EXPECT_EQ(summary.non_finite, 2);
  EXPECT_DOUBLE_EQ(summary.mean, 3.0);
  EXPECT_DOUBLE_EQ(summary.median, 3.0);
  EXPECT_DOUBLE_EQ(summary.min, 1.0);
  EXPECT_DOUBLE_EQ(summary.max, 5.0);
  EXPECT_DOUBLE_EQ(summary.percentile_90, 4.6);
  EXPECT_DOUBLE_EQ(Percentile(values, 25.0), 2.0);
  EXPECT_DOUBLE_EQ(Percentile(std::vector<double>{1.0, 2.0}, 50.0), 1.5);
  EXPECT_TRUE(std::isnan(Percentile(std::vector<double>{}, 50.0)));
  EXPECT_THROW(Percentile(values, 101.0), Error);
  EXPECT_EQ(Summarize(std::vector<double>{}).count, 0);
  EXPECT_EQ(Summarize(std::vector<double>{}).Describe(), "n=0");
}

}  // namespace
}  // namespace silpose
