#pragma once
// Internal to silpose_render: the geometry that RenderSilhouette (silhouette_renderer.h) and
// RenderShaded (shaded_renderer.h) share, so that both decide pixel coverage with the same
// floating-point operations and their masks are bit-identical. Not part of the public API.
//
// The pipeline: TransformVertices moves the mesh to the camera frame, sets the near plane and
// projects the vertices in front of it; RasterizeMesh walks the triangles, clips those crossing the
// near plane and hands every covered run of pixels of a row to a span functor supplied by the
// renderer (template parameter, inlined: it is the per-pixel hot path).
//
// Pixel rule: pixel centres are at integer coordinates; a pixel is covered by a triangle if its
// centre lies inside or on the projected triangle.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose::render_internal {

// Near plane, relative to the largest vertex depth in front of the camera: geometry closer to the
// camera than kNearFraction * max_depth is clipped away. Relative so that it does not depend on the
// model's units; small so that it only matters when the camera is inside or touching the object
// (and then the clipped geometry covers the image anyway). It also bounds the projected
// coordinates: |u - cx| <= fx * |X| / near.
constexpr double kNearFraction = 1e-6;
// Projections beyond this many pixels are treated like non-finite ones (the triangle is skipped).
// Only reachable with absurd inputs (a vertex ~1e94 depths off-axis); it keeps every difference
// and product in the span arithmetic far from overflow.
constexpr double kMaxProjectedCoordinate = 1e100;
// Largest |dx/dy| used for an edge: steeper (nearly horizontal) edges get this slope. Such an edge
// crosses a pixel row only within 1e-100 px of a vertex, so the difference is immaterial; with
// |coordinates| <= kMaxProjectedCoordinate it keeps every x finite (no inf, no NaN).
constexpr double kMaxSlope = 1e200;

struct Point2 {
  double x;
  double y;
};

// Per-vertex state after the transform to the camera frame.
enum VertexState : uint8_t {
  kInFront = 0,  // z >= near, finite projection in `projected`.
  kBehind = 1,   // finite, z < near: triangles using it are clipped.
  kInvalid = 2,  // non-finite coordinates or projection: triangles using it are skipped.
};

// The mesh's vertices seen by the camera. Meant as per-thread scratch, reused between calls (the
// database build renders thousands of views per thread): 41 bytes per vertex of the largest mesh.
struct CameraVertices {
  std::vector<Eigen::Vector3d> in_camera;  // Camera frame, model units.
  std::vector<Point2> projected;           // Pixels; valid where state is kInFront.
  std::vector<uint8_t> state;              // VertexState.
  double near = 0.0;                       // Near plane depth, model units.
};

// Transforms the vertices of `mesh` to the camera frame once, sets the near plane from the largest
// finite depth, then projects the vertices in front of it, once (triangles share them). Returns
// false, leaving `projected`, `state` and `near` unset, if no vertex is in front of the camera
// (nothing to draw).
bool TransformVertices(const TriangleMesh& mesh, const PinholeCamera& camera,
                       const Rigid3& camera_from_object, CameraVertices* vertices);

// Throws silpose::Error: triangle `index` of `mesh` references a missing vertex.
[[noreturn]] void ThrowMissingVertex(const TriangleMesh& mesh, size_t index);

// The image being drawn, as the rasteriser sees it.
struct Viewport {
  int width;
  double last_column;  // width - 1
  double last_row;     // height - 1

  Viewport(int width_px, int height_px)
      : width(width_px), last_column(width_px - 1.0), last_row(height_px - 1.0) {}
};

inline bool IsRepresentable(const Point2& p) {
  return std::abs(p.x) <= kMaxProjectedCoordinate && std::abs(p.y) <= kMaxProjectedCoordinate;
}

inline Point2 ProjectPoint(const PinholeCamera& camera, const Eigen::Vector3d& p) {
  return {camera.focal_x_px * p.x() / p.z() + camera.principal_x_px,
          camera.focal_y_px * p.y() / p.z() + camera.principal_y_px};
}

// The line through a triangle edge from `a` to `b`, a.y < b.y, as x(y). Edges are always set up
// from the endpoint with the smaller y, so the two triangles sharing an edge compute the same x on
// every row and a pixel centre on the edge is filled by at least one of them: no cracks (rounding
// could only matter for centres within ~1e-12 px of a vertex).
struct Edge {
  double x0;
  double y0;
  double slope;  // dx / dy.

  Edge(const Point2& a, const Point2& b)
      : x0(a.x),
        y0(a.y),
        slope(std::min(std::max((b.x - a.x) / (b.y - a.y), -kMaxSlope), kMaxSlope)) {}

  /// x where the line crosses the row line at height y (exact at y = a.y).
  double At(double y) const { return x0 + (y - y0) * slope; }
};

// Hands the pixels u of row `row` with x_left <= u <= x_right to span(row, begin, end) as the
// columns [begin, end), 0 <= begin <= width, end <= width; empty (end <= begin) spans are passed
// too, so that the functor may handle them without a branch.
// ceil(x_left) is computed as width - floor(width - x_left) and floor(x_right) as
// floor(x_right + 1) - 1, with the arguments clamped to [0, width] so that truncation is floor
// (cheaper than exact ceil/floor without SSE4.1). The rounding of the subtraction and addition can
// only widen the span, by pixels whose centres lie within ulp(width) (< 1e-11 px) of its ends:
// never a crack between triangles sharing an edge.
template <typename SpanFn>
inline void EmitSpan(const Viewport& viewport, int row, double x_left, double x_right,
                     SpanFn& span) {
  const double width = viewport.last_column + 1.0;
  const double from_right = std::min(std::max(width - x_left, 0.0), width);
  const double end_plus_one = std::min(std::max(x_right + 1.0, 0.0), width);
  const int begin = viewport.width - static_cast<int>(from_right);  // In [0, width].
  const int end = static_cast<int>(end_plus_one);                   // <= begin if empty.
  span(row, begin, end);
}

// Emits the spans of the pixels whose centres lie inside or on the triangle p0 p1 p2 (finite
// coordinates within +-kMaxProjectedCoordinate; any orientation; degenerate triangles give at most
// a segment of pixels), row by row from the top.
// (Forced inline: about 5% faster for fine meshes; unknown attributes are ignored elsewhere.)
template <typename SpanFn>
[[gnu::always_inline]] inline void RasterizeTriangle(Point2 p0, Point2 p1, Point2 p2,
                                                     const Viewport& viewport, SpanFn& span) {
  if (p1.y < p0.y) std::swap(p0, p1);
  if (p2.y < p1.y) std::swap(p1, p2);
  if (p1.y < p0.y) std::swap(p0, p1);
  if (!(p2.y >= 0.0) || !(p0.y <= viewport.last_row)) return;
  const double min_x = std::min({p0.x, p1.x, p2.x});
  const double max_x = std::max({p0.x, p1.x, p2.x});
  if (!(max_x >= 0.0) || !(min_x <= viewport.last_column)) return;
  // Rows v with p0.y <= v <= p2.y, within the image.
  const int row_begin = static_cast<int>(std::ceil(std::max(p0.y, 0.0)));
  const int row_end = static_cast<int>(std::floor(std::min(p2.y, viewport.last_row)));
  if (row_begin > row_end) return;
  if (p0.y == p2.y) {
    // Flat triangle lying on one row line (only reached if that row is a pixel row).
    EmitSpan(viewport, row_begin, min_x, max_x, span);
    return;
  }
  // The triangle is convex: on each row its span runs from the largest of the lines bounding it on
  // the left to the smallest of those bounding it on the right. The long edge p0 p2 is on one side
  // and the two short edges on the other, so whichever side p1 is on the span is
  // [min(long, max(upper, lower)), max(long, min(upper, lower))], without a branch. A horizontal
  // short edge bounds no row strictly inside the triangle: it is replaced by the other short edge
  // (on its own row the other two edges meet its endpoints).
  const Edge long_edge(p0, p2);
  const Edge upper_edge = p0.y < p1.y ? Edge(p0, p1) : Edge(p1, p2);
  const Edge lower_edge = p1.y < p2.y ? Edge(p1, p2) : upper_edge;
  for (int row = row_begin; row <= row_end; ++row) {
    const double y = row;
    const double x_long = long_edge.At(y);
    const double x_upper = upper_edge.At(y);
    const double x_lower = lower_edge.At(y);
    EmitSpan(viewport, row, std::min(x_long, std::max(x_upper, x_lower)),
             std::max(x_long, std::min(x_upper, x_lower)), span);
  }
}

// Triangle with at least one vertex in front of and one behind the near plane: clips it against
// z >= near (Sutherland-Hodgman, giving a triangle or a quad) and rasterises the result.
template <typename SpanFn>
void RasterizeClippedTriangle(const std::array<uint32_t, 3>& triangle,
                              const CameraVertices& vertices, const PinholeCamera& camera,
                              const Viewport& viewport, SpanFn& span) {
  Point2 polygon[4];
  int count = 0;
  for (int i = 0; i < 3; ++i) {
    const uint32_t current = triangle[i];
    const uint32_t next = triangle[(i + 1) % 3];
    const bool current_in = vertices.state[current] == kInFront;
    const bool next_in = vertices.state[next] == kInFront;
    if (current_in) polygon[count++] = vertices.projected[current];
    if (current_in != next_in) {
      // Intersection computed from the in-front vertex towards the behind one, so the two
      // triangles sharing this edge get the same point.
      const Eigen::Vector3d& in = vertices.in_camera[current_in ? current : next];
      const Eigen::Vector3d& out = vertices.in_camera[current_in ? next : current];
      const double t = (in.z() - vertices.near) / (in.z() - out.z());
      Eigen::Vector3d crossing = in + t * (out - in);
      crossing.z() = vertices.near;
      const Point2 p = ProjectPoint(camera, crossing);
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !IsRepresentable(p)) return;
      polygon[count++] = p;
    }
  }
  if (count >= 3) RasterizeTriangle(polygon[0], polygon[1], polygon[2], viewport, span);
  if (count == 4) RasterizeTriangle(polygon[0], polygon[2], polygon[3], viewport, span);
}

// Rasterises every triangle of `mesh` (vertices from TransformVertices, which returned true), in
// the mesh's order. For each triangle with something in front of the near plane, calls
// begin_face(triangle) and then span(row, begin, end) for each of its rows (see EmitSpan); skips
// triangles entirely behind the near plane or with a non-finite vertex. With `front_faces_only`,
// also skips the triangles in front of the near plane that face away from the camera (projected
// clockwise on the image, whose y axis points down: their normal (b - a) x (c - a) points away);
// those seen edge-on and those crossing the near plane are drawn. Throws silpose::Error if a
// triangle references a missing vertex (after drawing the triangles before it).
template <typename FaceFn, typename SpanFn>
void RasterizeMesh(const TriangleMesh& mesh, const CameraVertices& vertices,
                   const PinholeCamera& camera, const Viewport& viewport, FaceFn&& begin_face,
                   SpanFn&& span, bool front_faces_only = false) {
  const size_t vertex_count = mesh.vertices.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::array<uint32_t, 3>& triangle = mesh.triangles[t];
    if (triangle[0] >= vertex_count || triangle[1] >= vertex_count || triangle[2] >= vertex_count) {
      ThrowMissingVertex(mesh, t);
    }
    const uint8_t s0 = vertices.state[triangle[0]];
    const uint8_t s1 = vertices.state[triangle[1]];
    const uint8_t s2 = vertices.state[triangle[2]];
    if ((s0 | s1 | s2) == kInFront) {
      if (front_faces_only) {
        // Twice the signed area on the image; it has the sign of n . a for the camera-frame
        // vertices a, b, c and normal n (f > 0, depths > 0): positive facing away.
        const Point2& a = vertices.projected[triangle[0]];
        const Point2& b = vertices.projected[triangle[1]];
        const Point2& c = vertices.projected[triangle[2]];
        if ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x) > 0.0) continue;
      }
      begin_face(triangle);
      RasterizeTriangle(vertices.projected[triangle[0]], vertices.projected[triangle[1]],
                        vertices.projected[triangle[2]], viewport, span);
    } else if (s0 != kInvalid && s1 != kInvalid && s2 != kInvalid &&
               (s0 == kInFront || s1 == kInFront || s2 == kInFront)) {
      begin_face(triangle);
      RasterizeClippedTriangle(triangle, vertices, camera, viewport, span);
    }
    // Otherwise entirely behind the near plane, or not finite: nothing to draw.
  }
}

}  // namespace silpose::render_internal
