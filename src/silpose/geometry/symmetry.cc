#include "silpose/geometry/symmetry.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {
namespace {

bool IsRotation(const Eigen::Matrix3d& r) {
  return r.allFinite() && (r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
         std::abs(r.determinant() - 1.0) < 1e-6;
}

std::string FormatVector(const Eigen::Vector3d& v) {
  std::ostringstream out;
  const Eigen::Vector3d u = v.normalized();
  // Rounded to 3 decimals, without "-0".
  const auto round = [](double x) {
    const double r = std::round(x * 1000.0) / 1000.0;
    return r == 0.0 ? 0.0 : r;
  };
  out << "(" << round(u.x()) << ", " << round(u.y()) << ", " << round(u.z()) << ")";
  return out.str();
}

}  // namespace

Eigen::Vector3d FixedPerpendicular(const Eigen::Vector3d& axis) {
  Eigen::Index least = 0;
  axis.cwiseAbs().minCoeff(&least);
  return axis.cross(Eigen::Vector3d::Unit(least)).normalized();
}

Rigid3 MirrorTwinPose(const Rigid3& camera_from_object, const MirrorSymmetry& mirror,
                      const Eigen::Vector3d& centre_in_object) {
  // The mirror in the model frame: x -> A x + b.
  const Eigen::Vector3d n = mirror.normal.normalized();
  const Eigen::Matrix3d a = Eigen::Matrix3d::Identity() - 2.0 * n * n.transpose();
  const Eigen::Vector3d b = 2.0 * mirror.offset.dot(n) * n;
  // The reflection along the line of sight u through the centre c: p -> H p + 2 (c . u) u.
  const Eigen::Vector3d centre = camera_from_object * centre_in_object;
  const double depth = centre.norm();
  if (!(depth > 0.0)) ThrowError("MirrorTwinPose: the object centre is at the camera centre");
  const Eigen::Vector3d u = centre / depth;
  const Eigen::Matrix3d h = Eigen::Matrix3d::Identity() - 2.0 * u * u.transpose();
  Rigid3 twin;
  twin.rotation = h * camera_from_object.rotation * a;
  twin.translation =
      h * (camera_from_object.rotation * b + camera_from_object.translation) + 2.0 * depth * u;
  return twin;
}

std::string ObjectSymmetry::Describe() const {
  if (!HasRotations() && mirrors.empty()) return "none";
  std::ostringstream out;
  const char* separator = "";
  for (const ContinuousSymmetry& c : continuous) {
    out << separator << "continuous about " << FormatVector(c.axis);
    separator = "; ";
  }
  if (!discrete.empty()) {
    out << separator << discrete.size() << " discrete rotation" << (discrete.size() > 1 ? "s" : "")
        << " (";
    for (size_t i = 0; i < discrete.size() && i < 3; ++i) {
      const Eigen::AngleAxisd aa(discrete[i].rotation);
      out << (i > 0 ? ", " : "") << std::lround(aa.angle() * 180.0 / std::numbers::pi)
          << " deg about " << FormatVector(aa.axis());
    }
    if (discrete.size() > 3) out << ", ...";
    out << ")";
    separator = "; ";
  }
  if (!mirrors.empty()) {
    out << separator << mirrors.size() << " mirror plane" << (mirrors.size() > 1 ? "s" : "")
        << " (normal";
    for (size_t i = 0; i < mirrors.size() && i < 3; ++i)
      out << (i > 0 ? ", " : " ") << FormatVector(mirrors[i].normal);
    if (mirrors.size() > 3) out << ", ...";
    out << ")";
  }
  return out.str();
}

bool ObjectSymmetry::Check(std::string* error) const {
  const auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (discrete.size() > kMaxEntries || continuous.size() > kMaxEntries ||
      mirrors.size() > kMaxEntries)
    return fail("more than 256 symmetries of one kind");
  for (const Rigid3& s : discrete) {
    if (!IsRotation(s.rotation) || !s.translation.allFinite())
      return fail("a discrete symmetry is not a finite rotation");
  }
  for (const ContinuousSymmetry& c : continuous) {
    if (!c.axis.allFinite() || !(c.axis.norm() > 0.0) || !c.offset.allFinite())
      return fail("a continuous symmetry has a zero or non-finite axis");
  }
  for (const MirrorSymmetry& m : mirrors) {
    if (!m.normal.allFinite() || !(m.normal.norm() > 0.0) || !m.offset.allFinite())
      return fail("a mirror plane has a zero or non-finite normal");
  }
  return true;
}

std::vector<Rigid3> SymmetryTransforms(std::span<const Rigid3> discrete,
                                       std::span<const ContinuousSymmetry> continuous,
                                       double max_step_fraction) {
  if (!(max_step_fraction > 0.0 && max_step_fraction <= 1.0))
    ThrowError("symmetry sampling step must be in (0, 1], got ", max_step_fraction);
  std::vector<Rigid3> result(1);  // identity
  result.insert(result.end(), discrete.begin(), discrete.end());
  // Samples per turn: a point at diameter / 2 from the axis moves (diameter / 2) * (2 pi / n)
  // per sample, at most max_step_fraction * diameter.
  const int samples = static_cast<int>(std::ceil(std::numbers::pi / max_step_fraction));
  for (const ContinuousSymmetry& symmetry : continuous) {
    const double norm = symmetry.axis.norm();
    if (!(norm > 0.0) || !std::isfinite(norm))
      ThrowError("continuous symmetry with a zero or non-finite axis");
    if (static_cast<double>(result.size()) * samples > 100000.0)
      ThrowError("too many symmetry transforms (more than 100000)");
    const Eigen::Vector3d axis = symmetry.axis / norm;
    std::vector<Rigid3> combined;
    combined.reserve(result.size() * static_cast<size_t>(samples));
    for (int k = 0; k < samples; ++k) {
      const double angle = 2.0 * std::numbers::pi * k / samples;
      Rigid3 rotation;
      rotation.rotation = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      rotation.translation = symmetry.offset - rotation.rotation * symmetry.offset;
      for (const Rigid3& before : result) combined.push_back(rotation * before);
    }
    result = std::move(combined);
  }
  return result;
}

NearestPointIndex::NearestPointIndex(const Eigen::Matrix3Xd& points) : points_(points) {
  if (points_.cols() == 0) ThrowError("nearest-point index: no points");
  nodes_.reserve(static_cast<size_t>(2 * points_.cols() / 8 + 2));
  Build(0, static_cast<int>(points_.cols()));
}

int NearestPointIndex::Build(int begin, int end) {
  const int id = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{.begin = begin, .end = end});
  constexpr int kLeafSize = 8;
  if (end - begin <= kLeafSize) return id;
  const auto block = points_.middleCols(begin, end - begin);
  const Eigen::Vector3d extent = block.rowwise().maxCoeff() - block.rowwise().minCoeff();
  int axis = 0;
  extent.maxCoeff(&axis);
  // Median split along the widest axis: reorder the columns by a permutation.
  std::vector<int> order(static_cast<size_t>(end - begin));
  std::iota(order.begin(), order.end(), begin);
  const auto middle = order.begin() + (end - begin) / 2;
  std::nth_element(order.begin(), middle, order.end(),
                   [&](int a, int b) { return points_(axis, a) < points_(axis, b); });
  Eigen::Matrix3Xd reordered(3, end - begin);
  for (size_t k = 0; k < order.size(); ++k)
    reordered.col(static_cast<Eigen::Index>(k)) = points_.col(order[k]);
  points_.middleCols(begin, end - begin) = reordered;
  const int mid = begin + (end - begin) / 2;
  const double split = points_(axis, mid);
  const int left = Build(begin, mid);
  const int right = Build(mid, end);
  Node& node = nodes_[static_cast<size_t>(id)];
  node.axis = axis;
  node.split = split;
  node.left = left;
  node.right = right;
  return id;
}

void NearestPointIndex::Search(int id, const Eigen::Vector3d& query, double* best_squared) const {
  const Node& node = nodes_[static_cast<size_t>(id)];
  if (node.left < 0) {
    for (int i = node.begin; i < node.end; ++i)
      *best_squared = std::min(*best_squared, (points_.col(i) - query).squaredNorm());
    return;
  }
  // Points left of the split have coordinate <= split, those right >= split.
  const double offset = query[node.axis] - node.split;
  const int near = offset < 0.0 ? node.left : node.right;
  const int far = offset < 0.0 ? node.right : node.left;
  Search(near, query, best_squared);
  if (offset * offset < *best_squared) Search(far, query, best_squared);
}

double NearestPointIndex::NearestDistance(const Eigen::Vector3d& query) const {
  double best = std::numeric_limits<double>::infinity();
  Search(0, query, &best);
  return std::sqrt(best);
}

std::vector<Rigid3> SymmetryTransforms(const ObjectSymmetry& symmetry, double max_step_fraction) {
  return SymmetryTransforms(symmetry.discrete, symmetry.continuous, max_step_fraction);
}

double RotationErrorModuloSymmetryDeg(const Eigen::Matrix3d& estimated,
                                      const Eigen::Matrix3d& truth,
                                      std::span<const Rigid3> transforms) {
  double best = RotationAngleBetweenDeg(estimated, truth);
  for (const Rigid3& s : transforms)
    best = std::min(best, RotationAngleBetweenDeg(estimated * s.rotation, truth));
  return best;
}

double ViewErrorModuloSymmetry(const Eigen::Vector3d& estimated, const Eigen::Vector3d& truth,
                               std::span<const Rigid3> transforms) {
  const Eigen::Vector3d e = estimated.normalized();
  const Eigen::Vector3d t = truth.normalized();
  double best = (e - t).norm();
  for (const Rigid3& s : transforms) best = std::min(best, (s.rotation.transpose() * e - t).norm());
  return best;
}

ViewEquivalence::ViewEquivalence(const ObjectSymmetry& symmetry) {
  for (const Rigid3& s : symmetry.discrete) rotations_.push_back(s.rotation);
  if (!symmetry.continuous.empty() && symmetry.continuous.front().axis.norm() > 0.0) {
    continuous_ = true;
    axis_ = symmetry.continuous.front().axis.normalized();
  }
}

double ViewEquivalence::AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const {
  double best = std::numeric_limits<double>::infinity();
  const double b_to_axis = continuous_ ? std::acos(std::clamp(b.dot(axis_), -1.0, 1.0)) : 0.0;
  for (const Eigen::Matrix3d& r : rotations_) {
    const Eigen::Vector3d u = r.transpose() * a;
    const double angle = continuous_
                             ? std::abs(std::acos(std::clamp(u.dot(axis_), -1.0, 1.0)) - b_to_axis)
                             : std::acos(std::clamp(u.dot(b), -1.0, 1.0));
    best = std::min(best, angle);
  }
  return best * 180.0 / std::numbers::pi;
}

Eigen::Matrix3d NearestEquivalentRotation(const Eigen::Matrix3d& rotation,
                                          const Eigen::Matrix3d& reference,
                                          const ObjectSymmetry& symmetry) {
  if (!symmetry.HasRotations()) return rotation;
  Eigen::Matrix3d best = rotation;
  double best_angle = std::numeric_limits<double>::infinity();
  const auto consider = [&](const Eigen::Matrix3d& candidate) {
    Eigen::Matrix3d nearest = candidate;
    for (const ContinuousSymmetry& c : symmetry.continuous) {
      // The turn about the axis nearest the difference: the twist of its quaternion.
      const Eigen::Vector3d axis = c.axis.normalized();
      const Eigen::Quaterniond difference(Eigen::Matrix3d(nearest.transpose() * reference));
      const double twist = 2.0 * std::atan2(difference.vec().dot(axis), difference.w());
      nearest = nearest * Eigen::AngleAxisd(twist, axis).toRotationMatrix();
    }
    const double angle =
        Eigen::AngleAxisd(Eigen::Matrix3d(nearest.transpose() * reference)).angle();
    if (angle < best_angle) {
      best_angle = angle;
      best = nearest;
    }
  };
  consider(rotation);
  for (const Rigid3& s : symmetry.discrete) consider(rotation * s.rotation);
  return best;
}

Rigid3 CanonicalSymmetry(const Eigen::Vector3d& view_dir_in_object,
                         const ObjectSymmetry& symmetry) {
  if (!symmetry.HasRotations()) return Rigid3();
  const double norm = view_dir_in_object.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return Rigid3();
  const Eigen::Vector3d d = view_dir_in_object / norm;
  // The reference direction: generic for discrete symmetries; for a continuous one, a fixed
  // perpendicular to its axis tilted towards the axis (which also orders the discrete flips).
  Eigen::Vector3d reference = Eigen::Vector3d(0.802, 0.503, 0.322).normalized();
  const ContinuousSymmetry* continuous =
      symmetry.continuous.empty() ? nullptr : &symmetry.continuous.front();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ(), perpendicular = Eigen::Vector3d::UnitX();
  if (continuous) {
    axis = continuous->axis.normalized();
    perpendicular = FixedPerpendicular(axis);
    reference = (perpendicular + 0.3 * axis).normalized();
  }
  Rigid3 best;
  double best_score = -std::numeric_limits<double>::infinity();
  const auto consider = [&](const Rigid3& discrete) {
    Rigid3 s = discrete;
    Eigen::Vector3d u = discrete.rotation.transpose() * d;
    if (continuous) {
      // Turn about the axis so that u's part across the axis points along `perpendicular`.
      const Eigen::Vector3d across = u - u.dot(axis) * axis;
      double angle = 0.0;
      if (across.norm() > 1e-12)
        angle = std::atan2(perpendicular.cross(across).dot(axis), perpendicular.dot(across));
      Rigid3 turn;
      turn.rotation = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      turn.translation = continuous->offset - turn.rotation * continuous->offset;
      s = discrete * turn;
      u = turn.rotation.transpose() * u;
    }
    const double score = reference.dot(u);
    if (score > best_score + 1e-12) {
      best_score = score;
      best = s;
    }
  };
  consider(Rigid3());
  for (const Rigid3& discrete : symmetry.discrete) consider(discrete);
  return best;
}

}  // namespace silpose
