#pragma once
// Headless CPU rendering of binary silhouettes (no display, no GL): every triangle of the mesh is
// projected with an ideal pinhole camera and filled; a pixel is set if its centre lies inside a
// projected triangle. Triangles crossing the near plane are clipped.

#include <opencv2/core.hpp>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

/// Which triangles RenderSilhouette may leave out.
enum class FaceCulling {
  /// None: the silhouette of any triangle soup, from anywhere.
  kNone,
  /// The triangles facing away from the camera (with the mesh's orientation: counter-clockwise
  /// seen from outside), about half of them. The silhouette is the same, pixel for pixel, when
  /// IsClosedSurface(mesh) and the camera lies outside the mesh's bounding sphere (centre
  /// TriangleMesh::Centre(), radius TriangleMesh::Radius()): then every line of sight through the
  /// object crosses a triangle facing the camera. Otherwise parts of the silhouette may be missing.
  /// (Only a pixel centre within rounding of an outline edge could differ.) The database build
  /// uses it for closed meshes: it about halves the rendering time.
  kBackFaces,
};

/// Renders the silhouette of `mesh` seen by `camera` at pose `camera_from_object`.
/// Writes a CV_8UC1 mask of camera size into `mask` (reallocated if needed): 255 = object, 0 = not.
/// Throws silpose::Error if the camera is invalid.
void RenderSilhouette(const TriangleMesh& mesh, const PinholeCamera& camera,
                      const Rigid3& camera_from_object, cv::Mat* mask,
                      FaceCulling culling = FaceCulling::kNone);

/// How the database cameras frame an object (paper 4.1): a square image, the camera at
/// distance_in_radii * object radius from the object centre, focal length chosen so the object's
/// bounding sphere fills fill_fraction of the image width.
struct ViewRenderOptions {
  /// Image width and height in pixels (>= 32). 512 by default: at 256 the database's own pixel
  /// staircase biases the roll of some views by up to 1 degree (docs/PERFORMANCE.md).
  int resolution_px = 512;
  /// Camera distance from the object centre, in object radii (> 1).
  double distance_in_radii = 3.0;
  /// Diameter of the projected bounding sphere / image width, in (0, 1].
  double fill_fraction = 0.9;

  bool Check(std::string* error = nullptr) const;
};

/// The camera that ViewRenderOptions describe (independent of the object's size).
PinholeCamera ViewCamera(const ViewRenderOptions& options);

/// Renders the mesh from view direction `view_dir_in_object` with roll `roll_deg` (conventions in
/// geometry/view_frame.h), framed as `options` says. Convenience over RenderSilhouette.
void RenderView(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir_in_object,
                double roll_deg, const ViewRenderOptions& options, cv::Mat* mask);

}  // namespace silpose
