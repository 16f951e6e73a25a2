#include "silpose/render/silhouette_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

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

// Per-thread scratch buffers, reused between calls (the database build renders thousands of views
// per thread); they keep 41 bytes per vertex of the largest mesh rendered on the thread.
struct Scratch {
  std::vector<Eigen::Vector3d> in_camera;
  std::vector<Point2> projected;
  std::vector<uint8_t> state;
};

// Image being filled.
struct Raster {
  uint8_t* data;
  size_t stride;
  size_t size;  // Bytes in the (continuous) buffer.
  int width;
  double last_column;  // width - 1
  double last_row;     // height - 1
};

bool IsRepresentable(const Point2& p) {
  return std::abs(p.x) <= kMaxProjectedCoordinate && std::abs(p.y) <= kMaxProjectedCoordinate;
}

// Largest |dx/dy| used for an edge: steeper (nearly horizontal) edges get this slope. Such an edge
// crosses a pixel row only within 1e-100 px of a vertex, so the difference is immaterial; with
// |coordinates| <= kMaxProjectedCoordinate it keeps every x finite (no inf, no NaN).
constexpr double kMaxSlope = 1e200;

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

// kLeadingBytes[n]: 8 bytes, the first n of them 255.
constexpr std::array<std::array<uint8_t, 8>, 9> kLeadingBytes = [] {
  std::array<std::array<uint8_t, 8>, 9> table{};
  for (size_t n = 0; n <= 8; ++n) {
    for (size_t i = 0; i < n; ++i) table[n][i] = 255;
  }
  return table;
}();

// Sets `count` bytes from `offset` to 255 (nothing if count <= 0; 0 <= offset <= size). Without
// branches for spans of at most 8 pixels (the common case: fine meshes at low resolution give many
// short and empty spans): one 8-byte read-or-write that leaves the bytes after the span unchanged.
inline void SetSpan(const Raster& raster, size_t offset, int count) {
  uint8_t* const first = raster.data + offset;
  if (count > 8 || offset + 8 > raster.size) {
    if (count > 0) std::memset(first, 255, static_cast<size_t>(count));
    return;
  }
  uint64_t word;
  uint64_t leading;
  std::memcpy(&word, first, 8);
  std::memcpy(&leading, kLeadingBytes[static_cast<size_t>(std::max(count, 0))].data(), 8);
  word |= leading;
  std::memcpy(first, &word, 8);
}

// Sets the pixels u of row `row` with x_left <= u <= x_right (pixel centres at integers).
// ceil(x_left) is computed as width - floor(width - x_left) and floor(x_right) as
// floor(x_right + 1) - 1, with the arguments clamped to [0, width] so that truncation is floor
// (cheaper than exact ceil/floor without SSE4.1). The rounding of the subtraction and addition can
// only widen the span, by pixels whose centres lie within ulp(width) (< 1e-11 px) of its ends:
// never a crack between triangles sharing an edge.
inline void FillSpan(const Raster& raster, int row, double x_left, double x_right) {
  const double width = raster.last_column + 1.0;
  const double from_right = std::min(std::max(width - x_left, 0.0), width);
  const double end_plus_one = std::min(std::max(x_right + 1.0, 0.0), width);
  const int begin = raster.width - static_cast<int>(from_right);  // In [0, width].
  const int count = static_cast<int>(end_plus_one) - begin;       // <= 0 if empty.
  SetSpan(raster, static_cast<size_t>(row) * raster.stride + static_cast<size_t>(begin), count);
}

// Sets every pixel whose centre lies inside or on the triangle p0 p1 p2 (finite coordinates within
// +-kMaxProjectedCoordinate; any orientation; degenerate triangles give at most a segment of
// pixels).
// (Forced inline: about 5% faster for fine meshes; unknown attributes are ignored elsewhere.)
[[gnu::always_inline]] inline void FillTriangle(Point2 p0, Point2 p1, Point2 p2,
                                                const Raster& raster) {
  if (p1.y < p0.y) std::swap(p0, p1);
  if (p2.y < p1.y) std::swap(p1, p2);
  if (p1.y < p0.y) std::swap(p0, p1);
  if (!(p2.y >= 0.0) || !(p0.y <= raster.last_row)) return;
  const double min_x = std::min({p0.x, p1.x, p2.x});
  const double max_x = std::max({p0.x, p1.x, p2.x});
  if (!(max_x >= 0.0) || !(min_x <= raster.last_column)) return;
  // Rows v with p0.y <= v <= p2.y, within the image.
  const int row_begin = static_cast<int>(std::ceil(std::max(p0.y, 0.0)));
  const int row_end = static_cast<int>(std::floor(std::min(p2.y, raster.last_row)));
  if (row_begin > row_end) return;
  if (p0.y == p2.y) {
    // Flat triangle lying on one row line (only reached if that row is a pixel row).
    FillSpan(raster, row_begin, min_x, max_x);
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
    FillSpan(raster, row, std::min(x_long, std::max(x_upper, x_lower)),
             std::max(x_long, std::min(x_upper, x_lower)));
  }
}

Point2 ProjectPoint(const PinholeCamera& camera, const Eigen::Vector3d& p) {
  return {camera.focal_x_px * p.x() / p.z() + camera.principal_x_px,
          camera.focal_y_px * p.y() / p.z() + camera.principal_y_px};
}

// Triangle with at least one vertex in front of and one behind the near plane: clips it against
// z >= near (Sutherland-Hodgman, giving a triangle or a quad) and fills the result.
void FillClippedTriangle(const std::array<uint32_t, 3>& triangle, const Scratch& scratch,
                         double near, const PinholeCamera& camera, const Raster& raster) {
  Point2 polygon[4];
  int count = 0;
  for (int i = 0; i < 3; ++i) {
    const uint32_t current = triangle[i];
    const uint32_t next = triangle[(i + 1) % 3];
    const bool current_in = scratch.state[current] == kInFront;
    const bool next_in = scratch.state[next] == kInFront;
    if (current_in) polygon[count++] = scratch.projected[current];
    if (current_in != next_in) {
      // Intersection computed from the in-front vertex towards the behind one, so the two
      // triangles sharing this edge get the same point.
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
  if (count >= 3) FillTriangle(polygon[0], polygon[1], polygon[2], raster);
  if (count == 4) FillTriangle(polygon[0], polygon[2], polygon[3], raster);
}

}  // namespace

void RenderSilhouette(const TriangleMesh& mesh, const PinholeCamera& camera,
                      const Rigid3& camera_from_object, cv::Mat* mask) {
  SILPOSE_ASSERT(mask != nullptr);
  std::string error;
  if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
  // Continuous, so that a short span may be written as 8 bytes reaching into the next row.
  if (!mask->isContinuous()) mask->release();
  mask->create(camera.height_px, camera.width_px, CV_8UC1);
  mask->setTo(cv::Scalar(0));

  thread_local Scratch scratch;
  const size_t vertex_count = mesh.vertices.size();
  scratch.in_camera.resize(vertex_count);
  scratch.projected.resize(vertex_count);
  scratch.state.resize(vertex_count);

  // Transform once; find the largest finite depth to set the near plane. Then project the vertices
  // in front of it, once: triangles share them.
  const Eigen::Matrix3d& rotation = camera_from_object.rotation;
  const Eigen::Vector3d& translation = camera_from_object.translation;
  double max_depth = 0.0;
  for (size_t i = 0; i < vertex_count; ++i) {
    const Eigen::Vector3d p = rotation * mesh.vertices[i].cast<double>() + translation;
    scratch.in_camera[i] = p;
    if (std::isfinite(p.z()) && p.z() > max_depth) max_depth = p.z();
  }
  if (!(max_depth > 0.0)) return;  // Nothing in front of the camera.
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

  const Raster raster{mask->data,      mask->step[0],         mask->total(),
                      camera.width_px, camera.width_px - 1.0, camera.height_px - 1.0};
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::array<uint32_t, 3>& triangle = mesh.triangles[t];
    if (triangle[0] >= vertex_count || triangle[1] >= vertex_count || triangle[2] >= vertex_count) {
      ThrowError("mesh '", mesh.name, "': triangle ", t, " references vertex ",
                 std::max({triangle[0], triangle[1], triangle[2]}), " but there are only ",
                 vertex_count, " vertices");
    }
    const uint8_t s0 = scratch.state[triangle[0]];
    const uint8_t s1 = scratch.state[triangle[1]];
    const uint8_t s2 = scratch.state[triangle[2]];
    if ((s0 | s1 | s2) == kInFront) {
      FillTriangle(scratch.projected[triangle[0]], scratch.projected[triangle[1]],
                   scratch.projected[triangle[2]], raster);
    } else if (s0 != kInvalid && s1 != kInvalid && s2 != kInvalid &&
               (s0 == kInFront || s1 == kInFront || s2 == kInFront)) {
      FillClippedTriangle(triangle, scratch, near, camera, raster);
    }
    // Otherwise entirely behind the near plane, or not finite: nothing to draw.
  }
}

bool ViewRenderOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (resolution_px < 32 || resolution_px > 16384) {
    message << "resolution_px must be in [32, 16384], got " << resolution_px;
  } else if (!std::isfinite(distance_in_radii) || !(distance_in_radii > 1.0)) {
    message << "distance_in_radii must be finite and > 1, got " << distance_in_radii;
  } else if (!(fill_fraction > 0.0 && fill_fraction <= 1.0)) {
    message << "fill_fraction must be in (0, 1], got " << fill_fraction;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

PinholeCamera ViewCamera(const ViewRenderOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid view render options: ", error);
  // A sphere of radius r at distance D = k r on the optical axis is seen under the half-angle
  // asin(1 / k); its image is a disc of radius f * tan(asin(1 / k)) = f / sqrt(k^2 - 1), which must
  // be fill_fraction * resolution / 2.
  const double k = options.distance_in_radii;
  const double focal_px =
      options.fill_fraction * 0.5 * options.resolution_px * std::sqrt(k * k - 1.0);
  return PinholeCamera::Centered(options.resolution_px, options.resolution_px, focal_px);
}

void RenderView(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir_in_object,
                double roll_deg, const ViewRenderOptions& options, cv::Mat* mask) {
  const PinholeCamera camera = ViewCamera(options);  // Checks the options.
  const double view_norm = view_dir_in_object.norm();
  if (!(view_norm > 0.0) || !std::isfinite(view_norm)) {
    ThrowError("view direction must be non-zero and finite, got (", view_dir_in_object.x(), ", ",
               view_dir_in_object.y(), ", ", view_dir_in_object.z(), ")");
  }
  if (!std::isfinite(roll_deg)) ThrowError("roll_deg must be finite, got ", roll_deg);
  if (mesh.triangles.empty()) ThrowError("mesh '", mesh.name, "' has no triangles");
  const double radius = mesh.Radius();
  if (!(radius > 0.0) || !std::isfinite(radius)) {
    ThrowError("mesh '", mesh.name, "' has radius ", radius, "; it must be positive and finite");
  }
  const Rigid3 camera_from_object = CameraFromObjectAtView(
      view_dir_in_object, roll_deg, options.distance_in_radii * radius, mesh.Centre());
  RenderSilhouette(mesh, camera, camera_from_object, mask);
}

}  // namespace silpose
