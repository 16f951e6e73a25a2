#include "silpose/eval/bop_pose_error.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The 8 corners and the 12 edge midpoints of a box 80 x 50 x 30 centred at the origin.
Eigen::Matrix3Xd BoxPoints() {
  std::vector<Eigen::Vector3d> points;
  for (double x : {-40.0, 0.0, 40.0}) {
    for (double y : {-25.0, 0.0, 25.0}) {
      for (double z : {-15.0, 0.0, 15.0}) {
        const int zeros = (x == 0.0) + (y == 0.0) + (z == 0.0);
        if (zeros <= 1) points.emplace_back(x, y, z);
      }
    }
  }
  Eigen::Matrix3Xd matrix(3, static_cast<Eigen::Index>(points.size()));
  for (size_t i = 0; i < points.size(); ++i) matrix.col(static_cast<Eigen::Index>(i)) = points[i];
  return matrix;
}

std::vector<Rigid3> BoxSymmetries() {
  std::vector<Rigid3> discrete;
  for (int axis = 0; axis < 3; ++axis) {
    discrete.push_back(
        {Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::Unit(axis)).toRotationMatrix(),
         Eigen::Vector3d::Zero()});
  }
  return discrete;
}

Rigid3 SomePose() {
  Rigid3 pose;
  pose.rotation = (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()) *
                   Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY()))
                      .toRotationMatrix();
  pose.translation = Eigen::Vector3d(30.0, -20.0, 600.0);
  return pose;
}

PinholeCamera Camera() {
  PinholeCamera camera;
  camera.width_px = 640;
  camera.height_px = 480;
  camera.focal_x_px = camera.focal_y_px = 600.0;
  camera.principal_x_px = 320.0;
  camera.principal_y_px = 240.0;
  return camera;
}

TEST(BopPoseError, TruthItselfHasNoError) {
  const Eigen::Matrix3Xd points = BoxPoints();
  const NearestPointIndex index(points);
  const std::vector<Rigid3> symmetries = SymmetryTransforms(BoxSymmetries(), {});
  const Rigid3 pose = SomePose();
  EXPECT_NEAR(AddError(points, pose, pose), 0.0, 1e-12);
  EXPECT_NEAR(AddSError(points, index, pose, pose), 0.0, 1e-12);
  EXPECT_NEAR(MssdError(points, pose, pose, symmetries), 0.0, 1e-12);
  EXPECT_NEAR(MspdError(points, pose, pose, symmetries, Camera()), 0.0, 1e-9);
}

TEST(BopPoseError, TranslationOffsetGivesItsLength) {
  const Eigen::Matrix3Xd points = BoxPoints();
  const NearestPointIndex index(points);
  const Rigid3 truth = SomePose();
  Rigid3 estimate = truth;
  estimate.translation += Eigen::Vector3d(3.0, 0.0, 4.0);  // 5 mm
  EXPECT_NEAR(AddError(points, estimate, truth), 5.0, 1e-9);
  // Without symmetries the MSSD of a pure shift is the shift too.
  EXPECT_NEAR(MssdError(points, estimate, truth, {}), 5.0, 1e-9);
  // ADD-S cannot exceed ADD.
  EXPECT_LE(AddSError(points, index, estimate, truth), 5.0 + 1e-9);
  // A shift along x of 6 mm at depth z moves every projected point by about f 6 / z pixels.
  Rigid3 sideways = truth;
  sideways.translation.x() += 6.0;
  const double mspd = MspdError(points, sideways, truth, {}, Camera());
  EXPECT_GT(mspd, 600.0 * 6.0 / (600.0 + 60.0));
  EXPECT_LT(mspd, 600.0 * 6.0 / (600.0 - 60.0));
}

TEST(BopPoseError, SymmetricTurnCostsAddButNotMssd) {
  const Eigen::Matrix3Xd points = BoxPoints();
  const NearestPointIndex index(points);
  const std::vector<Rigid3> symmetries = SymmetryTransforms(BoxSymmetries(), {});
  ASSERT_EQ(symmetries.size(), 4u);
  const Rigid3 truth = SomePose();
  // The estimate is the truth turned by the box's half turn about its z axis.
  const Rigid3 estimate = truth * BoxSymmetries()[2];
  EXPECT_GT(AddError(points, estimate, truth), 30.0);
  EXPECT_NEAR(AddSError(points, index, estimate, truth), 0.0, 1e-9);
  EXPECT_NEAR(MssdError(points, estimate, truth, symmetries), 0.0, 1e-9);
  EXPECT_NEAR(MspdError(points, estimate, truth, symmetries, Camera()), 0.0, 1e-6);
  // Without the symmetries MSSD sees the turn: the corners move by 2 * sqrt(40^2 + 25^2).
  EXPECT_NEAR(MssdError(points, estimate, truth, {}), 2.0 * std::hypot(40.0, 25.0), 1e-9);
}

TEST(BopPoseError, ContinuousSymmetryIsSampledFinely) {
  // Points on two rings about the z axis through (0, 0, 10): a cylinder of radius 50.
  Eigen::Matrix3Xd points(3, 72);
  for (int i = 0; i < 36; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 36.0;
    points.col(i) = Eigen::Vector3d(50.0 * std::cos(a), 50.0 * std::sin(a), 0.0);
    points.col(36 + i) = Eigen::Vector3d(50.0 * std::cos(a), 50.0 * std::sin(a), 20.0);
  }
  const ContinuousSymmetry axis{.axis = Eigen::Vector3d(0.0, 0.0, 2.0),
                                .offset = Eigen::Vector3d(0.0, 0.0, 10.0)};
  const std::vector<Rigid3> symmetries = SymmetryTransforms({}, std::span(&axis, 1), 0.01);
  EXPECT_EQ(symmetries.size(), 315u);  // ceil(pi / 0.01)
  const Rigid3 truth = SomePose();
  Rigid3 turn;
  turn.rotation = Eigen::AngleAxisd(0.123, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Rigid3 estimate = truth * turn;
  EXPECT_GT(AddError(points, estimate, truth), 5.0);
  // Diameter ~ 104: consecutive samples are at most 1 % of it apart.
  EXPECT_LT(MssdError(points, estimate, truth, symmetries), 0.01 * 104.0);
  // Each symmetry maps the cylinder onto itself.
  for (const Rigid3& s : symmetries) {
    EXPECT_NEAR((s * Eigen::Vector3d(0.0, 0.0, 10.0) - Eigen::Vector3d(0.0, 0.0, 10.0)).norm(), 0.0,
                1e-9);
  }
  // Discrete and continuous combine.
  EXPECT_EQ(SymmetryTransforms(BoxSymmetries(), std::span(&axis, 1), 0.01).size(), 4u * 315u);
  const ContinuousSymmetry zero{.axis = Eigen::Vector3d::Zero()};
  EXPECT_THROW(SymmetryTransforms({}, std::span(&zero, 1)), Error);
  EXPECT_THROW(SymmetryTransforms({}, {}, 0.0), Error);
}

TEST(BopPoseError, NearestPointIndexAgreesWithBruteForce) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-100.0, 100.0);
  Eigen::Matrix3Xd points(3, 1000);
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    points.col(i) = Eigen::Vector3d(uniform(random), uniform(random), 0.1 * uniform(random));
  const NearestPointIndex index(points);
  EXPECT_EQ(index.size(), 1000);
  for (int q = 0; q < 200; ++q) {
    const Eigen::Vector3d query(uniform(random), uniform(random), uniform(random));
    const double brute = (points.colwise() - query).colwise().norm().minCoeff();
    EXPECT_DOUBLE_EQ(index.NearestDistance(query), brute);
  }
  EXPECT_THROW(NearestPointIndex(Eigen::Matrix3Xd(3, 0)), Error);
}

TEST(BopPoseError, ThresholdsAndRecall) {
  const std::vector<double> mssd = MssdThresholds(200.0);
  ASSERT_EQ(mssd.size(), 10u);
  EXPECT_DOUBLE_EQ(mssd.front(), 10.0);
  EXPECT_DOUBLE_EQ(mssd.back(), 100.0);
  const std::vector<double> mspd = MspdThresholds(640);
  EXPECT_DOUBLE_EQ(mspd.front(), 5.0);
  EXPECT_DOUBLE_EQ(mspd.back(), 50.0);
  EXPECT_DOUBLE_EQ(MspdThresholds(1280).back(), 25.0);

  const std::vector<double> errors = {1.0, 12.0, 30.0, kInf,
                                      std::numeric_limits<double>::quiet_NaN()};
  EXPECT_DOUBLE_EQ(Recall(errors, 12.0), 0.2);  // strictly below
  EXPECT_DOUBLE_EQ(Recall(errors, 12.5), 0.4);
  EXPECT_DOUBLE_EQ(Recall(errors, 1e300), 0.6);  // misses never count
  EXPECT_DOUBLE_EQ(Recall({}, 1.0), 0.0);
  const std::vector<double> thresholds = {5.0, 20.0};
  EXPECT_DOUBLE_EQ(AverageRecall(errors, thresholds), (0.2 + 0.4) / 2.0);
  EXPECT_THROW(AverageRecall(errors, {}), Error);
}

}  // namespace
}  // namespace silpose
