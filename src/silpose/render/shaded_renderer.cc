#include "silpose/render/shaded_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "silpose/render/rasterizer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using render_internal::CameraVertices;
using render_internal::Viewport;

// The projection, near plane, clipping and pixel rule are render/rasterizer.h's, shared with
// RenderSilhouette, so that the coverage, and hence the mask, is bit-identical to
// RenderSilhouette's; the tests compare the two masks over many poses, meshes and clipped views.

struct Scratch {
  CameraVertices vertices;
  std::vector<float> inverse_depth;  // z-buffer, one per pixel; 0 = nothing drawn
};

// What one face draws: its colour, its inverse depth as an affine function of the pixel
// coordinates, clamped to the face's depth range.
struct FaceDraw {
  uint8_t bgr[3];
  double inverse_depth_du;
  double inverse_depth_dv;
  double inverse_depth_0;
  double inverse_depth_min;
  double inverse_depth_max;
};

// The images being drawn (all camera size).
struct Target {
  cv::Mat* colour;
  cv::Mat* mask;
  float* inverse_depth;
  int width;
};

// Draws the pixels u in [begin, end) of row `row` (nothing if end <= begin): all of them into the
// mask, those nearer than the z-buffer into the z-buffer and the colour image.
inline void DrawSpan(const Target& target, const FaceDraw& face, int row, int begin, int end) {
  if (end <= begin) return;
  std::memset(target.mask->ptr<uint8_t>(row) + begin, 255, static_cast<size_t>(end - begin));
  float* depth_row = target.inverse_depth + static_cast<size_t>(row) * target.width;
  uint8_t* colour_row = target.colour->ptr<uint8_t>(row);
  const double row_term = face.inverse_depth_dv * row + face.inverse_depth_0;
  for (int u = begin; u < end; ++u) {
    const double value =
        std::min(std::max(face.inverse_depth_du * u + row_term, face.inverse_depth_min),
                 face.inverse_depth_max);
    const auto inverse_depth = static_cast<float>(value);
    if (inverse_depth > depth_row[u]) {
      depth_row[u] = inverse_depth;
      uint8_t* pixel = colour_row + 3 * static_cast<size_t>(u);
      pixel[0] = face.bgr[0];
      pixel[1] = face.bgr[1];
      pixel[2] = face.bgr[2];
    }
  }
}

uint8_t ToByte(double value) {
  return static_cast<uint8_t>(std::lround(std::min(std::max(value, 0.0), 255.0)));
}

// Colour and inverse-depth plane of the face with camera-frame corners a, b, c (finite; at least
// one in front of the near plane).
FaceDraw PrepareFace(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     double near, const PinholeCamera& camera, const ShadedRenderOptions& options,
                     const Eigen::Vector3d& light) {
  FaceDraw face;
  const Eigen::Vector3d centroid = (a + b + c) / 3.0;
  const Eigen::Vector3d to_camera = -centroid.normalized();
  Eigen::Vector3d normal = (b - a).cross(c - a);
  const double normal_norm = normal.norm();
  const bool has_plane = normal_norm > 0.0 && std::isfinite(normal_norm);
  Eigen::Vector3d unit_normal = has_plane ? Eigen::Vector3d(normal / normal_norm) : to_camera;
  if (unit_normal.dot(to_camera) < 0.0) unit_normal = -unit_normal;  // two-sided
  double brightness = options.ambient + options.diffuse * std::max(0.0, unit_normal.dot(light));
  double highlight = 0.0;
  if (options.specular > 0.0) {
    const Eigen::Vector3d half = (light + to_camera).normalized();
    highlight =
        options.specular * std::pow(std::max(0.0, unit_normal.dot(half)), options.shininess);
  }
  if (!std::isfinite(brightness)) brightness = options.ambient;
  if (!std::isfinite(highlight)) highlight = 0.0;
  for (int k = 0; k < 3; ++k) {
    face.bgr[k] = ToByte(options.base_colour_bgr[k] * brightness + 255.0 * highlight);
  }

  // Depth range of the visible (clipped) face, and 1/z over the image: the point on the ray
  // r(u, v) = ((u - cx) / fx, (v - cy) / fy, 1) at depth z lies on the face's plane n . x = n . a
  // when 1/z = n . r(u, v) / (n . a), affine in (u, v).
  const double z_min = std::max(std::min({a.z(), b.z(), c.z()}), near);
  const double z_max = std::max({a.z(), b.z(), c.z()});
  face.inverse_depth_min = 1.0 / z_max;
  face.inverse_depth_max = 1.0 / z_min;
  const double offset = has_plane ? normal.dot(a) : 0.0;
  const double du = normal.x() / (camera.focal_x_px * offset);
  const double dv = normal.y() / (camera.focal_y_px * offset);
  const double at_0 = normal.z() / offset - du * camera.principal_x_px - dv * camera.principal_y_px;
  if (std::isfinite(du) && std::isfinite(dv) && std::isfinite(at_0)) {
    face.inverse_depth_du = du;
    face.inverse_depth_dv = dv;
    face.inverse_depth_0 = at_0;
  } else {
    // Seen edge-on through the camera centre: a line of pixels at most; take its nearest depth.
    face.inverse_depth_du = 0.0;
    face.inverse_depth_dv = 0.0;
    face.inverse_depth_0 = face.inverse_depth_max;
  }
  return face;
}

bool InByteRange(const Eigen::Vector3d& colour) {
  for (int k = 0; k < 3; ++k) {
    if (!(colour[k] >= 0.0 && colour[k] <= 255.0)) return false;
  }
  return true;
}

}  // namespace

bool ShadedRenderOptions::Check(std::string* error) const {
  std::ostringstream message;
  const double light_norm = light_dir_in_camera.norm();
  if (!InByteRange(base_colour_bgr)) {
    message << "base colour must have B, G, R in [0, 255], got (" << base_colour_bgr.transpose()
            << ")";
  } else if (!InByteRange(background_bgr)) {
    message << "background colour must have B, G, R in [0, 255], got ("
            << background_bgr.transpose() << ")";
  } else if (!(light_norm > 0.0) || !std::isfinite(light_norm)) {
    message << "light direction must be non-zero and finite, got ("
            << light_dir_in_camera.transpose() << ")";
  } else if (!(ambient >= 0.0 && ambient <= 1.0)) {
    message << "ambient must be in [0, 1], got " << ambient;
  } else if (!(diffuse >= 0.0 && diffuse <= 1.0)) {
    message << "diffuse must be in [0, 1], got " << diffuse;
  } else if (!(specular >= 0.0 && specular <= 1.0)) {
    message << "specular must be in [0, 1], got " << specular;
  } else if (!(shininess >= 1.0 && shininess <= 1000.0)) {
    message << "shininess must be in [1, 1000], got " << shininess;
  } else if (!background.empty() && background.type() != CV_8UC3) {
    message << "background must be an 8-bit 3-channel (BGR) image";
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

void RenderShaded(const TriangleMesh& mesh, const PinholeCamera& camera,
                  const Rigid3& camera_from_object, const ShadedRenderOptions& options,
                  cv::Mat* colour_bgr, cv::Mat* mask, cv::Mat* depth) {
  SILPOSE_ASSERT(colour_bgr != nullptr && mask != nullptr);
  std::string error;
  if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
  if (!options.Check(&error)) ThrowError("invalid shaded render options: ", error);
  const cv::Size size(camera.width_px, camera.height_px);
  if (!options.background.empty()) {
    if (options.background.size() != size) {
      ThrowError("background image is ", options.background.cols, "x", options.background.rows,
                 " but the camera is ", size.width, "x", size.height);
    }
    if (colour_bgr->data != options.background.data || colour_bgr->size() != size ||
        colour_bgr->type() != CV_8UC3) {
      options.background.copyTo(*colour_bgr);
    }
  } else {
    colour_bgr->create(size, CV_8UC3);
    colour_bgr->setTo(cv::Scalar(options.background_bgr[0], options.background_bgr[1],
                                 options.background_bgr[2]));
  }
  mask->create(size, CV_8UC1);
  mask->setTo(cv::Scalar(0));

  thread_local Scratch scratch;
  scratch.inverse_depth.assign(static_cast<size_t>(size.area()), 0.0f);
  const CameraVertices& vertices = scratch.vertices;
  if (render_internal::TransformVertices(mesh, camera, camera_from_object, &scratch.vertices)) {
    const Eigen::Vector3d light = options.light_dir_in_camera.normalized();
    const Target target{colour_bgr, mask, scratch.inverse_depth.data(), camera.width_px};
    FaceDraw face;
    render_internal::RasterizeMesh(
        mesh, vertices, camera, Viewport(camera.width_px, camera.height_px),
        [&](const std::array<uint32_t, 3>& triangle) {
          face =
              PrepareFace(vertices.in_camera[triangle[0]], vertices.in_camera[triangle[1]],
                          vertices.in_camera[triangle[2]], vertices.near, camera, options, light);
        },
        [&](int row, int begin, int end) { DrawSpan(target, face, row, begin, end); });
  }

  if (depth != nullptr) {
    depth->create(size, CV_32FC1);
    for (int row = 0; row < size.height; ++row) {
      const float* inverse = scratch.inverse_depth.data() + static_cast<size_t>(row) * size.width;
      float* out = depth->ptr<float>(row);
      for (int u = 0; u < size.width; ++u) out[u] = inverse[u] > 0.0f ? 1.0f / inverse[u] : 0.0f;
    }
  }
}

}  // namespace silpose
