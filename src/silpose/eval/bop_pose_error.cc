#include "silpose/eval/bop_pose_error.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include "silpose/util/error.h"

namespace silpose {

double AddError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth) {
  if (points.cols() == 0) return 0.0;
  // P_est x - P_true x = (R_e - R_t) x + (t_e - t_t).
  const Eigen::Matrix3d dr = estimated.rotation - truth.rotation;
  const Eigen::Vector3d dt = estimated.translation - truth.translation;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < points.cols(); ++i) sum += (dr * points.col(i) + dt).norm();
  return sum / static_cast<double>(points.cols());
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
