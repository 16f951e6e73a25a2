#pragma once
// Symmetries of rigid objects, poses modulo them, and nearest-point search.
//
// A symmetry S of an object is a model_from_model rigid motion (x -> R_S x + t_S, model frame)
// that maps the object's surface onto itself, so that the object looks the same at the poses P
// and P * S (x_cam = R (R_S x + t_S) + t). As in the BOP benchmark's models_info.json, two kinds
// are kept:
//  - discrete: finitely many rotations (a hex bolt: five turns of 60 degrees about its axis;
//    the identity is implied and not listed);
//  - continuous: every rotation about one axis (a bottle, a bearing).
// Seen from the camera, P * S differs from P in the camera's direction in the model frame: the
// camera direction d of P (object centre -> camera, model frame) becomes R_S^T d.
//
// Mirror planes (reflections x -> x - 2 ((x - o) . n) n) are kept beside them. A reflection is not
// a motion, so it makes no two poses equivalent, but it makes two views look alike: under a
// far-away (orthographic) camera, the silhouette of a mirror-symmetric object seen from direction
// d is the silhouette seen from -M d (M the plane's reflection of directions), turned in the
// image. Those "twin" views cannot be told apart by the outline alone.

#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "silpose/geometry/rigid3.h"

namespace silpose {

/// A continuous rotational symmetry: rotation by any angle about the line through `offset` with
/// direction `axis` (model frame, model units; axis need not be normalised, must be non-zero).
struct ContinuousSymmetry {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};

/// A mirror plane: the plane through `offset` with normal `normal` (model frame, non-zero).
struct MirrorSymmetry {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();

  /// The mirror twin of a view direction (unit, model frame, camera towards the object): the view
  /// from which the object's outline is that seen from `view_dir`, mirrored (and turned). It is
  /// -M view_dir = 2 (d . n) n - d, M the plane's reflection of directions, n the unit normal.
  Eigen::Vector3d TwinView(const Eigen::Vector3d& view_dir) const {
    const Eigen::Vector3d n = normal.normalized();
    return (2.0 * view_dir.dot(n) * n - view_dir).normalized();
  }
};

/// The mirror twin of a pose: the pose at which a mirror-symmetric object shows, to a far-away
/// camera, the outline it shows at `camera_from_object` (x_cam = R x + t). The object is reflected
/// in `mirror` (which maps it onto itself) and then in the plane through the camera point of
/// `centre_in_object` perpendicular to the line of sight to it; the result is a proper rigid
/// motion. Seen along that line of sight, every point of the twin pose lies in front of or behind
/// the matching point of the original, so under a perspective camera the two outlines differ only
/// by the perspective. A centre on the mirror plane stays where it is, and the twin of the twin
/// is the pose itself. The camera direction (model frame) of the twin is mirror.TwinView of the
/// original's when the centre lies on the optical axis. `centre_in_object` must not be at the
/// camera centre.
Rigid3 MirrorTwinPose(const Rigid3& camera_from_object, const MirrorSymmetry& mirror,
                      const Eigen::Vector3d& centre_in_object);

/// Every symmetry found for (or given to) one object.
struct ObjectSymmetry {
  /// Most entries of each kind (Check).
  static constexpr size_t kMaxEntries = 256;
  /// Proper rotations other than the identity, model_from_model.
  std::vector<Rigid3> discrete;
  /// At most one in practice (an object with two continuous axes is a sphere).
  std::vector<ContinuousSymmetry> continuous;
  std::vector<MirrorSymmetry> mirrors;

  /// Whether some pose has an equivalent other than itself (a discrete or continuous symmetry).
  bool HasRotations() const { return !discrete.empty() || !continuous.empty(); }
  /// "none", or e.g. "continuous about (0, 1, 0); 1 discrete rotation (180 deg about (1, 0, 0));
  /// 2 mirror planes" (axes in the model frame, unit length).
  std::string Describe() const;
  /// False (with the reason) for a non-rotation or non-finite transform, a zero axis or normal,
  /// or more than kMaxEntries entries of a kind.
  bool Check(std::string* error = nullptr) const;
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
/// The same for an ObjectSymmetry (its mirrors play no part).
std::vector<Rigid3> SymmetryTransforms(const ObjectSymmetry& symmetry,
                                       double max_step_fraction = 0.01);

/// Rotation error modulo symmetry, degrees: min over S in `transforms` of the angle of
/// (R_est R_S)^T R_true. `transforms` from SymmetryTransforms (empty = identity only); with a
/// sampled continuous symmetry the result is within half a sample step of the exact minimum.
double RotationErrorModuloSymmetryDeg(const Eigen::Matrix3d& estimated,
                                      const Eigen::Matrix3d& truth,
                                      std::span<const Rigid3> transforms);

/// The paper's view error modulo symmetry: min over S in `transforms` of |R_S^T d_est - d_true|
/// with the unit view directions (object centre -> camera, model frame), in [0, 2].
double ViewErrorModuloSymmetry(const Eigen::Vector3d& estimated, const Eigen::Vector3d& truth,
                               std::span<const Rigid3> transforms);

/// The symmetry S that takes a camera direction `view_dir_in_object` (non-zero, model frame) to
/// its canonical form R_S^T d: among the equivalent directions, the one nearest a fixed reference
/// direction of the object (for a continuous symmetry about axis a: the half-plane spanned by a
/// and a fixed direction perpendicular to it, on the side of that direction). The canonical pose
/// of P is P * S. The identity for an object without rotations.
Rigid3 CanonicalSymmetry(const Eigen::Vector3d& view_dir_in_object, const ObjectSymmetry& symmetry);

/// Of the camera rotations equivalent to `rotation` by the object's rotational symmetries
/// (R R_S: the identity, each discrete rotation and, combined with each, every turn about a
/// continuous axis), the one nearest `reference` (smallest angle of R'^T reference). Exact for a
/// continuous symmetry (the twist of the difference about the axis is removed). Makes
/// frame-to-frame changes of a symmetric object's pose its motion, not a jump between equivalent
/// poses. `rotation` itself for an object without rotations.
Eigen::Matrix3d NearestEquivalentRotation(const Eigen::Matrix3d& rotation,
                                          const Eigen::Matrix3d& reference,
                                          const ObjectSymmetry& symmetry);

/// The angle between two camera directions modulo an object's rotational symmetries: the
/// smallest angle, degrees, between d_a and any direction equivalent to it (R_S^T d_a for the
/// identity, the discrete rotations and, for a continuous symmetry about axis u, every turn about
/// u, which leaves only the difference of the two directions' angles to u). Exact for continuous
/// symmetries (no sampling); mirror planes play no part. Built once per object; AngleDeg is
/// O(number of discrete rotations).
class ViewEquivalence {
 public:
  /// No symmetry: the plain angle.
  ViewEquivalence() = default;
  explicit ViewEquivalence(const ObjectSymmetry& symmetry);
  /// Unit directions (model frame) in, degrees in [0, 180] out.
  double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;

 private:
  std::vector<Eigen::Matrix3d> rotations_ = {Eigen::Matrix3d::Identity()};
  bool continuous_ = false;
  Eigen::Vector3d axis_ = Eigen::Vector3d::UnitZ();
};

/// A unit vector perpendicular to the unit vector `axis`, fixed by the axis alone (the cross
/// product with the coordinate axis least aligned with it).
Eigen::Vector3d FixedPerpendicular(const Eigen::Vector3d& axis);

/// Nearest-neighbour search among fixed 3D points (a k-d tree).
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

}  // namespace silpose
