#include "silpose/track/confidence.h"

#include <gtest/gtest.h>

#include <cmath>

#include "silpose/util/error.h"

namespace silpose {
namespace {

ConfidenceFeatures GoodFit() {
  ConfidenceFeatures f;
  f.object_probability = 0.999;
  f.mode_mass = 0.95;
  f.runner_up_mass = 0.01;
  f.score = 0.999;
  f.has_fit = true;
  f.iou = 0.99;
  f.outline_rms = 0.005;
  return f;
}

ConfidenceFeatures PoorFit() {
  ConfidenceFeatures f = GoodFit();
  f.score = 0.9;
  f.iou = 0.75;
  f.outline_rms = 0.1;
  f.mode_mass = 0.4;
  return f;
}

TEST(ConfidenceFeatures, VectorTransformsAndBoundsEveryInput) {
  ConfidenceFeatures f = GoodFit();
  f.area_change = 5.0;
  const auto x = f.Vector();
  EXPECT_DOUBLE_EQ(x[0], 0.999);
  EXPECT_NEAR(x[2], 0.01 / 0.95, 1e-12);
  EXPECT_NEAR(x[3], 3.0, 1e-9);  // -log10(1 - 0.999)
  EXPECT_EQ(x[4], 1.0);
  EXPECT_EQ(x[7], 2.0);  // area change capped
  ConfidenceFeatures none;
  none.has_fit = false;
  none.iou = 0.9;
  none.score = 1.0;  // a perfect score is capped, not infinite
  none.runner_up_mass = 1.0;
  none.mode_mass = 0.0;
  const auto y = none.Vector();
  EXPECT_EQ(y[4], 0.0);
  EXPECT_EQ(y[5], 0.0);  // IoU ignored without a fit
  EXPECT_NEAR(y[3], 4.0, 1e-9);
  EXPECT_EQ(y[2], 3.0);
  for (double v : y) EXPECT_TRUE(std::isfinite(v));
  EXPECT_EQ(ConfidenceFeatures::Names().size(), x.size());
  // The twin and pose gaps: clamped to [0, 0.05] and scaled to [0, 1]; unmeasured counts as clear.
  EXPECT_EQ(x[10], 1.0);
  EXPECT_EQ(x[11], 1.0);
  ConfidenceFeatures gaps = GoodFit();
  gaps.twin_score_gap = 0.01;
  gaps.pose_score_gap = -0.3;
  EXPECT_NEAR(gaps.Vector()[10], 0.2, 1e-12);
  EXPECT_EQ(gaps.Vector()[11], 0.0);
  gaps.pose_score_gap = 0.025;
  EXPECT_NEAR(gaps.Vector()[11], 0.5, 1e-12);
  gaps.pose_score_gap = 0.4;
  EXPECT_EQ(gaps.Vector()[11], 1.0);
  EXPECT_STREQ(ConfidenceFeatures::Names()[11], "pose_gap");
}

TEST(ConfidenceModel, DefaultModelRanksAGoodFitAboveAPoorOne) {
  const ConfidenceModel model = ConfidenceModel::Default();
  ASSERT_TRUE(model.Check());
  ConfidenceFeatures good = GoodFit(), poor = PoorFit();
  good.recent_iou = 0.99;
  good.recent_outline_rms = 0.005;
  poor.recent_iou = 0.75;
  poor.recent_outline_rms = 0.1;
  const double high = model.Evaluate(good);
  const double low = model.Evaluate(poor);
  EXPECT_GT(high, 0.9);
  EXPECT_LT(low, 0.2);
  ConfidenceModel broken;
  broken.weights[3] = std::nan("");
  std::string error;
  EXPECT_FALSE(broken.Check(&error));
  EXPECT_NE(error.find("finite"), std::string::npos);
}

TEST(TrackStateEstimator, StatesFollowTheDocumentedRules) {
  TrackStateEstimator estimator;
  EXPECT_EQ(estimator.NoSilhouette().state, TrackState::kNoSilhouette);
  EXPECT_EQ(estimator.NoSilhouette().confidence, 0.0);
  // A poor fit from the start: no database object fits.
  for (int i = 0; i < 3; ++i) {
    ConfidenceFeatures f = PoorFit();
    EXPECT_EQ(estimator.Measured(&f, -1.0).state, TrackState::kUnknownObject);
    EXPECT_NEAR(f.recent_iou, 0.75, 1e-12);
  }
  // Good fits (the mean IoU recovers over fit_frames frames): tracking.
  TrackStateEstimator tracker;
  for (int i = 0; i < 5; ++i) {
    ConfidenceFeatures f = GoodFit();
    const TrackStateEstimator::Output out = tracker.Measured(&f, -1.0);
    EXPECT_EQ(out.state, TrackState::kTracking) << i;
    EXPECT_GE(out.confidence, tracker.options().min_confidence);
  }
  // Refinement off (no fit): judged from the posterior and the score only, never unknown.
  TrackStateEstimator no_fit;
  ConfidenceFeatures plain = GoodFit();
  plain.has_fit = false;
  const TrackStateEstimator::Output unfitted = no_fit.Measured(&plain, -1.0);
  EXPECT_NE(unfitted.state, TrackState::kTracking);  // the model needs the fit to trust a frame
  EXPECT_NE(unfitted.state, TrackState::kUnknownObject);  // and without one it accuses nothing
  EXPECT_EQ(plain.recent_outline_rms, 1.0);
  // Then a poor frame after established tracking: bad segmentation, not an unknown object.
  ConfidenceFeatures occluded = PoorFit();
  occluded.area_change = 0.5;
  EXPECT_EQ(tracker.Measured(&occluded, -1.0).state, TrackState::kBadSegmentation);
  // A competing mode as heavy and as good as the reported one: ambiguous.
  ConfidenceFeatures twin = GoodFit();
  twin.mode_mass = 0.45;
  twin.runner_up_mass = 0.44;
  EXPECT_EQ(tracker.Measured(&twin, twin.score - 0.001).state, TrackState::kAmbiguous);
  // A mirror twin that scores as well as the reported view: ambiguous too; a clearly worse one is
  // not.
  ConfidenceFeatures mirrored = GoodFit();
  mirrored.twin_score_gap = 0.002;
  EXPECT_EQ(tracker.Measured(&mirrored, -1.0).state, TrackState::kAmbiguous);
  mirrored.twin_score_gap = 0.2;
  EXPECT_EQ(tracker.Measured(&mirrored, -1.0).state, TrackState::kTracking);
  // Another pose (any view or roll beyond the mode radius) that scores at least as well as the
  // reported one: ambiguous, and the rule says which; one that scores less is not.
  ConfidenceFeatures other = GoodFit();
  other.pose_score_gap = 0.0;
  const TrackStateEstimator::Output alike = tracker.Measured(&other, -1.0);
  EXPECT_EQ(alike.state, TrackState::kAmbiguous);
  EXPECT_TRUE(alike.pose_alike);
  EXPECT_FALSE(alike.twin_alike);
  EXPECT_FALSE(alike.competing_mode);
  other.pose_score_gap = 0.001;
  const TrackStateEstimator::Output clear_pose = tracker.Measured(&other, -1.0);
  EXPECT_EQ(clear_pose.state, TrackState::kTracking);
  EXPECT_FALSE(clear_pose.pose_alike);
  // A looser threshold makes that frame ambiguous too.
  TrackStateOptions loose;
  loose.pose_score_gap = 0.002;
  TrackStateEstimator loose_tracker(loose);
  for (int i = 0; i < 3; ++i) {
    ConfidenceFeatures f = GoodFit();
    loose_tracker.Measured(&f, -1.0);
  }
  EXPECT_EQ(loose_tracker.Measured(&other, -1.0).state, TrackState::kAmbiguous);
  // Not tracked lately, the model fits, the area jumps: bad segmentation; without the jump: lost.
  TrackStateEstimator fresh;
  ConfidenceFeatures jump = GoodFit();
  jump.score = 0.5;
  jump.mode_mass = 0.1;
  jump.object_probability = 0.3;
  jump.iou = 0.92;
  jump.outline_rms = 0.06;
  jump.area_change = 1.0;
  EXPECT_EQ(fresh.Measured(&jump, -1.0).state, TrackState::kBadSegmentation);
  jump.area_change = 0.0;
  EXPECT_EQ(fresh.Measured(&jump, -1.0).state, TrackState::kLost);
  // A competing mode with a poor fit is not called ambiguous: the fit rules decide.
  TrackStateEstimator misfit;
  ConfidenceFeatures poor_twin = PoorFit();
  poor_twin.runner_up_mass = 0.4;
  EXPECT_EQ(misfit.Measured(&poor_twin, poor_twin.score).state, TrackState::kUnknownObject);
  // ... but not when the runner-up's score is clearly worse.
  ConfidenceFeatures clear = GoodFit();
  clear.runner_up_mass = 0.9;
  EXPECT_NE(tracker.Measured(&clear, clear.score - 0.2).state, TrackState::kAmbiguous);
}

TEST(TrackStateEstimator, AConfidentFrameAmbiguousBetweenPosesIsFollowedEvenWithAPoorFit) {
  // A degraded mask (the fit below the unknown-object IoU) of an object whose pose is known only
  // up to another pose scoring as well: confident, so ambiguous, not an unknown object ...
  TrackStateEstimator estimator;
  ConfidenceFeatures ragged = GoodFit();
  ragged.iou = 0.88;
  ragged.outline_rms = 0.012;
  ragged.pose_score_gap = 0.0;
  for (int i = 0; i < 4; ++i) {
    ConfidenceFeatures f = ragged;
    const TrackStateEstimator::Output out = estimator.Measured(&f, -1.0);
    ASSERT_GE(out.confidence, estimator.options().min_confidence) << i;
    ASSERT_LT(f.recent_iou, estimator.options().unknown_fit_iou) << i;
    EXPECT_EQ(out.state, TrackState::kAmbiguous) << i;
  }
  // ... and the object counts as followed: a poor frame next is bad segmentation.
  ConfidenceFeatures poor = PoorFit();
  EXPECT_EQ(estimator.Measured(&poor, -1.0).state, TrackState::kBadSegmentation);
  // Without the ambiguity the same frames are tracked, and the poor one after them the same.
  TrackStateEstimator plain;
  for (int i = 0; i < 4; ++i) {
    ConfidenceFeatures f = ragged;
    f.pose_score_gap = 0.05;
    EXPECT_EQ(plain.Measured(&f, -1.0).state, TrackState::kTracking) << i;
  }
  poor = PoorFit();
  EXPECT_EQ(plain.Measured(&poor, -1.0).state, TrackState::kBadSegmentation);
  // A competing mode (perhaps another object) with a poor fit still is not followed: the fit
  // rules decide.
  TrackStateEstimator competing;
  for (int i = 0; i < 4; ++i) {
    ConfidenceFeatures f = ragged;
    f.pose_score_gap = 0.05;
    f.mode_mass = 0.45;
    f.runner_up_mass = 0.44;
    EXPECT_NE(competing.Measured(&f, f.score).state, TrackState::kAmbiguous) << i;
  }
}

TEST(TrackStateOptions, InvalidValuesAreRefusedWithTheirName) {
  TrackStateOptions options;
  EXPECT_TRUE(options.Check());
  std::string error;
  options.min_confidence = 1.5;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("minimum confidence"), std::string::npos);
  options = {};
  options.fit_frames = 2;  // the bad-segmentation rule needs 3 tracked frames in the window
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("fit frames"), std::string::npos);
  options = {};
  options.pose_score_gap = -0.01;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("pose score gap"), std::string::npos);
  EXPECT_THROW(TrackStateEstimator{options}, Error);
}

TEST(TrackStateNames, RoundTrip) {
  for (TrackState s :
       {TrackState::kTracking, TrackState::kAmbiguous, TrackState::kUnknownObject,
        TrackState::kBadSegmentation, TrackState::kLost, TrackState::kNoSilhouette}) {
    TrackState parsed = TrackState::kTracking;
    ASSERT_TRUE(ParseTrackState(TrackStateName(s), &parsed));
    EXPECT_EQ(parsed, s);
  }
  TrackState parsed;
  EXPECT_FALSE(ParseTrackState("measured", &parsed));
}

}  // namespace
}  // namespace silpose
