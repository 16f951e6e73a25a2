#include "silpose/mesh/mesh_symmetry.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

// Evenly spread points on the surface: sample k falls in the triangle that holds the area
// fraction (k + 0.5) / count, at barycentric coordinates from an additive recurrence (R2
// sequence) offset by `phase`. Deterministic.
Eigen::Matrix3Xd SampleSurface(const TriangleMesh& mesh, const std::vector<double>& cumulative,
                               int count, double phase) {
  Eigen::Matrix3Xd points(3, count);
  const double total = cumulative.back();
  constexpr double kA1 = 0.7548776662466927, kA2 = 0.5698402909980532;
  for (int k = 0; k < count; ++k) {
    const double target = (k + 0.5) / count * total;
    const size_t t = static_cast<size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin());
    const auto& tri = mesh.triangles[std::min(t, mesh.triangles.size() - 1)];
    double a = std::fmod(phase + kA1 * k, 1.0), b = std::fmod(phase + kA2 * k, 1.0);
    if (a + b > 1.0) {
      a = 1.0 - a;
      b = 1.0 - b;
    }
    const Eigen::Vector3d p0 = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d p1 = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d p2 = mesh.vertices[tri[2]].cast<double>();
    points.col(k) = p0 + a * (p1 - p0) + b * (p2 - p0);
  }
  return points;
}

class SymmetryTester {
 public:
  SymmetryTester(Eigen::Matrix3Xd queries, const Eigen::Matrix3Xd& reference, double limit,
                 double quantile)
      : queries_(std::move(queries)),
        index_(reference),
        limit_(limit),
        allowed_misses_(
            static_cast<int>(std::floor((1.0 - quantile) * static_cast<double>(queries_.cols())))) {
  }

  // Whether the surface moved by `transform` lies on the surface (see the header).
  template <typename Transform>
  bool Passes(const Transform& transform) const {
    int misses = 0;
    for (Eigen::Index i = 0; i < queries_.cols(); ++i) {
      if (index_.NearestDistance(transform(Eigen::Vector3d(queries_.col(i)))) > limit_ &&
          ++misses > allowed_misses_)
        return false;
    }
    return true;
  }

  bool RotationPasses(const Eigen::Vector3d& axis, const Eigen::Vector3d& centre,
                      double angle) const {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    return Passes(
        [&](const Eigen::Vector3d& x) { return Eigen::Vector3d(r * (x - centre) + centre); });
  }

  bool MirrorPasses(const Eigen::Vector3d& normal, const Eigen::Vector3d& centre) const {
    return Passes([&](const Eigen::Vector3d& x) {
      return Eigen::Vector3d(x - 2.0 * (x - centre).dot(normal) * normal);
    });
  }

 private:
  Eigen::Matrix3Xd queries_;
  NearestPointIndex index_;
  double limit_;
  int allowed_misses_;
};

Rigid3 RotationAbout(const Eigen::Vector3d& axis, const Eigen::Vector3d& centre, double angle) {
  Rigid3 s;
  s.rotation = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  s.translation = centre - s.rotation * centre;
  return s;
}

void AddMirror(const Eigen::Vector3d& normal, const Eigen::Vector3d& centre,
               std::vector<MirrorSymmetry>* mirrors) {
  for (const MirrorSymmetry& m : *mirrors) {
    if (std::abs(m.normal.dot(normal)) > std::cos(kPi / 180.0)) return;
  }
  mirrors->push_back({.normal = normal, .offset = centre});
}

}  // namespace

bool SymmetryDetectionOptions::Check(std::string* error) const {
  const auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(tolerance > 0.0 && tolerance < 1.0)) return fail("tolerance must be in (0, 1)");
  if (!(quantile > 0.0 && quantile <= 1.0)) return fail("quantile must be in (0, 1]");
  if (max_order < 2 || max_order > 360) return fail("max_order must be in 2..360");
  if (samples < 1 || samples > 1000000 || reference_samples < 1 || reference_samples > 10000000)
    return fail("sample counts must be in 1..1000000 and 1..10000000");
  return true;
}

ObjectSymmetry DetectSymmetry(const TriangleMesh& mesh, const SymmetryDetectionOptions& options) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("symmetry detection: ", problem);
  ObjectSymmetry result;
  if (mesh.triangles.empty()) return result;
  std::vector<double> cumulative;
  cumulative.reserve(mesh.triangles.size());
  double total = 0.0;
  Eigen::Vector3d weighted_centre = Eigen::Vector3d::Zero();
  for (const auto& tri : mesh.triangles) {
    const Eigen::Vector3d p0 = mesh.vertices[tri[0]].cast<double>();
    const Eigen::Vector3d p1 = mesh.vertices[tri[1]].cast<double>();
    const Eigen::Vector3d p2 = mesh.vertices[tri[2]].cast<double>();
    double area = 0.5 * (p1 - p0).cross(p2 - p0).norm();
    if (!std::isfinite(area)) area = 0.0;
    total += area;
    weighted_centre += area * (p0 + p1 + p2) / 3.0;
    cumulative.push_back(total);
  }
  const double diameter = 2.0 * mesh.Radius();
  if (!(total > 0.0) || !std::isfinite(total) || !(diameter > 0.0)) return result;
  const Eigen::Vector3d centre = weighted_centre / total;

  // The surface's exact second moments about the centroid: over a triangle (a, b, c) of area A,
  // the integral of x x^T is A / 12 (a a^T + b b^T + c c^T + s s^T), s = a + b + c.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const double area = cumulative[t] - (t > 0 ? cumulative[t - 1] : 0.0);
    if (!(area > 0.0)) continue;
    const auto& tri = mesh.triangles[t];
    const Eigen::Vector3d a = mesh.vertices[tri[0]].cast<double>() - centre;
    const Eigen::Vector3d b = mesh.vertices[tri[1]].cast<double>() - centre;
    const Eigen::Vector3d c = mesh.vertices[tri[2]].cast<double>() - centre;
    const Eigen::Vector3d sum = a + b + c;
    covariance +=
        area / 12.0 *
        (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance / total);
  const Eigen::Matrix3Xd reference =
      SampleSurface(mesh, cumulative, options.reference_samples, 0.5);
  const SymmetryTester tester(SampleSurface(mesh, cumulative, options.samples, 0.25), reference,
                              options.tolerance * diameter, options.quantile);

  // The primary axis: continuous, or of the highest discrete order found.
  std::optional<Eigen::Vector3d> primary;
  bool primary_continuous = false;
  int primary_order = 1;
  std::vector<Eigen::Vector3d> half_turn_axes;
  for (int i = 2; i >= 0; --i) {
    const Eigen::Vector3d axis = eigen.eigenvectors().col(i).normalized();
    const bool continuous = tester.RotationPasses(axis, centre, 23.0 * kPi / 180.0) &&
                            tester.RotationPasses(axis, centre, 71.0 * kPi / 180.0) &&
                            tester.RotationPasses(axis, centre, 137.0 * kPi / 180.0) &&
                            tester.RotationPasses(axis, centre, 211.0 * kPi / 180.0);
    if (continuous) {
      if (!primary_continuous) {
        primary = axis;
        primary_continuous = true;
      }
      continue;
    }
    int order = 1;
    // The largest n whose turn passes while half of it fails: turns too small to move the
    // surface beyond the tolerance pass for every axis, and are not symmetries. Every multiple of
    // the turn must pass too (the turns of a symmetry form a group): a turn close to a true
    // symmetry can pass on its own (an eight-sided solid turned by 36 degrees lies within the
    // tolerance of its 45-degree turn when its flat faces carry most of the surface), but its
    // multiples drift away from the true ones (72 degrees is 18 from 90).
    const auto all_multiples_pass = [&](int n) {
      for (int k = 2; k < n; ++k) {
        if (!tester.RotationPasses(axis, centre, 2.0 * kPi * k / n)) return false;
      }
      return true;
    };
    for (int n = options.max_order; n >= 2; --n) {
      if (tester.RotationPasses(axis, centre, 2.0 * kPi / n) &&
          !tester.RotationPasses(axis, centre, kPi / n) && all_multiples_pass(n)) {
        order = n;
        break;
      }
    }
    if (order == 2) half_turn_axes.push_back(axis);
    if (order >= 3 && !primary_continuous && order > primary_order) {
      primary = axis;
      primary_order = order;
    }
  }

  if (primary_continuous) {
    result.continuous.push_back({.axis = *primary, .offset = centre});
    // A flip (half turn about an axis across the continuous one): one represents them all.
    const Eigen::Vector3d across = FixedPerpendicular(*primary);
    if (tester.RotationPasses(across, centre, kPi))
      result.discrete.push_back(RotationAbout(across, centre, kPi));
    AddMirror(across, centre, &result.mirrors);
  } else if (primary) {
    const int n = primary_order;
    for (int k = 1; k < n; ++k)
      result.discrete.push_back(RotationAbout(*primary, centre, 2.0 * kPi * k / n));
    // Flips and mirror planes containing the axis repeat every 180 / n degrees: scan one period.
    const Eigen::Vector3d u = FixedPerpendicular(*primary), v = primary->cross(u);
    constexpr int kSteps = 64;
    std::optional<double> flip, mirror;
    for (int s = 0; s < kSteps && !(flip && mirror); ++s) {
      const double angle = kPi / n * s / kSteps;
      const Eigen::Vector3d direction = std::cos(angle) * u + std::sin(angle) * v;
      if (!flip && tester.RotationPasses(direction, centre, kPi)) flip = angle;
      if (!mirror && tester.MirrorPasses(direction, centre)) mirror = angle;
    }
    if (flip) {
      for (int k = 0; k < n; ++k) {
        const double angle = *flip + kPi * k / n;
        result.discrete.push_back(
            RotationAbout(std::cos(angle) * u + std::sin(angle) * v, centre, kPi));
      }
    }
    if (mirror) {
      for (int k = 0; k < n; ++k) {
        const double angle = *mirror + kPi * k / n;
        AddMirror(std::cos(angle) * u + std::sin(angle) * v, centre, &result.mirrors);
      }
    }
  } else {
    for (const Eigen::Vector3d& axis : half_turn_axes)
      result.discrete.push_back(RotationAbout(axis, centre, kPi));
  }
  // Mirror planes across the principal axes (for a continuous axis, only the one across it: the
  // others are arbitrary directions of a plane of equal moments).
  for (int i = 2; i >= 0; --i) {
    const Eigen::Vector3d normal = eigen.eigenvectors().col(i).normalized();
    if (primary_continuous && std::abs(normal.dot(*primary)) < 0.99) continue;
    if (tester.MirrorPasses(normal, centre)) AddMirror(normal, centre, &result.mirrors);
  }
  return result;
}

}  // namespace silpose
