#include "silpose/pose/pose_from_silhouette.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "silpose/database/database_builder.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/match/view_matcher.h"
#include "silpose/pose/lens_distortion.h"
#include "silpose/pose/pose_error.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

std::filesystem::path ModelPath(const char* name) {
  return std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / name;
}

// One small database of the bunny shared by the tests (building it is the slow part).
class PoseFromSilhouetteTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 600;
    options.parameters.render.resolution_px = 256;
    options.parameters.signature.length = 360;
    database_ =
        std::make_unique<ViewDatabase>(BuildViewDatabase({ModelPath("bunny.obj")}, options));
    mesh_ = std::make_unique<TriangleMesh>(LoadMesh(ModelPath("bunny.obj")));
    spectra_ = std::make_unique<ViewSpectra>(*database_);
  }
  static void TearDownTestSuite() {
    spectra_.reset();
    mesh_.reset();
    database_.reset();
  }

  static PolarSignature Describe(const cv::Mat& mask) {
    const SignatureResult result = ExtractSignature(mask, database_->parameters.signature);
    EXPECT_TRUE(result.ok()) << result.Describe();
    return result.signature;
  }

  static Eigen::Vector3d Centre() { return mesh_->Centre(); }
  static double Radius() { return mesh_->Radius(); }
  static double SpacingDeg() { return database_->sphere.typical_spacing_rad / kDegToRad; }

  // Pose whose virtual camera (looking along `ray`) is the database camera at (view, roll,
  // distance): R = Q R_on, t = D u - R c.
  static Rigid3 OffAxisPose(const Eigen::Vector3d& view_dir, double roll_deg, double distance,
                            const Eigen::Vector3d& ray) {
    Rigid3 pose;
    pose.rotation =
        RotationFromOpticalAxisTo(ray.normalized()) * CameraFromObjectRotation(view_dir, roll_deg);
    pose.translation = distance * ray.normalized() - pose.rotation * Centre();
    return pose;
  }

  static std::unique_ptr<ViewDatabase> database_;
  static std::unique_ptr<TriangleMesh> mesh_;
  static std::unique_ptr<ViewSpectra> spectra_;
};

std::unique_ptr<ViewDatabase> PoseFromSilhouetteTest::database_;
std::unique_ptr<TriangleMesh> PoseFromSilhouetteTest::mesh_;
std::unique_ptr<ViewSpectra> PoseFromSilhouetteTest::spectra_;

TEST_F(PoseFromSilhouetteTest, DatabaseViewsSeenByTheDatabaseCameraGiveBackTheirPose) {
  const ViewRenderOptions& render = database_->parameters.render;
  const PinholeCamera camera = ViewCamera(render);
  const double distance = render.distance_in_radii * Radius();
  cv::Mat mask;
  for (int view = 0; view < database_->num_views(); view += 37) {
    for (double roll : {0.0, 37.0, -120.0}) {
      const Eigen::Vector3d& d = database_->sphere.directions[static_cast<size_t>(view)];
      RenderView(*mesh_, d, roll, render, &mask);
      const SilhouettePose estimate =
          EstimatePoseFromSilhouette(*database_, 0, view, roll, Describe(mask), camera);
      const Rigid3 truth = CameraFromObjectAtView(d, roll, distance, Centre());
      const PoseError error = ComputePoseError(estimate.camera_from_object, truth, Centre());
      if (roll == 0.0) {
        // The very image the database was built from: exact up to float rounding.
        EXPECT_LT(error.rotation_deg, 1e-3) << "view " << view;
        EXPECT_LT(error.translation_relative, 1e-5) << "view " << view;
      } else {
        // A rolled rendering differs from the rolled database image by pixel staircase only.
        EXPECT_LT(error.rotation_deg, 0.3) << "view " << view << " roll " << roll;
        EXPECT_LT(error.translation_relative, 0.01) << "view " << view << " roll " << roll;
      }
    }
  }
}

TEST_F(PoseFromSilhouetteTest, CentredObjectsSeenByAnotherCameraAtAnotherDistance) {
  const PinholeCamera camera = DefaultSynthCamera();
  cv::Mat mask;
  std::vector<double> rotation, translation;
  for (int view = 5; view < database_->num_views(); view += 53) {
    const Eigen::Vector3d& d = database_->sphere.directions[static_cast<size_t>(view)];
    const double roll = 0.7 * view - 150.0;
    const Rigid3 truth = CameraFromObjectAtView(d, roll, 4.5 * Radius(), Centre());
    RenderSilhouette(*mesh_, camera, truth, &mask);
    const Rigid3 estimate = PoseFromSilhouette(*database_, 0, view, roll, Describe(mask), camera);
    const PoseError error = ComputePoseError(estimate, truth, Centre());
    rotation.push_back(error.rotation_deg);
    translation.push_back(error.translation_relative);
  }
  // What is left is the perspective change between 3 and 4.5 radii and the staircase.
  std::printf("centred, exact view, 4.5 radii: rotation deg %s\n  translation rel %s\n",
              Summarize(rotation).Describe().c_str(), Summarize(translation).Describe().c_str());
  EXPECT_LT(Summarize(rotation).max, 0.5);
  EXPECT_LT(Summarize(translation).median, 0.03);
  EXPECT_LT(Summarize(translation).max, 0.05);
}

// Objects whose centre projects near each image corner, seen from exact database views: the pose
// needs the off-axis rotation Q applied after the on-axis one (R = Q R_on).
TEST_F(PoseFromSilhouetteTest, ObjectsNearTheImageCornersGiveBackTheirPose) {
  const PinholeCamera camera = DefaultSynthCamera();
  const double distance = 8.0 * Radius();  // bounding sphere about 66 px in radius
  const Eigen::Vector2d corners_px[] = {{90, 80}, {550, 80}, {90, 400}, {550, 400}};
  PoseFromSilhouetteOptions closed_form;
  closed_form.outline_iterations = 0;
  std::vector<double> rotation, translation, rotation_closed, translation_closed, on_axis_only;
  cv::Mat mask;
  int index = 0;
  for (const Eigen::Vector2d& corner : corners_px) {
    for (int view = 11; view < database_->num_views(); view += 97, ++index) {
      const Eigen::Vector3d& d = database_->sphere.directions[static_cast<size_t>(view)];
      const double roll = 47.0 * index - 160.0;
      const Eigen::Vector3d ray((corner.x() - camera.principal_x_px) / camera.focal_x_px,
                                (corner.y() - camera.principal_y_px) / camera.focal_y_px, 1.0);
      const Rigid3 truth = OffAxisPose(d, roll, distance, ray);
      RenderSilhouette(*mesh_, camera, truth, &mask);
      const SignatureResult frame = ExtractSignature(mask, database_->parameters.signature);
      ASSERT_TRUE(frame.ok());
      ASSERT_FALSE(frame.flags & kSilhouetteTouchesBorder);
      const SilhouettePose estimate =
          EstimatePoseFromSilhouette(*database_, 0, view, roll, frame.signature, camera);
      const PoseError error = ComputePoseError(estimate.camera_from_object, truth, Centre());
      rotation.push_back(error.rotation_deg);
      translation.push_back(error.translation_relative);
      EXPECT_GT(estimate.off_axis_deg, 25.0);
      const Rigid3 closed =
          PoseFromSilhouette(*database_, 0, view, roll, frame.signature, camera, closed_form);
      const PoseError closed_error = ComputePoseError(closed, truth, Centre());
      rotation_closed.push_back(closed_error.rotation_deg);
      translation_closed.push_back(closed_error.translation_relative);
      on_axis_only.push_back(RotationErrorDeg(CameraFromObjectRotation(d, roll), truth.rotation));
    }
  }
  std::printf(
      "near corners, exact view, 8 radii:\n  iterated rotation deg %s\n  iterated translation rel "
      "%s\n  closed-form rotation deg %s\n  closed-form translation rel %s\n  without off-axis "
      "rotation: rotation deg %s\n",
      Summarize(rotation).Describe().c_str(), Summarize(translation).Describe().c_str(),
      Summarize(rotation_closed).Describe().c_str(),
      Summarize(translation_closed).Describe().c_str(), Summarize(on_axis_only).Describe().c_str());
  // What is left is mostly perspective: the database was rendered at 3 radii, these at 8.
  EXPECT_LT(Summarize(rotation).max, 1.0);
  EXPECT_LT(Summarize(translation).max, 0.05);
  EXPECT_LT(Summarize(rotation_closed).max, 1.5);
  EXPECT_LT(Summarize(translation_closed).max, 0.06);
  // Leaving the off-axis rotation out would be wrong by the off-axis angle (about 28 degrees).
  EXPECT_GT(Summarize(on_axis_only).min, 20.0);
}

struct MatchedErrors {
  std::vector<double> rotation_deg, translation_relative, view_direction;
  // With RefinePoseByRendering (measured for the record, not the must-show targets).
  std::vector<double> refined_rotation_deg, refined_translation_relative;
};

// Matcher top-1 (view, roll) -> pose for every frame of a sequence.
MatchedErrors MatchSequence(const ViewDatabase& database, const ViewSpectra& spectra,
                            const SyntheticSequence& sequence, const Eigen::Vector3d& centre) {
  RenderRefinementOptions refine;
  refine.signature = database.parameters.signature;
  ViewMatcher matcher(spectra);
  MatchedErrors errors;
  SyntheticFrame frame;
  for (int f = 0; f < sequence.num_frames(); ++f) {
    sequence.Generate(f, &frame);
    const SignatureResult silhouette = ExtractSignature(frame.mask, database.parameters.signature);
    if (!silhouette.ok() || frame.touches_border) continue;
    const MatchCandidate best = matcher.Match(silhouette.signature.radii, {.top_k = 1}).front();
    const SilhouettePose estimate = EstimatePoseFromSilhouette(
        database, best.model, best.view, best.roll_deg, silhouette.signature, sequence.camera());
    const PoseError error =
        ComputePoseError(estimate.camera_from_object, frame.truth.camera_from_object, centre);
    errors.rotation_deg.push_back(error.rotation_deg);
    errors.translation_relative.push_back(error.translation_relative);
    errors.view_direction.push_back(error.view_direction);
    const SilhouettePose refined =
        RefinePoseByRendering(sequence.meshes()[static_cast<size_t>(best.model)], sequence.camera(),
                              silhouette.signature, estimate, refine);
    const PoseError refined_error =
        ComputePoseError(refined.camera_from_object, frame.truth.camera_from_object, centre);
    errors.refined_rotation_deg.push_back(refined_error.rotation_deg);
    errors.refined_translation_relative.push_back(refined_error.translation_relative);
  }
  return errors;
}

void ExpectMustShowTargets(const char* name, const MatchedErrors& errors, double spacing_deg,
                           int frames) {
  const ErrorSummary rotation = Summarize(errors.rotation_deg);
  const ErrorSummary translation = Summarize(errors.translation_relative);
  std::printf(
      "%s (view spacing %.2f deg):\n  rotation deg %s\n  translation rel %s\n  view dir %s\n", name,
      spacing_deg, rotation.Describe().c_str(), translation.Describe().c_str(),
      Summarize(errors.view_direction).Describe().c_str());
  if (!errors.refined_rotation_deg.empty()) {
    std::printf("  refined by rendering: rotation deg %s\n    translation rel %s\n",
                Summarize(errors.refined_rotation_deg).Describe().c_str(),
                Summarize(errors.refined_translation_relative).Describe().c_str());
  }
  EXPECT_GE(rotation.count, frames * 9 / 10);
  EXPECT_LE(rotation.median, spacing_deg + 2.0);
  EXPECT_LE(translation.median, 0.05);
}

TEST_F(PoseFromSilhouetteTest, MatcherTopOnePosesMeetTheTargetsOnAnOrbit) {
  SequenceOptions options;
  options.trajectory.kind = TrajectoryKind::kOrbit;
  options.trajectory.num_frames = 72;
  options.trajectory.orbit.step_deg = 5.0;
  options.trajectory.orbit.roll_deg = 25.0;
  const SyntheticSequence sequence({*mesh_}, options);
  ExpectMustShowTargets("orbit", MatchSequence(*database_, *spectra_, sequence, Centre()),
                        SpacingDeg(), sequence.num_frames());
}

TEST_F(PoseFromSilhouetteTest, MatcherTopOnePosesMeetTheTargetsOnAWalk) {
  SequenceOptions options;
  options.trajectory.kind = TrajectoryKind::kWalk;
  options.trajectory.num_frames = 72;
  options.trajectory.walk.seed = 7;
  options.trajectory.walk.speed_sigma_deg = 4.0;
  options.trajectory.walk.roll_speed_sigma_deg = 4.0;
  options.trajectory.walk.distance_sigma = 0.05;
  const SyntheticSequence sequence({*mesh_}, options);
  ExpectMustShowTargets("walk", MatchSequence(*database_, *spectra_, sequence, Centre()),
                        SpacingDeg(), sequence.num_frames());
}

// Random poses shifted so that the object is seen near a corner, with the matcher's view and roll.
TEST_F(PoseFromSilhouetteTest, MatcherTopOnePosesOfObjectsNearTheCorners) {
  const PinholeCamera camera = DefaultSynthCamera();
  ViewMatcher matcher(*spectra_);
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(-180.0, 180.0);
  const Eigen::Vector2d corners_px[] = {{90, 80}, {550, 80}, {90, 400}, {550, 400}};
  MatchedErrors errors;
  cv::Mat mask;
  for (int i = 0; i < 48; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const Eigen::Vector2d& corner = corners_px[i % 4];
    const Eigen::Vector3d ray((corner.x() - camera.principal_x_px) / camera.focal_x_px,
                              (corner.y() - camera.principal_y_px) / camera.focal_y_px, 1.0);
    const Rigid3 truth = OffAxisPose(d, uniform(rng), 8.0 * Radius(), ray);
    RenderSilhouette(*mesh_, camera, truth, &mask);
    const SignatureResult silhouette = ExtractSignature(mask, database_->parameters.signature);
    ASSERT_TRUE(silhouette.ok());
    const MatchCandidate best = matcher.Match(silhouette.signature.radii, {.top_k = 1}).front();
    const Rigid3 estimate = PoseFromSilhouette(*database_, best.model, best.view, best.roll_deg,
                                               silhouette.signature, camera);
    const PoseError error = ComputePoseError(estimate, truth, Centre());
    errors.rotation_deg.push_back(error.rotation_deg);
    errors.translation_relative.push_back(error.translation_relative);
    errors.view_direction.push_back(error.view_direction);
  }
  ExpectMustShowTargets("near corners, random views", errors, SpacingDeg(), 48);
}

// Remaps an ideal-pinhole rendering into the image of the same camera with lens distortion.
cv::Mat DistortMask(const cv::Mat& ideal_mask, const PinholeCamera& camera) {
  cv::Mat map_x(ideal_mask.size(), CV_32FC1), map_y(ideal_mask.size(), CV_32FC1);
  for (int v = 0; v < ideal_mask.rows; ++v) {
    for (int u = 0; u < ideal_mask.cols; ++u) {
      Eigen::Vector2d ideal;
      const bool ok = PixelToIdealNormalized(camera, Eigen::Vector2d(u, v), &ideal);
      map_x.at<float>(v, u) =
          ok ? static_cast<float>(camera.focal_x_px * ideal.x() + camera.principal_x_px) : -1.0f;
      map_y.at<float>(v, u) =
          ok ? static_cast<float>(camera.focal_y_px * ideal.y() + camera.principal_y_px) : -1.0f;
    }
  }
  cv::Mat distorted;
  cv::remap(ideal_mask, distorted, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  cv::threshold(distorted, distorted, 127, 255, cv::THRESH_BINARY);
  return distorted;
}

TEST_F(PoseFromSilhouetteTest, UndistortionImprovesTheCentreWithLensDistortion) {
  PinholeCamera camera = DefaultSynthCamera();
  camera.distortion = {-0.25, 0.08, 0.0, 0.0, 0.0};
  PinholeCamera ignoring = camera;
  ignoring.distortion = {0, 0, 0, 0, 0};
  PoseFromSilhouetteOptions closed_form;
  closed_form.outline_iterations = 0;
  const Eigen::Vector2d places_px[] = {{130, 110}, {510, 110}, {130, 370}, {510, 370}};
  std::vector<double> modelled, closed, ignored, modelled_rotation, ignored_rotation;
  cv::Mat ideal;
  int index = 0;
  for (const Eigen::Vector2d& place : places_px) {
    for (int view = 23; view < database_->num_views(); view += 151, ++index) {
      const Eigen::Vector3d& d = database_->sphere.directions[static_cast<size_t>(view)];
      const double roll = 31.0 * index;
      const Eigen::Vector3d ray((place.x() - camera.principal_x_px) / camera.focal_x_px,
                                (place.y() - camera.principal_y_px) / camera.focal_y_px, 1.0);
      const Rigid3 truth = OffAxisPose(d, roll, 8.0 * Radius(), ray);
      RenderSilhouette(*mesh_, camera, truth, &ideal);
      const PolarSignature frame = Describe(DistortMask(ideal, camera));
      const auto error_of = [&](const PinholeCamera& assumed,
                                const PoseFromSilhouetteOptions& options) {
        return ComputePoseError(
            PoseFromSilhouette(*database_, 0, view, roll, frame, assumed, options), truth,
            Centre());
      };
      const PoseError with = error_of(camera, {});
      const PoseError without = error_of(ignoring, {});
      modelled.push_back(with.translation_relative);
      modelled_rotation.push_back(with.rotation_deg);
      closed.push_back(error_of(camera, closed_form).translation_relative);
      ignored.push_back(without.translation_relative);
      ignored_rotation.push_back(without.rotation_deg);
      EXPECT_LT(with.translation_relative, without.translation_relative) << "view " << view;
    }
  }
  std::printf(
      "distortion k1=-0.25 k2=0.08, exact view, 8 radii:\n  modelled, iterated: translation rel "
      "%s\n    rotation deg %s\n  modelled, closed form: translation rel %s\n  ignored: "
      "translation "
      "rel %s\n    rotation deg %s\n",
      Summarize(modelled).Describe().c_str(), Summarize(modelled_rotation).Describe().c_str(),
      Summarize(closed).Describe().c_str(), Summarize(ignored).Describe().c_str(),
      Summarize(ignored_rotation).Describe().c_str());
  EXPECT_LT(Summarize(modelled).max, 0.05);
  EXPECT_LT(Summarize(modelled_rotation).max, 0.5);
  EXPECT_GT(Summarize(ignored).median, 2.5 * Summarize(modelled).median);
  EXPECT_GT(Summarize(ignored_rotation).median, 2.0 * Summarize(modelled_rotation).median);
}

// The optional refinement by rendering removes the perspective error left by the database image.
TEST_F(PoseFromSilhouetteTest, RenderRefinementReducesTheErrors) {
  PinholeCamera camera = DefaultSynthCamera();
  camera.distortion = {-0.1, 0.0, 0.0, 0.0, 0.0};
  RenderRefinementOptions refine;
  refine.signature = database_->parameters.signature;
  const Eigen::Vector2d places_px[] = {{320, 240}, {90, 80}, {550, 400}, {200, 380}};
  std::vector<double> before_t, after_t, before_r, after_r;
  cv::Mat ideal;
  int index = 0;
  for (const Eigen::Vector2d& place : places_px) {
    for (int view = 17; view < database_->num_views(); view += 113, ++index) {
      const Eigen::Vector3d& d = database_->sphere.directions[static_cast<size_t>(view)];
      const double roll = 23.0 * index - 90.0;
      const Eigen::Vector3d ray((place.x() - camera.principal_x_px) / camera.focal_x_px,
                                (place.y() - camera.principal_y_px) / camera.focal_y_px, 1.0);
      const Rigid3 truth = OffAxisPose(d, roll, (5.0 + index % 4) * Radius(), ray);
      RenderSilhouette(*mesh_, camera, truth, &ideal);
      const PolarSignature frame = Describe(DistortMask(ideal, camera));
      const SilhouettePose initial =
          EstimatePoseFromSilhouette(*database_, 0, view, roll, frame, camera);
      const SilhouettePose refined = RefinePoseByRendering(*mesh_, camera, frame, initial, refine);
      EXPECT_EQ(refined.iterations, 2);
      const PoseError before = ComputePoseError(initial.camera_from_object, truth, Centre());
      const PoseError after = ComputePoseError(refined.camera_from_object, truth, Centre());
      before_t.push_back(before.translation_relative);
      after_t.push_back(after.translation_relative);
      before_r.push_back(before.rotation_deg);
      after_r.push_back(after.rotation_deg);
    }
  }
  std::printf(
      "render refinement (exact view, 5-8 radii, k1=-0.1):\n  before: translation rel %s\n"
      "    rotation deg %s\n  after: translation rel %s\n    rotation deg %s\n",
      Summarize(before_t).Describe().c_str(), Summarize(before_r).Describe().c_str(),
      Summarize(after_t).Describe().c_str(), Summarize(after_r).Describe().c_str());
  EXPECT_LT(Summarize(after_t).median, 0.5 * Summarize(before_t).median);
  EXPECT_LT(Summarize(after_t).max, 0.02);
  EXPECT_LE(Summarize(after_r).median, Summarize(before_r).median);
  refine.iterations = 0;
  EXPECT_THROW(RefinePoseByRendering(*mesh_, camera, Describe(ideal), {}, refine), Error);
}

TEST_F(PoseFromSilhouetteTest, NearlySquarePixelsAreHandledOthersRefused) {
  const Eigen::Vector3d& d = database_->sphere.directions[40];
  PinholeCamera camera = DefaultSynthCamera();
  camera.focal_x_px = 528.0;  // fx / fy = 1.0057
  const Rigid3 truth = CameraFromObjectAtView(d, 10.0, 4.0 * Radius(), Centre());
  cv::Mat mask;
  RenderSilhouette(*mesh_, camera, truth, &mask);
  const PolarSignature frame = Describe(mask);
  const PoseError error =
      ComputePoseError(PoseFromSilhouette(*database_, 0, 40, 10.0, frame, camera), truth, Centre());
  EXPECT_LT(error.rotation_deg, 1.0);
  EXPECT_LT(error.translation_relative, 0.02);
  camera.focal_x_px = 580.0;
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, 40, 10.0, frame, camera), Error);
  PoseFromSilhouetteOptions lenient;
  lenient.max_pixel_aspect_deviation = 0.2;
  EXPECT_NO_THROW(PoseFromSilhouette(*database_, 0, 40, 10.0, frame, camera, lenient));
}

TEST_F(PoseFromSilhouetteTest, BadArgumentsThrow) {
  const PinholeCamera camera = DefaultSynthCamera();
  PolarSignature frame;
  frame.mean_radius_px = 50.0;
  frame.centroid_px = Eigen::Vector2d(300, 200);
  EXPECT_NO_THROW(PoseFromSilhouette(*database_, 0, 0, 0.0, frame, camera));
  EXPECT_THROW(PoseFromSilhouette(*database_, 1, 0, 0.0, frame, camera), Error);
  EXPECT_THROW(PoseFromSilhouette(*database_, -1, 0, 0.0, frame, camera), Error);
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, database_->num_views(), 0.0, frame, camera),
               Error);
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, 0, std::nan(""), frame, camera), Error);
  PinholeCamera bad = camera;
  bad.focal_x_px = 0.0;
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, 0, 0.0, frame, bad), Error);
  PoseFromSilhouetteOptions options;
  options.outline_iterations = -1;
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, 0, 0.0, frame, camera, options), Error);
  frame.mean_radius_px = 0.0;
  EXPECT_THROW(PoseFromSilhouette(*database_, 0, 0, 0.0, frame, camera), Error);
}

TEST(RotationFromOpticalAxisTo, TakesTheAxisToTheRayWithoutTwist) {
  EXPECT_TRUE(RotationFromOpticalAxisTo(Eigen::Vector3d::UnitZ()).isIdentity(1e-15));
  const Eigen::Vector3d ray = Eigen::Vector3d(0.3, -0.4, 1.0).normalized();
  const Eigen::Matrix3d q = RotationFromOpticalAxisTo(ray);
  EXPECT_TRUE((q * Eigen::Vector3d::UnitZ()).isApprox(ray, 1e-12));
  EXPECT_NEAR(q.determinant(), 1.0, 1e-12);
  // The axis perpendicular to both stays fixed (the minimal rotation).
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(ray).normalized();
  EXPECT_TRUE((q * axis).isApprox(axis, 1e-12));
}

}  // namespace
}  // namespace silpose
