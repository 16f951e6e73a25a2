#include "silpose/pose/on_axis.h"

#include <cmath>
#include <numbers>
#include <vector>

#include "silpose/pose/lens_distortion.h"
#include "silpose/pose/pose_from_silhouette.h"

namespace silpose {

bool DescribeOnAxis(std::span<const Eigen::Vector2d> outline_px, const PinholeCamera& camera,
                    const SignatureOptions& options, OnAxisSilhouette* result) {
  if (outline_px.size() < 3) return false;
  const bool distorted = HasDistortion(camera);
  std::vector<Eigen::Vector3d> rays(outline_px.size());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < outline_px.size(); ++i) {
    Eigen::Vector2d ideal((outline_px[i].x() - camera.principal_x_px) / camera.focal_x_px,
                          (outline_px[i].y() - camera.principal_y_px) / camera.focal_y_px);
    if (distorted && !PixelToIdealNormalized(camera, outline_px[i], &ideal)) return false;
    if (!ideal.allFinite()) return false;
    rays[i] = Eigen::Vector3d(ideal.x(), ideal.y(), 1.0);
    mean += ideal;
  }
  mean /= static_cast<double>(outline_px.size());
  const double focal = std::sqrt(camera.focal_x_px * camera.focal_y_px);
  const double min_cos = std::cos(80.0 * std::numbers::pi / 180.0);

  Eigen::Vector3d axis = Eigen::Vector3d(mean.x(), mean.y(), 1.0).normalized();
  Eigen::Matrix3d rotation;
  std::vector<Eigen::Vector2d> mapped(rays.size());
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double signed_area = 0.0;
  constexpr int kIterations = 4;
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    rotation = RotationFromOpticalAxisTo(axis);
    const Eigen::Matrix3d virtual_from_camera = rotation.transpose();
    for (size_t i = 0; i < rays.size(); ++i) {
      const Eigen::Vector3d v = virtual_from_camera * rays[i];
      if (!(v.z() > min_cos * v.norm())) return false;
      mapped[i] = focal * Eigen::Vector2d(v.x() / v.z(), v.y() / v.z());
    }
    signed_area = PolygonAreaCentroid(mapped, &centroid);
    if (!centroid.allFinite()) return false;
    if (centroid.norm() < 1e-3) break;
    const Eigen::Vector3d moved =
        rotation * Eigen::Vector3d(centroid.x() / focal, centroid.y() / focal, 1.0);
    if (!(moved.z() > min_cos * moved.norm())) return false;
    axis = moved.normalized();
  }

  PolarSignature& signature = result->signature;
  signature = PolarSignature{};
  signature.radii = StarConvexRadii(mapped, centroid, options.length, &signature.missed_directions);
  // Half a pixel outside the boundary pixels' centres, as for database silhouettes; in virtual
  // pixels it is half a pixel times the local scale, close to 1 near the centre.
  double sum = 0.0;
  for (float& r : signature.radii) {
    if (r > 0.0f) r += 0.5f;
    sum += r;
  }
  const double mean_radius = sum / static_cast<double>(options.length);
  if (!(mean_radius > 0.0) || !std::isfinite(mean_radius)) return false;
  double sum_squares = 0.0;
  for (float& r : signature.radii) {
    r = static_cast<float>(r / mean_radius);
    sum_squares += (r - 1.0) * (r - 1.0);
  }
  signature.mean_radius_px = mean_radius;
  signature.centroid_px = centroid;
  signature.area_px = std::abs(signed_area);
  signature.relative_std = std::sqrt(sum_squares / static_cast<double>(options.length));
  result->camera_from_virtual = rotation;
  result->focal_px = focal;
  result->apparent_radius = mean_radius / focal;
  // The virtual axis is where `rotation` (the one the outline was mapped with) takes e_z.
  result->off_axis_deg = std::acos(std::min(1.0, rotation(2, 2))) * 180.0 / std::numbers::pi;
  return true;
}

}  // namespace silpose
