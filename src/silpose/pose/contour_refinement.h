#pragma once
// Continuous 6-DOF refinement of a pose against the frame's silhouette outline, below the
// database's view grid.
//
// Model outline points. At the current pose the mesh's contour generator (edges between a
// triangle facing the camera and one facing away, plus open boundary edges) is sampled at even
// spacing in the image, and the model's silhouette is rendered (RenderSilhouette, ideal pinhole)
// in a window around the model only; for a closed, consistently oriented mesh only the triangles
// facing the camera are drawn (same silhouette, half the work). A sample is kept if the rendered
// outline crosses the pixel cell around its projection p (the bilinearly interpolated coverage c
// is strictly between 0 and 1): hidden generator points, deeper inside the silhouette, are
// dropped. Its offset o = 0.5 - c is the signed distance from p to the rendered outline; the
// sample then stands for the outline beside it. At most `contour_points` samples, evenly spread,
// are kept as fixed points of the model frame (with o and the outline's outward image normal n)
// until the next reselection.
//
// Residuals, pixels, both through the Huber loss:
//  - model -> frame: the signed distance from the point's projection (with lens distortion,
//    ProjectDistorted) to the frame silhouette's outline (positive outside the frame mask,
//    negative inside, read bilinearly from FrameOutline), minus o. Signed, it constrains the size
//    both ways: a model silhouette too large has its outline outside the frame mask, too small
//    inside.
//  - frame -> model: up to `contour_points` frame outline points q, evenly spread, each matched
//    (once per iteration) to the nearest projected model outline point p_j; the residual is the
//    gap n_j . (q - p_j) + o_j (positive where the frame silhouette reaches beyond the model's),
//    less a 1-pixel dead zone. This stops the model from sliding into, or shrinking onto, part of
//    the frame outline (a wrong minimum the first kind alone allows, measured: the 90th percentile
//    of the rotation error dropped from 3.1 to 0.8 degrees); the dead zone keeps the frame's pixel
//    staircase from adding noise near the solution. Frame outline parts without a model
//    counterpart (an attached stick) are bounded by the Huber loss and max_residual_px.
//
// Update. A 6-vector (w, d): the object turns by the axis-angle w (radians, camera frame) about
// its own centre c and moves by d (model units, camera frame):
//   x_cam' = exp([w]x) (x_cam - c_cam) + c_cam + d,   c_cam = R c + t,
// i.e. R' = exp([w]x) R, t' = exp([w]x) (t - c_cam) + c_cam + d. Turning about the object centre
// (not the camera centre) keeps rotation and translation nearly decoupled. Jacobian per residual:
// g (1 x 2) * d(pixel)/d(x_cam) (2 x 3, pinhole and distortion) * [-[x_cam - c_cam]x, I] (3 x 6),
// with g the gradient of the frame's distance (first kind) or -n_j (second kind).
// Levenberg-Marquardt with Marquardt's diagonal scaling on the Huber-weighted normal equations;
// the cost is the truncated Huber loss (residuals beyond max_residual_px count a constant), and a
// step is accepted if it lowers the cost on the same points and matches. Depth along the optical
// axis is observed through the outline's size and its perspective shape.
//
// Lens distortion: the rendered silhouette (for choosing the outline points) is an ideal pinhole
// image, the residuals are taken in the distorted frame image. The IoU of the result counts ideal
// pixels: each looks up the frame mask at its distorted position (the distortion evaluated on an
// 8-pixel grid and interpolated bilinearly).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

struct ContourRefinementOptions {
  /// Largest number of Levenberg-Marquardt iterations (each solves one 6 x 6 system and may try
  /// several damping values). In [1, 200].
  int max_iterations = 10;
  /// Largest number of model outline points used per iteration (fewer if the outline is short).
  /// In [6, 100000].
  int contour_points = 200;
  /// Scale of the Huber loss, pixels: residuals beyond it count linearly. Masks are imperfect
  /// (ragged borders, attached sticks, holes). > 0.
  double huber_px = 3.0;
  /// Points farther than this from the frame outline, pixels, are ignored (weight 0, constant
  /// cost). Also ignored: points outside the frame's distance-transform window (FrameOutline's
  /// margin_px beyond the silhouette). > huber_px.
  double max_residual_px = 30.0;
  /// Re-extract the model outline points (one rendering) every this many iterations. >= 1.
  /// 1 is about 25 % more accurate (median rotation error 0.23 instead of 0.30 degrees in the
  /// test's set) and takes about 1.6 times as long.
  int reselect_every = 2;
  /// Converged when an accepted step turns the object by less than this, degrees. > 0.
  double tolerance_rotation_deg = 0.01;
  /// ... and moves it by less than this fraction of its distance from the camera. > 0.
  double tolerance_translation = 1e-4;
  /// ... or when a step lowers the robust cost by less than this per residual, pixels^2 (the
  /// mean Huber loss, r^2 / 2 for small r). Such a step only fits the outlines' pixel noise along
  /// weakly observed directions; it is not applied. >= 0 (0: never). For a frame silhouette
  /// smaller than tolerance_radius_px, see there.
  double tolerance_cost_px2 = 1e-3;
  /// A frame silhouette whose equivalent radius r (sqrt(area / pi), pixels) is below this uses
  /// tolerance_cost_px2 * r / tolerance_radius_px. A far object's outline distances, and what a
  /// step gains, shrink with its size, so a fixed tolerance stops its refinement early: at 15 radii
  /// (r about 30 px) after one or two steps, about 0.5 degrees from the truth. >= 0 (0: a fixed
  /// tolerance). 100 px, the linear scale and the value were chosen on the tuning models; the
  /// square of the ratio (what the cost's own scale suggests) refined ragged masks into their
  /// noise.
  double tolerance_radius_px = 100.0;
  /// Compute ContourRefinementResult::iou (one more rendering plus a pass over the window).
  bool compute_iou = true;

  /// True if the options are usable; otherwise `error` (may be null) says which is wrong.
  bool Check(std::string* error = nullptr) const;
};

struct ContourRefinementResult {
  /// The refined pose, same convention as SilhouettePose: x_cam = R x_obj + t, OpenCV camera
  /// frame, t in model units.
  Rigid3 camera_from_object;
  /// Iterations done (normal-equation solves).
  int iterations = 0;
  /// True if the last accepted step was below both tolerances, or no step lowered the cost any
  /// more (a minimum). False if the iterations ran out or too few outline points were found.
  bool converged = false;
  /// Robust RMS distance, pixels, of the model outline points to the frame outline at the initial
  /// and at the refined pose: sqrt(2 sum huber(r) / n) over the n points within max_residual_px
  /// (the plain RMS when all are within huber_px).
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
  /// Intersection over union of the model silhouette rendered at the refined pose with the frame
  /// mask (0 if not computed).
  double iou = 0.0;
  /// Outline points within max_residual_px in the last evaluation.
  int points_used = 0;
};

/// Per frame: the signed distance, pixels, from each pixel centre to the silhouette's outline
/// (positive outside the mask, negative inside, the outline running halfway between an object
/// pixel and a background one), in a window around the silhouette only. Distances are chamfer
/// distances (steps 1 and sqrt(2)) to the pixels next to the outline, plus half a pixel: exact
/// along rows, columns and diagonals, up to 8 % long in between.
class FrameOutline {
 public:
  /// `mask`: CV_8UC1, frame size, non-zero = object (distorted image of the camera used with it).
  /// The window is the bounding box of the object pixels grown by `margin_px` pixels (>= 2) on
  /// each side, clipped to the image. Throws silpose::Error for an empty mask, a mask of another
  /// type, or margin_px < 2.
  explicit FrameOutline(const cv::Mat& mask, int margin_px = 40);

  /// Signed distance at pixel (u, v), bilinear between pixel centres; false (and nothing written)
  /// outside the window. `gradient` (may be null) receives the derivative of the bilinear
  /// interpolant with respect to (u, v).
  bool Distance(double u, double v, double* distance, Eigen::Vector2d* gradient = nullptr) const;

  /// The window in frame pixels, and the signed distances over it (CV_32FC1).
  const cv::Rect& window() const { return window_; }
  const cv::Mat& signed_distance() const { return signed_distance_; }
  /// The frame mask (shared, not copied) and its size.
  const cv::Mat& mask() const { return mask_; }
  /// Number of object pixels, and their bounding box (frame pixels).
  int area_px() const { return area_px_; }
  const cv::Rect& object_box() const { return object_box_; }
  /// Points of the outline, frame pixels: the midpoint of every pair of 4-neighbouring pixels of
  /// which one is object and the other not, in scan order.
  const std::vector<Eigen::Vector2d>& outline_points() const { return outline_points_; }

 private:
  cv::Mat mask_;
  std::vector<Eigen::Vector2d> outline_points_;
  cv::Rect window_;
  cv::Rect object_box_;
  cv::Mat signed_distance_;
  int area_px_ = 0;
};

/// The mesh prepared for outline extraction, built once per model: face planes and the edges with
/// their two faces. Building costs O(F log F) (about 1-2 ms for 10k triangles).
class ContourModel {
 public:
  /// Throws silpose::Error if the mesh has no triangle or a triangle references a missing vertex.
  explicit ContourModel(const TriangleMesh& mesh);

  const TriangleMesh& mesh() const { return mesh_; }
  Eigen::Vector3d centre() const { return centre_; }
  /// True if built from a mesh with the same vertices and triangles as `mesh`.
  bool SameMesh(const TriangleMesh& mesh) const;

  /// An edge of the mesh with (up to) two of its triangles. Edges of more than two triangles keep
  /// the first two.
  struct Edge {
    uint32_t a, b;         // Vertex indices, a < b.
    int32_t face0, face1;  // Adjacent triangles; face1 = -1 on an open boundary.
    // True if both triangles run along the edge in the same direction (inconsistent winding):
    // their normals then point to opposite sides and the facing test is inverted.
    bool flipped;
  };
  /// Face normals (not normalised, right-handed in the triangle's vertex order) and offsets
  /// n . v0, model frame: the sign of n . c - offset says on which side of the triangle's plane a
  /// camera at c (model frame) is. An edge is on the contour generator where that side differs
  /// between its two triangles (corrected for `flipped`), whatever the mesh's overall orientation.
  const std::vector<Eigen::Vector3d>& normals() const { return normals_; }
  const std::vector<double>& offsets() const { return offsets_; }
  const std::vector<Edge>& edges() const { return edges_; }
  /// True if every edge has exactly two triangles running along it in opposite directions (a
  /// closed, consistently oriented surface); then its silhouette is rendered from the triangles
  /// facing the camera only, half the work.
  bool closed() const { return closed_; }
  /// For a closed mesh: true if the normals point out of the enclosed volume.
  bool outward() const { return outward_; }

 private:
  TriangleMesh mesh_;  // Copy, so that a model outlives the caller's mesh.
  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> normals_;
  std::vector<double> offsets_;
  std::vector<Edge> edges_;
  bool closed_ = true;
  bool outward_ = true;
};

/// Refines `initial` (camera_from_object of `mesh`, e.g. from EstimatePoseFromSilhouette) against
/// the frame silhouette `frame`, seen by `camera` (intrinsics and distortion of the frame image),
/// as described above. Throws silpose::Error for invalid options or camera, a frame of another
/// size than the camera, or an object centre not in front of the camera. Fewer than 6 usable
/// outline points end the refinement (converged = false, pose unchanged since the last step).
ContourRefinementResult RefinePoseToContour(const ContourModel& model, const PinholeCamera& camera,
                                            const FrameOutline& frame, const Rigid3& initial,
                                            const ContourRefinementOptions& options = {});

/// Same, for a mesh: the ContourModel is built on the first call and kept per thread while the
/// same mesh (compared by content) is refined again. Building one sorts the mesh's edges (a few
/// milliseconds for 10 000 triangles): to refine several meshes in turn, keep a ContourModel per
/// mesh and call the overload above (the Tracker does).
ContourRefinementResult RefinePoseToContour(const TriangleMesh& mesh, const PinholeCamera& camera,
                                            const FrameOutline& frame, const Rigid3& initial,
                                            const ContourRefinementOptions& options = {});

/// How well `initial` explains the frame before any refinement: the robust cost that
/// RefinePoseToContour lowers, per residual (pixels^2: the mean Huber loss, r^2 / 2 for small r,
/// over the model -> frame and frame -> model residuals, far points at the truncated value).
/// One rendering of the model outline and one pass over its points: about a tenth of a
/// refinement. Choosing between starting poses by it: the refinement converges in fewer
/// iterations from the lower. NaN if fewer than 6 outline points are usable. Throws as
/// RefinePoseToContour.
double ContourFitCost(const ContourModel& model, const PinholeCamera& camera,
                      const FrameOutline& frame, const Rigid3& pose,
                      const ContourRefinementOptions& options = {});

/// Same, for a mesh (the per-thread ContourModel of RefinePoseToContour's mesh overload).
double ContourFitCost(const TriangleMesh& mesh, const PinholeCamera& camera,
                      const FrameOutline& frame, const Rigid3& pose,
                      const ContourRefinementOptions& options = {});

/// The IoU of the model's silhouette at `pose` with the frame's, as RefinePoseToContour reports
/// it with compute_iou (ContourRefinementResult::iou): one rendering. For a pose refined without
/// it, e.g. the one kept of several refinements. Throws as RefinePoseToContour.
double ContourIou(const ContourModel& model, const PinholeCamera& camera, const FrameOutline& frame,
                  const Rigid3& pose);

/// Same, for a mesh (the per-thread ContourModel of RefinePoseToContour's mesh overload).
double ContourIou(const TriangleMesh& mesh, const PinholeCamera& camera, const FrameOutline& frame,
                  const Rigid3& pose);

/// The model -> frame residuals and their Jacobian at `pose` for outline points
/// `points_in_object` (model frame), as RefinePoseToContour computes them but without the
/// rendered-outline offsets o: residual[i] (pixels) and row i of `jacobian` (d residual / d(w, d),
/// update as above, about `centre` in the model frame). Points not evaluable
/// (behind the camera, outside the frame window) get valid[i] = 0. For tests and diagnostics.
void ContourResiduals(const PinholeCamera& camera, const FrameOutline& frame, const Rigid3& pose,
                      const Eigen::Vector3d& centre,
                      const std::vector<Eigen::Vector3d>& points_in_object,
                      std::vector<double>* residuals,
                      std::vector<Eigen::Matrix<double, 1, 6>>* jacobian,
                      std::vector<uint8_t>* valid);

/// The pose after the update (w, d) about the model-frame point `centre` (see above).
Rigid3 ApplyContourUpdate(const Rigid3& pose, const Eigen::Vector3d& centre,
                          const Eigen::Matrix<double, 6, 1>& update);

/// The model outline points at `pose` (see above), model frame, at most `max_points`.
std::vector<Eigen::Vector3d> ModelOutlinePoints(const ContourModel& model,
                                                const PinholeCamera& camera, const Rigid3& pose,
                                                int max_points);

namespace contour_internal {

/// Exact nearest-neighbour search among 2D points (pixels) within a radius, as the refinement
/// matches the frame's outline points to the model's: the points are binned in square cells, and
/// each query searches the rings of cells around its own outwards until no nearer point can be
/// left. Internal to the refinement; declared here for its tests.
class NearestPointGrid {
 public:
  /// Bins `points` (kept by reference until the next Build); those with usable[j] == 0 or a
  /// non-finite coordinate are left out. Same sizes.
  void Build(std::span<const Eigen::Vector2d> points, std::span<const uint8_t> usable);
  /// The index of the point nearest to `q` at a distance below `max_distance` (the lowest index
  /// among equally near ones), or -1 if there is none.
  int Nearest(const Eigen::Vector2d& q, double max_distance) const;

 private:
  static constexpr double kCellPx = 8.0;  // About the spacing of the refinement's outline points.
  static constexpr int kMaxCells = 64;    // Per side; wider cells for a wider spread.
  std::span<const Eigen::Vector2d> points_;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  double cell_px_ = kCellPx;
  int columns_ = 0;
  int rows_ = 0;
  std::vector<int> cell_start_;  // First entry of each cell in sorted_, and one past the last.
  std::vector<int> fill_;
  std::vector<int> point_cell_;
  std::vector<uint32_t> sorted_;  // Point indices by cell.
};

}  // namespace contour_internal

}  // namespace silpose
