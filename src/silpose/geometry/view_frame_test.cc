#include "silpose/geometry/view_frame.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace silpose {
namespace {

Eigen::Vector3d RandomDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

TEST(ViewFrame, RotationIsProperAndLooksAtTheCentre) {
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d d = RandomDirection(rng);
    const double roll = std::uniform_real_distribution<double>(-180, 180)(rng);
    const Eigen::Matrix3d r = CameraFromObjectRotation(d, roll);
    EXPECT_NEAR((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    const Rigid3 pose = CameraFromObjectAtView(d, roll, 5.0, Eigen::Vector3d(1, 2, 3));
    const Eigen::Vector3d centre_in_camera = pose * Eigen::Vector3d(1, 2, 3);
    EXPECT_NEAR(centre_in_camera.x(), 0.0, 1e-12);
    EXPECT_NEAR(centre_in_camera.y(), 0.0, 1e-12);
    EXPECT_NEAR(centre_in_camera.z(), 5.0, 1e-12);
  }
}

TEST(ViewFrame, ModelUpAxisPointsUpInTheImageAtRollZero) {
  const Eigen::Matrix3d r = CameraFromObjectRotation(Eigen::Vector3d(1, 0, 0), 0.0);
  // +Z of the model maps to image -y (up on screen).
  EXPECT_NEAR((r * Eigen::Vector3d::UnitZ() - Eigen::Vector3d(0, -1, 0)).norm(), 0.0, 1e-12);
}

TEST(ViewFrame, PositiveRollTurnsImageXTowardsImageY) {
  // A point on the reference image x axis appears at image angle -roll after rolling.
  const Eigen::Vector3d d(0, -1, 0);
  const Eigen::Matrix3d r0 = CameraFromObjectRotation(d, 0.0);
  const Eigen::Vector3d point_in_object = r0.transpose() * Eigen::Vector3d(1, 0, 0);
  const Eigen::Vector3d rolled = CameraFromObjectRotation(d, 30.0) * point_in_object;
  EXPECT_NEAR(std::atan2(rolled.y(), rolled.x()) * 180.0 / M_PI, -30.0, 1e-9);
}

TEST(ViewFrame, ViewAndRollRoundTrip) {
  std::mt19937 rng(11);
  for (int i = 0; i < 200; ++i) {
    Eigen::Vector3d d = RandomDirection(rng);
    if (i == 0) d = Eigen::Vector3d::UnitZ();  // the pole uses the fallback reference
    const double roll = std::uniform_real_distribution<double>(-179, 179)(rng);
    Eigen::Vector3d d_out;
    double roll_out = 0.0;
    ViewAndRollFromRotation(CameraFromObjectRotation(d, roll), &d_out, &roll_out);
    EXPECT_NEAR((d - d_out).norm(), 0.0, 1e-9);
    EXPECT_NEAR(WrapDegrees(roll - roll_out), 0.0, 1e-9);
  }
}

TEST(ViewFrame, TransportRollIsIdentityForTheSameViewAndSmoothAwayFromPoles) {
  const Eigen::Vector3d a = Eigen::Vector3d(1, 0.2, 0.1).normalized();
  EXPECT_NEAR(WrapDegrees(TransportRoll(a, 42.0, a) - 42.0), 0.0, 1e-9);
  // Moving along the equator keeps the model's up axis up: the roll is unchanged.
  const Eigen::Vector3d e1(1, 0, 0);
  const Eigen::Vector3d e2(std::cos(0.1), std::sin(0.1), 0);
  EXPECT_NEAR(WrapDegrees(TransportRoll(e1, 10.0, e2) - 10.0), 0.0, 1e-9);
}

TEST(ViewFrame, WrapDegrees) {
  EXPECT_DOUBLE_EQ(WrapDegrees(190.0), -170.0);
  EXPECT_DOUBLE_EQ(WrapDegrees(-180.0), 180.0);
  EXPECT_DOUBLE_EQ(WrapDegrees(720.0 + 5.0), 5.0);
}

}  // namespace
}  // namespace silpose
