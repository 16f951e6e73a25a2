#include "silpose/track/tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <any>
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>
#include <utility>

#include "silpose/database/database_builder.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/match/view_matcher.h"
#include "silpose/pose/pose_error.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/segment_ahead.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

const std::filesystem::path kModels(SILPOSE_SAMPLE_MODELS_DIR);

// Two sample models, 400 views: small enough to build in a second.
const ViewDatabase& Database() {
  static const ViewDatabase* database = [] {
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 400;
    options.parameters.render.resolution_px = 192;
    return new ViewDatabase(
        BuildViewDatabase({kModels / "cow.obj", kModels / "hand.obj"}, options));
  }();
  return *database;
}

// A 80-frame random walk over the cow, then the hand from frame 40 on.
const SyntheticSequence& Sequence() {
  static const SyntheticSequence* sequence = [] {
    SequenceOptions options;
    options.trajectory.kind = TrajectoryKind::kWalk;
    options.trajectory.num_frames = 80;
    options.trajectory.walk.seed = 7;
    options.trajectory.object_switches = {{0, 0}, {40, 1}};
    return new SyntheticSequence({LoadMesh(kModels / "cow.obj"), LoadMesh(kModels / "hand.obj")},
                                 options);
  }();
  return *sequence;
}

double Median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

double SpacingDeg() { return Database().sphere.typical_spacing_rad * 180.0 / std::numbers::pi; }

struct RunSummary {
  std::vector<std::string> objects;
  // Per frame: object, view, roll and translation, printed exactly.
  std::vector<std::string> estimates;
  std::vector<double> rotation_errors_deg;
  std::vector<double> translation_errors;  // relative to the true distance
};

// A frame's object, roll, view and translation, printed exactly.
std::string EstimateText(const FrameResult& result) {
  std::ostringstream estimate;
  estimate.precision(17);
  estimate << result.object << ' ' << result.roll_deg << ' ';
  if (result.view_dir_in_object) estimate << result.view_dir_in_object->x();
  if (result.camera_from_object)
    estimate << ' ' << result.camera_from_object->translation.transpose();
  return estimate.str();
}

RunSummary TrackSequence(const TrackerOptions& options) {
  Tracker tracker(Database(), Sequence().camera(), options);
  RunSummary summary;
  for (int f = 0; f < Sequence().num_frames(); ++f) {
    const SyntheticFrame frame = Sequence().Generate(f);
    const TrackedFrame tracked = tracker.Process(frame.mask);
    EXPECT_EQ(tracked.result.frame, f);
    EXPECT_EQ(tracked.result.status, "measured") << "frame " << f;
    summary.objects.push_back(tracked.result.object_name);
    summary.estimates.push_back(EstimateText(tracked.result));
    // Settled frames only: 10 frames after the start and after the switch.
    const bool settled = (f >= 10 && f < 40) || f >= 50;
    if (settled && tracked.result.object_name == frame.truth.object) {
      EXPECT_TRUE(tracked.result.camera_from_object.has_value()) << "frame " << f;
      if (!tracked.result.camera_from_object) continue;
      const Rigid3& estimated = *tracked.result.camera_from_object;
      const Rigid3& truth = frame.truth.camera_from_object;
      summary.rotation_errors_deg.push_back(RotationErrorDeg(estimated.rotation, truth.rotation));
      summary.translation_errors.push_back((estimated.translation - truth.translation).norm() /
                                           truth.translation.norm());
    }
  }
  return summary;
}

TEST(Tracker, IdentifiesTheObjectAndItsPoseAcrossASwitch) {
  TrackerOptions options;
  options.filter.seed = 3;
  const RunSummary run = TrackSequence(options);
  int right = 0, settled = 0;
  for (int f = 0; f < Sequence().num_frames(); ++f) {
    if ((f >= 10 && f < 40) || f >= 50) {
      ++settled;
      right += run.objects[static_cast<size_t>(f)] == Sequence().Truth(f).object;
    }
  }
  // Right object in every settled frame but at most 2 (the filter needs a few frames to switch).
  EXPECT_GE(right, settled - 2);
  ASSERT_GE(run.rotation_errors_deg.size(), 40u);
  // Rotation: within the view grid spacing plus a few degrees (roll, view between grid points);
  // translation: a few percent of the distance (scale from the silhouette).
  EXPECT_LT(Median(run.rotation_errors_deg), SpacingDeg() + 4.0);
  EXPECT_LT(Median(run.translation_errors), 0.05);
}

TEST(Tracker, SameSeedSameResults) {
  TrackerOptions options;
  options.filter.seed = 11;
  const RunSummary first = TrackSequence(options);
  EXPECT_EQ(first.estimates, TrackSequence(options).estimates);
  EXPECT_EQ(first.estimates.size(), 80u);
}

TEST(Tracker, ACorruptSignatureBlockIsAnErrorAtThePoseNotAFrameWithoutPose) {
  // A database file with stored spectra, read lazily: matching does not read whole signature
  // blocks, the pose does, and checks the block first.
  ViewDatabase with_spectra = Database();
  StoreViewSpectra(&with_spectra);
  const std::string bytes = with_spectra.Serialize();
  const auto keep = std::make_shared<std::string>(bytes);
  const ViewDatabase good =
      ViewDatabase::Deserialize(*keep, "parts.db", ViewChecks::kOnFirstUse, keep);
  auto corrupt = std::make_shared<std::string>(bytes);
  const int cow = good.FindModel("cow");
  ASSERT_GE(cow, 0);
  for (int shell = 0; shell < good.num_shells(); ++shell) {  // the lowest bit of one radius each
    const size_t at =
        static_cast<size_t>(reinterpret_cast<const char*>(
                                good.models[static_cast<size_t>(cow)].Signature(5, shell).data()) -
                            keep->data());
    (*corrupt)[at] = static_cast<char>((*corrupt)[at] ^ 0x01);
  }
  const ViewDatabase broken =
      ViewDatabase::Deserialize(*corrupt, "parts.db", ViewChecks::kOnFirstUse, corrupt);
  TrackerOptions options;
  options.brute_force = true;
  const cv::Mat cow_frame = Sequence().Generate(20).mask;
  Tracker fine(good, Sequence().camera(), options);
  const TrackedFrame tracked = fine.Process(cow_frame);
  ASSERT_EQ(tracked.result.object_name, "cow");
  EXPECT_TRUE(tracked.result.camera_from_object.has_value());
  Tracker tracker(broken, Sequence().camera(), options);
  try {
    (void)tracker.Process(cow_frame);
    ADD_FAILURE() << "a pose was computed from a corrupt signature block";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what())
                  .find("parts.db: corrupt database (checksum mismatch in the signatures of model "
                        "'cow'"),
              std::string::npos)
        << error.what();
  }
}

TEST(Tracker, BruteForceMatchesEveryFrameAlone) {
  TrackerOptions options;
  options.brute_force = true;
  Tracker tracker(Database(), Sequence().camera(), options);
  const TrackedFrame tracked = tracker.Process(Sequence().Generate(20).mask);
  EXPECT_EQ(tracked.result.object_name, "cow");
  EXPECT_TRUE(std::isnan(tracked.result.probability));
  EXPECT_EQ(tracked.result.particles, 0);
  EXPECT_FALSE(tracked.estimate.has_value());
  EXPECT_TRUE(tracked.result.camera_from_object.has_value());
}

TEST(Tracker, StageTimesSplitTheFrameTime) {
  for (const bool brute_force : {false, true}) {
    TrackerOptions options;
    options.brute_force = brute_force;
    Tracker tracker(Database(), Sequence().camera(), options);
    const TrackedFrame tracked = tracker.Process(Sequence().Generate(20).mask);
    const FrameResult& r = tracked.result;
    ASSERT_TRUE(r.camera_from_object.has_value());
    ASSERT_TRUE(tracked.refinement.has_value());
    double sum = 0.0;
    for (const double ms : {r.time_segment_ms, r.time_describe_ms, r.time_match_ms, r.time_pose_ms,
                            r.time_refine_ms}) {
      EXPECT_TRUE(std::isfinite(ms) && ms >= 0.0) << ms;
      sum += ms;
    }
    EXPECT_LE(sum, r.time_ms * (1.0 + 1e-9));
    // Without a silhouette only segmentation (and the filter's prediction) runs.
    const TrackedFrame blank =
        tracker.Process(cv::Mat::zeros(Sequence().Generate(1).mask.size(), CV_8UC1));
    EXPECT_TRUE(std::isfinite(blank.result.time_segment_ms));
    EXPECT_TRUE(std::isnan(blank.result.time_describe_ms));
    EXPECT_TRUE(std::isnan(blank.result.time_pose_ms));
    EXPECT_TRUE(std::isnan(blank.result.time_refine_ms));
    EXPECT_EQ(std::isfinite(blank.result.time_match_ms), !brute_force);
  }
}

TEST(Tracker, AFrameSegmentedAheadIsTrackedAsWhenTheTrackerSegmentsIt) {
  // `silpose track` segments each frame on the thread that reads the frames (SegmentAhead) and
  // gives the tracker the result: the frames must come out as when the tracker segments them.
  TrackerOptions options;
  options.filter.seed = 5;
  Tracker own(Database(), Sequence().camera(), options);
  Tracker given(Database(), Sequence().camera(), options);
  const ReadAheadSource::FrameWork segment = SegmentAhead(options.segmentation);
  for (int f = 0; f < 30; ++f) {
    const cv::Mat mask = Sequence().Generate(f).mask;
    const TrackedFrame by_own = own.Process(mask);
    AheadSegmentation ahead = std::any_cast<AheadSegmentation>(segment(mask));
    const double ms = ahead.ms;
    ASSERT_TRUE(ahead.result.ok()) << f;
    const TrackedFrame by_given = given.Process(mask, std::move(ahead.result), ms);
    EXPECT_EQ(EstimateText(by_given.result), EstimateText(by_own.result)) << "frame " << f;
    EXPECT_EQ(by_given.result.status, by_own.result.status);
    EXPECT_EQ(by_given.result.confidence, by_own.result.confidence) << "frame " << f;
    EXPECT_EQ(cv::norm(by_given.segmentation.mask, by_own.segmentation.mask, cv::NORM_INF), 0.0);
    // The segmentation's time is the one given, and part of the frame's.
    EXPECT_EQ(by_given.result.time_segment_ms, ms);
    EXPECT_GE(by_given.result.time_ms, ms);
  }
  // A time that is not one is refused.
  for (const double bad_ms : {-1.0, std::nan("")}) {
    SegmentationResult fine;
    fine.mask = cv::Mat(Sequence().Generate(30).mask.size(), CV_8UC1, cv::Scalar(0));
    EXPECT_THROW(given.Process(Sequence().Generate(30).mask, fine, bad_ms), Error) << bad_ms;
  }
  // A mask that is not the frame's size is refused, naming the frame.
  SegmentationResult wrong;
  wrong.mask = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  try {
    given.Process(Sequence().Generate(30).mask, wrong, 0.1);
    ADD_FAILURE() << "no Error for a 10x10 mask";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("frame 30: the segmentation given"), std::string::npos)
        << error.what();
  }
}

TEST(Tracker, FrameWithoutSilhouetteIsAPredictionWithoutPose) {
  Tracker tracker(Database(), Sequence().camera());
  const cv::Mat blank = cv::Mat::zeros(Sequence().Generate(1).mask.size(), CV_8UC1);
  // Before any silhouette: a prediction of the uniform prior, which names no object.
  const TrackedFrame first = tracker.Process(blank);
  EXPECT_EQ(first.result.object, -1);
  EXPECT_FALSE(first.result.view_dir_in_object.has_value());
  EXPECT_EQ(first.result.status, "predicted-no-silhouette-empty");
  tracker.Process(Sequence().Generate(0).mask);
  const TrackedFrame tracked = tracker.Process(blank);
  EXPECT_EQ(tracked.result.status, "predicted-no-silhouette-empty");
  EXPECT_FALSE(tracked.result.camera_from_object.has_value());
  ASSERT_TRUE(tracked.estimate.has_value());
  EXPECT_FALSE(tracked.estimate->measured);
  EXPECT_GE(tracked.result.object, 0);  // the filter still has an estimate
  EXPECT_EQ(tracker.num_frames(), 3);
}

TEST(Tracker, ConfidenceAndStateTellATrackedObjectFromOneNotInTheDatabase) {
  TrackerOptions options;
  options.filter.seed = 5;
  Tracker tracker(Database(), Sequence().camera(), options);
  int tracking = 0, confident = 0;
  for (int f = 0; f < 40; ++f) {
    const TrackedFrame tracked = tracker.Process(Sequence().Generate(f).mask);
    const FrameResult& r = tracked.result;
    ASSERT_TRUE(tracked.confidence_features.has_value());
    EXPECT_GE(r.confidence, 0.0);
    EXPECT_LE(r.confidence, 1.0);
    EXPECT_GT(r.iou, 0.0);
    if (f >= 10) {
      tracking += r.state == TrackState::kTracking;
      confident += r.confidence >= tracker.options().state.min_confidence;
    }
  }
  // The cow, clean masks, a database of 400 views: trusted once identified.
  EXPECT_GE(tracking, 25);
  EXPECT_GE(confident, 25);
  // An object that is not in the database (the elephant), shown to a fresh tracker.
  SequenceOptions elephant_options;
  elephant_options.trajectory.kind = TrajectoryKind::kWalk;
  elephant_options.trajectory.num_frames = 30;
  elephant_options.trajectory.walk.seed = 11;
  const SyntheticSequence elephant({LoadMesh(kModels / "elephant.obj")}, elephant_options);
  Tracker stranger(Database(), elephant.camera(), options);
  int unknown = 0, trusted = 0;
  for (int f = 0; f < elephant.num_frames(); ++f) {
    const FrameResult r = stranger.Process(elephant.Generate(f).mask).result;
    unknown += r.state == TrackState::kUnknownObject;
    trusted += r.state == TrackState::kTracking;
  }
  EXPECT_GE(unknown, 20);
  EXPECT_LE(trusted, 2);
  // A blank frame: no silhouette, confidence 0 (the filter still has an estimate).
  const cv::Mat blank = cv::Mat::zeros(Sequence().Generate(1).mask.size(), CV_8UC1);
  const FrameResult none = tracker.Process(blank).result;
  EXPECT_EQ(none.state, TrackState::kNoSilhouette);
  EXPECT_EQ(none.confidence, 0.0);
}

// One frame of `model` (0 cow, 1 hand) seen from `view_dir` at `distance_radii`, its silhouette
// about 200 px across in a 640 x 480 image, tracked alone by brute force.
TrackedFrame TrackOneView(int model, const Eigen::Vector3d& view_dir, double distance_radii) {
  const TriangleMesh mesh = LoadMesh(kModels / (model == 0 ? "cow.obj" : "hand.obj"));
  const PinholeCamera camera = PinholeCamera::Centered(640, 480, 100.0 * distance_radii);
  cv::Mat mask;
  RenderSilhouette(mesh, camera,
                   CameraFromObjectAtView(view_dir.normalized(), 20.0,
                                          distance_radii * mesh.Radius(), mesh.Centre()),
                   &mask);
  TrackerOptions options;
  options.brute_force = true;
  Tracker tracker(Database(), camera, options);
  return tracker.Process(mask);
}

TEST(Tracker, PoseGapIsSmallWhereAnotherPoseCastsTheSameOutline) {
  // The cow has one mirror plane (normal along its z axis); seen from far away from a direction
  // off the plane and off its normal, its mirror twin (a pose far from the true one) casts the
  // same outline up to perspective, so another pose explains the frame nearly as well: the pose
  // gap is small, at most the twin's own gap (both are limited by the 400-view grid here), and
  // below that of an asymmetric object seen from a generic direction.
  const Eigen::Vector3d oblique(0.6, 0.5, 0.62);
  const TrackedFrame far = TrackOneView(0, oblique, 40.0);
  ASSERT_EQ(far.result.object, 0);
  ASSERT_TRUE(far.confidence_features.has_value());
  const double twin_gap = far.confidence_features->twin_score_gap;
  const double pose_gap = far.confidence_features->pose_score_gap;
  ASSERT_TRUE(std::isfinite(pose_gap));
  ASSERT_TRUE(std::isfinite(twin_gap));
  EXPECT_LT(pose_gap, 0.03);
  EXPECT_LE(pose_gap, twin_gap);
  // The hand has no symmetry: nearby at 4 radii, from a generic direction, no far pose fits.
  const TrackedFrame hand = TrackOneView(1, Eigen::Vector3d(0.3, -0.8, 0.5), 4.0);
  ASSERT_EQ(hand.result.object, 1);
  ASSERT_TRUE(hand.confidence_features.has_value());
  EXPECT_FALSE(std::isfinite(hand.confidence_features->twin_score_gap));
  EXPECT_GT(hand.confidence_features->pose_score_gap, 2.0 * pose_gap);
  EXPECT_GT(hand.confidence_features->pose_score_gap, 0.03);
}

// The cow's silhouette shrunk by `scale` and centred at `centre` in an empty frame.
cv::Mat PlacedSilhouette(double scale, cv::Point centre) {
  const cv::Mat full = Sequence().Generate(5).mask;
  const cv::Rect box = cv::boundingRect(full);
  cv::Mat small;
  cv::resize(full(box), small, cv::Size(), scale, scale, cv::INTER_NEAREST);
  cv::Mat frame = cv::Mat::zeros(full.size(), CV_8UC1);
  const cv::Rect target(centre.x - small.cols / 2, centre.y - small.rows / 2, small.cols,
                        small.rows);
  const cv::Rect inside = target & cv::Rect(0, 0, frame.cols, frame.rows);
  small(cv::Rect(inside.x - target.x, inside.y - target.y, inside.width, inside.height))
      .copyTo(frame(inside));
  return frame;
}

TEST(Tracker, SilhouetteCutByTheBorderGetsNoPose) {
  Tracker tracker(Database(), Sequence().camera());
  tracker.Process(Sequence().Generate(5).mask);
  const TrackedFrame tracked = tracker.Process(PlacedSilhouette(0.5, {20, 240}));
  EXPECT_EQ(tracked.result.status, "measured-cut-by-border-no-pose");
  EXPECT_GE(tracked.result.object, 0);
  EXPECT_FALSE(tracked.result.camera_from_object.has_value());
}

TEST(Tracker, AFrameWhosePoseCannotBeComputedKeepsItsObjectAndTheRunGoesOn) {
  // Strong barrel distortion: the lens model folds before the image corner, so a silhouette
  // centred there cannot be undistorted.
  PinholeCamera camera = Sequence().camera();
  camera.distortion = {-0.5, 0.0, 0.0, 0.0, 0.0};
  Tracker tracker(Database(), camera);
  const TrackedFrame corner = tracker.Process(PlacedSilhouette(0.25, {560, 400}));
  EXPECT_EQ(corner.result.status, "measured-no-pose");
  EXPECT_GE(corner.result.object, 0);
  EXPECT_FALSE(corner.result.camera_from_object.has_value());
  const TrackedFrame centre = tracker.Process(PlacedSilhouette(0.25, {320, 240}));
  EXPECT_EQ(centre.result.status, "measured");
  EXPECT_TRUE(centre.result.camera_from_object.has_value());
}

// A hand-held sequence of the cow: 4-10 radii, up to 25 degrees off the axis, 2-15 degrees per
// frame with pauses, reversals and a cut; perfect masks.
struct HandheldErrors {
  std::vector<double> rotation_deg;
  std::vector<double> translation;
  int right_object = 0;
  int frames = 0;
};

HandheldErrors TrackHandheld(const TrackerOptions& options) {
  static const SyntheticSequence* sequence = [] {
    SequenceOptions sequence_options;
    sequence_options.trajectory.kind = TrajectoryKind::kHandheld;
    sequence_options.trajectory.num_frames = 60;
    sequence_options.trajectory.handheld.seed = 3;
    sequence_options.trajectory.handheld.cut_probability = 0.03;
    return new SyntheticSequence({LoadMesh(kModels / "cow.obj")}, sequence_options);
  }();
  Tracker tracker(Database(), sequence->camera(), options);
  HandheldErrors errors;
  for (int f = 0; f < sequence->num_frames(); ++f) {
    const SyntheticFrame frame = sequence->Generate(f);
    const TrackedFrame tracked = tracker.Process(frame.mask);
    if (f < 10) continue;
    ++errors.frames;
    if (tracked.result.object_name != "cow" || !tracked.result.camera_from_object) continue;
    ++errors.right_object;
    const Rigid3& truth = frame.truth.camera_from_object;
    errors.rotation_deg.push_back(
        RotationErrorDeg(tracked.result.camera_from_object->rotation, truth.rotation));
    errors.translation.push_back(
        (tracked.result.camera_from_object->translation - truth.translation).norm() /
        truth.translation.norm());
  }
  return errors;
}

TEST(Tracker, HandheldOffAxisSequenceIsTrackedBelowTheViewGrid) {
  // Default: on-axis matching, distance shells, adaptive motion with proposals, refinement.
  const HandheldErrors refined = TrackHandheld(TrackerOptions());
  EXPECT_EQ(refined.right_object, refined.frames);
  // Below the grid: the 400-view sphere's spacing is about 10 degrees.
  EXPECT_LT(Median(refined.rotation_deg), 1.5);
  EXPECT_LT(Median(refined.translation), 0.01);
  // Without the refinement the estimate is only as fine as the grid.
  TrackerOptions grid;
  grid.refine = false;
  const HandheldErrors coarse = TrackHandheld(grid);
  EXPECT_GT(Median(coarse.rotation_deg), 2.0 * Median(refined.rotation_deg));
  // The paper's filter (one neighbouring view per frame, no proposal) loses such motion more
  // often than the adaptive one, which is never worse than matching each frame alone.
  TrackerOptions paper = grid;
  paper.filter.motion_model = MotionModel::kNeighbour;
  paper.filter.data_driven_proposal = false;
  const HandheldErrors paper_errors = TrackHandheld(paper);
  TrackerOptions brute = grid;
  brute.brute_force = true;
  const HandheldErrors brute_errors = TrackHandheld(brute);
  auto mean = [](const std::vector<double>& values) {
    double sum = 0.0;
    for (double v : values) sum += v;
    return values.empty() ? 0.0 : sum / static_cast<double>(values.size());
  };
  EXPECT_LE(mean(coarse.rotation_deg), mean(brute_errors.rotation_deg) + 0.5);
  EXPECT_LT(mean(coarse.rotation_deg), mean(paper_errors.rotation_deg));
}

// A slow orbit of the cow (1 deg per frame, 3 radii) tracked with and without the motion start:
// per frame (from frame 10) the rotation error and the refined outline distance.
struct OrbitRun {
  std::vector<double> rotation_deg;
  std::vector<double> outline_rms_px;
  std::vector<std::string> estimates;
};

OrbitRun TrackSlowOrbit(const TrackerOptions& options) {
  static const SyntheticSequence* sequence = [] {
    SequenceOptions sequence_options;
    sequence_options.trajectory.kind = TrajectoryKind::kOrbit;
    sequence_options.trajectory.num_frames = 50;
    sequence_options.trajectory.orbit.tilt_deg = 40.0;
    sequence_options.trajectory.orbit.start_deg = 20.0;
    return new SyntheticSequence({LoadMesh(kModels / "cow.obj")}, sequence_options);
  }();
  Tracker tracker(Database(), sequence->camera(), options);
  OrbitRun run;
  for (int f = 0; f < sequence->num_frames(); ++f) {
    const SyntheticFrame frame = sequence->Generate(f);
    const TrackedFrame tracked = tracker.Process(frame.mask);
    run.estimates.push_back(EstimateText(tracked.result));
    if (f < 10 || tracked.result.object_name != "cow" || !tracked.result.camera_from_object ||
        !tracked.refinement)
      continue;
    run.rotation_deg.push_back(RotationErrorDeg(tracked.result.camera_from_object->rotation,
                                                frame.truth.camera_from_object.rotation));
    run.outline_rms_px.push_back(
        std::min(tracked.refinement->final_rms_px, tracked.refinement->initial_rms_px));
  }
  return run;
}

double Mean(const std::vector<double>& values) {
  double sum = 0.0;
  for (const double v : values) sum += v;
  return values.empty() ? std::nan("") : sum / static_cast<double>(values.size());
}

TEST(Tracker, MotionStartRefinesFromThePreviousPoseWhereTheGridIsCoarse) {
  // The 400-view grid is about 10 degrees apart: its poses start the refinement up to 5 degrees
  // off, the previous frame's refined pose about 1 degree.
  TrackerOptions with;
  with.filter.seed = 5;
  TrackerOptions without = with;
  without.refine_from_motion = false;
  const OrbitRun carried = TrackSlowOrbit(with);
  const OrbitRun grid = TrackSlowOrbit(without);
  ASSERT_EQ(carried.rotation_deg.size(), 40u);
  ASSERT_EQ(grid.rotation_deg.size(), 40u);
  // Of the two refined starts the one that ends closer to the outline is kept: the outline fits
  // better on average, and so does the rotation. Both runs end near the floor that the masks'
  // pixel staircase leaves (about 0.09 deg from the grid pose alone).
  std::cout << "outline " << Mean(carried.outline_rms_px) << " vs " << Mean(grid.outline_rms_px)
            << " px, rotation error " << Mean(carried.rotation_deg) << " vs "
            << Mean(grid.rotation_deg) << " deg\n";
  EXPECT_LT(Mean(carried.outline_rms_px), Mean(grid.outline_rms_px));
  EXPECT_LT(Mean(carried.rotation_deg), Mean(grid.rotation_deg));
  EXPECT_LT(Median(carried.rotation_deg), 1.0);
  // Brute force matches every frame alone: the option changes nothing there.
  TrackerOptions brute = with;
  brute.brute_force = true;
  TrackerOptions brute_without = brute;
  brute_without.refine_from_motion = false;
  EXPECT_EQ(TrackSlowOrbit(brute).estimates, TrackSlowOrbit(brute_without).estimates);
}

TEST(Tracker, ViewPolishStartsThePoseFromTheBestScoringViewNearTheEstimate) {
  // Without refinement nothing the pose gives flows back into the filter, so the runs with and
  // without the polish see the same filter estimates frame by frame; the polish may only move the
  // reported database view to a better-scoring one at most polish_steps neighbour steps away.
  TrackerOptions plain;
  plain.filter.seed = 5;
  plain.refine = false;
  plain.polish_steps = 0;
  TrackerOptions polished = plain;
  polished.polish_steps = 2;
  Tracker without(Database(), Sequence().camera(), plain);
  Tracker with(Database(), Sequence().camera(), polished);
  const ViewSphere& sphere = Database().sphere;
  const auto view_of = [&](const FrameResult& result) {
    int nearest = -1;
    double best = -2.0;
    for (int v = 0; v < sphere.num_views(); ++v) {
      const double dot = sphere.directions[static_cast<size_t>(v)].dot(*result.view_dir_in_object);
      if (dot > best) best = dot, nearest = v;
    }
    return nearest;
  };
  int moved = 0;
  int compared = 0;
  for (int f = 0; f < Sequence().num_frames(); ++f) {
    const SyntheticFrame frame = Sequence().Generate(f);
    const TrackedFrame a = without.Process(frame.mask);
    const TrackedFrame b = with.Process(frame.mask);
    ASSERT_TRUE(a.estimate && b.estimate);
    // The same filter estimate in both runs.
    ASSERT_EQ(a.estimate->object, b.estimate->object) << "frame " << f;
    ASSERT_EQ(a.estimate->view, b.estimate->view) << "frame " << f;
    if (!a.result.view_dir_in_object || !b.result.view_dir_in_object) continue;
    ++compared;
    EXPECT_EQ(a.result.object, b.result.object);
    EXPECT_GE(b.result.score, a.result.score) << "frame " << f;
    const int start = view_of(a.result);
    const int end = view_of(b.result);
    EXPECT_EQ(start, a.estimate->view);
    if (end == start) continue;
    ++moved;
    // One or two steps along the view graph.
    const auto near = [&](int from, int to) {
      const std::span<const uint32_t> n = sphere.Neighbours(from);
      return std::find(n.begin(), n.end(), static_cast<uint32_t>(to)) != n.end();
    };
    bool within_two = near(start, end);
    for (const uint32_t middle : sphere.Neighbours(start))
      within_two = within_two || near(static_cast<int>(middle), end);
    EXPECT_TRUE(within_two) << "frame " << f << ": view " << start << " -> " << end;
    // Clearly better: at least 30 % of the remaining mismatch 1 - score removed.
    EXPECT_LT(1.0 - b.result.score, 0.7 * (1.0 - a.result.score)) << "frame " << f;
    // Within the filter's mode (these models have no rotational symmetry) and near its roll.
    const double apart_deg = std::acos(std::clamp(sphere.directions[static_cast<size_t>(start)].dot(
                                                      sphere.directions[static_cast<size_t>(end)]),
                                                  -1.0, 1.0)) *
                             180.0 / std::numbers::pi;
    EXPECT_LE(apart_deg, polished.filter.mode_radius_deg) << "frame " << f;
    EXPECT_LE(std::abs(std::remainder(b.result.roll_deg - a.result.roll_deg, 360.0)), 15.0);
  }
  std::cout << moved << " of " << compared << " frames start from a better neighbour\n";
  EXPECT_GT(compared, 70);
  EXPECT_GT(moved, 0);
}

TEST(Tracker, FitArbitrationReportsTheHypothesisWhoseOutlineFitsTheFrameBetter) {
  // Trackers with and without fit arbitration, in lockstep (same seed) over hand-held sequences
  // of the sample models with threshold-like masks, up to the first frame in which the arbitration
  // took the challenger. Until then both report the same; in that frame the tracker without it
  // reports the filter's choice, and its refined outline distance is what the challenger's beat.
  TrackerOptions off;
  off.fit_arbitration_ratio = 0.0;
  // The arbitration alone (its rule also decides the mirror-twin check, tested below).
  TrackerOptions on;
  on.mirror_twin_check = false;
  // The fit rule with the margin alone (the IoU and score-gap rules are tested by
  // FitArbitrationRule below).
  on.fit_arbitration_iou_gain = 0.0;
  on.fit_arbitration_score_gap = 0.0;
  int frames_arbitrated = 0;
  for (const uint64_t seed : {1, 2, 3, 4}) {
    for (const char* name : {"cow", "hand"}) {
      SequenceOptions sequence_options;
      sequence_options.trajectory.kind = TrajectoryKind::kHandheld;
      sequence_options.trajectory.num_frames = 40;
      sequence_options.trajectory.handheld.seed = seed;
      sequence_options.degradation.seed = seed;
      sequence_options.degradation =
          WithMaskQuality(sequence_options.degradation, MaskQuality::kThreshold);
      const SyntheticSequence sequence({LoadMesh(kModels / (std::string(name) + ".obj"))},
                                       sequence_options);
      Tracker with(Database(), sequence.camera(), on);
      Tracker without(Database(), sequence.camera(), off);
      for (int f = 0; f < sequence.num_frames(); ++f) {
        const cv::Mat mask = sequence.Generate(f).mask;
        const TrackedFrame a = with.Process(mask);
        const TrackedFrame b = without.Process(mask);
        ASSERT_TRUE(a.estimate && b.estimate);
        EXPECT_FALSE(b.estimate->arbitrated);
        if (!a.estimate->challenger_won) {
          EXPECT_EQ(EstimateText(a.result), EstimateText(b.result)) << name << seed << " " << f;
          continue;
        }
        ++frames_arbitrated;
        // The challenger is reported, posed and refined.
        EXPECT_EQ(a.result.object, a.estimate->top.object);
        ASSERT_TRUE(a.refinement.has_value() && a.result.camera_from_object.has_value());
        // Without arbitration the same frame reports another hypothesis (the filter's choice),
        // which fits the outline worse by the ratio and the margin.
        EXPECT_TRUE(b.result.object != a.result.object || b.estimate->view != a.estimate->view);
        ASSERT_TRUE(b.refinement.has_value());
        const auto fit = [](const ContourRefinementResult& r) {
          return std::min(r.final_rms_px, r.initial_rms_px);
        };
        EXPECT_LT(fit(*a.refinement), on.fit_arbitration_ratio * fit(*b.refinement));
        EXPECT_GT(fit(*b.refinement) - fit(*a.refinement), on.fit_arbitration_margin_px);
        EXPECT_GE(a.refinement->iou, b.refinement->iou);
        // Its time counts as refinement, not as the filter step.
        EXPECT_GT(a.result.time_refine_ms, 0.0);
        break;
      }
      if (frames_arbitrated > 0) break;
    }
    if (frames_arbitrated > 0) break;
  }
  // Threshold-like masks make such frames common: the first sequence already has one.
  EXPECT_EQ(frames_arbitrated, 1);
}

TEST(Tracker, FitArbitrationRule) {
  const TrackerOptions options;
  // Figures of a frame of a spool seen nearly end-on at 3 radii: the filter's mode sat on the
  // other end, whose refined pose fits the nearly circular outline almost as well, while its
  // database view scored 0.17 against the challenger's 0.88.
  const HypothesisFit chosen{.object = 3, .score = 0.171, .rms_px = 0.74, .iou = 0.994};
  HypothesisFit challenger{.object = 3, .score = 0.876, .rms_px = 0.52, .iou = 0.996};
  // Not clearly the better fit (0.22 px, within the margin) ...
  ASSERT_LE(chosen.rms_px - challenger.rms_px, options.fit_arbitration_margin_px);
  // ... but as good a fit and far the better score.
  EXPECT_TRUE(FitArbitrationPrefersChallenger(chosen, challenger, options));
  TrackerOptions no_gap = options;
  no_gap.fit_arbitration_score_gap = 0.0;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, challenger, no_gap));
  // A score gap below the option's, a worse fit, a lower IoU or another object: the mode stays.
  HypothesisFit other = challenger;
  other.score = chosen.score + 0.9 * options.fit_arbitration_score_gap;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, other, options));
  other = challenger;
  other.rms_px = chosen.rms_px + 0.01;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, other, options));
  other = challenger;
  other.iou = chosen.iou - 0.001;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, other, options));
  other = challenger;
  other.object = 4;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, other, options));

  // The fit rule: below 0.8 times the RMS and lower by more than the margin, IoU no lower; any
  // object, any score.
  HypothesisFit better{.object = 4, .score = 0.0, .rms_px = 0.3, .iou = 0.995};
  EXPECT_TRUE(FitArbitrationPrefersChallenger(chosen, better, options));
  better.rms_px = 0.8 * chosen.rms_px;  // not below the ratio
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, better, options));
  better.rms_px = 0.3;
  better.iou = 0.99;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, better, options));
  const HypothesisFit close_small{.object = 3, .score = 0.9, .rms_px = 0.2, .iou = 0.99};
  HypothesisFit closer_small{.object = 4, .score = 0.9, .rms_px = 0.1, .iou = 0.99};
  // 0.5 times the RMS but only 0.1 px lower, and the same IoU: pixel noise.
  EXPECT_FALSE(FitArbitrationPrefersChallenger(close_small, closer_small, options));
  // The IoU rule: the back of a flat object at 15 radii fitted in 0.45 px against its front's
  // 0.21 px (within the margin), with an IoU of 0.971 against 0.999.
  const HypothesisFit back{.object = 9, .score = 0.996, .rms_px = 0.45, .iou = 0.971};
  HypothesisFit front{.object = 9, .score = 0.997, .rms_px = 0.21, .iou = 0.999};
  EXPECT_TRUE(FitArbitrationPrefersChallenger(back, front, options));
  TrackerOptions no_iou = options;
  no_iou.fit_arbitration_iou_gain = 0.0;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(back, front, no_iou));
  // ... the IoU gain below the option's, or the RMS not below the ratio: no.
  front.iou = back.iou + 0.9 * options.fit_arbitration_iou_gain;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(back, front, options));
  front.iou = 0.999;
  front.rms_px = 0.8 * back.rms_px;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(back, front, options));
  closer_small.iou = close_small.iou + options.fit_arbitration_iou_gain;
  EXPECT_TRUE(FitArbitrationPrefersChallenger(close_small, closer_small, options));

  // Off (ratio 0: --no-fit-arbitration) and fits that are not numbers.
  TrackerOptions off = options;
  off.fit_arbitration_ratio = 0.0;
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, challenger, off));
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, better, off));
  other = challenger;
  other.rms_px = std::nan("");
  EXPECT_FALSE(FitArbitrationPrefersChallenger(chosen, other, options));
  other = chosen;
  other.iou = std::nan("");
  EXPECT_FALSE(FitArbitrationPrefersChallenger(other, challenger, options));

  // The option's range.
  std::string error;
  TrackerOptions invalid = options;
  invalid.fit_arbitration_score_gap = -0.1;
  EXPECT_FALSE(invalid.Check(&error));
  EXPECT_NE(error.find("fit_arbitration_score_gap"), std::string::npos);
  invalid.fit_arbitration_score_gap = std::nan("");
  EXPECT_FALSE(invalid.Check());
  invalid = options;
  invalid.fit_arbitration_iou_gain = 1.5;
  EXPECT_FALSE(invalid.Check(&error));
  EXPECT_NE(error.find("fit_arbitration_iou_gain"), std::string::npos);
}

// The cow (one mirror plane) on a 40-frame orbit at 12 radii, 3 degrees per frame, about 200 px
// across: far enough that a view and its mirror twin cast nearly the same outline, so that the
// database's views often match the twin, and near enough that the refined twin poses fit the
// outline differently.
// Orbits (start, tilt, degrees) of FarCowOrbit on which the filter without the mirror-twin check
// takes the wrong twin at times.
constexpr std::array<std::pair<double, double>, 3> kFarCowOrbits = {
    std::pair{60.0, 20.0}, std::pair{120.0, 20.0}, std::pair{120.0, 80.0}};

SyntheticSequence FarCowOrbit(double start_deg, double tilt_deg) {
  SequenceOptions sequence_options;
  sequence_options.camera = PinholeCamera::Centered(640, 480, 1200.0);
  sequence_options.trajectory.kind = TrajectoryKind::kOrbit;
  sequence_options.trajectory.num_frames = 40;
  sequence_options.trajectory.orbit.step_deg = 3.0;
  sequence_options.trajectory.orbit.start_deg = start_deg;
  sequence_options.trajectory.orbit.tilt_deg = tilt_deg;
  sequence_options.trajectory.orbit.distance_in_radii = 12.0;
  return SyntheticSequence({LoadMesh(kModels / "cow.obj")}, sequence_options);
}

TEST(Tracker, MirrorTwinCheckReportsTheTwinPoseThatFitsAndTheFilterFollowsIt) {
  // FarCowOrbit: the database's views often match the mirror twin.
  for (const bool brute_force : {true, false}) {
    SCOPED_TRACE(brute_force ? "brute force" : "filter");
    TrackerOptions on;
    on.brute_force = brute_force;
    // The other-pose check finds mirror twins too: this test is of the twin check alone.
    on.other_pose_check = false;
    TrackerOptions off = on;
    off.mirror_twin_check = false;
    int flips = 0, wrong_with = 0, wrong_without = 0;
    for (const auto& [start_deg, tilt_deg] : kFarCowOrbits) {
      const SyntheticSequence sequence = FarCowOrbit(start_deg, tilt_deg);
      Tracker with(Database(), sequence.camera(), on);
      Tracker without(Database(), sequence.camera(), off);
      bool flipped = false;
      // The view reported after a flip, and the filter's estimate (the other twin) before it.
      Eigen::Vector3d flipped_view = Eigen::Vector3d::Zero();
      Eigen::Vector3d matched_view = Eigen::Vector3d::Zero();
      for (int f = 0; f < sequence.num_frames(); ++f) {
        const SyntheticFrame frame = sequence.Generate(f);
        const TrackedFrame a = with.Process(frame.mask);
        const TrackedFrame b = without.Process(frame.mask);
        ASSERT_EQ(a.result.object, 0) << f;
        ASSERT_TRUE(a.result.camera_from_object && b.result.camera_from_object) << f;
        const Eigen::Matrix3d& truth = frame.truth.camera_from_object.rotation;
        const double error_a = RotationErrorDeg(a.result.camera_from_object->rotation, truth);
        const double error_b = RotationErrorDeg(b.result.camera_from_object->rotation, truth);
        // On the wrong twin: a pose far from the truth (the twins of these views are more than
        // 60 degrees apart), which the refinement alone does not leave.
        wrong_with += error_a > 30.0;
        wrong_without += error_b > 30.0;
        EXPECT_FALSE(b.mirror_twin_fitted);
        if (flipped) {
          // The frame after a flip: the filter's particles were moved to the twin, so its
          // estimate lies near the view reported then, not back on the other twin.
          ASSERT_TRUE(a.estimate.has_value());
          const Eigen::Vector3d& estimated =
              Database().sphere.directions[static_cast<size_t>(a.estimate->view)];
          const auto angle_deg = [&](const Eigen::Vector3d& v) {
            return std::acos(std::clamp(estimated.dot(v), -1.0, 1.0)) * 180.0 / std::numbers::pi;
          };
          EXPECT_LT(angle_deg(flipped_view), 3.0 * SpacingDeg()) << f;
          EXPECT_LT(angle_deg(flipped_view), angle_deg(matched_view)) << f;
          flipped = false;
        }
        if (!a.mirror_twin_fitted) continue;
        ++flips;
        // The reported twin is the right pose.
        EXPECT_LT(error_a, 10.0) << f;
        ASSERT_TRUE(a.refinement.has_value());
        if (brute_force) {
          // Matched alone, the frame without the check reports the matched pose, the wrong
          // twin, and the reported twin fits the outline better than it by the rule.
          EXPECT_GT(error_b, 30.0) << f;
          ASSERT_TRUE(b.refinement.has_value());
          const auto fit = [](const ContourRefinementResult& r) {
            return std::min(r.final_rms_px, r.initial_rms_px);
          };
          EXPECT_TRUE(
              FitArbitrationPrefersChallenger({0, 0.0, fit(*b.refinement), b.refinement->iou},
                                              {0, 0.0, fit(*a.refinement), a.refinement->iou}, on))
              << f;
          EXPECT_LT(fit(*a.refinement), on.fit_arbitration_ratio * fit(*b.refinement)) << f;
          EXPECT_GE(a.refinement->iou, b.refinement->iou) << f;
        } else {
          flipped = true;
          flipped_view = *a.result.view_dir_in_object;
          matched_view = Database().sphere.directions[static_cast<size_t>(a.estimate->view)];
        }
      }
    }
    // Without the check some frames are on the wrong twin; with it, at most half as many.
    EXPECT_GT(wrong_without, brute_force ? 10 : 1);
    EXPECT_GT(flips, 0);
    EXPECT_LE(2 * wrong_with, wrong_without);
  }
}

TEST(Tracker, ReviseRunsTheMirrorTwinCheckSoASmoothedFrameKeepsTheTwinItCorrected) {
  // The smoothing re-poses frames at the views their particle histories hold; a history may hold
  // the wrong twin that the mirror-twin check corrected live. Re-posed there, the frame must come
  // back to the corrected pose; without the check it stays on the wrong twin.
  TrackerOptions on;
  TrackerOptions off = on;
  off.mirror_twin_check = false;
  int revised_frames = 0, wrong_without_check = 0;
  for (const auto& [start_deg, tilt_deg] : kFarCowOrbits) {
    const SyntheticSequence sequence = FarCowOrbit(start_deg, tilt_deg);
    Tracker with(Database(), sequence.camera(), on);
    Tracker without(Database(), sequence.camera(), off);
    for (int f = 0; f < sequence.num_frames(); ++f) {
      const SyntheticFrame frame = sequence.Generate(f);
      const TrackedFrame live = with.Process(frame.mask);
      without.Process(frame.mask);
      if (!live.mirror_twin_fitted) continue;
      ASSERT_TRUE(live.estimate.has_value());
      ASSERT_TRUE(live.result.camera_from_object && live.result.view_dir_in_object);
      const Eigen::Matrix3d& truth = frame.truth.camera_from_object.rotation;
      ASSERT_LT(RotationErrorDeg(live.result.camera_from_object->rotation, truth), 10.0) << f;
      // A history at the filter's estimate, the wrong twin, in a frame whose estimate was
      // elsewhere (the reported twin), so that Revise re-poses it.
      PoseState wrong;
      wrong.object = live.estimate->object;
      wrong.view = live.estimate->view;
      wrong.roll_deg = live.estimate->roll_deg;
      wrong.roll_known = true;
      wrong.score = live.estimate->score;
      TrackedFrame moved = live;
      moved.estimate->view = Database().sphere.NearestView(*live.result.view_dir_in_object);
      const TrackedFrame revised = with.Revise(moved, wrong);
      const TrackedFrame plain = without.Revise(moved, wrong);
      ASSERT_TRUE(revised.result.camera_from_object && plain.result.camera_from_object) << f;
      EXPECT_LT(RotationErrorDeg(revised.result.camera_from_object->rotation, truth), 10.0) << f;
      EXPECT_FALSE(plain.mirror_twin_fitted) << f;
      if (RotationErrorDeg(plain.result.camera_from_object->rotation, truth) > 30.0) {
        // Re-posed without the check the frame is on the wrong twin again; with it, the twin
        // was taken.
        EXPECT_TRUE(revised.mirror_twin_fitted) << f;
        ++wrong_without_check;
      }
      ++revised_frames;
    }
  }
  EXPECT_GT(revised_frames, 0);
  EXPECT_GT(wrong_without_check, 0);
}

TEST(Tracker, CanonicalFormIsAnEquivalentPoseSharedByAllEquivalentPoses) {
  // A bearing-like object: continuous about y through c, with a flip about x.
  const Eigen::Vector3d c(0.0, 1.0, 0.5);
  ObjectSymmetry symmetry;
  symmetry.continuous.push_back({.axis = Eigen::Vector3d::UnitY(), .offset = c});
  Rigid3 flip;
  flip.rotation = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  flip.translation = c - flip.rotation * c;
  symmetry.discrete.push_back(flip);
  const std::vector<Rigid3> transforms = SymmetryTransforms(symmetry, 0.002);
  Eigen::Vector3d first_across = Eigen::Vector3d::Zero();
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d view = Eigen::Vector3d::Random().normalized();
    const double roll = -170.0 + 17.0 * trial;
    FrameResult result;
    result.view_dir_in_object = view;
    result.roll_deg = roll;
    result.camera_from_object = CameraFromObjectAtView(view, roll, 8.0, c);
    const Rigid3 original = *result.camera_from_object;
    ToCanonicalForm(symmetry, &result);
    const Rigid3& canonical = *result.camera_from_object;
    // Equivalent to the original: the same up to a symmetry.
    EXPECT_LT(RotationErrorModuloSymmetryDeg(canonical.rotation, original.rotation, transforms),
              0.3);
    // In the canonical sector: every canonical camera lies in one half-plane bounded by the
    // axis (the same direction across the axis), at the original's angle to the axis.
    const Eigen::Vector3d canonical_view = *result.view_dir_in_object;
    EXPECT_NEAR(std::abs(canonical_view.dot(Eigen::Vector3d::UnitY())),
                std::abs(view.dot(Eigen::Vector3d::UnitY())), 1e-9);
    const Eigen::Vector3d across =
        (canonical_view - canonical_view.dot(Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitY())
            .normalized();
    if (trial == 0) first_across = across;
    EXPECT_LT((across - first_across).norm(), 1e-9) << "trial " << trial;
    // View, roll and pose agree with each other.
    EXPECT_LT(
        (CameraFromObjectRotation(canonical_view, result.roll_deg) - canonical.rotation).norm(),
        1e-9);
    EXPECT_LT((ViewDirectionOfPose(canonical, c) - canonical_view).norm(), 1e-9);
    // An equivalent pose has the same canonical form.
    const Rigid3& s = transforms[static_cast<size_t>(trial * 37) % transforms.size()];
    FrameResult equivalent;
    equivalent.view_dir_in_object = s.rotation.transpose() * view;
    equivalent.camera_from_object = original * s;
    Eigen::Vector3d unused;
    double equivalent_roll = 0.0;
    ViewAndRollFromRotation(equivalent.camera_from_object->rotation, &unused, &equivalent_roll);
    equivalent.roll_deg = equivalent_roll;
    ToCanonicalForm(symmetry, &equivalent);
    EXPECT_LT((equivalent.camera_from_object->rotation - canonical.rotation).norm(), 1e-6);
    EXPECT_LT((equivalent.camera_from_object->translation - canonical.translation).norm(), 1e-6);
    EXPECT_NEAR(WrapDegrees(equivalent.roll_deg - result.roll_deg), 0.0, 1e-6);
  }
  // Without rotations nothing changes.
  FrameResult plain;
  plain.view_dir_in_object = Eigen::Vector3d(0.0, 0.6, 0.8);
  plain.roll_deg = 12.0;
  ObjectSymmetry mirror_only;
  mirror_only.mirrors.push_back({});
  ToCanonicalForm(mirror_only, &plain);
  EXPECT_EQ(*plain.view_dir_in_object, Eigen::Vector3d(0.0, 0.6, 0.8));
  EXPECT_EQ(plain.roll_deg, 12.0);
}

TEST(Tracker, RefusesFramesOfAnotherSize) {
  Tracker tracker(Database(), Sequence().camera());
  const cv::Mat small = cv::Mat::zeros(100, 100, CV_8UC1);
  EXPECT_THROW(tracker.Process(small), Error);
  EXPECT_THROW(tracker.Process(cv::Mat()), Error);
}

// Brute force matches every frame alone, so a frame's pose with the check differs from the one
// without it exactly where the check reported another pose: one that fits the outline far closer.
// The far cow orbits' wrong mirror twins are such poses (the twin check, which would take them
// first, is off here).
TEST(Tracker, OtherPoseCheckReportsAnotherPoseOnlyWhereItFitsFarCloser) {
  TrackerOptions on;
  on.brute_force = true;
  on.mirror_twin_check = false;
  TrackerOptions off = on;
  off.other_pose_check = false;
  int fitted = 0, closer = 0;
  std::vector<SyntheticSequence> sequences;
  for (const auto& [start_deg, tilt_deg] : kFarCowOrbits) {
    sequences.push_back(FarCowOrbit(start_deg, tilt_deg));
  }
  for (const SyntheticSequence& sequence : sequences) {
    Tracker with(Database(), sequence.camera(), on);
    Tracker without(Database(), sequence.camera(), off);
    for (int f = 0; f < sequence.num_frames(); ++f) {
      const SyntheticFrame frame = sequence.Generate(f);
      const TrackedFrame a = with.Process(frame.mask);
      const TrackedFrame b = without.Process(frame.mask);
      EXPECT_FALSE(b.other_pose_fitted);
      ASSERT_EQ(a.result.object, b.result.object) << f;
      if (!a.other_pose_fitted) {
        ASSERT_EQ(EstimateText(a.result), EstimateText(b.result)) << f;
        // The confidence searched the same view's other poses (with the check on it reads the
        // check's search of this frame).
        ASSERT_TRUE(a.confidence_features && b.confidence_features) << f;
        const double gap_a = a.confidence_features->pose_score_gap;
        const double gap_b = b.confidence_features->pose_score_gap;
        EXPECT_TRUE(gap_a == gap_b || (std::isnan(gap_a) && std::isnan(gap_b)))
            << f << ": " << gap_a << " vs " << gap_b;
        continue;
      }
      ++fitted;
      ASSERT_TRUE(a.refinement && b.refinement && a.result.camera_from_object &&
                  b.result.camera_from_object)
          << f;
      const auto fit = [](const ContourRefinementResult& r) {
        return std::min(r.final_rms_px, r.initial_rms_px);
      };
      EXPECT_LT(fit(*a.refinement), on.other_pose_fit_ratio * fit(*b.refinement)) << f;
      EXPECT_TRUE(FitArbitrationPrefersChallenger({0, 0.0, fit(*b.refinement), b.refinement->iou},
                                                  {0, 0.0, fit(*a.refinement), a.refinement->iou},
                                                  on))
          << f;
      // Another pose: farther than the mode radius from the one it replaced.
      EXPECT_GT(RotationErrorDeg(a.result.camera_from_object->rotation,
                                 b.result.camera_from_object->rotation),
                on.filter.mode_radius_deg)
          << f;
      const Eigen::Matrix3d& truth = frame.truth.camera_from_object.rotation;
      closer += RotationErrorDeg(a.result.camera_from_object->rotation, truth) <
                RotationErrorDeg(b.result.camera_from_object->rotation, truth);
    }
  }
  EXPECT_GT(fitted, 0);
  // The pose that fits far closer is nearer the truth in most of those frames.
  EXPECT_GT(2 * closer, fitted);
}

TEST(Tracker, RefusesInvalidOptions) {
  TrackerOptions options;
  options.filter.particles_per_object = 0;
  EXPECT_THROW(Tracker(Database(), Sequence().camera(), options), Error);
  options = {};
  options.polish_steps = -1;
  EXPECT_THROW(Tracker(Database(), Sequence().camera(), options), Error);
  options = {};
  options.other_pose_score_gap = -0.1;
  EXPECT_THROW(Tracker(Database(), Sequence().camera(), options), Error);
  options = {};
  options.other_pose_fit_ratio = 0.0;
  EXPECT_THROW(Tracker(Database(), Sequence().camera(), options), Error);
  PinholeCamera camera = Sequence().camera();
  camera.focal_x_px = -1.0;
  EXPECT_THROW(Tracker(Database(), camera), Error);
}

}  // namespace
}  // namespace silpose
