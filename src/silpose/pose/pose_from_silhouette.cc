#include "silpose/pose/pose_from_silhouette.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/pose/lens_distortion.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

// Area centroid of a closed polygon (either orientation); the vertex mean if it has no area.
Eigen::Vector2d AreaCentroid(const std::vector<Eigen::Vector2d>& polygon) {
  double twice_area = 0.0;
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  for (size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const double cross = polygon[j].x() * polygon[i].y() - polygon[i].x() * polygon[j].y();
    twice_area += cross;
    weighted += cross * (polygon[j] + polygon[i]);
  }
  if (std::abs(twice_area) < 1e-300) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : polygon) mean += p;
    return mean / static_cast<double>(polygon.size());
  }
  return weighted / (3.0 * twice_area);
}

// What stays fixed while the pose is estimated: the database view's silhouette in normalised
// coordinates of the database camera, and the frame camera.
struct Problem {
  const PinholeCamera* camera;
  Eigen::Matrix2d roll;         // Rot(r): database image -> rolled (virtual) image.
  Eigen::Vector2d db_centroid;  // c_db, normalised, relative to the database principal point.
  double db_mean_radius;        // r_db / f_db.
  std::vector<Eigen::Vector2d> db_outline;  // Star-convex outline, normalised.
  Eigen::Vector2d db_outline_centroid;      // Its area centroid.
  double db_distance;                       // D_db, model units.
  // Radius of the sphere whose image has the database silhouette's mean radius at D_db
  // (ScaleModel::kSphere), model units; 0 for ScaleModel::kWeakPerspective.
  double sphere_radius = 0.0;

  // Distance at which the silhouette appears `scale` times as large as in the database image.
  double DistanceFromScale(double scale) const {
    if (sphere_radius == 0.0) return db_distance / scale;
    const double a = scale * db_mean_radius;  // tan of the apparent half angle
    return sphere_radius * std::sqrt(1.0 + a * a) / a;
  }
  int signature_length = 0;
};

// The estimate being refined: where the object centre is seen and how far away it is.
struct State {
  Eigen::Vector2d centre_px;
  Eigen::Vector3d ray;
  double scale;  // Silhouette size in the virtual image / in the database image.
};

bool SetCentre(const PinholeCamera& camera, const Eigen::Vector2d& centre_px, State* state) {
  Eigen::Vector2d ideal;
  if (!PixelToIdealNormalized(camera, centre_px, &ideal)) return false;
  state->centre_px = centre_px;
  state->ray = Eigen::Vector3d(ideal.x(), ideal.y(), 1.0).normalized();
  return true;
}

// Pixel in the frame of a point of the database image (normalised) for the state's pose.
struct Mapper {
  const Problem& problem;
  Eigen::Matrix3d axis_to_ray;
  double scale;

  bool Map(const Eigen::Vector2d& db_point, Eigen::Vector2d* pixel) const {
    const Eigen::Vector2d virtual_point = scale * (problem.roll * db_point);
    const Eigen::Vector3d in_camera =
        axis_to_ray * Eigen::Vector3d(virtual_point.x(), virtual_point.y(), 1.0);
    if (!(in_camera.z() > 1e-9)) return false;
    *pixel = ProjectDistorted(*problem.camera, in_camera);
    return pixel->allFinite();
  }
};

// Predicted centroid and mean radius of the frame silhouette for `state`; false if the outline
// leaves the half space in front of the camera.
bool Predict(const Problem& problem, const State& state, Eigen::Vector2d* centroid_px,
             double* mean_radius_px) {
  const Mapper mapper{problem, RotationFromOpticalAxisTo(state.ray), state.scale};
  std::vector<Eigen::Vector2d> outline(problem.db_outline.size());
  for (size_t i = 0; i < outline.size(); ++i) {
    if (!mapper.Map(problem.db_outline[i], &outline[i])) return false;
  }
  Eigen::Vector2d mapped_centroid, mapped_outline_centroid;
  if (!mapper.Map(problem.db_centroid, &mapped_centroid) ||
      !mapper.Map(problem.db_outline_centroid, &mapped_outline_centroid)) {
    return false;
  }
  // The mapping moves the outline's area centroid away from the image of its old centroid; the
  // true silhouette's centroid (c_db, not stored as an outline: concavities hidden from it are not
  // in the signature) is assumed to move alike.
  *centroid_px = mapped_centroid + (AreaCentroid(outline) - mapped_outline_centroid);
  const std::vector<float> radii = StarConvexRadii(outline, *centroid_px, problem.signature_length);
  double sum = 0.0;
  for (float r : radii) sum += r;
  *mean_radius_px = sum / static_cast<double>(radii.size());
  return std::isfinite(*mean_radius_px) && *mean_radius_px > 0.0;
}

}  // namespace

bool PoseFromSilhouetteOptions::Check(std::string* error) const {
  auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (outline_iterations < 0 || outline_iterations > 100) {
    return fail("outline_iterations must be in [0, 100]");
  }
  if (!(tolerance_px > 0.0) || !std::isfinite(tolerance_px)) {
    return fail("tolerance_px must be positive and finite");
  }
  if (!(tolerance_relative > 0.0) || !std::isfinite(tolerance_relative)) {
    return fail("tolerance_relative must be positive and finite");
  }
  if (!(max_pixel_aspect_deviation >= 0.0 && max_pixel_aspect_deviation < 1.0)) {
    return fail("max_pixel_aspect_deviation must be in [0, 1)");
  }
  return true;
}

Eigen::Matrix3d RotationFromOpticalAxisTo(const Eigen::Vector3d& ray) {
  SILPOSE_ASSERT(ray.z() > 0.0);
  return Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray.normalized())
      .toRotationMatrix();
}

SilhouettePose EstimatePoseFromSilhouette(const ViewDatabase& database, int model, int view,
                                          double roll_deg, const PolarSignature& frame_silhouette,
                                          const PinholeCamera& camera,
                                          const PoseFromSilhouetteOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid pose options: ", error);
  if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
  if (model < 0 || model >= static_cast<int>(database.models.size())) {
    ThrowError("model index ", model, " out of range: the database has ", database.models.size(),
               " models");
  }
  if (view < 0 || view >= database.num_views()) {
    ThrowError("view index ", view, " out of range: the database has ", database.num_views(),
               " views");
  }
  if (!std::isfinite(roll_deg)) ThrowError("roll_deg must be finite, got ", roll_deg);
  const ModelViews& views = database.models[static_cast<size_t>(model)];
  if (options.shell < 0 || options.shell >= database.num_shells()) {
    ThrowError("shell index ", options.shell, " out of range: the database has ",
               database.num_shells(), " distance shells");
  }
  if (views.views.size() !=
      static_cast<size_t>(database.num_views()) * static_cast<size_t>(database.num_shells())) {
    ThrowError("model '", views.name, "' has ", views.views.size(), " view records, expected ",
               database.num_views(), " x ", database.num_shells(), " shells");
  }
  const ViewRecord& record = views.Record(view, options.shell);
  if (record.status != SignatureStatus::kOk || !(record.mean_radius_px > 0.0f)) {
    ThrowError("view ", view, " of model '", views.name, "' has no usable silhouette (",
               ToString(record.status), ")");
  }
  const double frame_radius_px = frame_silhouette.mean_radius_px;
  if (!(frame_radius_px > 0.0) || !std::isfinite(frame_radius_px) ||
      !frame_silhouette.centroid_px.allFinite()) {
    ThrowError("frame silhouette must have a positive finite mean radius and a finite centroid");
  }
  const double aspect = camera.focal_x_px / camera.focal_y_px;
  if (std::abs(aspect - 1.0) > options.max_pixel_aspect_deviation) {
    ThrowError("camera pixels are not square (fx / fy = ", aspect, ", more than ",
               options.max_pixel_aspect_deviation,
               " from 1): resample the mask to square pixels first");
  }

  // The database view, in normalised coordinates of its (square-pixel) camera.
  const PinholeCamera db_camera = ViewCamera(database.parameters.ShellRender(options.shell));
  const double db_focal = db_camera.focal_x_px;
  Problem problem;
  problem.camera = &camera;
  const double c = std::cos(roll_deg * kDegToRad), s = std::sin(roll_deg * kDegToRad);
  problem.roll << c, s, -s, c;
  problem.db_centroid = Eigen::Vector2d(record.centroid_x_px - db_camera.principal_x_px,
                                        record.centroid_y_px - db_camera.principal_y_px) /
                        db_focal;
  problem.db_mean_radius = record.mean_radius_px / db_focal;
  problem.db_distance =
      database.parameters.distances_in_radii[static_cast<size_t>(options.shell)] * views.radius;
  if (options.scale_model == ScaleModel::kSphere) {
    // a = rho / sqrt(D^2 - rho^2)  <=>  rho = D a / sqrt(1 + a^2).
    const double a = problem.db_mean_radius;
    problem.sphere_radius = problem.db_distance * a / std::sqrt(1.0 + a * a);
  }
  const Eigen::Vector3d object_centre(views.centre[0], views.centre[1], views.centre[2]);

  // Closed form (steps 1-4 of the header).
  Eigen::Vector2d frame_ideal;
  if (!PixelToIdealNormalized(camera, frame_silhouette.centroid_px, &frame_ideal)) {
    ThrowError("cannot undistort the silhouette centroid (", frame_silhouette.centroid_px.x(), ", ",
               frame_silhouette.centroid_px.y(),
               "): it lies where the camera's distortion model is not invertible");
  }
  Eigen::Matrix2d distortion_jacobian;
  DistortNormalized(camera.distortion, frame_ideal, &distortion_jacobian);
  const double distortion_area = distortion_jacobian.determinant();
  if (!(distortion_area > 0.0)) {
    ThrowError("the camera's distortion folds the image at the silhouette centroid");
  }
  const double frame_radius = frame_radius_px / std::sqrt(camera.focal_x_px * camera.focal_y_px) /
                              std::sqrt(distortion_area);
  const double off_axis = std::atan(frame_ideal.norm());
  const double cos_off_axis = std::cos(off_axis);
  const double virtual_radius = frame_radius * std::pow(cos_off_axis, 1.5);
  const double scale = virtual_radius / problem.db_mean_radius;
  Eigen::Matrix2d stretch = Eigen::Matrix2d::Identity() / cos_off_axis;
  if (frame_ideal.norm() > 0.0) {
    const Eigen::Vector2d radial = frame_ideal.normalized();
    stretch += (1.0 / cos_off_axis - 1.0) / cos_off_axis * radial * radial.transpose();
  }
  const Eigen::Vector2d centre_ideal =
      frame_ideal - stretch * (scale * (problem.roll * problem.db_centroid));

  State state;
  state.scale = scale;
  state.ray = Eigen::Vector3d(centre_ideal.x(), centre_ideal.y(), 1.0).normalized();
  state.centre_px = ProjectDistorted(camera, state.ray);

  SilhouettePose result;
  if (options.outline_iterations > 0) {
    // The database outline: the star-convex polygon of the stored signature around c_db.
    const std::span<const float> signature = views.Signature(view, options.shell);
    problem.signature_length = static_cast<int>(signature.size());
    problem.db_outline.resize(signature.size());
    for (size_t i = 0; i < signature.size(); ++i) {
      const double angle =
          2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(signature.size());
      problem.db_outline[i] =
          problem.db_centroid + problem.db_mean_radius * static_cast<double>(signature[i]) *
                                    Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    problem.db_outline_centroid = AreaCentroid(problem.db_outline);
    for (int iteration = 0;; ++iteration) {
      Eigen::Vector2d predicted_centroid;
      double predicted_radius = 0.0;
      if (!Predict(problem, state, &predicted_centroid, &predicted_radius)) break;
      const Eigen::Vector2d residual = predicted_centroid - frame_silhouette.centroid_px;
      const double ratio = predicted_radius / frame_radius_px;
      result.centroid_residual_px = residual.norm();
      result.radius_residual = ratio - 1.0;
      if (iteration == options.outline_iterations ||
          (residual.norm() <= options.tolerance_px &&
           std::abs(ratio - 1.0) <= options.tolerance_relative)) {
        break;
      }
      // The centroid moves with the object centre's image (to first order one for one) and the
      // size with the inverse distance.
      State next = state;
      next.scale = state.scale / ratio;
      if (!SetCentre(camera, state.centre_px - residual, &next)) break;
      state = next;
      result.iterations = iteration + 1;
    }
  }

  // Step 5: R = Q R_on, t = D u - R c.
  const Eigen::Matrix3d on_axis =
      CameraFromObjectRotation(database.sphere.directions[static_cast<size_t>(view)], roll_deg);
  result.camera_from_object.rotation = RotationFromOpticalAxisTo(state.ray) * on_axis;
  const double distance = problem.DistanceFromScale(state.scale);
  result.camera_from_object.translation =
      distance * state.ray - result.camera_from_object.rotation * object_centre;
  result.distance = distance;
  result.centre_ray = state.ray;
  result.centre_px = state.centre_px;
  result.off_axis_deg = std::acos(std::min(1.0, state.ray.z())) / kDegToRad;
  return result;
}

bool RenderRefinementOptions::Check(std::string* error) const {
  if (iterations < 1 || iterations > 20) {
    if (error != nullptr) *error = "iterations must be in [1, 20]";
    return false;
  }
  std::string detail;
  if (!signature.Check(&detail)) {
    if (error != nullptr) *error = "signature options: " + detail;
    return false;
  }
  return true;
}

SilhouettePose RefinePoseByRendering(const TriangleMesh& mesh, const PinholeCamera& camera,
                                     const PolarSignature& frame_silhouette,
                                     const SilhouettePose& initial,
                                     const RenderRefinementOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid render refinement options: ", error);
  if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
  if (!(frame_silhouette.mean_radius_px > 0.0) || !std::isfinite(frame_silhouette.mean_radius_px)) {
    ThrowError("frame silhouette must have a positive finite mean radius");
  }
  const Eigen::Vector3d object_centre = mesh.Centre();
  const Eigen::Matrix3d on_axis = RotationFromOpticalAxisTo(initial.centre_ray).transpose() *
                                  initial.camera_from_object.rotation;
  PinholeCamera ideal_camera = camera;
  ideal_camera.distortion = {0, 0, 0, 0, 0};
  SilhouettePose result = initial;
  cv::Mat mask;
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    RenderSilhouette(mesh, ideal_camera, result.camera_from_object, &mask);
    const SignatureResult rendered = ExtractSignature(mask, options.signature);
    if (!rendered.ok()) break;
    // The rendered silhouette as it would appear in the distorted image (centroid exactly, radius
    // by the local area change).
    const Eigen::Vector2d ideal(
        (rendered.signature.centroid_px.x() - camera.principal_x_px) / camera.focal_x_px,
        (rendered.signature.centroid_px.y() - camera.principal_y_px) / camera.focal_y_px);
    Eigen::Matrix2d jacobian;
    const Eigen::Vector2d distorted = DistortNormalized(camera.distortion, ideal, &jacobian);
    const Eigen::Vector2d predicted_centroid(
        camera.focal_x_px * distorted.x() + camera.principal_x_px,
        camera.focal_y_px * distorted.y() + camera.principal_y_px);
    const double predicted_radius =
        rendered.signature.mean_radius_px * std::sqrt(std::abs(jacobian.determinant()));
    const Eigen::Vector2d residual = predicted_centroid - frame_silhouette.centroid_px;
    const double ratio = predicted_radius / frame_silhouette.mean_radius_px;
    State state;
    if (!SetCentre(camera, result.centre_px - residual, &state)) break;
    const double distance = result.distance * ratio;
    result.camera_from_object.rotation = RotationFromOpticalAxisTo(state.ray) * on_axis;
    result.camera_from_object.translation =
        distance * state.ray - result.camera_from_object.rotation * object_centre;
    result.distance = distance;
    result.centre_ray = state.ray;
    result.centre_px = state.centre_px;
    result.off_axis_deg = std::acos(std::min(1.0, state.ray.z())) / kDegToRad;
    result.iterations = iteration + 1;
    result.centroid_residual_px = residual.norm();
    result.radius_residual = ratio - 1.0;
  }
  return result;
}

Rigid3 PoseFromSilhouette(const ViewDatabase& database, int model, int view, double roll_deg,
                          const PolarSignature& frame_silhouette, const PinholeCamera& camera,
                          const PoseFromSilhouetteOptions& options) {
  return EstimatePoseFromSilhouette(database, model, view, roll_deg, frame_silhouette, camera,
                                    options)
      .camera_from_object;
}

}  // namespace silpose
