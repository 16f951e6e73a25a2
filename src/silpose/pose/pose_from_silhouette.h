#pragma once
// The 6-DOF pose from a matched database view (docs/tracking.md, "6-DOF pose": "pose from (view,
// roll, scale, centroid, camera)"). The paper estimates 4 DOF (view direction, roll, scale); the
// image position of the silhouette and the camera intrinsics give the remaining two and turn scale
// into distance.
//
// Inputs: the database view v of model m (view_dir d_v, its silhouette's mean radius r_db and
// centroid c_db in the database image, rendered by the database camera K_db = ViewCamera(render
// options) with focal f_db at distance D_db = distance_in_radii * radius from the object centre
// c), the roll r found by matching, and the frame silhouette's mean radius r_f and centroid c_f
// (pixels of the frame camera K, possibly distorted).
//
// Closed form (PoseFromSilhouetteOptions::outline_iterations = 0):
//  1. Undistort. c_f goes to ideal normalised coordinates n_f (lens_distortion.h); the radius is
//     scaled by the local area change of the distortion, rho_f = r_f / sqrt(fx fy) / sqrt(det J_d).
//  2. Off-axis. The object centre lies on a ray u (unit, camera frame) that is in general not the
//     optical axis. Its silhouette is the one a "virtual" camera would see looking along u, i.e.
//     the database silhouette (rolled and scaled), mapped into the real image by the homography of
//     the rotation Q = the minimal rotation taking the optical axis e_z to u (x_camera = Q
//     x_virtual). Near the ray this homography stretches the image by 1 / cos^2(theta) along the
//     radial direction and 1 / cos(theta) across it, theta = angle(u, e_z), and does not turn it
//     (so the roll found in the real image is the virtual camera's roll); the virtual radius is
//     rho_v = rho_f * cos^1.5(theta) (geometric mean of the two stretches).
//  3. Scale -> distance. The silhouette appears k = rho_v / (r_db / f_db) times as large as in
//     the database image. Under weak perspective (ScaleModel::kWeakPerspective) D = D_db / k. The
//     default ScaleModel::kSphere accounts for perspective making an object's outline grow faster
//     than 1 / D: it treats the silhouette as that of a sphere, of apparent half-angle tangent
//     a = rho / sqrt(D^2 - rho^2), with rho = D_db a_db / sqrt(1 + a_db^2) fitted to the database
//     view (a_db = r_db / f_db), so D = rho sqrt(1 + a^2) / a with a = k a_db. (Measured on the
//     bunny at 3-8 radii: median distance errors alike, largest errors about a third smaller.)
//  4. Centre. The database centroid is offset from the image of the object centre (the principal
//     point of the database camera) by o_db = (c_db - pp_db) / f_db (normalised). Seen at roll r
//     it turns into Rot(r) o_db with Rot(r) = [[cos r, sin r], [-sin r, cos r]] (the camera turns
//     by r, geometry/view_frame.h), scaled by k; mapped into the real image by the local stretch J
//     of step 2: the object centre's ideal normalised image is p = n_f - J k Rot(r) o_db, and the
//     ray u = (p, 1) / |(p, 1)|.
//  5. Pose. The virtual camera is the database camera at view d_v, roll r, distance D:
//     x_virtual = R_on (x - c) + D e_z with R_on = CameraFromObjectRotation(d_v, r). Hence
//       R = Q R_on,   t = D u - R c      (x_camera = R x_object + t, t in model units).
//     (Q applies after R_on: it turns the virtual camera's frame into the real one.)
//
// Outline iterations (default 4): the closed form linearises the homography and the distortion at
// one point, which is off by a few percent for objects near the image corners (theta ~ 30 deg)
// and with strong distortion. Each iteration predicts the frame silhouette exactly instead: the
// database outline (the star-convex polygon of the stored signature around c_db) is rolled,
// scaled, mapped through Q and the lens distortion into the frame image; the predicted centroid
// and mean radius (measured as the frame's are) are compared with the frame's, the object
// centre's image is moved by the centroid residual and k divided by the radius ratio. Cost: one
// pass over the M signature points per iteration.
//
// Not modelled: the change of the silhouette's shape between the database's distance shells and
// the exact shape of the object between the database views; contour refinement
// (pose/contour_refinement.h) removes both. The match itself is made in the on-axis virtual camera
// (pose/on_axis.h), so off-axis stretch and lens distortion do not bias the view and roll.
//
// Non-square pixels: accepted when |fx / fy - 1| <= max_pixel_aspect_deviation (1 % by default),
// with positions converted through fx and fy separately and scale through sqrt(fx fy); refused
// with a silpose::Error beyond that, as the silhouette itself (and so the match) would be stretched
// by the aspect ratio and the mask must be resampled to square pixels first.

#include <Eigen/Core>
#include <string>

#include "silpose/database/view_database.h"
#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/shape/polar_signature.h"

namespace silpose {

/// How the silhouette's size changes with distance (step 3 above).
enum class ScaleModel {
  /// Size proportional to 1 / D (weak perspective).
  kWeakPerspective,
  /// Size of a sphere's image, rho / sqrt(D^2 - rho^2), with rho chosen so that the database
  /// silhouette's mean radius is matched at D_db. Perspective makes near objects' outlines grow
  /// faster than 1 / D (the outline moves towards the camera); this models it.
  kSphere,
};

struct PoseFromSilhouetteOptions {
  ScaleModel scale_model = ScaleModel::kSphere;
  /// Distance shell of the database view to place (the one it was matched in: MatchCandidate or
  /// FilterEstimate::shell); its distance is D_db. In [0, database shells).
  int shell = 0;
  /// Outline iterations after the closed form (see above); 0 = closed form only. In [0, 100].
  int outline_iterations = 4;
  /// The iterations stop when the predicted centroid is within this many pixels of the frame's
  /// and the predicted mean radius within this fraction of the frame's. > 0.
  double tolerance_px = 1e-3;
  double tolerance_relative = 1e-6;
  /// Largest accepted |fx / fy - 1| (see above). In [0, 1).
  double max_pixel_aspect_deviation = 0.01;

  bool Check(std::string* error = nullptr) const;
};

/// The pose and how it was found.
struct SilhouettePose {
  /// object_to_camera of the output files: x_in_camera = R x_in_object + t, OpenCV camera frame, t
  /// in model units.
  Rigid3 camera_from_object;
  /// Distance from the camera centre to the object centre, model units.
  double distance = 0.0;
  /// Unit ray from the camera centre through the object centre, camera frame.
  Eigen::Vector3d centre_ray = Eigen::Vector3d::UnitZ();
  /// Pixel of the object centre in the (distorted) frame image.
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  /// Angle between the optical axis and centre_ray, degrees.
  double off_axis_deg = 0.0;
  /// Outline iterations done, and the residuals after the last one (0 without iterations):
  /// predicted minus frame centroid, pixels, and predicted / frame mean radius - 1.
  int iterations = 0;
  double centroid_residual_px = 0.0;
  double radius_residual = 0.0;
};

/// The 6-DOF pose of `model` (index into database.models) seen from database view `view` with
/// roll `roll_deg` (as a matcher or the particle filter reports them), placed by the frame
/// silhouette's centroid and mean radius (`frame_silhouette`, extracted from an image of
/// `camera`). Throws silpose::Error if an index is out of range, the database view has no usable
/// silhouette, the frame silhouette has no positive finite mean radius, the camera or options are
/// invalid, the pixels are too far from square, or the centroid cannot be undistorted.
SilhouettePose EstimatePoseFromSilhouette(const ViewDatabase& database, int model, int view,
                                          double roll_deg, const PolarSignature& frame_silhouette,
                                          const PinholeCamera& camera,
                                          const PoseFromSilhouetteOptions& options = {});

/// EstimatePoseFromSilhouette(...).camera_from_object.
Rigid3 PoseFromSilhouette(const ViewDatabase& database, int model, int view, double roll_deg,
                          const PolarSignature& frame_silhouette, const PinholeCamera& camera,
                          const PoseFromSilhouetteOptions& options = {});

/// Optional refinement by rendering (off unless called): the model is rendered at the estimated
/// pose, and the rendered silhouette's centroid and mean radius are compared with the frame's; the
/// object centre's image is moved by the centroid residual and the distance scaled by the radius
/// ratio, keeping the on-axis rotation (R_on = Q^T R) fixed. This removes what the database image
/// cannot tell: the silhouette's change of shape with distance (perspective) and off-axis position.
/// Lens distortion is applied to the rendered centroid and, locally, to its radius (the renderer
/// is an ideal pinhole). Each iteration renders one frame-sized silhouette (about a millisecond for
/// the sample models at 640 x 480).
struct RenderRefinementOptions {
  /// Iterations (>= 1, <= 20).
  int iterations = 2;
  /// Descriptor options for the rendered silhouette (use the database's).
  SignatureOptions signature;

  bool Check(std::string* error = nullptr) const;
};

/// Refines `initial` (from EstimatePoseFromSilhouette) as described above. `mesh` must be the
/// database model (same centre). Stops early, returning the last good pose, if a rendering has no
/// usable silhouette. Throws silpose::Error for invalid options or camera, or a frame silhouette
/// without positive mean radius. In the result, `iterations` counts the renderings used and the
/// residuals are those of the last one (before its correction was applied).
SilhouettePose RefinePoseByRendering(const TriangleMesh& mesh, const PinholeCamera& camera,
                                     const PolarSignature& frame_silhouette,
                                     const SilhouettePose& initial,
                                     const RenderRefinementOptions& options = {});

/// The minimal rotation taking the optical axis (0, 0, 1) to the unit vector `ray` (camera frame);
/// identity for ray = e_z. `ray` must be non-zero and not point backwards (z > 0).
Eigen::Matrix3d RotationFromOpticalAxisTo(const Eigen::Vector3d& ray);

}  // namespace silpose
