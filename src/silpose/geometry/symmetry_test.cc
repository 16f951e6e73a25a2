#include "silpose/geometry/symmetry.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>

#include "silpose/geometry/view_frame.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

Rigid3 Turn(const Eigen::Vector3d& axis, double angle, const Eigen::Vector3d& through) {
  Rigid3 s;
  s.rotation = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  s.translation = through - s.rotation * through;
  return s;
}

Eigen::Matrix3d RandomRotation(std::mt19937* rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(*rng), normal(*rng), normal(*rng), normal(*rng));
  return q.normalized().toRotationMatrix();
}

ObjectSymmetry Bearing() {
  // Continuous about y through (0, 1, 0), with a flip about x.
  ObjectSymmetry s;
  s.continuous.push_back({.axis = Eigen::Vector3d::UnitY(), .offset = Eigen::Vector3d(0, 1, 0)});
  s.discrete.push_back(Turn(Eigen::Vector3d::UnitX(), kPi, Eigen::Vector3d(0, 1, 0)));
  return s;
}

ObjectSymmetry HexBolt() {
  ObjectSymmetry s;
  for (int k = 1; k < 6; ++k)
    s.discrete.push_back(Turn(Eigen::Vector3d::UnitZ(), kPi * k / 3.0, Eigen::Vector3d::Zero()));
  return s;
}

TEST(Symmetry, ErrorsModuloSymmetryIgnoreTheSymmetryAndOnlyIt) {
  std::mt19937 rng(3);
  const ObjectSymmetry bolt = HexBolt();
  const std::vector<Rigid3> transforms = SymmetryTransforms(bolt);
  ASSERT_EQ(transforms.size(), 6u);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d truth = RandomRotation(&rng);
    // An estimate off by a symmetry and 4 degrees about another axis.
    const Eigen::Matrix3d small =
        Eigen::AngleAxisd(4.0 * kPi / 180.0, Eigen::Vector3d(1, 1, 0).normalized())
            .toRotationMatrix();
    const Eigen::Matrix3d estimated =
        small * truth * transforms[static_cast<size_t>(1 + trial % 5)].rotation.transpose();
    EXPECT_NEAR(RotationErrorModuloSymmetryDeg(estimated, truth, transforms), 4.0, 1e-6);
    EXPECT_GT(RotationErrorModuloSymmetryDeg(estimated, truth, {}), 50.0);
  }
  // The view error: a view turned by 120 degrees about the bolt's axis is the same view.
  const Eigen::Vector3d view = Eigen::Vector3d(0.6, 0.0, 0.8);
  const Eigen::Vector3d turned = transforms[2].rotation * view;
  EXPECT_NEAR(ViewErrorModuloSymmetry(turned, view, transforms), 0.0, 1e-9);
  EXPECT_GT(ViewErrorModuloSymmetry(turned, view, {}), 0.9);
  // A view turned by 30 degrees is not.
  const Eigen::Vector3d off =
      Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * view;
  EXPECT_NEAR(ViewErrorModuloSymmetry(off, view, transforms), (off - view).norm(), 1e-9);
}

TEST(Symmetry, ContinuousSamplingBoundsTheError) {
  const std::vector<Rigid3> transforms = SymmetryTransforms(Bearing(), 0.01);
  // ceil(pi / 0.01) = 315 samples per turn, times the identity and the flip.
  EXPECT_EQ(transforms.size(), 630u);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * kPi);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d truth = RandomRotation(&rng);
    const Eigen::Matrix3d estimated =
        truth * Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitY()).toRotationMatrix();
    // Half a step of 360 / 315 degrees at most.
    EXPECT_LT(RotationErrorModuloSymmetryDeg(estimated, truth, transforms), 0.58);
  }
}

TEST(Symmetry, CanonicalPosesAgreeForEquivalentPosesAndLookTheSame) {
  std::mt19937 rng(11);
  for (const ObjectSymmetry& symmetry : {Bearing(), HexBolt()}) {
    const std::vector<Rigid3> transforms = SymmetryTransforms(symmetry, 0.002);
    for (int trial = 0; trial < 30; ++trial) {
      const Eigen::Vector3d view = Eigen::Vector3d::Random().normalized();
      const Rigid3 pose =
          CameraFromObjectAtView(view, 37.0 * trial, 5.0, Eigen::Vector3d(0.0, 1.0, 0.0));
      const Rigid3 s = CanonicalSymmetry(view, symmetry);
      const Rigid3 canonical = pose * s;
      // The canonical pose is equivalent: S is one of the object's symmetries (up to sampling).
      double nearest = 1e9;
      for (const Rigid3& t : transforms) {
        nearest = std::min(
            nearest, (t.rotation - s.rotation).norm() + (t.translation - s.translation).norm());
      }
      EXPECT_LT(nearest, 0.02);
      // An equivalent pose (a random symmetry applied) has the same canonical form.
      const Rigid3& other = transforms[rng() % transforms.size()];
      const Rigid3 equivalent = pose * other;
      const Eigen::Vector3d equivalent_view = other.rotation.transpose() * view;
      const Rigid3 canonical_again = equivalent * CanonicalSymmetry(equivalent_view, symmetry);
      EXPECT_LT((canonical_again.rotation - canonical.rotation).norm(), 1e-6);
      EXPECT_LT((canonical_again.translation - canonical.translation).norm(), 1e-6);
    }
  }
  // No symmetry: the identity.
  const Rigid3 none = CanonicalSymmetry(Eigen::Vector3d(1, 2, 3), ObjectSymmetry());
  EXPECT_TRUE(none.rotation.isIdentity());
}

double AngleDegBetween(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(Eigen::Matrix3d(a.transpose() * b)).angle() * 180.0 / kPi;
}

TEST(Symmetry, NearestEquivalentRotationRemovesTheSymmetryFromAChange) {
  std::mt19937 rng(7);
  const Eigen::Matrix3d motion =
      Eigen::AngleAxisd(2.0 * kPi / 180.0, Eigen::Vector3d(1, 2, 3).normalized())
          .toRotationMatrix();
  // Without rotations: the rotation itself, however far from the reference.
  for (int i = 0; i < 5; ++i) {
    const Eigen::Matrix3d r = RandomRotation(&rng);
    const Eigen::Matrix3d reference = RandomRotation(&rng);
    EXPECT_TRUE(NearestEquivalentRotation(r, reference, ObjectSymmetry()).isApprox(r, 1e-12));
  }
  const ObjectSymmetry bearing = Bearing();
  const ObjectSymmetry bolt = HexBolt();
  const std::vector<Rigid3> bearing_set = SymmetryTransforms(bearing);
  const std::vector<Rigid3> bolt_set = SymmetryTransforms(bolt);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Matrix3d reference = RandomRotation(&rng);
    // The pose moved by 2 deg, then reported as an equivalent pose: turned about the continuous
    // axis and flipped (bearing), or turned by a sixth (bolt).
    const double twist = std::uniform_real_distribution<double>(-kPi, kPi)(rng);
    const Eigen::Matrix3d turned_bearing =
        motion * reference * Eigen::AngleAxisd(twist, Eigen::Vector3d::UnitY()).toRotationMatrix() *
        bearing.discrete[0].rotation;
    const Eigen::Matrix3d near_bearing =
        NearestEquivalentRotation(turned_bearing, reference, bearing);
    // Equivalent to the reported pose: they differ by a turn about the axis (y), or a flip
    // about x and a turn, which both keep the axis' line ...
    const Eigen::Matrix3d between = near_bearing.transpose() * turned_bearing;
    EXPECT_NEAR(std::abs((between * Eigen::Vector3d::UnitY()).y()), 1.0, 1e-9);
    EXPECT_NEAR(RotationErrorModuloSymmetryDeg(near_bearing, turned_bearing, bearing_set), 0.0,
                0.6);
    // ... and the change from the reference is the motion's 2 deg at most (the twist of the
    // motion about the axis is removed too), not the twist or the flip.
    EXPECT_LE(AngleDegBetween(near_bearing, reference), 2.0 + 1e-9);
    EXPECT_GT(AngleDegBetween(turned_bearing, reference), 2.0);

    const Eigen::Matrix3d turned_bolt = motion * reference * bolt.discrete[i % 5].rotation;
    const Eigen::Matrix3d near_bolt = NearestEquivalentRotation(turned_bolt, reference, bolt);
    EXPECT_NEAR(RotationErrorModuloSymmetryDeg(near_bolt, turned_bolt, bolt_set), 0.0, 1e-6);
    EXPECT_NEAR(AngleDegBetween(near_bolt, reference), 2.0, 1e-6);
    EXPECT_GT(AngleDegBetween(turned_bolt, reference), 2.5);
  }
}

TEST(Symmetry, DescribeAndCheck) {
  EXPECT_EQ(ObjectSymmetry().Describe(), "none");
  const std::string bearing = Bearing().Describe();
  EXPECT_NE(bearing.find("continuous about (0, 1, 0)"), std::string::npos) << bearing;
  EXPECT_NE(bearing.find("1 discrete rotation (180 deg about (1, 0, 0))"), std::string::npos)
      << bearing;
  std::string problem;
  EXPECT_TRUE(Bearing().Check(&problem)) << problem;
  ObjectSymmetry bad = HexBolt();
  bad.discrete[0].rotation(0, 0) = 2.0;
  EXPECT_FALSE(bad.Check(&problem));
  EXPECT_NE(problem.find("not a finite rotation"), std::string::npos);
  ObjectSymmetry zero;
  zero.continuous.push_back({.axis = Eigen::Vector3d::Zero()});
  EXPECT_FALSE(zero.Check(&problem));
  ObjectSymmetry mirror;
  mirror.mirrors.push_back({.normal = Eigen::Vector3d(0, 0, std::nan(""))});
  EXPECT_FALSE(mirror.Check(&problem));
}

}  // namespace
}  // namespace silpose

namespace silpose {
namespace {

TEST(ViewEquivalence, AnglesModuloContinuousAndDiscreteSymmetries) {
  const Eigen::Vector3d a = Eigen::Vector3d(1.0, 0.0, 1.0).normalized();
  const Eigen::Vector3d b = Eigen::Vector3d(0.0, 1.0, 1.0).normalized();  // a turned 90 deg about z
  EXPECT_NEAR(ViewEquivalence().AngleDeg(a, b), 60.0, 1e-9);
  ObjectSymmetry bottle;
  bottle.continuous.push_back({Eigen::Vector3d(0, 0, 2), Eigen::Vector3d::Zero()});
  const ViewEquivalence about_z(bottle);
  EXPECT_NEAR(about_z.AngleDeg(a, b), 0.0, 1e-9);
  // Only the angle to the axis counts: 45 deg against 0 deg.
  EXPECT_NEAR(about_z.AngleDeg(a, Eigen::Vector3d::UnitZ()), 45.0, 1e-9);
  // A flip (180 deg about x) makes +z and -z alike.
  ObjectSymmetry flip;
  flip.discrete.push_back(
      {Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix(),
       Eigen::Vector3d::Zero()});
  EXPECT_NEAR(ViewEquivalence(flip).AngleDeg(Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ()),
              0.0, 1e-9);
  EXPECT_NEAR(ViewEquivalence().AngleDeg(Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ()),
              180.0, 1e-9);
  // Mirror planes make no two views equivalent.
  ObjectSymmetry mirror;
  mirror.mirrors.push_back({Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()});
  EXPECT_NEAR(ViewEquivalence(mirror).AngleDeg(a, b), 60.0, 1e-9);
}

}  // namespace
}  // namespace silpose

namespace silpose {
namespace {

TEST(Symmetry, MirrorTwinViewIsTheReflectedReversedDirection) {
  MirrorSymmetry mirror;
  mirror.normal = Eigen::Vector3d(0.0, 0.0, 2.0);  // need not be unit
  const Eigen::Vector3d d = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const Eigen::Vector3d twin = mirror.TwinView(d);
  // Reflection across the plane z = 0 (z -> -z), then reversed: (-x, -y, z).
  EXPECT_TRUE(twin.isApprox(Eigen::Vector3d(-d.x(), -d.y(), d.z()), 1e-12));
  EXPECT_NEAR(twin.norm(), 1.0, 1e-12);
  EXPECT_TRUE(mirror.TwinView(twin).isApprox(d, 1e-12));  // its own inverse
  // Along the normal a view is its own twin; in the plane, the twin is the opposite view.
  EXPECT_TRUE(mirror.TwinView(Eigen::Vector3d::UnitZ()).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE(mirror.TwinView(Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitX()));
}

}  // namespace
}  // namespace silpose

namespace silpose {
namespace {

TEST(Symmetry, MirrorTwinPoseShowsTheSameOutlineAlongTheLineOfSight) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  const auto random_vector = [&] { return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)); };
  for (int trial = 0; trial < 20; ++trial) {
    // A mirror plane through o with normal n, and points of a mirror-symmetric object in pairs.
    MirrorSymmetry mirror;
    mirror.normal = random_vector();
    mirror.offset = random_vector();
    const Eigen::Vector3d n = mirror.normal.normalized();
    const auto reflect = [&](const Eigen::Vector3d& x) {
      return Eigen::Vector3d(x - 2.0 * (x - mirror.offset).dot(n) * n);
    };
    // The object's centre, on the plane.
    const Eigen::Vector3d off = mirror.offset + random_vector();
    const Eigen::Vector3d on_plane = off - (off - mirror.offset).dot(n) * n;
    Rigid3 pose;
    pose.rotation = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
    // On or off the optical axis, 10 units from the camera.
    const Eigen::Vector3d where =
        Eigen::Vector3d(0.3 * normal(rng), 0.3 * normal(rng), 1.0).normalized() * 10.0;
    pose.translation = where - pose.rotation * on_plane;
    const Rigid3 twin = MirrorTwinPose(pose, mirror, on_plane);

    EXPECT_NEAR(twin.rotation.determinant(), 1.0, 1e-9);
    EXPECT_TRUE(
        (twin.rotation.transpose() * twin.rotation).isApprox(Eigen::Matrix3d::Identity(), 1e-9));
    EXPECT_TRUE((twin * on_plane).isApprox(pose * on_plane, 1e-9)) << "the centre moved";
    const Rigid3 back = MirrorTwinPose(twin, mirror, on_plane);
    EXPECT_TRUE(back.rotation.isApprox(pose.rotation, 1e-9));
    EXPECT_TRUE(back.translation.isApprox(pose.translation, 1e-9));
    // Each point of the twin pose lies on the line of sight (parallel to the centre's) through
    // the mirrored point at the original pose: the far-away camera's outlines are the same.
    const Eigen::Vector3d u = where.normalized();
    for (int i = 0; i < 10; ++i) {
      const Eigen::Vector3d x = on_plane + random_vector();
      const Eigen::Vector3d difference = twin * x - pose * reflect(x);
      EXPECT_LT(difference.cross(u).norm(), 1e-9 * (1.0 + difference.norm()));
    }
    // The twin's camera direction (model frame) is the twin view of the original's when the
    // centre is on the optical axis.
    if (trial == 0) {
      Rigid3 on_axis = pose;
      on_axis.translation = Eigen::Vector3d(0.0, 0.0, 10.0) - pose.rotation * on_plane;
      const Rigid3 t = MirrorTwinPose(on_axis, mirror, on_plane);
      const Eigen::Vector3d d = -(on_axis.rotation.transpose() * Eigen::Vector3d::UnitZ());
      const Eigen::Vector3d d_twin = -(t.rotation.transpose() * Eigen::Vector3d::UnitZ());
      EXPECT_TRUE(d_twin.isApprox(mirror.TwinView(d), 1e-9));
    }
  }
}

}  // namespace
}  // namespace silpose
