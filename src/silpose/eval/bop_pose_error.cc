#include "silpose/eval/bop_pose_error.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "silpose/util/error.h"

namespace silpose {

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

double AddError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth) {
  if (points.cols() == 0) return 0.0;
  // P_est x - P_true x = (R_e - R_t) x + (t_e - t_t).
  const Eigen::Matrix3d dr = estimated.rotation - truth.rotation;
  const Eigen::Vector3d dt = estimated.translation - truth.translation;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < points.cols(); ++i) sum += (dr * points.col(i) + dt).norm();
  return sum / static_cast<double>(points.cols());
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

double AddSError(const Eigen::Matrix3Xd& points, const NearestPointIndex& index,
                 const Rigid3& estimated, const Rigid3& truth) {
  if (points.cols() == 0) return 0.0;
  // Distances are rigid-invariant: bring the estimated points into the true model frame,
  // y = P_true^-1 P_est x, and look up their nearest model vertices there.
  const Rigid3 true_from_estimated = truth.Inverse() * estimated;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    sum += index.NearestDistance(true_from_estimated * Eigen::Vector3d(points.col(i)));
  return sum / static_cast<double>(points.cols());
}

namespace {

// min over symmetries of max over points of distance(a(x), b(S x)), with early exit of a
// symmetry once its running maximum exceeds the best so far.
template <typename Distance>
double MinMaxOverSymmetries(const Eigen::Matrix3Xd& points, std::span<const Rigid3> symmetries,
                            const Rigid3& truth, const Distance& distance) {
  static const Rigid3 kIdentity;
  const std::span<const Rigid3> set =
      symmetries.empty() ? std::span<const Rigid3>(&kIdentity, 1) : symmetries;
  double best = std::numeric_limits<double>::infinity();
  for (const Rigid3& symmetry : set) {
    const Rigid3 truth_symmetric = truth * symmetry;
    double worst = 0.0;
    for (Eigen::Index i = 0; i < points.cols() && worst < best; ++i)
      worst = std::max(worst, distance(Eigen::Vector3d(points.col(i)), truth_symmetric));
    best = std::min(best, worst);
  }
  return points.cols() == 0 ? 0.0 : best;
}

}  // namespace

double MssdError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth,
                 std::span<const Rigid3> symmetries) {
  return MinMaxOverSymmetries(points, symmetries, truth,
                              [&](const Eigen::Vector3d& x, const Rigid3& truth_symmetric) {
                                return (estimated * x - truth_symmetric * x).norm();
                              });
}

double MspdError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth,
                 std::span<const Rigid3> symmetries, const PinholeCamera& camera) {
  return MinMaxOverSymmetries(
      points, symmetries, truth, [&](const Eigen::Vector3d& x, const Rigid3& truth_symmetric) {
        return (camera.Project(estimated * x) - camera.Project(truth_symmetric * x)).norm();
      });
}

std::vector<double> MssdThresholds(double diameter) {
  std::vector<double> thresholds;
  for (int k = 1; k <= 10; ++k) thresholds.push_back(0.05 * k * diameter);
  return thresholds;
}

std::vector<double> MspdThresholds(int image_width_px) {
  std::vector<double> thresholds;
  const double scale = 640.0 / std::max(image_width_px, 1);
  for (int k = 1; k <= 10; ++k) thresholds.push_back(5.0 * k * scale);
  return thresholds;
}

double Recall(std::span<const double> errors, double threshold) {
  if (errors.empty()) return 0.0;
  const auto hits = std::count_if(errors.begin(), errors.end(), [threshold](double e) {
    return std::isfinite(e) && e < threshold;
  });
  return static_cast<double>(hits) / static_cast<double>(errors.size());
}

double AverageRecall(std::span<const double> errors, std::span<const double> thresholds) {
  if (thresholds.empty()) ThrowError("average recall needs at least one threshold");
  double sum = 0.0;
  for (double threshold : thresholds) sum += Recall(errors, threshold);
  return sum / static_cast<double>(thresholds.size());
}

}  // namespace silpose
