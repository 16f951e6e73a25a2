#include "silpose/mesh/mesh_symmetry.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

// Adds a closed prism: a regular `sides`-gon of circumradius `radius` in the xy-plane, from z0
// to z1, centred at (cx, cy), first corner at angle `phase`.
void AddPrism(TriangleMesh* mesh, int sides, double radius, double z0, double z1, double cx = 0.0,
              double cy = 0.0, double phase = 0.0) {
  const auto base = static_cast<uint32_t>(mesh->vertices.size());
  for (int k = 0; k < sides; ++k) {
    const double a = phase + 2.0 * kPi * k / sides;
    const float x = static_cast<float>(cx + radius * std::cos(a));
    const float y = static_cast<float>(cy + radius * std::sin(a));
    mesh->vertices.emplace_back(x, y, static_cast<float>(z0));
    mesh->vertices.emplace_back(x, y, static_cast<float>(z1));
  }
  const auto bottom = static_cast<uint32_t>(mesh->vertices.size());
  mesh->vertices.emplace_back(static_cast<float>(cx), static_cast<float>(cy),
                              static_cast<float>(z0));
  mesh->vertices.emplace_back(static_cast<float>(cx), static_cast<float>(cy),
                              static_cast<float>(z1));
  const auto n = static_cast<uint32_t>(sides);
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t a0 = base + 2 * k, a1 = a0 + 1;
    const uint32_t b0 = base + 2 * ((k + 1) % n), b1 = b0 + 1;
    mesh->triangles.push_back({a0, b0, b1});
    mesh->triangles.push_back({a0, b1, a1});
    mesh->triangles.push_back({bottom, b0, a0});
    mesh->triangles.push_back({bottom + 1, a1, b1});
  }
}

// A box with half sizes (hx, hy, hz) centred at c.
void AddBox(TriangleMesh* mesh, double hx, double hy, double hz,
            const Eigen::Vector3d& c = Eigen::Vector3d::Zero()) {
  // A 4-sided prism turned by 45 degrees is a square box; scale it to the half sizes.
  TriangleMesh box;
  AddPrism(&box, 4, std::sqrt(2.0), -1.0, 1.0, 0.0, 0.0, kPi / 4.0);
  const auto base = static_cast<uint32_t>(mesh->vertices.size());
  for (const Eigen::Vector3f& v : box.vertices) {
    mesh->vertices.emplace_back(static_cast<float>(c.x() + hx * v.x()),
                                static_cast<float>(c.y() + hy * v.y()),
                                static_cast<float>(c.z() + hz * v.z()));
  }
  for (auto t : box.triangles) mesh->triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

bool HasAxis(const ObjectSymmetry& s, const Eigen::Vector3d& axis) {
  for (const ContinuousSymmetry& c : s.continuous) {
    if (std::abs(c.axis.normalized().dot(axis)) > 0.999) return true;
  }
  return false;
}

TEST(MeshSymmetry, CylinderIsContinuousAboutItsAxisWithAFlip) {
  TriangleMesh mesh;
  AddPrism(&mesh, 96, 1.0, -2.0, 2.0);
  const ObjectSymmetry s = DetectSymmetry(mesh);
  ASSERT_EQ(s.continuous.size(), 1u) << s.Describe();
  EXPECT_TRUE(HasAxis(s, Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(s.continuous[0].offset.norm(), 0.0, 1e-6);
  // The flip: a half turn about an axis across z.
  ASSERT_EQ(s.discrete.size(), 1u) << s.Describe();
  const Eigen::AngleAxisd flip(s.discrete[0].rotation);
  EXPECT_NEAR(flip.angle(), kPi, 1e-6);
  EXPECT_NEAR(flip.axis().z(), 0.0, 1e-6);
  EXPECT_TRUE(s.HasRotations());
}

TEST(MeshSymmetry, CupWithABaseHasNoFlipAndAHandleLeavesOnlyAMirror) {
  TriangleMesh cup;
  AddPrism(&cup, 96, 1.0, -1.5, 1.5);
  AddPrism(&cup, 96, 1.4, -1.7, -1.5);  // a wider foot at one end
  ObjectSymmetry s = DetectSymmetry(cup);
  ASSERT_EQ(s.continuous.size(), 1u) << s.Describe();
  EXPECT_TRUE(s.discrete.empty()) << s.Describe();

  AddBox(&cup, 0.35, 0.1, 0.8, Eigen::Vector3d(1.3, 0.0, 0.0));  // a handle along +x
  s = DetectSymmetry(cup);
  EXPECT_FALSE(s.HasRotations()) << s.Describe();
  // The plane y = 0 holds the axis and the handle.
  bool found = false;
  for (const MirrorSymmetry& m : s.mirrors) found |= std::abs(m.normal.normalized().y()) > 0.999;
  EXPECT_TRUE(found) << s.Describe();
}

TEST(MeshSymmetry, HexagonalBoltHasSixTurnsAndNoFlip) {
  TriangleMesh bolt;
  AddPrism(&bolt, 6, 1.0, 0.0, 0.6);                   // head
  AddPrism(&bolt, 64, 0.45, 0.6, 3.0, 0.0, 0.0, 0.0);  // shank
  const ObjectSymmetry s = DetectSymmetry(bolt);
  EXPECT_TRUE(s.continuous.empty()) << s.Describe();
  ASSERT_EQ(s.discrete.size(), 5u) << s.Describe();
  double smallest = kPi;
  for (const Rigid3& r : s.discrete) {
    const Eigen::AngleAxisd aa(r.rotation);
    EXPECT_GT(std::abs(aa.axis().z()), 0.999);
    smallest = std::min(smallest, aa.angle());
  }
  EXPECT_NEAR(smallest, kPi / 3.0, 1e-6);
  // Six mirror planes contain the axis.
  EXPECT_EQ(s.mirrors.size(), 6u) << s.Describe();
}

TEST(MeshSymmetry, PrismsWhoseFlatEndsCarryMostOfTheSurfaceGetTheirOwnOrder) {
  // On a short prism most surface samples lie on the two end faces, which any turn about the
  // axis keeps on the surface; a turn near a true symmetry then passes too (a ten-sided prism
  // turned by 30 degrees lies within the tolerance of its 36-degree turn), and only its
  // multiples (90 degrees is 18 from 72 and 108) tell the true order.
  for (const auto& [sides, half_height] :
       std::vector<std::pair<int, double>>{{8, 1.0}, {10, 1.0}, {12, 1.0}, {8, 3.0}}) {
    TriangleMesh mesh;
    AddPrism(&mesh, sides, 1.0, -half_height, half_height);
    const ObjectSymmetry s = DetectSymmetry(mesh);
    EXPECT_TRUE(s.continuous.empty()) << sides << " sides: " << s.Describe();
    int turns = 0;
    double smallest = 2.0 * kPi;
    for (const Rigid3& r : s.discrete) {
      const Eigen::AngleAxisd turn(r.rotation);
      if (std::abs(std::abs(turn.axis().z()) - 1.0) > 1e-6) continue;  // a flip
      ++turns;
      smallest = std::min(smallest, turn.angle());
    }
    EXPECT_EQ(turns, sides - 1) << sides << " sides: " << s.Describe();
    EXPECT_NEAR(smallest, 2.0 * kPi / sides, 1e-6) << sides << " sides: " << s.Describe();
  }
}

TEST(MeshSymmetry, BoxWithUnequalSidesHasThreeHalfTurns) {
  TriangleMesh box;
  AddBox(&box, 3.0, 2.0, 1.0);
  const ObjectSymmetry s = DetectSymmetry(box);
  EXPECT_TRUE(s.continuous.empty()) << s.Describe();
  EXPECT_EQ(s.discrete.size(), 3u) << s.Describe();
  EXPECT_EQ(s.mirrors.size(), 3u) << s.Describe();
  for (const Rigid3& r : s.discrete) EXPECT_NEAR(Eigen::AngleAxisd(r.rotation).angle(), kPi, 1e-6);
}

TEST(MeshSymmetry, LopsidedShapeHasNone) {
  TriangleMesh shape;
  AddBox(&shape, 3.0, 2.0, 1.0);
  AddBox(&shape, 0.5, 0.7, 0.9, Eigen::Vector3d(2.0, 1.2, 0.8));
  AddBox(&shape, 0.3, 0.4, 1.5, Eigen::Vector3d(-1.7, -0.2, -0.6));
  const ObjectSymmetry s = DetectSymmetry(shape);
  EXPECT_FALSE(s.HasRotations()) << s.Describe();
  EXPECT_TRUE(s.mirrors.empty()) << s.Describe();
  EXPECT_EQ(s.Describe(), "none");
}

TEST(MeshSymmetry, SymmetriesMoveTheMeshOntoItselfInAnyFrame) {
  // The same bolt, turned and moved: the axes and offsets follow.
  TriangleMesh bolt;
  AddPrism(&bolt, 6, 1.0, 0.0, 0.6);
  AddPrism(&bolt, 60, 0.45, 0.6, 3.0);  // 60 sides: its vertices map onto each other too
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, -0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(10.0, -4.0, 2.5);
  for (Eigen::Vector3f& v : bolt.vertices) v = (turn * v.cast<double>() + shift).cast<float>();
  const ObjectSymmetry s = DetectSymmetry(bolt);
  ASSERT_EQ(s.discrete.size(), 5u) << s.Describe();
  const Eigen::Vector3d axis = turn * Eigen::Vector3d::UnitZ();
  for (const Rigid3& r : s.discrete) {
    EXPECT_GT(std::abs(Eigen::AngleAxisd(r.rotation).axis().dot(axis)), 0.999);
    // Every vertex lands on a vertex.
    double worst = 0.0;
    for (const Eigen::Vector3f& v : bolt.vertices) {
      const Eigen::Vector3d moved = r * v.cast<double>();
      double nearest = 1e9;
      for (const Eigen::Vector3f& w : bolt.vertices)
        nearest = std::min(nearest, (w.cast<double>() - moved).norm());
      worst = std::max(worst, nearest);
    }
    EXPECT_LT(worst, 1e-3);
  }
}

TEST(MeshSymmetry, EmptyMeshHasNoneAndBadOptionsAreRefused) {
  EXPECT_EQ(DetectSymmetry(TriangleMesh()).Describe(), "none");
  TriangleMesh flat;  // all triangles of zero area
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_FALSE(DetectSymmetry(flat).HasRotations());
  TriangleMesh mesh;
  AddPrism(&mesh, 8, 1.0, 0.0, 1.0);
  EXPECT_THROW(DetectSymmetry(mesh, {.tolerance = 0.0}), Error);
  EXPECT_THROW(DetectSymmetry(mesh, {.max_order = 1}), Error);
  EXPECT_THROW(DetectSymmetry(mesh, {.samples = 0}), Error);
}

}  // namespace
}  // namespace silpose
