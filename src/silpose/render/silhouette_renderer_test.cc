#include "silpose/render/silhouette_renderer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

// ----- Meshes built in code -----------------------------------------------------------------

void AddTriangle(TriangleMesh* mesh, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                 const Eigen::Vector3d& c) {
  const auto first = static_cast<uint32_t>(mesh->vertices.size());
  mesh->vertices.push_back(a.cast<float>());
  mesh->vertices.push_back(b.cast<float>());
  mesh->vertices.push_back(c.cast<float>());
  mesh->triangles.push_back({first, first + 1, first + 2});
}

// Icosahedron subdivided `levels` times (20 * 4^levels triangles), vertices on the sphere.
TriangleMesh Icosphere(double radius, int levels, const Eigen::Vector3d& centre) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> points = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                                         {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                                         {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (Eigen::Vector3d& p : points) p.normalize();
  std::vector<std::array<uint32_t, 3>> faces = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto found = midpoints.find(key);
      if (found != midpoints.end()) return found->second;
      points.push_back((points[a] + points[b]).normalized());
      const auto index = static_cast<uint32_t>(points.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<uint32_t, 3>> finer;
    for (const auto& f : faces) {
      const uint32_t ab = midpoint(f[0], f[1]);
      const uint32_t bc = midpoint(f[1], f[2]);
      const uint32_t ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }
  TriangleMesh mesh;
  mesh.name = "icosphere";
  for (const Eigen::Vector3d& p : points)
    mesh.vertices.push_back((centre + radius * p).cast<float>());
  mesh.triangles = faces;
  return mesh;
}

// Closed axis-aligned box, appended to `mesh` (12 triangles).
void AddBox(TriangleMesh* mesh, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const auto first = static_cast<uint32_t>(mesh->vertices.size());
  for (int i = 0; i < 8; ++i) {
    mesh->vertices.push_back(Eigen::Vector3d((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                                             (i & 4) ? hi.z() : lo.z())
                                 .cast<float>());
  }
  const uint32_t quads[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  for (const auto& q : quads) {
    mesh->triangles.push_back({first + q[0], first + q[1], first + q[2]});
    mesh->triangles.push_back({first + q[0], first + q[2], first + q[3]});
  }
}

// Centre and radius per TriangleMesh's definitions, computed here so the tests only rely on the
// renderer.
Eigen::Vector3d BoxCentre(const TriangleMesh& mesh) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    lo = lo.cwiseMin(v.cast<double>());
    hi = hi.cwiseMax(v.cast<double>());
  }
  return 0.5 * (lo + hi);
}

double MaxDistance(const TriangleMesh& mesh, const Eigen::Vector3d& centre) {
  double radius = 0.0;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    radius = std::max(radius, (v.cast<double>() - centre).norm());
  }
  return radius;
}

// Smallest distance from `centre` to the plane of a face: the ball of that radius lies inside a
// closed convex polyhedron containing `centre`.
double MinFacePlaneDistance(const TriangleMesh& mesh, const Eigen::Vector3d& centre) {
  double distance = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    distance = std::min(distance, std::abs(normal.dot(a - centre)));
  }
  return distance;
}

// ----- Mask helpers -------------------------------------------------------------------------

int CountDifferences(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::compare(a, b, difference, cv::CMP_NE);
  return cv::countNonZero(difference);
}

bool OnlyZeroOr255(const cv::Mat& mask) {
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      const uint8_t value = mask.at<uint8_t>(v, u);
      if (value != 0 && value != 255) return false;
    }
  }
  return true;
}

Eigen::Vector2d Centroid(const cv::Mat& mask) {
  double su = 0.0, sv = 0.0, n = 0.0;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (mask.at<uint8_t>(v, u) != 0) {
        su += u;
        sv += v;
        n += 1.0;
      }
    }
  }
  return {su / n, sv / n};
}

// Bounding box of the non-zero pixels (same result as cv::boundingRect on the mask).
cv::Rect NonZeroBounds(const cv::Mat& mask) {
  int u0 = mask.cols, v0 = mask.rows, u1 = -1, v1 = -1;
  for (int v = 0; v < mask.rows; ++v) {
    for (int u = 0; u < mask.cols; ++u) {
      if (mask.at<uint8_t>(v, u) == 0) continue;
      u0 = std::min(u0, u);
      v0 = std::min(v0, v);
      u1 = std::max(u1, u);
      v1 = std::max(v1, v);
    }
  }
  if (u1 < 0) return {};
  return {u0, v0, u1 - u0 + 1, v1 - v0 + 1};
}

PinholeCamera TestCamera(int width, int height, double f, double cx, double cy) {
  PinholeCamera camera;
  camera.width_px = width;
  camera.height_px = height;
  camera.focal_x_px = f;
  camera.focal_y_px = f;
  camera.principal_x_px = cx;
  camera.principal_y_px = cy;
  return camera;
}

// ----- Sphere and cube through RenderView --------------------------------------------------

TEST(RenderView, SphereIsTheAnalyticDisc) {
  const TriangleMesh sphere = Icosphere(2.5, 5, Eigen::Vector3d(0.3, -1.0, 4.0));
  ASSERT_EQ(sphere.triangles.size(), 20480u);
  const Eigen::Vector3d centre = BoxCentre(sphere);
  const double radius = MaxDistance(sphere, centre);
  const double inner_radius = MinFacePlaneDistance(sphere, centre);
  // The tessellation is within 0.03% of the sphere: the silhouette lies between two discs whose
  // radii differ by much less than a pixel.
  ASSERT_GT(inner_radius, 0.9997 * radius);

  ViewRenderOptions options;  // 256 px, 3 radii, fill 0.9.
  options.resolution_px = 256;
  const PinholeCamera camera = ViewCamera(options);
  const double distance = options.distance_in_radii * radius;
  const double outer_px = camera.focal_x_px * std::tan(std::asin(radius / distance));
  const double inner_px = camera.focal_x_px * std::tan(std::asin(inner_radius / distance));
  EXPECT_NEAR(outer_px, 0.9 * 128.0, 1e-9);
  const double cx = camera.principal_x_px;
  const double cy = camera.principal_y_px;
  EXPECT_EQ(cx, 127.5);

  const std::vector<std::pair<Eigen::Vector3d, double>> views = {
      {{1, 0, 0}, 0.0},  {{0, 0, 1}, 0.0},        {{0, 0, -1}, 45.0},
      {{1, 2, 3}, 17.0}, {{-1, -1, 0.5}, -120.0}, {{0.2, -0.9, -0.3}, 90.0}};
  for (const auto& [view, roll] : views) {
    SCOPED_TRACE(::testing::Message() << "view " << view.transpose() << " roll " << roll);
    cv::Mat mask;
    RenderView(sphere, view, roll, options, &mask);
    ASSERT_EQ(mask.type(), CV_8UC1);
    ASSERT_EQ(mask.rows, 256);
    ASSERT_EQ(mask.cols, 256);
    EXPECT_TRUE(OnlyZeroOr255(mask));

    const double area = cv::countNonZero(mask);
    const double disc_area = kPi * outer_px * outer_px;
    EXPECT_NEAR(area / disc_area, 1.0, 0.01);
    // Rigorous bounds: the unit squares of the counted pixels cover the inner disc shrunk by half a
    // pixel diagonal and lie within the outer disc grown by it.
    EXPECT_GE(area, kPi * std::pow(inner_px - std::sqrt(0.5), 2));
    EXPECT_LE(area, kPi * std::pow(outer_px + std::sqrt(0.5), 2));

    const Eigen::Vector2d centroid = Centroid(mask);
    EXPECT_NEAR(centroid.x(), cx, 0.5);
    EXPECT_NEAR(centroid.y(), cy, 0.5);

    // Exact per pixel: every centre inside the inner disc is set (no cracks between the
    // triangles), every centre outside the outer disc is clear.
    int holes = 0, spill = 0;
    for (int v = 0; v < mask.rows; ++v) {
      for (int u = 0; u < mask.cols; ++u) {
        const double r = std::hypot(u - cx, v - cy);
        const bool set = mask.at<uint8_t>(v, u) != 0;
        if (r < inner_px - 1e-6 && !set) ++holes;
        if (r > outer_px + 1e-6 && set) ++spill;
      }
    }
    EXPECT_EQ(holes, 0);
    EXPECT_EQ(spill, 0);
  }
}

TEST(RenderView, CubeSeenAlongAnAxisIsItsNearFace) {
  const double a = 0.5;
  const Eigen::Vector3d centre(1.0, -2.0, 0.5);
  TriangleMesh cube;
  cube.name = "cube";
  AddBox(&cube, centre - Eigen::Vector3d::Constant(a), centre + Eigen::Vector3d::Constant(a));

  const ViewRenderOptions options;
  const PinholeCamera camera = ViewCamera(options);
  const double distance = options.distance_in_radii * a * std::sqrt(3.0);
  const double half_side_px = camera.focal_x_px * a / (distance - a);
  const double c = camera.principal_x_px;
  const int first = static_cast<int>(std::ceil(c - half_side_px));
  const int last = static_cast<int>(std::floor(c + half_side_px));

  for (const Eigen::Vector3d& view : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0)}) {
    SCOPED_TRACE(::testing::Message() << "view " << view.transpose());
    cv::Mat mask;
    RenderView(cube, view, 0.0, options, &mask);
    const cv::Rect box = NonZeroBounds(mask);
    EXPECT_NEAR(box.x, first, 1);
    EXPECT_NEAR(box.y, first, 1);
    EXPECT_NEAR(box.x + box.width - 1, last, 1);
    EXPECT_NEAR(box.y + box.height - 1, last, 1);
    const double side = 2.0 * half_side_px;
    EXPECT_NEAR(cv::countNonZero(mask) / (side * side), 1.0, 0.02);
    // The square is full: no cracks along the diagonals of the faces.
    EXPECT_EQ(cv::countNonZero(mask), box.area());
  }
}

// ----- RenderSilhouette with a general camera --------------------------------------------

TEST(RenderSilhouette, TriangleMatchesPointInTriangleAtEveryPixelCentre) {
  PinholeCamera camera = TestCamera(200, 150, 180.0, 83.3, 61.7);
  camera.focal_y_px = 171.0;
  Rigid3 camera_from_object;
  camera_from_object.rotation =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  camera_from_object.translation = Eigen::Vector3d(0.2, -0.1, 3.0);
  const Rigid3 object_from_camera = camera_from_object.Inverse();

  // Corners given in the camera frame (one projects outside the image), moved to the object frame.
  const std::vector<std::array<Eigen::Vector3d, 3>> cases = {
      {{{-0.8, -0.5, 2.0}, {0.9, -0.2, 2.5}, {0.1, 0.7, 1.8}}},
      {{{-1.5, 0.3, 1.2}, {0.4, -1.1, 2.2}, {0.6, 0.5, 3.1}}},  // Crosses the left and top borders.
      {{{0.05, 0.02, 1.0}, {0.3, 0.031, 1.01}, {0.29, 0.035, 1.02}}},  // Thin sliver.
      // Small, across the bottom-right corner: short spans at the very end of the buffer.
      {{{1.2522, 0.99766, 2.0}, {1.3078, 0.98596, 2.0}, {1.2856, 1.04444, 2.0}}},
  };
  for (const auto& corners : cases) {
    TriangleMesh mesh;
    AddTriangle(&mesh, object_from_camera * corners[0], object_from_camera * corners[1],
                object_from_camera * corners[2]);
    cv::Mat mask;
    RenderSilhouette(mesh, camera, camera_from_object, &mask);

    // Reference from the vertices as stored (float) and an edge-function test in double.
    std::array<Eigen::Vector2d, 3> p;
    for (int i = 0; i < 3; ++i) {
      p[i] = camera.Project(camera_from_object * mesh.vertices[i].cast<double>());
    }
    int mismatches = 0, set_count = 0;
    for (int v = 0; v < camera.height_px; ++v) {
      for (int u = 0; u < camera.width_px; ++u) {
        const Eigen::Vector2d q(u, v);
        double min_abs_distance = std::numeric_limits<double>::infinity();
        int positive = 0, negative = 0;
        for (int i = 0; i < 3; ++i) {
          const Eigen::Vector2d e = p[(i + 1) % 3] - p[i];
          const Eigen::Vector2d w = q - p[i];
          const double signed_distance = (e.x() * w.y() - e.y() * w.x()) / e.norm();
          min_abs_distance = std::min(min_abs_distance, std::abs(signed_distance));
          if (signed_distance > 0) ++positive;
          if (signed_distance < 0) ++negative;
        }
        const bool inside = positive == 0 || negative == 0;
        const bool set = mask.at<uint8_t>(v, u) != 0;
        set_count += set ? 1 : 0;
        if (inside != set) {
          ++mismatches;
          EXPECT_LT(min_abs_distance, 1e-6) << "pixel " << u << ", " << v;
        }
      }
    }
    EXPECT_LE(mismatches, 3);
    EXPECT_GT(set_count, 0);
  }
}

TEST(RenderSilhouette, SharedEdgesLeaveNoCracks) {
  // A square of 8 x 8 cells, each split in two along alternating diagonals. With f = 64 and
  // coordinates k / 64 (exact in float) the outer vertices project exactly onto pixel centres
  // (u, v = 10 + 5 i); the inner ones are jittered off the pixel grid. The union is exactly the
  // closed square [10, 50]^2: every pixel centre on an inner edge or at an inner vertex belongs to
  // some triangle, and none outside the square is set.
  const PinholeCamera camera = TestCamera(64, 64, 64.0, 0.0, 0.0);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-1.5, 1.5);
  const int n = 8;
  TriangleMesh grid;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const bool inner = i > 0 && i < n && j > 0 && j < n;
      const double u = 10.0 + 5.0 * i + (inner ? jitter(rng) : 0.0);
      const double v = 10.0 + 5.0 * j + (inner ? jitter(rng) : 0.0);
      grid.vertices.push_back(Eigen::Vector3d(u / 64.0, v / 64.0, 1.0).cast<float>());
    }
  }
  auto id = [n](int i, int j) { return static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      if ((i + j) % 2 == 0) {
        grid.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        grid.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        grid.triangles.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
        grid.triangles.push_back({id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  }
  cv::Mat mask;
  RenderSilhouette(grid, camera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 41 * 41);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(10, 10, 41, 41))), 41 * 41);
}

// ----- Roll --------------------------------------------------------------------------------

TEST(RenderView, RollTurnsTheImageContentTheOtherWay) {
  // L-shaped object (two boxes), clearly without any rotational symmetry.
  TriangleMesh l_shape;
  l_shape.name = "l_shape";
  AddBox(&l_shape, {-0.3, 0.0, 0.0}, {0.3, 2.0, 0.5});
  AddBox(&l_shape, {-0.3, 0.0, 0.0}, {0.3, 0.5, 1.5});
  ViewRenderOptions options;
  options.resolution_px = 128;  // Centre 63.5: cv::rotate maps pixel centres onto pixel centres.

  for (const Eigen::Vector3d& view :
       {Eigen::Vector3d(1, 0.4, 0.3), Eigen::Vector3d(-0.2, 1, -0.5)}) {
    for (const double base_roll : {0.0, 30.0}) {
      SCOPED_TRACE(::testing::Message() << "view " << view.transpose() << " roll " << base_roll);
      cv::Mat base, rolled_90, rolled_180, rolled_minus_90;
      RenderView(l_shape, view, base_roll, options, &base);
      RenderView(l_shape, view, base_roll + 90.0, options, &rolled_90);
      RenderView(l_shape, view, base_roll + 180.0, options, &rolled_180);
      RenderView(l_shape, view, base_roll - 90.0, options, &rolled_minus_90);
      ASSERT_GT(cv::countNonZero(base), 500);

      // Image offset (x, y) at roll r appears at (y, -x) at roll r + 90: counterclockwise on
      // screen (y down).
      cv::Mat expected;
      cv::rotate(base, expected, cv::ROTATE_90_COUNTERCLOCKWISE);
      EXPECT_LE(CountDifferences(rolled_90, expected), 6);
      cv::rotate(base, expected, cv::ROTATE_180);
      EXPECT_LE(CountDifferences(rolled_180, expected), 6);
      cv::rotate(base, expected, cv::ROTATE_90_CLOCKWISE);
      EXPECT_LE(CountDifferences(rolled_minus_90, expected), 6);
      // The test can tell the directions apart.
      cv::rotate(base, expected, cv::ROTATE_90_CLOCKWISE);
      EXPECT_GT(CountDifferences(rolled_90, expected), 200);
    }
  }
}

// ----- Near-plane clipping -----------------------------------------------------------------

TEST(RenderSilhouette, GroundPlaneUnderAndBehindTheCameraIsClipped) {
  // Ground z = 0 (model Z up), a 100 x 100 square; the camera stands above it at height 1.5,
  // looking slightly down: the square passes under and behind the camera.
  TriangleMesh ground;
  ground.name = "ground";
  const double h = 50.0;
  AddTriangle(&ground, {-h, -h, 0}, {h, -h, 0}, {h, h, 0});
  AddTriangle(&ground, {-h, -h, 0}, {h, h, 0}, {-h, h, 0});

  const PinholeCamera camera = TestCamera(320, 240, 200.0, 159.5, 119.5);
  const Eigen::Vector3d camera_centre(3.0, -2.0, 1.5);
  for (const double pitch_deg : {0.0, 12.0, 60.0}) {
    SCOPED_TRACE(::testing::Message() << "pitch " << pitch_deg);
    const double pitch = pitch_deg * kPi / 180.0;
    const double yaw = 0.5;
    const Eigen::Vector3d forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                                  -std::sin(pitch));
    const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d down = forward.cross(right);
    Rigid3 camera_from_object;
    camera_from_object.rotation.row(0) = right.transpose();
    camera_from_object.rotation.row(1) = down.transpose();
    camera_from_object.rotation.row(2) = forward.transpose();
    camera_from_object.translation = -(camera_from_object.rotation * camera_centre);

    cv::Mat mask;
    RenderSilhouette(ground, camera, camera_from_object, &mask);

    // Reference: cast the ray through the pixel, hit the plane in front of the camera within the
    // square. Pixels whose answer changes within 0.01 px are on the outline and are not checked.
    auto hits = [&](double u, double v) {
      const Eigen::Vector3d ray_in_camera((u - camera.principal_x_px) / camera.focal_x_px,
                                          (v - camera.principal_y_px) / camera.focal_y_px, 1.0);
      const Eigen::Vector3d ray = camera_from_object.rotation.transpose() * ray_in_camera;
      if (!(ray.z() < 0.0)) return false;
      const double depth = -camera_centre.z() / ray.z();
      const Eigen::Vector3d point = camera_centre + depth * ray;
      return std::abs(point.x()) <= h && std::abs(point.y()) <= h;
    };
    int checked = 0, mismatches = 0, expected_set = 0;
    for (int v = 0; v < camera.height_px; ++v) {
      for (int u = 0; u < camera.width_px; ++u) {
        const bool expected = hits(u, v);
        const double d = 0.01;
        if (hits(u - d, v) != expected || hits(u + d, v) != expected ||
            hits(u, v - d) != expected || hits(u, v + d) != expected) {
          continue;
        }
        ++checked;
        expected_set += expected ? 1 : 0;
        if (expected != (mask.at<uint8_t>(v, u) != 0)) ++mismatches;
      }
    }
    EXPECT_GT(checked, camera.width_px * camera.height_px * 9 / 10);
    EXPECT_EQ(mismatches, 0);
    // Partly covered: the ground below the horizon, nothing above it.
    EXPECT_GT(expected_set, 1000);
    EXPECT_EQ(mask.at<uint8_t>(camera.height_px - 1, camera.width_px / 2), 255);
    if (pitch_deg < 30.0) {
      EXPECT_EQ(mask.at<uint8_t>(0, camera.width_px / 2), 0);
    }
  }
}

// ----- Degenerate input --------------------------------------------------------------------

const PinholeCamera kSmallCamera = TestCamera(100, 80, 100.0, 50.0, 40.0);

TEST(RenderSilhouette, TrianglesBehindTheCameraDrawNothing) {
  TriangleMesh mesh;
  // Behind the camera; projected naively (dividing by a negative depth) it would cover the centre.
  AddTriangle(&mesh, {-1, -1, -2}, {1, -1, -2}, {0, 1, -1});
  // A vertex in front elsewhere keeps the near plane meaningful.
  AddTriangle(&mesh, {100, 100, 1}, {101, 100, 1}, {100, 101, 1});
  cv::Mat mask;
  RenderSilhouette(mesh, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 0);

  TriangleMesh all_behind;
  AddTriangle(&all_behind, {-1, -1, -2}, {1, -1, -2}, {0, 1, -1});
  RenderSilhouette(all_behind, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 0);
}

TEST(RenderSilhouette, TrianglesFarOutsideTheImageDrawNothingAndHugeOnesCoverIt) {
  TriangleMesh outside;
  AddTriangle(&outside, {1e6, 1e6, 1}, {2e6, 1e6, 1}, {1e6, 3e6, 1});
  AddTriangle(&outside, {-1e30, 1e30, 1}, {-2e30, 1e30, 1}, {-1e30, 3e30, 1});
  AddTriangle(&outside, {-1e30, -1e30, 1e-3}, {1e30, -1e30, 1e-3}, {0, -3e30, 1e-3});
  cv::Mat mask;
  RenderSilhouette(outside, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 0);

  TriangleMesh huge;
  AddTriangle(&huge, {-1e30, -1e30, 1}, {3e30, -1e30, 1}, {-1e30, 3e30, 1});
  RenderSilhouette(huge, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 100 * 80);
}

TEST(RenderSilhouette, DegenerateTrianglesDrawAtMostALine) {
  cv::Mat mask;
  // Collinear, diagonal.
  TriangleMesh diagonal;
  AddTriangle(&diagonal, {-0.2, -0.1, 1}, {0.1, 0.05, 1}, {0.3, 0.15, 1});
  RenderSilhouette(diagonal, kSmallCamera, Rigid3(), &mask);
  EXPECT_LE(cv::countNonZero(mask), 60);

  // Collinear along a pixel row (v = 40 + 100 * 0.25 = 65): a segment of that row, u in [50, 75].
  TriangleMesh on_row;
  AddTriangle(&on_row, {0, 0.25, 1}, {0.25, 0.25, 1}, {0.125, 0.25, 1});
  RenderSilhouette(on_row, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), 26);
  EXPECT_EQ(cv::countNonZero(mask.row(65)), 26);

  // A single point on a pixel centre.
  TriangleMesh point;
  AddTriangle(&point, {0.25, 0.25, 1}, {0.25, 0.25, 1}, {0.25, 0.25, 1});
  RenderSilhouette(point, kSmallCamera, Rigid3(), &mask);
  EXPECT_LE(cv::countNonZero(mask), 1);

  // Edge-on to the camera (its plane contains the camera centre).
  TriangleMesh edge_on;
  AddTriangle(&edge_on, {0, -0.1, 1}, {0, 0.2, 2}, {0, 0.1, 3});
  RenderSilhouette(edge_on, kSmallCamera, Rigid3(), &mask);
  EXPECT_LE(cv::countNonZero(mask), 80);
}

TEST(RenderSilhouette, NonFiniteTrianglesAreSkipped) {
  TriangleMesh good;
  AddTriangle(&good, {-0.2, -0.1, 1}, {0.3, -0.05, 1.2}, {0.0, 0.25, 0.9});
  TriangleMesh with_nan = good;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  AddTriangle(&with_nan, {-0.3, -0.3, 1}, {0.3, 0.3, 1}, {0.0, 0.3, 1});
  with_nan.vertices.back().x() = nan;
  AddTriangle(&with_nan, {-0.3, -0.3, 1}, {0.3, 0.3, 1}, {0.0, 0.3, 1});
  with_nan.vertices.back().z() = inf;
  cv::Mat expected, mask;
  RenderSilhouette(good, kSmallCamera, Rigid3(), &expected);
  RenderSilhouette(with_nan, kSmallCamera, Rigid3(), &mask);
  EXPECT_GT(cv::countNonZero(expected), 100);
  EXPECT_EQ(CountDifferences(mask, expected), 0);
}

TEST(RenderSilhouette, ReallocatesAndClearsTheMask) {
  TriangleMesh mesh;
  AddTriangle(&mesh, {-0.2, -0.1, 1}, {0.3, -0.05, 1.2}, {0.0, 0.25, 0.9});
  cv::Mat mask(7, 9, CV_32FC3, cv::Scalar(5, 5, 5));
  RenderSilhouette(mesh, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(mask.type(), CV_8UC1);
  EXPECT_EQ(mask.rows, 80);
  EXPECT_EQ(mask.cols, 100);
  const int count = cv::countNonZero(mask);
  mask.setTo(cv::Scalar(17));  // Same size and type: reused, must be cleared.
  RenderSilhouette(mesh, kSmallCamera, Rigid3(), &mask);
  EXPECT_EQ(cv::countNonZero(mask), count);
  EXPECT_TRUE(OnlyZeroOr255(mask));
}

TEST(RenderSilhouette, IsDeterministic) {
  const TriangleMesh sphere = Icosphere(1.0, 3, Eigen::Vector3d(0.1, 0.2, 0.3));
  ViewRenderOptions options;
  options.resolution_px = 100;
  cv::Mat first, second;
  RenderView(sphere, Eigen::Vector3d(0.3, -0.5, 0.8), 33.0, options, &first);
  RenderView(sphere, Eigen::Vector3d(0.3, -0.5, 0.8), 33.0, options, &second);
  EXPECT_GT(cv::countNonZero(first), 1000);
  EXPECT_EQ(CountDifferences(first, second), 0);
}

// ----- Back-face culling ---------------------------------------------------------------------

TEST(RenderSilhouette, BackFaceCullingKeepsTheSilhouetteOfClosedMeshes) {
  // The sample models (closed surfaces) and a subdivided sphere, from random directions and
  // distances outside the bounding sphere, at the database's framing and off-centre.
  std::vector<TriangleMesh> meshes;
  for (const char* name : {"bunny", "hand", "anchor"}) {
    meshes.push_back(
        LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / (std::string(name) + ".obj")));
  }
  meshes.push_back(Icosphere(1.0, 3, Eigen::Vector3d(0.1, 0.2, 0.3)));
  const PinholeCamera camera = PinholeCamera::Centered(256, 192, 240.0);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> roll(-180.0, 180.0);
  const double distances_in_radii[] = {1.05, 2.0, 3.0, 7.5, 20.0};
  int drawn_pixels = 0;
  for (const TriangleMesh& mesh : meshes) {
    ASSERT_TRUE(IsClosedSurface(mesh)) << mesh.name;
    for (int trial = 0; trial < 10; ++trial) {
      Eigen::Vector3d view(unit(random), unit(random), unit(random));
      if (view.norm() < 1e-3) view = Eigen::Vector3d::UnitX();
      const double distance = distances_in_radii[trial % 5] * mesh.Radius();
      Rigid3 pose = CameraFromObjectAtView(view, roll(random), distance, mesh.Centre());
      if (trial % 2 == 1) pose.translation.x() += 0.3 * distance;  // off the optical axis
      cv::Mat all, culled;
      RenderSilhouette(mesh, camera, pose, &all);
      RenderSilhouette(mesh, camera, pose, &culled, FaceCulling::kBackFaces);
      EXPECT_EQ(CountDifferences(all, culled), 0) << mesh.name << " trial " << trial;
      drawn_pixels += cv::countNonZero(culled);
    }
  }
  EXPECT_GT(drawn_pixels, 40 * 500);
}

TEST(RenderSilhouette, BackFaceCullingDrawsOnlyTrianglesFacingTheCamera) {
  // One triangle, wound one way and the other: culling keeps it only when it faces the camera.
  // (Alone it is not a closed surface, so culling changes its silhouette.)
  TriangleMesh triangle;
  AddTriangle(&triangle, {-0.2, -0.1, 1}, {0.0, 0.25, 0.9}, {0.3, -0.05, 1.2});
  TriangleMesh reversed;
  AddTriangle(&reversed, {-0.2, -0.1, 1}, {0.3, -0.05, 1.2}, {0.0, 0.25, 0.9});
  const PinholeCamera camera = TestCamera(100, 80, 90.0, 50.0, 40.0);
  cv::Mat front, back, all;
  RenderSilhouette(triangle, camera, Rigid3(), &all);
  ASSERT_GT(cv::countNonZero(all), 100);
  // Exactly one of the two windings faces the camera: that one draws all its pixels, the other
  // none.
  RenderSilhouette(triangle, camera, Rigid3(), &front, FaceCulling::kBackFaces);
  RenderSilhouette(reversed, camera, Rigid3(), &back, FaceCulling::kBackFaces);
  EXPECT_EQ(cv::countNonZero(front) + cv::countNonZero(back), cv::countNonZero(all));
  EXPECT_TRUE(cv::countNonZero(front) == 0 || cv::countNonZero(back) == 0);
  // The winding that faces the camera is the one whose normal (b - a) x (c - a) points towards it.
  const Eigen::Vector3d a(-0.2, -0.1, 1), b(0.0, 0.25, 0.9), c(0.3, -0.05, 1.2);
  const bool faces_camera = (b - a).cross(c - a).dot(a) < 0.0;
  EXPECT_EQ(cv::countNonZero(front) > 0, faces_camera);
}

// ----- Invalid arguments ---------------------------------------------------------------------

template <typename Function>
std::string ErrorMessage(Function&& function) {
  try {
    function();
  } catch (const Error& error) {
    return error.what();
  }
  return "(no silpose::Error thrown)";
}

TEST(RenderSilhouette, InvalidCameraThrows) {
  TriangleMesh mesh;
  AddTriangle(&mesh, {-0.2, -0.1, 1}, {0.3, -0.05, 1.2}, {0.0, 0.25, 0.9});
  cv::Mat mask;
  PinholeCamera camera = kSmallCamera;
  camera.width_px = 0;
  EXPECT_NE(
      ErrorMessage([&] { RenderSilhouette(mesh, camera, Rigid3(), &mask); }).find("invalid camera"),
      std::string::npos);
  camera = kSmallCamera;
  camera.focal_y_px = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(
      ErrorMessage([&] { RenderSilhouette(mesh, camera, Rigid3(), &mask); }).find("invalid camera"),
      std::string::npos);
}

TEST(RenderSilhouette, OutOfRangeVertexIndexThrows) {
  TriangleMesh mesh;
  mesh.name = "broken";
  AddTriangle(&mesh, {-0.2, -0.1, 1}, {0.3, -0.05, 1.2}, {0.0, 0.25, 0.9});
  mesh.triangles.push_back({0, 1, 3});
  cv::Mat mask;
  EXPECT_NE(
      ErrorMessage([&] { RenderSilhouette(mesh, kSmallCamera, Rigid3(), &mask); }).find("broken"),
      std::string::npos);
}

TEST(ViewRenderOptions, CheckNamesTheInvalidField) {
  EXPECT_TRUE(ViewRenderOptions().Check());
  struct Case {
    ViewRenderOptions options;
    const char* field;
  };
  std::vector<Case> cases;
  auto add = [&cases](auto modify, const char* field) {
    ViewRenderOptions options;
    modify(options);
    cases.push_back({options, field});
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  add([](ViewRenderOptions& o) { o.resolution_px = 31; }, "resolution_px");
  add([](ViewRenderOptions& o) { o.resolution_px = 16385; }, "resolution_px");
  add([](ViewRenderOptions& o) { o.distance_in_radii = 1.0; }, "distance_in_radii");
  add([nan](ViewRenderOptions& o) { o.distance_in_radii = nan; }, "distance_in_radii");
  add([inf](ViewRenderOptions& o) { o.distance_in_radii = inf; }, "distance_in_radii");
  add([](ViewRenderOptions& o) { o.fill_fraction = 0.0; }, "fill_fraction");
  add([](ViewRenderOptions& o) { o.fill_fraction = 1.01; }, "fill_fraction");
  add([nan](ViewRenderOptions& o) { o.fill_fraction = nan; }, "fill_fraction");

  TriangleMesh mesh;
  AddBox(&mesh, {0, 0, 0}, {1, 1, 1});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.field);
    std::string error;
    EXPECT_FALSE(c.options.Check(&error));
    EXPECT_FALSE(c.options.Check());
    EXPECT_NE(error.find(c.field), std::string::npos) << error;
    EXPECT_NE(ErrorMessage([&] { ViewCamera(c.options); }).find(c.field), std::string::npos);
    cv::Mat mask;
    EXPECT_NE(ErrorMessage([&] {
                RenderView(mesh, {1, 0, 0}, 0.0, c.options, &mask);
              }).find(c.field),
              std::string::npos);
  }
  ViewRenderOptions extremes;
  extremes.resolution_px = 32;
  extremes.fill_fraction = 1.0;
  extremes.distance_in_radii = 1.0001;
  EXPECT_TRUE(extremes.Check());
}

TEST(ViewCamera, FramesTheBoundingSphere) {
  ViewRenderOptions options;
  options.resolution_px = 300;
  options.distance_in_radii = 2.5;
  options.fill_fraction = 0.8;
  const PinholeCamera camera = ViewCamera(options);
  EXPECT_EQ(camera.width_px, 300);
  EXPECT_EQ(camera.height_px, 300);
  EXPECT_EQ(camera.principal_x_px, 149.5);
  EXPECT_EQ(camera.principal_y_px, 149.5);
  EXPECT_EQ(camera.focal_x_px, camera.focal_y_px);
  // The ray tangent to a sphere of radius r at distance 2.5 r makes the angle asin(1 / 2.5) with
  // the axis; it lands 0.8 * 150 px from the centre.
  EXPECT_NEAR(camera.focal_x_px * std::tan(std::asin(1.0 / 2.5)), 0.8 * 150.0, 1e-9);
}

TEST(RenderView, RejectsDegenerateMeshesAndViews) {
  cv::Mat mask;
  const ViewRenderOptions options;
  TriangleMesh empty;
  empty.name = "empty";
  EXPECT_NE(ErrorMessage([&] {
              RenderView(empty, {1, 0, 0}, 0.0, options, &mask);
            }).find("no triangles"),
            std::string::npos);
  TriangleMesh point;
  point.name = "point";
  point.vertices.push_back(Eigen::Vector3f(1, 2, 3));
  point.triangles.push_back({0, 0, 0});
  EXPECT_NE(ErrorMessage([&] {
              RenderView(point, {1, 0, 0}, 0.0, options, &mask);
            }).find("radius"),
            std::string::npos);
  TriangleMesh cube;
  AddBox(&cube, {0, 0, 0}, {1, 1, 1});
  EXPECT_NE(ErrorMessage([&] {
              RenderView(cube, {0, 0, 0}, 0.0, options, &mask);
            }).find("view direction"),
            std::string::npos);
}

}  // namespace
}  // namespace silpose
