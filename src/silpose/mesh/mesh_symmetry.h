#pragma once
// Finding a mesh's symmetries (geometry/symmetry.h) from its surface.
//
// The surface is sampled evenly (by area); its centroid and principal axes (eigenvectors of the
// samples' covariance) give the candidate axes. A symmetry axis passes through the centroid, and
// is a principal axis, or lies in the plane of two equal principal moments. A candidate
// transform T (rotation about a candidate axis, or reflection in a plane through the centroid)
// is a symmetry if the surface moved by it lies on the surface: the `quantile` of the distances
// from the moved samples to the nearest sample of a denser set is at most `tolerance` times the
// diameter. Checked, per candidate axis:
//  - continuous: rotations by several unrelated angles all pass;
//  - discrete of order n (2 <= n <= max_order): the rotation by 360 / n degrees passes and the
//    one by 180 / n fails (a turn too small to move the surface beyond the tolerance passes about
//    any axis); the largest such n is kept, with all its n - 1 rotations;
//  - half turns about the axes perpendicular to a continuous or n-fold axis (the flips of a
//    bearing or a gear), and half turns about the principal axes of objects without one;
//  - mirror planes: perpendicular to each principal axis, and containing a continuous or n-fold
//    axis.
// The quantile (not the maximum) makes the test robust to small details (a scan's noise, an
// engraving); `tolerance` sets how large a departure still counts as symmetric.

#include "silpose/geometry/symmetry.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

struct SymmetryDetectionOptions {
  /// Largest departure from symmetry that still counts, as a fraction of the diameter (> 0).
  double tolerance = 0.01;
  /// Fraction of the surface that must lie within the tolerance, (0, 1].
  double quantile = 0.95;
  /// Highest order of discrete rotations tried (2..360).
  int max_order = 64;
  /// Surface samples tested, and the denser reference set they are compared against (> 0).
  int samples = 3000;
  int reference_samples = 30000;

  bool Check(std::string* error = nullptr) const;
};

/// The symmetries of `mesh` (see above); none for an empty or degenerate mesh (all triangles of
/// zero area). Deterministic. Throws silpose::Error for invalid options.
ObjectSymmetry DetectSymmetry(const TriangleMesh& mesh,
                              const SymmetryDetectionOptions& options = {});

}  // namespace silpose
