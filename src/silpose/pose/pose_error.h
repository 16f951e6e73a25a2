#pragma once
// Pose errors against ground truth, and their summaries.
//
// Poses are object_to_camera = camera_from_object (geometry/rigid3.h): x_cam = R x_obj + t, t in
// model units. The errors:
//  - rotation: the angle of R_est^T R_true, degrees in [0, 180];
//  - translation: |t_est - t_true| in model units, and that divided by |t_true| (the distance
//    from the camera centre to the model origin; the object centre for models centred at it);
//  - view direction (the paper's pose error, section 5.1): the Euclidean distance between the
//    estimated and true unit view directions (object centre -> camera centre, model frame), in
//    [0, 2]. Of a pose it is taken as normalize(-R^T t - c), c = object centre; for an object on
//    the optical axis that is the view direction (docs/conventions.md) -R.row(2).

#include <Eigen/Core>
#include <span>
#include <string>

#include "silpose/geometry/rigid3.h"

namespace silpose {

/// Angle of R_a^T R_b in degrees, [0, 180]. The matrices should be rotations.
double RotationErrorDeg(const Eigen::Matrix3d& estimated, const Eigen::Matrix3d& truth);

/// Euclidean distance between two view directions after normalising them (non-zero), [0, 2].
double ViewDirectionError(const Eigen::Vector3d& estimated, const Eigen::Vector3d& truth);

/// Unit direction from the object centre towards the camera centre, model frame, of a pose.
Eigen::Vector3d ViewDirectionOfPose(const Rigid3& camera_from_object,
                                    const Eigen::Vector3d& object_centre);

/// All errors of one estimate.
struct PoseError {
  double rotation_deg = 0.0;
  /// |t_est - t_true|, model units.
  double translation = 0.0;
  /// translation / |t_true|.
  double translation_relative = 0.0;
  /// Paper metric, [0, 2].
  double view_direction = 0.0;
};

/// Errors of `estimated` against `truth`; `object_centre` (model frame) for the view directions.
/// translation_relative is NaN if |t_true| = 0.
PoseError ComputePoseError(const Rigid3& estimated, const Rigid3& truth,
                           const Eigen::Vector3d& object_centre = Eigen::Vector3d::Zero());

/// Summary statistics of a sample (non-finite values are left out and counted).
struct ErrorSummary {
  int count = 0;
  /// Values left out because they were NaN or infinite.
  int non_finite = 0;
  double mean = 0.0;
  double min = 0.0;
  double median = 0.0;
  double percentile_90 = 0.0;
  double percentile_95 = 0.0;
  double max = 0.0;

  /// "n=100 mean=1.2 median=0.9 p90=2.1 p95=3 max=7.5" (all NaN-free; "n=0" if empty).
  std::string Describe() const;
};

/// The p-th percentile (p in [0, 100]) of the finite values by linear interpolation between order
/// statistics (numpy's default); NaN if there are none. Throws silpose::Error for p outside [0,
/// 100].
double Percentile(std::span<const double> values, double p);

/// Summary of the finite values (all zero with count 0 if there are none).
ErrorSummary Summarize(std::span<const double> values);

}  // namespace silpose
