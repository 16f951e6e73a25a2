#pragma once
// Headless CPU rendering of shaded colour images (no display, no GL), for synthetic colour video
// and for drawing models over frames. Same projection and pixel rule as RenderSilhouette
// (render/silhouette_renderer.h): ideal pinhole camera, a pixel belongs to a triangle if its centre
// lies inside or on the projected triangle, triangles crossing the near plane are clipped; so the
// mask RenderShaded returns is exactly the mask RenderSilhouette returns for the same inputs.
//
// Visibility: a z-buffer of inverse depth (1/z interpolated exactly across each triangle), the
// nearest triangle wins; between triangles at the same depth, the one listed first.
//
// Shading, flat per triangle (one colour per face), with a directional light fixed to the camera:
//   colour = base_colour * (ambient + diffuse * max(0, n . l)) + 255 * specular * max(0, n . h)^s
// n: the face normal in the camera frame, turned towards the camera (two-sided: the winding of the
//    mesh does not matter, back faces seen through holes are lit like front faces);
// l: `light_dir_in_camera` normalised, the direction from the surface towards the light;
// h: the half vector of l and the direction from the face's centroid to the camera (Blinn-Phong).
// The default light comes from above-left of the camera and a little behind it, so faces turned
// towards the camera are bright and faces seen at grazing angles or turned down/right are darker.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

struct ShadedRenderOptions {
  /// Colour of the object's surface, B, G, R in [0, 255].
  Eigen::Vector3d base_colour_bgr{60.0, 140.0, 230.0};
  /// Direction from the surface towards the (directional) light, in the camera frame (x right,
  /// y down, z forward); need not be normalised, must be non-zero. Default: up, left and behind
  /// the camera, 30 degrees off the optical axis.
  Eigen::Vector3d light_dir_in_camera{-0.35, -0.4, -1.0};
  /// Light that reaches every face, fraction of the base colour, in [0, 1].
  double ambient = 0.3;
  /// Lambert term weight, in [0, 1].
  double diffuse = 0.7;
  /// Blinn-Phong highlight weight, in [0, 1] (0: none), in units of full white.
  double specular = 0.0;
  /// Blinn-Phong exponent, in [1, 1000].
  double shininess = 32.0;
  /// Background drawn first: CV_8UC3 of camera size, or empty for `background_bgr` everywhere.
  /// It may share its data with the output colour image (draw over a frame in place).
  cv::Mat background;
  /// Uniform background colour when `background` is empty, B, G, R in [0, 255].
  Eigen::Vector3d background_bgr{0.0, 0.0, 0.0};

  bool Check(std::string* error = nullptr) const;
};

/// Renders `mesh` seen by `camera` at pose `camera_from_object`, shaded as `options` say.
///  - colour_bgr: CV_8UC3 of camera size (reallocated if needed): the background with the object
///    drawn over it; pixels the object does not cover keep the background.
///  - mask: CV_8UC1 of camera size, 255 = object, 0 = not; equal to RenderSilhouette's mask.
///  - depth (optional): CV_32FC1 of camera size, the camera-frame depth z of the visible surface in
///    model units, 0 where the object does not cover the pixel.
/// Throws silpose::Error if the camera or options are invalid, the background has the wrong size
/// or type, or a triangle references a missing vertex.
void RenderShaded(const TriangleMesh& mesh, const PinholeCamera& camera,
                  const Rigid3& camera_from_object, const ShadedRenderOptions& options,
                  cv::Mat* colour_bgr, cv::Mat* mask, cv::Mat* depth = nullptr);

}  // namespace silpose
