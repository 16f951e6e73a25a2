#include "silpose/render/shaded_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// The projection, near plane, clipping and pixel rule below repeat those of
// silhouette_renderer.cc operation for operation (the same floating-point expressions in the same
// order), so that the coverage, and hence the mask, is bit-identical to RenderSilhouette's; the
// tests compare the two masks over many poses, meshes and clipped views. See that file for why
// each step is done the way it is.
constexpr double kNearFraction = 1e-6;
constexpr double kMaxProjectedCoordinate = 1e100;
constexpr double kMaxSlope = 1e200;

struct Point2 {
  double x;
  double y;
};

enum VertexState : uint8_t { kInFront = 0, kBehind = 1, kInvalid = 2 };

struct Scratch {
  std::vector<Eigen::Vector3d> in_camera;
  std::vector<Point2> projected;
  std::vector<uint8_t> state;
  std::vector<float> inverse_depth;  // z-buffer, one per pixel; 0 = nothing drawn
};

bool IsRepresentable(const Point2& p) {
  return std::abs(p.x) <= kMaxProjectedCoordinate && std::abs(p.y) <= kMaxProjectedCoordinate;
}

struct Edge {
  double x0;
  double y0;
  double slope;

  Edge(const Point2& a, const Point2& b)
      : x0(a.x),
        y0(a.y),
        slope(std::min(std::max((b.x - a.x) / (b.y - a.y), -kMaxSlope), kMaxSlope)) {}

  double At(double y) const { return x0 + (y - y0) * slope; }
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
  double last_column;
  double last_row;
};

// Draws the pixels u of row `row` with x_left <= u <= x_right, with the span arithmetic of
// silhouette_renderer.cc's FillSpan.
inline void DrawSpan(const Target& target, const FaceDraw& face, int row, double x_left,
                     double x_right) {
  const double width = target.last_column + 1.0;
  const double from_right = std::min(std::max(width - x_left, 0.0), width);
  const double end_plus_one = std::min(std::max(x_right + 1.0, 0.0), width);
  const int begin = target.width - static_cast<int>(from_right);
  const int end = static_cast<int>(end_plus_one);
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

// silhouette_renderer.cc's FillTriangle, drawing spans with DrawSpan.
void DrawTriangle(Point2 p0, Point2 p1, Point2 p2, const Target& target, const FaceDraw& face) {
  if (p1.y < p0.y) std::swap(p0, p1);
  if (p2.y < p1.y) std::swap(p1, p2);
  if (p1.y < p0.y) std::swap(p0, p1);
  if (!(p2.y >= 0.0) || !(p0.y <= target.last_row)) return;
  const double min_x = std::min({p0.x, p1.x, p2.x});
  const double max_x = std::max({p0.x, p1.x, p2.x});
  if (!(max_x >= 0.0) || !(min_x <= target.last_column)) return;
  const int row_begin = static_cast<int>(std::ceil(std::max(p0.y, 0.0)));
  const int row_end = static_cast<int>(std::floor(std::min(p2.y, target.last_row)));
  if (row_begin > row_end) return;
  if (p0.y == p2.y) {
    DrawSpan(target, face, row_begin, min_x, max_x);
    return;
  }
  const Edge long_edge(p0, p2);
  const Edge upper_edge = p0.y < p1.y ? Edge(p0, p1) : Edge(p1, p2);
  const Edge lower_edge = p1.y < p2.y ? Edge(p1, p2) : upper_edge;
  for (int row = row_begin; row <= row_end; ++row) {
    const double y = row;
    const double x_long = long_edge.At(y);
    const double x_upper = upper_edge.At(y);
    const double x_lower = lower_edge.At(y);
    DrawSpan(target, face, row, std::min(x_long, std::max(x_upper, x_lower)),
             std::max(x_long, std::min(x_upper, x_lower)));
  }
}

Point2 ProjectPoint(const PinholeCamera& camera, const Eigen::Vector3d& p) {
  return {camera.focal_x_px * p.x() / p.z() + camera.principal_x_px,
          camera.focal_y_px * p.y() / p.z() + camera.principal_y_px};
}

void DrawClippedTriangle(const std::array<uint32_t, 3>& triangle, const Scratch& scratch,
                         double near, const PinholeCamera& camera, const Target& target,
                         const FaceDraw& face) {
  Point2 polygon[4];
  int count = 0;
  for (int i = 0; i < 3; ++i) {
    const uint32_t current = triangle[i];
    const uint32_t next = triangle[(i + 1) % 3];
    const bool current_in = scratch.state[current] == kInFront;
    const bool next_in = scratch.state[next] == kInFront;
    if (current_in) polygon[count++] = scratch.projected[current];
    if (current_in != next_in) {
      const Eigen::Vector3d& in = scratch.in_camera[current_in ? current : next];
      const Eigen::Vector3d& out = scratch.in_camera[current_in ? next : current];
      const double t = (in.z() - near) / (in.z() - out.z());
      Eigen::Vector3d crossing = in + t * (out - in);
      crossing.z() = near;
      const Point2 p = ProjectPoint(camera, crossing);
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !IsRepresentable(p)) return;
      polygon[count++] = p;
    }
  }
  if (count >= 3) DrawTriangle(polygon[0], polygon[1], polygon[2], target, face);
  if (count == 4) DrawTriangle(polygon[0], polygon[2], polygon[3], target, face);
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
  const size_t vertex_count = mesh.vertices.size();
  scratch.in_camera.resize(vertex_count);
  scratch.projected.resize(vertex_count);
  scratch.state.resize(vertex_count);
  scratch.inverse_depth.assign(static_cast<size_t>(size.area()), 0.0f);

  const Eigen::Matrix3d& rotation = camera_from_object.rotation;
  const Eigen::Vector3d& translation = camera_from_object.translation;
  double max_depth = 0.0;
  for (size_t i = 0; i < vertex_count; ++i) {
    const Eigen::Vector3d p = rotation * mesh.vertices[i].cast<double>() + translation;
    scratch.in_camera[i] = p;
    if (std::isfinite(p.z()) && p.z() > max_depth) max_depth = p.z();
  }
  if (max_depth > 0.0) {
    const double near = kNearFraction * max_depth;
    const double fx = camera.focal_x_px;
    const double fy = camera.focal_y_px;
    const double cx = camera.principal_x_px;
    const double cy = camera.principal_y_px;
    for (size_t i = 0; i < vertex_count; ++i) {
      const Eigen::Vector3d& p = scratch.in_camera[i];
      if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
        scratch.state[i] = kInvalid;
      } else if (p.z() < near) {
        scratch.state[i] = kBehind;
      } else {
        const double inverse_depth = 1.0 / p.z();
        const Point2 q{fx * p.x() * inverse_depth + cx, fy * p.y() * inverse_depth + cy};
        scratch.projected[i] = q;
        scratch.state[i] = IsRepresentable(q) ? kInFront : kInvalid;
      }
    }

    const Eigen::Vector3d light = options.light_dir_in_camera.normalized();
    const Target target{
        colour_bgr,       mask, scratch.inverse_depth.data(), camera.width_px, size.width - 1.0,
        size.height - 1.0};
    for (size_t t = 0; t < mesh.triangles.size(); ++t) {
      const std::array<uint32_t, 3>& triangle = mesh.triangles[t];
      if (triangle[0] >= vertex_count || triangle[1] >= vertex_count ||
          triangle[2] >= vertex_count) {
        ThrowError("mesh '", mesh.name, "': triangle ", t, " references vertex ",
                   std::max({triangle[0], triangle[1], triangle[2]}), " but there are only ",
                   vertex_count, " vertices");
      }
      const uint8_t s0 = scratch.state[triangle[0]];
      const uint8_t s1 = scratch.state[triangle[1]];
      const uint8_t s2 = scratch.state[triangle[2]];
      const bool all_in_front = (s0 | s1 | s2) == kInFront;
      if (!all_in_front && !(s0 != kInvalid && s1 != kInvalid && s2 != kInvalid &&
                             (s0 == kInFront || s1 == kInFront || s2 == kInFront))) {
        continue;  // Entirely behind the near plane, or not finite.
      }
      const FaceDraw face =
          PrepareFace(scratch.in_camera[triangle[0]], scratch.in_camera[triangle[1]],
                      scratch.in_camera[triangle[2]], near, camera, options, light);
      if (all_in_front) {
        DrawTriangle(scratch.projected[triangle[0]], scratch.projected[triangle[1]],
                     scratch.projected[triangle[2]], target, face);
      } else {
        DrawClippedTriangle(triangle, scratch, near, camera, target, face);
      }
    }
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
