#include "silpose/pose/contour_refinement.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

#include "silpose/pose/lens_distortion.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
// Contour-generator samples tried per outline point wanted (most of the generator is hidden).
constexpr int kCandidatesPerPoint = 8;
// Smallest spacing of the samples along the projected generator, pixels.
constexpr double kMinSpacingPx = 0.25;
// Border, pixels, around the model's projection when rendering it.
constexpr int kRenderBorderPx = 3;
// Frame -> model gaps smaller than this, pixels, cost nothing: near the solution the frame's own
// pixel staircase would only add noise to what the model -> frame residuals measure; the term is
// there to pull the model over parts of the frame silhouette it does not reach.
constexpr double kReverseDeadZonePx = 1.0;
// Fewest outline points for a 6-DOF step.
constexpr int kMinPoints = 6;
// Damping tries per iteration before the pose is taken as a minimum.
constexpr int kMaxDampingTries = 8;

using Row6 = Eigen::Matrix<double, 1, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Pixel of a camera-frame point (z > 0) and, if `jacobian` is non-null, d(pixel) / d(point).
Eigen::Vector2d ProjectWithJacobian(const PinholeCamera& camera, bool distorted,
                                    const Eigen::Vector3d& x,
                                    Eigen::Matrix<double, 2, 3>* jacobian) {
  const double inv_z = 1.0 / x.z();
  const Eigen::Vector2d ideal(x.x() * inv_z, x.y() * inv_z);
  Eigen::Vector2d normalized = ideal;
  Eigen::Matrix2d d_distort = Eigen::Matrix2d::Identity();
  if (distorted) normalized = DistortNormalized(camera.distortion, ideal, &d_distort);
  if (jacobian != nullptr) {
    Eigen::Matrix<double, 2, 3> d_ideal;
    d_ideal << inv_z, 0.0, -ideal.x() * inv_z, 0.0, inv_z, -ideal.y() * inv_z;
    *jacobian = Eigen::DiagonalMatrix<double, 2>(camera.focal_x_px, camera.focal_y_px) * d_distort *
                d_ideal;
  }
  return {camera.focal_x_px * normalized.x() + camera.principal_x_px,
          camera.focal_y_px * normalized.y() + camera.principal_y_px};
}

// Huber loss and IRLS weight at scale k.
double HuberLoss(double r, double k) {
  const double a = std::abs(r);
  return a <= k ? 0.5 * r * r : k * (a - 0.5 * k);
}
double HuberWeight(double r, double k) {
  const double a = std::abs(r);
  return a <= k ? 1.0 : k / a;
}

// Scratch reused between calls on one thread (no allocation once warmed up).
struct Workspace {
  std::vector<Eigen::Vector3d> in_camera;
  std::vector<Eigen::Vector2d> projected;
  std::vector<uint8_t> facing;
  std::vector<uint8_t> projected_ok;
  std::vector<const ContourModel::Edge*> contour_edges;
  // The triangles of a closed model facing the camera (vertices copied once per model).
  TriangleMesh front_mesh;
  std::vector<Eigen::Vector3d> candidates;
  std::vector<double> candidate_offsets;
  std::vector<Eigen::Vector2d> candidate_normals;
  // Outline points (model frame) and the signed distance of each to the rendered outline at
  // selection, pixels (subtracted from its residual: the point stands for the outline beside it).
  std::vector<Eigen::Vector3d> points;
  std::vector<double> offsets;
  // Outward unit normal of the rendered outline at each point (image).
  std::vector<Eigen::Vector2d> normals;
  // Frame outline points matched to a model outline point: (frame point, index into points).
  std::vector<std::pair<Eigen::Vector2d, size_t>> matches;
  // The projected outline points, binned (MatchFrameOutline).
  contour_internal::NearestPointGrid grid;
  // Per outline point at the last evaluated pose: camera frame, in front of the camera, pixel
  // (distorted) and d(pixel) / d(camera frame).
  std::vector<Eigen::Vector3d> point_in_camera;
  std::vector<uint8_t> in_front;
  std::vector<Eigen::Vector2d> projections;
  std::vector<Eigen::Matrix<double, 2, 3>> d_pixel;
  cv::Mat render;
};

Workspace& ThreadWorkspace() {
  thread_local Workspace workspace;
  return workspace;
}

// The window of the camera's image covered by the model's projection, grown by a border; the whole
// image if part of the model is behind the camera. Fills ws.in_camera / projected / projected_ok.
cv::Rect ModelWindow(const TriangleMesh& mesh, const PinholeCamera& camera, const Rigid3& pose,
                     Workspace& ws) {
  const size_t n = mesh.vertices.size();
  ws.in_camera.resize(n);
  ws.projected.resize(n);
  ws.projected_ok.resize(n);
  double max_z = 0.0;
  for (size_t i = 0; i < n; ++i) {
    ws.in_camera[i] = pose.rotation * mesh.vertices[i].cast<double>() + pose.translation;
    max_z = std::max(max_z, ws.in_camera[i].z());
  }
  const double near = 1e-6 * max_z;
  const cv::Rect image(0, 0, camera.width_px, camera.height_px);
  double min_u = 1e300, min_v = 1e300, max_u = -1e300, max_v = -1e300;
  bool behind = false;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& x = ws.in_camera[i];
    if (!(x.z() > near)) {
      behind = true;
      ws.projected_ok[i] = 0;
      continue;
    }
    const Eigen::Vector2d p = camera.Project(x);
    ws.projected[i] = p;
    ws.projected_ok[i] = 1;
    min_u = std::min(min_u, p.x());
    max_u = std::max(max_u, p.x());
    min_v = std::min(min_v, p.y());
    max_v = std::max(max_v, p.y());
  }
  if (behind) return image;
  if (!(max_u >= min_u)) return {};
  const double lo_u = std::max(std::floor(min_u) - kRenderBorderPx, 0.0);
  const double lo_v = std::max(std::floor(min_v) - kRenderBorderPx, 0.0);
  const double hi_u = std::min(std::ceil(max_u) + kRenderBorderPx, image.width - 1.0);
  const double hi_v = std::min(std::ceil(max_v) + kRenderBorderPx, image.height - 1.0);
  if (hi_u < lo_u || hi_v < lo_v) return {};
  return {static_cast<int>(lo_u), static_cast<int>(lo_v), static_cast<int>(hi_u - lo_u) + 1,
          static_cast<int>(hi_v - lo_v) + 1};
}

// Renders the ideal silhouette into ws.render over `window` (window-relative pixels).
void RenderWindow(const TriangleMesh& mesh, const PinholeCamera& camera, const Rigid3& pose,
                  const cv::Rect& window, Workspace& ws) {
  PinholeCamera cropped = camera;
  cropped.width_px = window.width;
  cropped.height_px = window.height;
  cropped.principal_x_px = camera.principal_x_px - window.x;
  cropped.principal_y_px = camera.principal_y_px - window.y;
  cropped.distortion = {0, 0, 0, 0, 0};
  RenderSilhouette(mesh, cropped, pose, &ws.render);
}

// ws.facing[f]: whether the camera centre is on the side of face f's plane its normal points to.
void ComputeFacing(const ContourModel& model, const Rigid3& pose, Workspace& ws) {
  const Eigen::Vector3d eye = -(pose.rotation.transpose() * pose.translation);
  const std::vector<Eigen::Vector3d>& normals = model.normals();
  const std::vector<double>& offsets = model.offsets();
  ws.facing.resize(normals.size());
  for (size_t f = 0; f < normals.size(); ++f) {
    ws.facing[f] = normals[f].dot(eye) > offsets[f] ? 1 : 0;
  }
}

// Renders the model's silhouette at `pose` into ws.render over `window` (RenderWindow). A closed
// mesh's silhouette is that of its triangles facing the camera (ws.facing, from ComputeFacing at
// `pose`): only those are drawn.
void RenderModel(const ContourModel& model, const PinholeCamera& camera, const Rigid3& pose,
                 const cv::Rect& window, Workspace& ws) {
  const TriangleMesh& mesh = model.mesh();
  if (!model.closed()) {
    RenderWindow(mesh, camera, pose, window, ws);
    return;
  }
  const uint8_t front = model.outward() ? 1 : 0;
  if (ws.front_mesh.vertices.size() != mesh.vertices.size() ||
      std::memcmp(ws.front_mesh.vertices.data(), mesh.vertices.data(),
                  mesh.vertices.size() * sizeof(Eigen::Vector3f)) != 0) {
    ws.front_mesh.vertices = mesh.vertices;
  }
  ws.front_mesh.triangles.clear();
  for (size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (ws.facing[f] == front) ws.front_mesh.triangles.push_back(mesh.triangles[f]);
  }
  RenderWindow(ws.front_mesh, camera, pose, window, ws);
}

// Outline points into ws.points (see the header).
void SelectOutlinePoints(const ContourModel& model, const PinholeCamera& camera, const Rigid3& pose,
                         int max_points, Workspace& ws) {
  ws.points.clear();
  ws.offsets.clear();
  ws.normals.clear();
  const TriangleMesh& mesh = model.mesh();
  const cv::Rect window = ModelWindow(mesh, camera, pose, ws);
  if (window.area() == 0) return;
  ComputeFacing(model, pose, ws);
  RenderModel(model, camera, pose, window, ws);

  // Total projected length of the contour generator.
  const auto is_contour = [&ws](const ContourModel::Edge& e) {
    if (e.face1 < 0) return true;
    return (ws.facing[static_cast<size_t>(e.face0)] != ws.facing[static_cast<size_t>(e.face1)]) !=
           e.flipped;
  };
  double total_length = 0.0;
  ws.contour_edges.clear();
  for (const ContourModel::Edge& e : model.edges()) {
    if (!ws.projected_ok[e.a] || !ws.projected_ok[e.b] || !is_contour(e)) continue;
    total_length += (ws.projected[e.b] - ws.projected[e.a]).norm();
    ws.contour_edges.push_back(&e);
  }
  if (!(total_length > 0.0)) return;
  const double spacing = std::max(
      total_length / (static_cast<double>(kCandidatesPerPoint) * max_points), kMinSpacingPx);

  const uint8_t* render = ws.render.ptr<uint8_t>(0);
  const size_t stride = ws.render.step[0];
  const int last_x = ws.render.cols - 1;
  const int last_y = ws.render.rows - 1;
  // Rendered coverage (0 or 1 at pixel centres) interpolated bilinearly at (u, v), and its
  // gradient; -1 outside the rendered window.
  const auto coverage = [&](double u, double v, Eigen::Vector2d* gradient) {
    const double x = u - window.x, y = v - window.y;
    if (!(x >= 0.0 && y >= 0.0 && x < last_x && y < last_y)) return -1.0;
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    const uint8_t* row0 = render + static_cast<size_t>(y0) * stride + static_cast<size_t>(x0);
    const uint8_t* row1 = row0 + stride;
    const double c00 = row0[0] != 0, c10 = row0[1] != 0, c01 = row1[0] != 0, c11 = row1[1] != 0;
    const double top = c00 + fx * (c10 - c00);
    const double bottom = c01 + fx * (c11 - c01);
    *gradient = {(1.0 - fy) * (c10 - c00) + fy * (c11 - c01), bottom - top};
    return top + fy * (bottom - top);
  };

  ws.candidates.clear();
  ws.candidate_offsets.clear();
  ws.candidate_normals.clear();
  double phase = 0.5 * spacing;  // Arc length to the next sample from the current edge's start.
  for (const ContourModel::Edge* edge : ws.contour_edges) {
    const ContourModel::Edge& e = *edge;
    const Eigen::Vector2d& pa = ws.projected[e.a];
    const Eigen::Vector2d& pb = ws.projected[e.b];
    const double length = (pb - pa).norm();
    if (phase > length) {
      phase -= length;
      continue;
    }
    const double za = ws.in_camera[e.a].z();
    const double zb = ws.in_camera[e.b].z();
    const Eigen::Vector3d va = mesh.vertices[e.a].cast<double>();
    const Eigen::Vector3d vb = mesh.vertices[e.b].cast<double>();
    for (; phase <= length; phase += spacing) {
      const double s = phase / length;  // Fraction along the projected edge.
      const Eigen::Vector2d p = pa + s * (pb - pa);
      // On the rendered outline if the pixel cell around p has both object and background
      // corners; 0.5 - coverage is then the signed distance from p to that outline, pixels.
      Eigen::Vector2d gradient;
      const double c = coverage(p.x(), p.y(), &gradient);
      const double gradient_norm = gradient.norm();
      if (!(c > 0.0 && c < 1.0) || !(gradient_norm > 0.0)) continue;
      // The 3D point projecting to p (perspective: not the same fraction along the 3D edge).
      const double t = s * za / (s * za + (1.0 - s) * zb);
      ws.candidates.push_back(va + t * (vb - va));
      ws.candidate_offsets.push_back(0.5 - c);
      ws.candidate_normals.push_back(-gradient / gradient_norm);
    }
    phase -= length;
  }

  const size_t found = ws.candidates.size();
  const size_t wanted = static_cast<size_t>(max_points);
  if (found <= wanted) {
    ws.points.swap(ws.candidates);
    ws.offsets.swap(ws.candidate_offsets);
    ws.normals.swap(ws.candidate_normals);
    return;
  }
  const double stride_points = static_cast<double>(found) / static_cast<double>(wanted);
  for (size_t i = 0; i < wanted; ++i) {
    const auto index = static_cast<size_t>((static_cast<double>(i) + 0.5) * stride_points);
    ws.points.push_back(ws.candidates[index]);
    ws.offsets.push_back(ws.candidate_offsets[index]);
    ws.normals.push_back(ws.candidate_normals[index]);
  }
}

// Robust cost of the residuals at `pose` and its parts; with `normal`/`gradient` non-null, also
// the Huber-weighted normal equations. Two kinds of residuals (the header explains the first):
//  - model -> frame: the frame's signed distance at each model outline point's projection, minus
//    the point's offset from the rendered outline;
//  - frame -> model: for each frame outline point q matched (ws.matches) to model outline point j,
//    n_j . (q - p_j) + offset_j, the signed distance from q to the model outline near p_j (tangent
//    line with outward normal n_j): positive where the frame silhouette reaches beyond the model's.
struct Evaluation {
  double cost = 0.0;       // Sum of truncated Huber losses, all residuals.
  double used_loss = 0.0;  // Sum of Huber losses of the used model -> frame residuals.
  int used = 0;            // Used model -> frame residuals.
  double RmsPx() const { return used > 0 ? std::sqrt(2.0 * used_loss / used) : 0.0; }
};

Evaluation Evaluate(const PinholeCamera& camera, bool distorted, const FrameOutline& frame,
                    const Rigid3& pose, const Eigen::Vector3d& centre_in_camera, Workspace& ws,
                    const ContourRefinementOptions& options, Matrix6d* normal, Vector6d* gradient) {
  Evaluation out;
  const double k = options.huber_px;
  const double truncated = HuberLoss(options.max_residual_px, k);
  const bool linearise = normal != nullptr;
  if (linearise) {
    normal->setZero();
    gradient->setZero();
  }
  const auto add = [&](double r, const Eigen::RowVector3d& d_point, const Eigen::Vector3d& x) {
    Row6 row;
    row.head<3>() = (x - centre_in_camera).cross(d_point.transpose()).transpose();
    row.tail<3>() = d_point;
    const double w = HuberWeight(r, k);
    normal->selfadjointView<Eigen::Upper>().rankUpdate(row.transpose(), w);
    *gradient += w * r * row.transpose();
  };
  const size_t count = ws.points.size();
  ws.projections.resize(count);
  ws.in_front.resize(count);
  ws.point_in_camera.resize(count);
  ws.d_pixel.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d x = pose.rotation * ws.points[i] + pose.translation;
    ws.point_in_camera[i] = x;
    ws.in_front[i] = x.z() > 0.0;
    double r = 0.0;
    Eigen::Vector2d g;
    bool ok = ws.in_front[i] != 0;
    if (ok) {
      const Eigen::Vector2d p =
          ProjectWithJacobian(camera, distorted, x, linearise ? &ws.d_pixel[i] : nullptr);
      ws.projections[i] = p;
      ok = frame.Distance(p.x(), p.y(), &r, linearise ? &g : nullptr);
      r -= ws.offsets[i];
      ok = ok && std::abs(r) <= options.max_residual_px;
    }
    if (!ok) {
      out.cost += truncated;
      continue;
    }
    const double loss = HuberLoss(r, k);
    out.cost += loss;
    out.used_loss += loss;
    ++out.used;
    if (linearise) add(r, g.transpose() * ws.d_pixel[i], x);
  }
  for (const auto& [q, j] : ws.matches) {
    if (!ws.in_front[j]) {
      out.cost += truncated;
      continue;
    }
    const Eigen::Vector2d& n = ws.normals[j];
    const double gap = n.dot(q - ws.projections[j]) + ws.offsets[j];
    // Dead zone: within it the model -> frame residuals already see the same outline.
    const double r = std::copysign(std::max(std::abs(gap) - kReverseDeadZonePx, 0.0), gap);
    if (!(std::abs(gap) <= options.max_residual_px)) {
      out.cost += truncated;
      continue;
    }
    out.cost += HuberLoss(r, k);
    if (linearise && r != 0.0) add(r, -(n.transpose() * ws.d_pixel[j]), ws.point_in_camera[j]);
  }
  if (linearise) *normal = normal->selfadjointView<Eigen::Upper>();
  return out;
}

// Matches up to `max_matches` frame outline points, evenly spread, to the nearest projected model
// outline point (ws.projections, from the last Evaluate at the current pose) within
// `max_distance_px` (ties: the lowest index).
void MatchFrameOutline(const FrameOutline& frame, int max_matches, double max_distance_px,
                       Workspace& ws) {
  ws.matches.clear();
  const std::vector<Eigen::Vector2d>& outline = frame.outline_points();
  if (outline.empty() || ws.points.empty()) return;
  ws.grid.Build(ws.projections, ws.in_front);
  const double step =
      std::max(1.0, static_cast<double>(outline.size()) / static_cast<double>(max_matches));
  for (double position = 0.5 * step; position < static_cast<double>(outline.size());
       position += step) {
    const Eigen::Vector2d& q = outline[static_cast<size_t>(position)];
    const int nearest = ws.grid.Nearest(q, max_distance_px);
    if (nearest >= 0) ws.matches.emplace_back(q, static_cast<size_t>(nearest));
  }
}

// Forward distortion of ideal pixels, sampled on a grid and interpolated (for the IoU).
class DistortionGrid {
 public:
  static constexpr int kStep = 8;

  DistortionGrid(const PinholeCamera& camera, const cv::Rect& window) : origin_(window.tl()) {
    columns_ = window.width / kStep + 2;
    rows_ = window.height / kStep + 2;
    nodes_.resize(static_cast<size_t>(columns_) * rows_);
    for (int j = 0; j < rows_; ++j) {
      for (int i = 0; i < columns_; ++i) {
        const Eigen::Vector2d ideal(
            (origin_.x + i * kStep - camera.principal_x_px) / camera.focal_x_px,
            (origin_.y + j * kStep - camera.principal_y_px) / camera.focal_y_px);
        const Eigen::Vector2d d = DistortNormalized(camera.distortion, ideal);
        nodes_[static_cast<size_t>(j) * columns_ + i] = {
            camera.focal_x_px * d.x() + camera.principal_x_px,
            camera.focal_y_px * d.y() + camera.principal_y_px};
      }
    }
  }

  // Distorted pixel of the ideal pixel (x, y) relative to the window.
  Eigen::Vector2d At(int x, int y) const {
    const int i = x / kStep, j = y / kStep;
    const double fx = (x - i * kStep) / static_cast<double>(kStep);
    const double fy = (y - j * kStep) / static_cast<double>(kStep);
    const size_t base = static_cast<size_t>(j) * columns_ + i;
    return (1 - fy) * ((1 - fx) * nodes_[base] + fx * nodes_[base + 1]) +
           fy * ((1 - fx) * nodes_[base + columns_] + fx * nodes_[base + columns_ + 1]);
  }

 private:
  cv::Point origin_;
  int columns_ = 0;
  int rows_ = 0;
  std::vector<Eigen::Vector2d> nodes_;
};

double ComputeIou(const ContourModel& model, const PinholeCamera& camera, bool distorted,
                  const FrameOutline& frame, const Rigid3& pose, Workspace& ws) {
  const cv::Rect image(0, 0, camera.width_px, camera.height_px);
  cv::Rect window = ModelWindow(model.mesh(), camera, pose, ws);
  // The frame silhouette's box in ideal pixels (with distortion: the box of its border undistorted,
  // grown by 2 pixels; the straight sides of the distorted box bulge a little in ideal pixels).
  cv::Rect frame_ideal = frame.object_box();
  if (distorted) {
    const cv::Rect w(frame.object_box().x - 2, frame.object_box().y - 2,
                     frame.object_box().width + 4, frame.object_box().height + 4);
    double min_u = 1e300, min_v = 1e300, max_u = -1e300, max_v = -1e300;
    for (int a = 0; a <= 4; ++a) {
      for (int b = 0; b <= 4; ++b) {
        if (a != 0 && a != 4 && b != 0 && b != 4) continue;
        const Eigen::Vector2d pixel(w.x + a * (w.width - 1) / 4.0, w.y + b * (w.height - 1) / 4.0);
        Eigen::Vector2d ideal;
        if (!PixelToIdealNormalized(camera, pixel, &ideal)) continue;
        const double u = camera.focal_x_px * ideal.x() + camera.principal_x_px;
        const double v = camera.focal_y_px * ideal.y() + camera.principal_y_px;
        min_u = std::min(min_u, u);
        max_u = std::max(max_u, u);
        min_v = std::min(min_v, v);
        max_v = std::max(max_v, v);
      }
    }
    if (max_u >= min_u) {
      frame_ideal = cv::Rect(cv::Point(static_cast<int>(std::floor(min_u)) - 1,
                                       static_cast<int>(std::floor(min_v)) - 1),
                             cv::Point(static_cast<int>(std::ceil(max_u)) + 2,
                                       static_cast<int>(std::ceil(max_v)) + 2)) &
                    image;
    } else {
      frame_ideal = image;
    }
  }
  window = (window.area() > 0 ? (window | frame_ideal) : frame_ideal) & image;
  if (window.area() == 0) return 0.0;
  if (model.closed()) ComputeFacing(model, pose, ws);
  RenderModel(model, camera, pose, window, ws);
  const cv::Mat& mask = frame.mask();
  int64_t both = 0, either = 0;
  if (!distorted) {
    for (int y = 0; y < window.height; ++y) {
      const uint8_t* a = ws.render.ptr<uint8_t>(y);
      const uint8_t* b = mask.ptr<uint8_t>(y + window.y) + window.x;
      for (int x = 0; x < window.width; ++x) {
        const bool in_a = a[x] != 0, in_b = b[x] != 0;
        both += in_a && in_b;
        either += in_a || in_b;
      }
    }
  } else {
    const DistortionGrid grid(camera, window);
    for (int y = 0; y < window.height; ++y) {
      const uint8_t* a = ws.render.ptr<uint8_t>(y);
      for (int x = 0; x < window.width; ++x) {
        const Eigen::Vector2d d = grid.At(x, y);
        const int u = static_cast<int>(std::lround(d.x()));
        const int v = static_cast<int>(std::lround(d.y()));
        const bool in_b =
            u >= 0 && v >= 0 && u < mask.cols && v < mask.rows && mask.at<uint8_t>(v, u) != 0;
        const bool in_a = a[x] != 0;
        both += in_a && in_b;
        either += in_a || in_b;
      }
    }
  }
  return either > 0 ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
}

}  // namespace

namespace contour_internal {

void NearestPointGrid::Build(std::span<const Eigen::Vector2d> points,
                             std::span<const uint8_t> usable) {
  SILPOSE_ASSERT(usable.size() == points.size());
  points_ = points;
  const auto ok = [&](size_t j) {
    return usable[j] != 0 && std::isfinite(points[j].x()) && std::isfinite(points[j].y());
  };
  double min_u = std::numeric_limits<double>::infinity(), min_v = min_u;
  double max_u = -min_u, max_v = -min_u;
  for (size_t j = 0; j < points.size(); ++j) {
    if (!ok(j)) continue;
    min_u = std::min(min_u, points[j].x());
    max_u = std::max(max_u, points[j].x());
    min_v = std::min(min_v, points[j].y());
    max_v = std::max(max_v, points[j].y());
  }
  cell_start_.clear();
  sorted_.clear();
  if (!(max_u >= min_u)) {
    columns_ = rows_ = 0;
    return;
  }
  origin_ = {min_u, min_v};
  cell_px_ =
      std::max({kCellPx, (max_u - min_u) / (kMaxCells - 1), (max_v - min_v) / (kMaxCells - 1)});
  columns_ = std::min(static_cast<int>((max_u - min_u) / cell_px_) + 1, kMaxCells);
  rows_ = std::min(static_cast<int>((max_v - min_v) / cell_px_) + 1, kMaxCells);
  const auto cell_of = [&](const Eigen::Vector2d& p) {
    const int column = std::clamp(static_cast<int>((p.x() - min_u) / cell_px_), 0, columns_ - 1);
    const int row = std::clamp(static_cast<int>((p.y() - min_v) / cell_px_), 0, rows_ - 1);
    return row * columns_ + column;
  };
  // Counting sort by cell; within a cell the indices stay ascending.
  cell_start_.assign(static_cast<size_t>(columns_) * rows_ + 1, 0);
  point_cell_.assign(points.size(), -1);
  for (size_t j = 0; j < points.size(); ++j) {
    if (!ok(j)) continue;
    point_cell_[j] = cell_of(points[j]);
    ++cell_start_[static_cast<size_t>(point_cell_[j]) + 1];
  }
  for (size_t c = 1; c < cell_start_.size(); ++c) cell_start_[c] += cell_start_[c - 1];
  sorted_.resize(static_cast<size_t>(cell_start_.back()));
  fill_.assign(cell_start_.begin(), cell_start_.end() - 1);
  for (size_t j = 0; j < points.size(); ++j) {
    if (point_cell_[j] < 0) continue;
    sorted_[static_cast<size_t>(fill_[static_cast<size_t>(point_cell_[j])]++)] =
        static_cast<uint32_t>(j);
  }
}

int NearestPointGrid::Nearest(const Eigen::Vector2d& q, double max_distance) const {
  if (columns_ == 0 || !std::isfinite(q.x()) || !std::isfinite(q.y()) || !(max_distance > 0.0)) {
    return -1;
  }
  // The query's cell, not clamped: it may lie beyond the grid.
  const double qu = std::floor((q.x() - origin_.x()) / cell_px_);
  const double qv = std::floor((q.y() - origin_.y()) / cell_px_);
  const double limit = max_distance * max_distance;
  double best = limit;
  int best_index = -1;
  const auto visit = [&](int row, int column) {
    const size_t cell = static_cast<size_t>(row) * columns_ + column;
    for (int k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
      const uint32_t j = sorted_[static_cast<size_t>(k)];
      const double d = (points_[j] - q).squaredNorm();
      if (d < best || (d == best && best_index >= 0 && static_cast<int>(j) < best_index)) {
        best = d;
        best_index = static_cast<int>(j);
      }
    }
  };
  // Rings of cells at Chebyshev distance r from the query's cell, outwards. A point in ring r is
  // more than (r - 1) cells from the query: the search stops at the first ring that cannot hold a
  // point nearer than the best so far, or within reach (with a little slack for the rounding of
  // the cell indices). It starts at the ring just inside the nearest cell of the grid.
  const double first_ring = std::max({-1.0 - qu, qu - columns_, -1.0 - qv, qv - rows_, 0.0});
  const double last_ring = columns_ + rows_ + 2.0;
  if (first_ring > last_ring) return -1;
  const int row = static_cast<int>(qv), column = static_cast<int>(qu);
  for (int ring = static_cast<int>(first_ring); ring <= last_ring; ++ring) {
    const double reach = std::max((ring - 1.0) * cell_px_ - 1e-6, 0.0);
    if (reach * reach > best || reach * reach >= limit) break;
    const int r0 = std::max(row - ring, 0), r1 = std::min(row + ring, rows_ - 1);
    const int c0 = std::max(column - ring, 0), c1 = std::min(column + ring, columns_ - 1);
    for (int r = r0; r <= r1; ++r) {
      if (r == row - ring || r == row + ring) {
        for (int c = c0; c <= c1; ++c) visit(r, c);
        continue;
      }
      if (column - ring >= 0 && column - ring < columns_) visit(r, column - ring);
      if (ring > 0 && column + ring >= 0 && column + ring < columns_) visit(r, column + ring);
    }
  }
  return best_index;
}

}  // namespace contour_internal

bool ContourRefinementOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (max_iterations < 1 || max_iterations > 200) {
    message << "max_iterations must be in [1, 200], got " << max_iterations;
  } else if (contour_points < kMinPoints || contour_points > 100000) {
    message << "contour_points must be in [6, 100000], got " << contour_points;
  } else if (!(huber_px > 0.0) || !std::isfinite(huber_px)) {
    message << "huber_px must be positive and finite, got " << huber_px;
  } else if (!(max_residual_px > huber_px) || !std::isfinite(max_residual_px)) {
    message << "max_residual_px must be finite and larger than huber_px (" << huber_px << "), got "
            << max_residual_px;
  } else if (reselect_every < 1) {
    message << "reselect_every must be >= 1, got " << reselect_every;
  } else if (!(tolerance_rotation_deg > 0.0) || !std::isfinite(tolerance_rotation_deg)) {
    message << "tolerance_rotation_deg must be positive and finite, got " << tolerance_rotation_deg;
  } else if (!(tolerance_translation > 0.0) || !std::isfinite(tolerance_translation)) {
    message << "tolerance_translation must be positive and finite, got " << tolerance_translation;
  } else if (!(tolerance_cost_px2 >= 0.0) || !std::isfinite(tolerance_cost_px2)) {
    message << "tolerance_cost_px2 must be >= 0 and finite, got " << tolerance_cost_px2;
  } else if (!(tolerance_radius_px >= 0.0) || !std::isfinite(tolerance_radius_px)) {
    message << "tolerance_radius_px must be >= 0 and finite, got " << tolerance_radius_px;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

namespace {

// One pass of FrameOutline's chamfer transform over `distance`: each row first from the row before
// it (steps 1 and sqrt(2)), then along itself (step 1). kForward: rows from the top, each from the
// left; else rows from the bottom, each from the right. A row's sweep is a chain of dependent
// operations, so four rows are swept together, each two pixels behind the row before it (which it
// needs up to the next pixel): the same operations on the same values as row after row.
template <bool kForward>
void ChamferPass(cv::Mat* distance) {
  constexpr int kRows = 4;
  constexpr float kDiagonal = static_cast<float>(std::numbers::sqrt2);
  const int width = distance->cols, height = distance->rows;
  // Element i of a row in the pass's order.
  const auto at = [width](float* row, int i) -> float& {
    return kForward ? row[i] : row[width - 1 - i];
  };
  const auto step = [&](float* row, float* previous, int i) {
    float v = at(row, i);
    if (previous != nullptr) {
      if (i == 0) {
        v = std::min({v, at(previous, 0) + 1.0f, at(previous, std::min(1, width - 1)) + kDiagonal});
      } else if (i == width - 1) {
        v = std::min({v, at(previous, i) + 1.0f, at(previous, i - 1) + kDiagonal});
      } else {
        v = std::min({v, at(previous, i) + 1.0f, at(previous, i - 1) + kDiagonal,
                      at(previous, i + 1) + kDiagonal});
      }
    }
    if (i > 0) v = std::min(v, at(row, i - 1) + 1.0f);
    at(row, i) = v;
  };
  for (int first = 0; first < height; first += kRows) {
    const int rows = std::min(kRows, height - first);
    std::array<float*, kRows> row{};
    std::array<float*, kRows> previous{};
    for (int j = 0; j < rows; ++j) {
      const int k = first + j;
      row[j] = distance->ptr<float>(kForward ? k : height - 1 - k);
      previous[j] = k == 0 ? nullptr : distance->ptr<float>(kForward ? k - 1 : height - k);
    }
    for (int t = 0; t < width + 2 * (rows - 1); ++t) {
      for (int j = 0; j < rows; ++j) {
        const int i = t - 2 * j;
        if (i >= 0 && i < width) step(row[j], previous[j], i);
      }
    }
  }
}

}  // namespace

FrameOutline::FrameOutline(const cv::Mat& mask, int margin_px) {
  if (mask.empty() || mask.type() != CV_8UC1) {
    ThrowError("FrameOutline: the mask must be a non-empty CV_8UC1 image");
  }
  if (margin_px < 2) ThrowError("FrameOutline: margin_px must be >= 2, got ", margin_px);
  // Only the bounding box of the object pixels is looked at (cv::boundingRect of a mask scans it a
  // pixel at a time: a tenth of a millisecond for 640 x 480).
  const cv::Rect box = NonZeroBoundingBox(mask);
  if (box.empty()) ThrowError("FrameOutline: the mask has no object pixel");
  area_px_ = cv::countNonZero(mask(box));
  mask_ = mask;
  object_box_ = box;
  window_ = cv::Rect(box.x - margin_px, box.y - margin_px, box.width + 2 * margin_px,
                     box.height + 2 * margin_px) &
            cv::Rect(0, 0, mask.cols, mask.rows);
  // Pixels next to the outline (a 4-neighbour of the other kind) get distance 0, the others the
  // chamfer distance to the nearest of them (two passes, steps 1 and sqrt(2): exact along rows,
  // columns and diagonals, up to 8 % long in between, which only matters far from the outline).
  const cv::Mat object = mask(window_);
  const int width = window_.width, height = window_.height;
  signed_distance_.create(window_.size(), CV_32FC1);
  constexpr float kFar = 1e9f;
  // 0 if the 8 bytes from p are all 0, 1 if none is, -1 otherwise.
  const auto uniform8 = [](const uint8_t* p) {
    uint64_t word;
    std::memcpy(&word, p, 8);
    if (word == 0) return 0;
    constexpr uint64_t kOnes = 0x0101010101010101ull;
    constexpr uint64_t kHighs = 0x8080808080808080ull;
    return ((word - kOnes) & ~word & kHighs) == 0 ? 1 : -1;
  };
  for (int y = 0; y < height; ++y) {
    const uint8_t* o = object.ptr<uint8_t>(y);
    const uint8_t* above = y > 0 ? object.ptr<uint8_t>(y - 1) : nullptr;
    const uint8_t* below = y + 1 < height ? object.ptr<uint8_t>(y + 1) : nullptr;
    float* d = signed_distance_.ptr<float>(y);
    for (int x = 0; x < width;) {
      // Eight pixels of one kind, as are their neighbours: none is next to the outline.
      if (x + 8 <= width) {
        const int kind = uniform8(o + x);
        if (kind >= 0 && (x == 0 || (o[x - 1] != 0) == (kind == 1)) &&
            (x + 8 == width || (o[x + 8] != 0) == (kind == 1)) &&
            (above == nullptr || uniform8(above + x) == kind) &&
            (below == nullptr || uniform8(below + x) == kind)) {
          std::fill(d + x, d + x + 8, kFar);
          x += 8;
          continue;
        }
      }
      const bool in = o[x] != 0;
      bool edge = false;
      if (x + 1 < width && in != (o[x + 1] != 0)) {
        outline_points_.emplace_back(window_.x + x + 0.5, window_.y + y);
        edge = true;
      }
      if (below != nullptr && in != (below[x] != 0)) {
        outline_points_.emplace_back(window_.x + x, window_.y + y + 0.5);
        edge = true;
      }
      edge =
          edge || (x > 0 && in != (o[x - 1] != 0)) || (above != nullptr && in != (above[x] != 0));
      d[x] = edge ? 0.0f : kFar;
      ++x;
    }
  }
  ChamferPass<true>(&signed_distance_);
  ChamferPass<false>(&signed_distance_);
  // The outline runs half a pixel beyond the pixels next to it: signed distance -(d + 0.5)
  // inside, d + 0.5 outside.
  for (int y = 0; y < height; ++y) {
    const uint8_t* o = object.ptr<uint8_t>(y);
    float* d = signed_distance_.ptr<float>(y);
    for (int x = 0; x < width; ++x) d[x] = o[x] != 0 ? -(d[x] + 0.5f) : d[x] + 0.5f;
  }
}

bool FrameOutline::Distance(double u, double v, double* distance, Eigen::Vector2d* gradient) const {
  const double x = u - window_.x;
  const double y = v - window_.y;
  const int last_x = window_.width - 1;
  const int last_y = window_.height - 1;
  if (!(x >= 0.0 && y >= 0.0 && x <= last_x && y <= last_y)) return false;
  const int x0 = std::min(static_cast<int>(x), std::max(last_x - 1, 0));
  const int y0 = std::min(static_cast<int>(y), std::max(last_y - 1, 0));
  const int x1 = std::min(x0 + 1, last_x);
  const int y1 = std::min(y0 + 1, last_y);
  const double fx = x - x0;
  const double fy = y - y0;
  const float* row0 = signed_distance_.ptr<float>(y0);
  const float* row1 = signed_distance_.ptr<float>(y1);
  const double d00 = row0[x0], d10 = row0[x1], d01 = row1[x0], d11 = row1[x1];
  const double top = d00 + fx * (d10 - d00);
  const double bottom = d01 + fx * (d11 - d01);
  *distance = top + fy * (bottom - top);
  if (gradient != nullptr) {
    gradient->x() = (1.0 - fy) * (d10 - d00) + fy * (d11 - d01);
    gradient->y() = bottom - top;
  }
  return true;
}

ContourModel::ContourModel(const TriangleMesh& mesh) : mesh_(mesh) {
  if (mesh.triangles.empty()) ThrowError("ContourModel: mesh '", mesh.name, "' has no triangle");
  const size_t vertex_count = mesh.vertices.size();
  const size_t face_count = mesh.triangles.size();
  centre_ = mesh.Centre();
  normals_.resize(face_count);
  offsets_.resize(face_count);
  // Half-edges keyed by their sorted vertex pair; the low bit of the value says the direction.
  std::vector<std::pair<uint64_t, uint64_t>> half_edges;
  half_edges.reserve(3 * face_count);
  for (size_t f = 0; f < face_count; ++f) {
    const std::array<uint32_t, 3>& t = mesh.triangles[f];
    for (uint32_t index : t) {
      if (index >= vertex_count) {
        ThrowError("ContourModel: triangle ", f, " of mesh '", mesh.name,
                   "' references missing vertex ", index);
      }
    }
    const Eigen::Vector3d v0 = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d v1 = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d v2 = mesh.vertices[t[2]].cast<double>();
    normals_[f] = (v1 - v0).cross(v2 - v0);
    offsets_[f] = normals_[f].dot(v0);
    for (int i = 0; i < 3; ++i) {
      const uint32_t a = t[i], b = t[(i + 1) % 3];
      if (a == b) continue;
      const uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
      half_edges.emplace_back(key, (static_cast<uint64_t>(f) << 1) | (a < b ? 1u : 0u));
    }
  }
  std::sort(half_edges.begin(), half_edges.end());
  edges_.reserve(half_edges.size() / 2 + 16);
  for (size_t i = 0; i < half_edges.size();) {
    size_t j = i + 1;
    while (j < half_edges.size() && half_edges[j].first == half_edges[i].first) ++j;
    Edge edge;
    edge.a = static_cast<uint32_t>(half_edges[i].first >> 32);
    edge.b = static_cast<uint32_t>(half_edges[i].first & 0xffffffffu);
    edge.face0 = static_cast<int32_t>(half_edges[i].second >> 1);
    edge.face1 = j > i + 1 ? static_cast<int32_t>(half_edges[i + 1].second >> 1) : -1;
    edge.flipped = j > i + 1 && (half_edges[i].second & 1) == (half_edges[i + 1].second & 1);
    // Degenerate faces (zero normal) face no side: skip edges to them rather than see a contour.
    const bool degenerate =
        normals_[static_cast<size_t>(edge.face0)].squaredNorm() == 0.0 ||
        (edge.face1 >= 0 && normals_[static_cast<size_t>(edge.face1)].squaredNorm() == 0.0);
    if (!degenerate) edges_.push_back(edge);
    if (j != i + 2 || edge.flipped) closed_ = false;
    i = j;
  }
  // Orientation of a closed mesh: the sign of its volume (divergence theorem).
  if (closed_) {
    double volume = 0.0;
    for (size_t f = 0; f < face_count; ++f) {
      volume += normals_[f].dot(mesh.vertices[mesh.triangles[f][0]].cast<double>());
    }
    outward_ = volume > 0.0;
  }
}

bool ContourModel::SameMesh(const TriangleMesh& mesh) const {
  return mesh.vertices.size() == mesh_.vertices.size() &&
         mesh.triangles.size() == mesh_.triangles.size() &&
         std::memcmp(mesh.vertices.data(), mesh_.vertices.data(),
                     mesh.vertices.size() * sizeof(Eigen::Vector3f)) == 0 &&
         std::memcmp(mesh.triangles.data(), mesh_.triangles.data(),
                     mesh.triangles.size() * sizeof(std::array<uint32_t, 3>)) == 0;
}

Rigid3 ApplyContourUpdate(const Rigid3& pose, const Eigen::Vector3d& centre,
                          const Eigen::Matrix<double, 6, 1>& update) {
  const Eigen::Vector3d w = update.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d turn = angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix()
                                           : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d centre_in_camera = pose.rotation * centre + pose.translation;
  Rigid3 out;
  out.rotation = turn * pose.rotation;
  out.translation =
      turn * (pose.translation - centre_in_camera) + centre_in_camera + update.tail<3>();
  return out;
}

void ContourResiduals(const PinholeCamera& camera, const FrameOutline& frame, const Rigid3& pose,
                      const Eigen::Vector3d& centre,
                      const std::vector<Eigen::Vector3d>& points_in_object,
                      std::vector<double>* residuals,
                      std::vector<Eigen::Matrix<double, 1, 6>>* jacobian,
                      std::vector<uint8_t>* valid) {
  const bool distorted = HasDistortion(camera);
  const Eigen::Vector3d centre_in_camera = pose.rotation * centre + pose.translation;
  residuals->assign(points_in_object.size(), 0.0);
  jacobian->assign(points_in_object.size(), Row6::Zero());
  valid->assign(points_in_object.size(), 0);
  Eigen::Matrix<double, 2, 3> d_pixel;
  for (size_t i = 0; i < points_in_object.size(); ++i) {
    const Eigen::Vector3d x = pose.rotation * points_in_object[i] + pose.translation;
    if (!(x.z() > 0.0)) continue;
    const Eigen::Vector2d p = ProjectWithJacobian(camera, distorted, x, &d_pixel);
    double r = 0.0;
    Eigen::Vector2d g;
    if (!frame.Distance(p.x(), p.y(), &r, &g)) continue;
    const Eigen::RowVector3d d_point = g.transpose() * d_pixel;
    (*jacobian)[i].head<3>() = (x - centre_in_camera).cross(d_point.transpose()).transpose();
    (*jacobian)[i].tail<3>() = d_point;
    (*residuals)[i] = r;
    (*valid)[i] = 1;
  }
}

std::vector<Eigen::Vector3d> ModelOutlinePoints(const ContourModel& model,
                                                const PinholeCamera& camera, const Rigid3& pose,
                                                int max_points) {
  std::string error;
  if (!camera.Check(&error)) ThrowError("ModelOutlinePoints: invalid camera: ", error);
  if (max_points < 1) ThrowError("ModelOutlinePoints: max_points must be >= 1");
  Workspace& ws = ThreadWorkspace();
  SelectOutlinePoints(model, camera, pose, max_points, ws);
  return ws.points;
}

namespace {

// The cost tolerance per residual for this frame (ContourRefinementOptions::tolerance_radius_px).
double CostTolerance(const ContourRefinementOptions& options, const FrameOutline& frame) {
  if (!(options.tolerance_radius_px > 0.0)) return options.tolerance_cost_px2;
  const double radius = std::sqrt(static_cast<double>(frame.area_px()) / std::numbers::pi);
  return options.tolerance_cost_px2 * std::min(1.0, radius / options.tolerance_radius_px);
}

// The checks RefinePoseToContour and ContourFitCost share (`what` names the function).
void CheckRefinementInputs(const char* what, const ContourModel& model, const PinholeCamera& camera,
                           const FrameOutline& frame, const Rigid3& initial,
                           const ContourRefinementOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError(what, ": invalid options: ", error);
  if (!camera.Check(&error)) ThrowError(what, ": invalid camera: ", error);
  if (frame.mask().cols != camera.width_px || frame.mask().rows != camera.height_px) {
    ThrowError(what, ": the frame mask is ", frame.mask().cols, " x ", frame.mask().rows,
               " pixels, the camera's image ", camera.width_px, " x ", camera.height_px);
  }
  if (!((initial.rotation * model.centre() + initial.translation).z() > 0.0)) {
    ThrowError(what, ": the object centre is not in front of the camera");
  }
}

const ContourModel& CachedContourModel(const TriangleMesh& mesh) {
  thread_local std::unique_ptr<ContourModel> cached;
  if (!cached || !cached->SameMesh(mesh)) {
    cached.reset();
    cached = std::make_unique<ContourModel>(mesh);
  }
  return *cached;
}

}  // namespace

double ContourFitCost(const ContourModel& model, const PinholeCamera& camera,
                      const FrameOutline& frame, const Rigid3& pose,
                      const ContourRefinementOptions& options) {
  CheckRefinementInputs("ContourFitCost", model, camera, frame, pose, options);
  Workspace& ws = ThreadWorkspace();
  const bool distorted = HasDistortion(camera);
  const Eigen::Vector3d centre_in_camera = pose.rotation * model.centre() + pose.translation;
  SelectOutlinePoints(model, camera, pose, options.contour_points, ws);
  ws.matches.clear();
  Evaluate(camera, distorted, frame, pose, centre_in_camera, ws, options, nullptr, nullptr);
  MatchFrameOutline(frame, options.contour_points, options.max_residual_px, ws);
  const Evaluation fit =
      Evaluate(camera, distorted, frame, pose, centre_in_camera, ws, options, nullptr, nullptr);
  const size_t residuals = ws.points.size() + ws.matches.size();
  if (fit.used < kMinPoints || residuals == 0) return std::nan("");
  return fit.cost / static_cast<double>(residuals);
}

double ContourFitCost(const TriangleMesh& mesh, const PinholeCamera& camera,
                      const FrameOutline& frame, const Rigid3& pose,
                      const ContourRefinementOptions& options) {
  return ContourFitCost(CachedContourModel(mesh), camera, frame, pose, options);
}

double ContourIou(const ContourModel& model, const PinholeCamera& camera, const FrameOutline& frame,
                  const Rigid3& pose) {
  CheckRefinementInputs("ContourIou", model, camera, frame, pose, ContourRefinementOptions{});
  return ComputeIou(model, camera, HasDistortion(camera), frame, pose, ThreadWorkspace());
}

double ContourIou(const TriangleMesh& mesh, const PinholeCamera& camera, const FrameOutline& frame,
                  const Rigid3& pose) {
  return ContourIou(CachedContourModel(mesh), camera, frame, pose);
}

ContourRefinementResult RefinePoseToContour(const ContourModel& model, const PinholeCamera& camera,
                                            const FrameOutline& frame, const Rigid3& initial,
                                            const ContourRefinementOptions& options) {
  CheckRefinementInputs("RefinePoseToContour", model, camera, frame, initial, options);
  const Eigen::Vector3d centre = model.centre();
  const bool distorted = HasDistortion(camera);
  Workspace& ws = ThreadWorkspace();

  ContourRefinementResult result;
  Rigid3 pose = initial;
  double lambda = 1e-3;
  Matrix6d normal;
  Vector6d gradient;
  Evaluation current;
  bool have_initial = false;
  const double tolerance_cost = CostTolerance(options, frame);
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    const Eigen::Vector3d centre_in_camera = pose.rotation * centre + pose.translation;
    if (iteration % options.reselect_every == 0) {
      SelectOutlinePoints(model, camera, pose, options.contour_points, ws);
    }
    // Frame -> model matches at this pose (projections from a first pass without them).
    ws.matches.clear();
    Evaluate(camera, distorted, frame, pose, centre_in_camera, ws, options, nullptr, nullptr);
    MatchFrameOutline(frame, options.contour_points, options.max_residual_px, ws);
    current =
        Evaluate(camera, distorted, frame, pose, centre_in_camera, ws, options, &normal, &gradient);
    if (!have_initial) {
      result.initial_rms_px = current.RmsPx();
      have_initial = true;
    }
    if (current.used < kMinPoints) break;
    ++result.iterations;
    // Marquardt: damp each parameter by its own curvature (floored, so none is free).
    const Eigen::Matrix<double, 6, 1> diagonal =
        normal.diagonal().cwiseMax(1e-9 * normal.diagonal().maxCoeff() + 1e-300);
    bool accepted = false;
    Vector6d step;
    for (int attempt = 0; attempt < kMaxDampingTries; ++attempt) {
      Matrix6d damped = normal;
      damped.diagonal() += lambda * diagonal;
      step = -damped.ldlt().solve(gradient);
      if (!step.allFinite()) {
        lambda *= 10.0;
        continue;
      }
      const Rigid3 candidate = ApplyContourUpdate(pose, centre, step);
      const Eigen::Vector3d candidate_centre = candidate.rotation * centre + candidate.translation;
      const Evaluation trial = Evaluate(camera, distorted, frame, candidate, candidate_centre, ws,
                                        options, nullptr, nullptr);
      if (trial.cost < current.cost) {
        const double residual_count = static_cast<double>(ws.points.size() + ws.matches.size());
        if (current.cost - trial.cost < tolerance_cost * residual_count) {
          // Too small a gain to tell from the outline's pixel noise: keep the pose, done.
          accepted = false;
          break;
        }
        pose = candidate;
        current = trial;
        lambda = std::max(lambda * 0.1, 1e-7);
        accepted = true;
        break;
      }
      lambda *= 10.0;
    }
    if (!accepted) {
      // No lower cost near this pose (a minimum), or only a negligibly lower one.
      result.converged = true;
      break;
    }
    const double rotation_deg = step.head<3>().norm() / kDegToRad;
    const double relative_move = step.tail<3>().norm() / centre_in_camera.norm();
    if (rotation_deg < options.tolerance_rotation_deg &&
        relative_move < options.tolerance_translation) {
      result.converged = true;
      break;
    }
  }
  result.camera_from_object = pose;
  result.final_rms_px = current.RmsPx();
  result.points_used = current.used;
  if (options.compute_iou) {
    result.iou = ComputeIou(model, camera, distorted, frame, pose, ws);
  }
  return result;
}

ContourRefinementResult RefinePoseToContour(const TriangleMesh& mesh, const PinholeCamera& camera,
                                            const FrameOutline& frame, const Rigid3& initial,
                                            const ContourRefinementOptions& options) {
  return RefinePoseToContour(CachedContourModel(mesh), camera, frame, initial, options);
}

}  // namespace silpose
