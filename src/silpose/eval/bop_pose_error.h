#pragma once
// The pose-error functions of the BOP benchmark (Hodan et al., "BOP: Benchmark for 6D Object Pose
// Estimation", ECCV 2018, and the BOP Challenge 2019/2020 evaluation), for one estimate of one
// object against its ground truth.
//
// Poses are camera_from_object (x_cam = R x_obj + t, OpenCV camera frame, model units: millimetres
// for BOP models). `points` are the model's vertices in the model frame (one per column; BOP
// evaluates on the vertices of its "models_eval" meshes, which are resampled evenly).
//  - ADD: mean over the vertices x of |P_est x - P_true x|.
//  - ADD-S: mean over the vertices x of min over vertices y of |P_est x - P_true y| (for objects
//    whose symmetry makes ADD unfair); ADD(-S) is ADD-S for objects with a symmetry, else ADD.
//  - MSSD (maximum symmetry-aware surface distance): min over the object's symmetries S of
//    max over the vertices x of |P_est x - P_true S x|, model units.
//  - MSPD (maximum symmetry-aware projection distance): the same with the points projected by the
//    camera: min over S of max over x of |proj(P_est x) - proj(P_true S x)|, pixels.
// Symmetries S are model_from_model transforms (x -> R x + t) that leave the object's appearance
// unchanged; the identity is always among them (SymmetryTransforms, geometry/symmetry.h, builds the
// set).
//
// Recall: the fraction of estimates whose error is strictly below a threshold; an estimate that is
// missing (no pose, wrong object) has an infinite error. BOP's thresholds: ADD(-S) < 0.1 diameter;
// MSSD thresholds 0.05, 0.10, ..., 0.50 diameter; MSPD thresholds 5, 10, ..., 50 px times
// 640 / image width; the average recall (AR) of a metric is the mean of its recalls over its
// thresholds.

#include <Eigen/Core>
#include <span>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/geometry/symmetry.h"

namespace silpose {

/// ADD, model units (see above).
double AddError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth);

/// ADD-S, model units; `index` indexes the same `points`.
double AddSError(const Eigen::Matrix3Xd& points, const NearestPointIndex& index,
                 const Rigid3& estimated, const Rigid3& truth);

/// MSSD, model units; `symmetries` from SymmetryTransforms (empty = identity only).
double MssdError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth,
                 std::span<const Rigid3> symmetries);

/// MSPD, pixels, with `camera`'s pinhole projection (distortion ignored, as in BOP); points must
/// lie in front of the camera (z > 0) at both poses.
double MspdError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth,
                 std::span<const Rigid3> symmetries, const PinholeCamera& camera);

/// BOP's MSSD thresholds: 0.05, 0.10, ..., 0.50 times `diameter` (model units).
std::vector<double> MssdThresholds(double diameter);
/// BOP's MSPD thresholds: 5, 10, ..., 50 px times 640 / image_width_px.
std::vector<double> MspdThresholds(int image_width_px);

/// Fraction of `errors` strictly below `threshold`, in [0, 1]; NaN and infinite errors count as
/// failures; 0 for no errors.
double Recall(std::span<const double> errors, double threshold);
/// Mean of Recall over `thresholds` (non-empty).
double AverageRecall(std::span<const double> errors, std::span<const double> thresholds);

}  // namespace silpose
