#include "silpose/pose/pose_error.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

std::vector<double> SortedFinite(std::span<const double> values) {
  std::vector<double> finite;
  finite.reserve(values.size());
  for (double v : values) {
    if (std::isfinite(v)) finite.push_back(v);
  }
  std::sort(finite.begin(), finite.end());
  return finite;
}

double SortedPercentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return std::nan("");
  const double position = p / 100.0 * static_cast<double>(sorted.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, sorted.size() - 1);
  const double fraction = position - static_cast<double>(below);
  return sorted[below] + fraction * (sorted[above] - sorted[below]);
}

}  // namespace

double RotationErrorDeg(const Eigen::Matrix3d& estimated, const Eigen::Matrix3d& truth) {
  return RotationAngleBetweenDeg(estimated, truth);
}

double ViewDirectionError(const Eigen::Vector3d& estimated, const Eigen::Vector3d& truth) {
  return (estimated.normalized() - truth.normalized()).norm();
}

Eigen::Vector3d ViewDirectionOfPose(const Rigid3& camera_from_object,
                                    const Eigen::Vector3d& object_centre) {
  const Eigen::Vector3d camera_centre =
      -(camera_from_object.rotation.transpose() * camera_from_object.translation);
  return (camera_centre - object_centre).normalized();
}

PoseError ComputePoseError(const Rigid3& estimated, const Rigid3& truth,
                           const Eigen::Vector3d& object_centre) {
  PoseError error;
  error.rotation_deg = RotationErrorDeg(estimated.rotation, truth.rotation);
  error.translation = (estimated.translation - truth.translation).norm();
  const double distance = truth.translation.norm();
  error.translation_relative = distance > 0.0 ? error.translation / distance : std::nan("");
  error.view_direction = ViewDirectionError(ViewDirectionOfPose(estimated, object_centre),
                                            ViewDirectionOfPose(truth, object_centre));
  return error;
}

std::string ErrorSummary::Describe() const {
  std::ostringstream stream;
  stream.precision(4);
  stream << "n=" << count;
  if (count > 0) {
    stream << " mean=" << mean << " median=" << median << " p90=" << percentile_90
           << " p95=" << percentile_95 << " max=" << max;
  }
  if (non_finite > 0) stream << " non-finite=" << non_finite;
  return stream.str();
}

double Percentile(std::span<const double> values, double p) {
  if (!(p >= 0.0 && p <= 100.0)) ThrowError("percentile must be in [0, 100], got ", p);
  return SortedPercentile(SortedFinite(values), p);
}

ErrorSummary Summarize(std::span<const double> values) {
  const std::vector<double> sorted = SortedFinite(values);
  ErrorSummary summary;
  summary.count = static_cast<int>(sorted.size());
  summary.non_finite = static_cast<int>(values.size() - sorted.size());
  if (sorted.empty()) return summary;
  double sum = 0.0;
  for (double v : sorted) sum += v;
  summary.mean = sum / static_cast<double>(sorted.size());
  summary.min = sorted.front();
  summary.max = sorted.back();
  summary.median = SortedPercentile(sorted, 50.0);
  summary.percentile_90 = SortedPercentile(sorted, 90.0);
  summary.percentile_95 = SortedPercentile(sorted, 95.0);
  return summary;
}

}  // namespace silpose
