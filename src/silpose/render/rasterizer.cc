#include "silpose/render/rasterizer.h"

#include "silpose/util/error.h"

namespace silpose::render_internal {

bool TransformVertices(const TriangleMesh& mesh, const PinholeCamera& camera,
                       const Rigid3& camera_from_object, CameraVertices* vertices) {
  const size_t vertex_count = mesh.vertices.size();
  vertices->in_camera.resize(vertex_count);
  vertices->projected.resize(vertex_count);
  vertices->state.resize(vertex_count);

  const Eigen::Matrix3d& rotation = camera_from_object.rotation;
  const Eigen::Vector3d& translation = camera_from_object.translation;
  double max_depth = 0.0;
  for (size_t i = 0; i < vertex_count; ++i) {
    const Eigen::Vector3d p = rotation * mesh.vertices[i].cast<double>() + translation;
    vertices->in_camera[i] = p;
    if (std::isfinite(p.z()) && p.z() > max_depth) max_depth = p.z();
  }
  if (!(max_depth > 0.0)) return false;  // Nothing in front of the camera.
  const double near = kNearFraction * max_depth;
  vertices->near = near;

  const double fx = camera.focal_x_px;
  const double fy = camera.focal_y_px;
  const double cx = camera.principal_x_px;
  const double cy = camera.principal_y_px;
  for (size_t i = 0; i < vertex_count; ++i) {
    const Eigen::Vector3d& p = vertices->in_camera[i];
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) {
      vertices->state[i] = kInvalid;
    } else if (p.z() < near) {
      vertices->state[i] = kBehind;
    } else {
      const double inverse_depth = 1.0 / p.z();
      const Point2 q{fx * p.x() * inverse_depth + cx, fy * p.y() * inverse_depth + cy};
      vertices->projected[i] = q;
      vertices->state[i] = IsRepresentable(q) ? kInFront : kInvalid;
    }
  }
  return true;
}

void ThrowMissingVertex(const TriangleMesh& mesh, size_t index) {
  const std::array<uint32_t, 3>& triangle = mesh.triangles[index];
  ThrowError("mesh '", mesh.name, "': triangle ", index, " references vertex ",
             std::max({triangle[0], triangle[1], triangle[2]}), " but there are only ",
             mesh.vertices.size(), " vertices");
}

}  // namespace silpose::render_internal
