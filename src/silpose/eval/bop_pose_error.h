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
// unchanged; the identity is always among them (SymmetryTransforms builds the set).
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

namespace silpose {

/// A continuous rotational symmetry: rotation by any angle about the line through `offset` with
/// direction `axis` (model frame, model units; axis need not be normalised, must be non-zero).
struct ContinuousSymmetry {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

/// The symmetry set of an object: the identity, the discrete symmetries (model_from_model) and,
/// for each continuous symmetry, rotations about its axis sampled so that a point at distance
/// diameter / 2 from the axis moves at most `max_step_fraction` of the diameter between
/// consecutive samples (ceil(pi / max_step_fraction) samples per turn; BOP uses 0.01), combined
/// with every discrete one (continuous after discrete). Throws silpose::Error for a zero axis, a
/// step fraction outside (0, 1] or more than 100000 transforms.
std::vector<Rigid3> SymmetryTransforms(std::span<const Rigid3> discrete,
                                       std::span<const ContinuousSymmetry> continuous,
                                       double max_step_fraction = 0.01);

/// ADD, model units (see above).
double AddError(const Eigen::Matrix3Xd& points, const Rigid3& estimated, const Rigid3& truth);

/// Nearest-neighbour search among fixed 3D points (a k-d tree), for ADD-S.
class NearestPointIndex {
 public:
  /// Indexes the columns of `points` (copied). Throws silpose::Error if there are none.
  explicit NearestPointIndex(const Eigen::Matrix3Xd& points);
  /// Distance from `query` to the nearest indexed point (same units as the points).
  double NearestDistance(const Eigen::Vector3d& query) const;
  int size() const { return static_cast<int>(points_.cols()); }

 private:
  struct Node {
    int begin = 0, end = 0;  // leaf range in points_ (reordered)
    int left = -1, right = -1;
    int axis = 0;
    double split = 0.0;
  };
  int Build(int begin, int end);
  void Search(int node, const Eigen::Vector3d& query, double* best_squared) const;

  Eigen::Matrix3Xd points_;
  std::vector<Node> nodes_;
};

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
