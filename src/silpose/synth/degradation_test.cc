#include "silpose/synth/degradation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// A 200 x 150 mask with a filled ellipse (semi-axes 50 x 35) in the middle.
cv::Mat Silhouette() {
  cv::Mat mask(150, 200, CV_8UC1, cv::Scalar(0));
  cv::ellipse(mask, cv::Point(100, 75), cv::Size(50, 35), 20.0, 0.0, 360.0, cv::Scalar(255),
              cv::FILLED);
  return mask;
}

cv::Mat Degraded(const DegradationOptions& options, int frame, FrameDegradation* kind = nullptr) {
  cv::Mat mask = Silhouette();
  const FrameDegradation result = DegradeMask(options, frame, &mask);
  if (kind != nullptr) *kind = result;
  return mask;
}

int Count(const cv::Mat& mask) { return cv::countNonZero(mask); }
// Pixels set in `a` but not in `b`.
int Extra(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::bitwise_and(a, ~b, difference);
  return cv::countNonZero(difference);
}
int Different(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::bitwise_xor(a, b, difference);
  return cv::countNonZero(difference);
}

// The options are refused with a message containing `word`.
void ExpectRefused(const DegradationOptions& options, const char* word) {
  std::string error;
  EXPECT_FALSE(options.Check(&error)) << word;
  EXPECT_NE(error.find(word), std::string::npos) << error;
}

TEST(Degradation, NothingByDefault) {
  const DegradationOptions options;
  EXPECT_FALSE(options.Any());
  FrameDegradation kind = FrameDegradation::kBad;
  const cv::Mat mask = Degraded(options, 4, &kind);
  EXPECT_EQ(kind, FrameDegradation::kNone);
  EXPECT_EQ(Different(mask, Silhouette()), 0);
}

TEST(Degradation, NoiseFlipsAboutTheRequestedFraction) {
  const cv::Mat original = Silhouette();
  const double pixels = static_cast<double>(original.total());
  for (double fraction : {0.01, 0.1, 0.5}) {
    DegradationOptions options;
    options.noise_fraction = fraction;
    const int flipped = Different(Degraded(options, 0), original);
    // Binomial: within 5 standard deviations.
    const double sigma = std::sqrt(pixels * fraction * (1.0 - fraction));
    EXPECT_NEAR(flipped, pixels * fraction, 5.0 * sigma) << "fraction " << fraction;
  }
  DegradationOptions all;
  all.noise_fraction = 1.0;
  EXPECT_EQ(Different(Degraded(all, 0), original), static_cast<int>(original.total()));
}

TEST(Degradation, ErosionShrinksAndDilationGrows) {
  const cv::Mat original = Silhouette();
  DegradationOptions options;
  options.erode_px = 3;
  const cv::Mat eroded = Degraded(options, 0);
  EXPECT_EQ(Extra(eroded, original), 0);
  // About the perimeter (~270 px) times 3 pixels.
  EXPECT_GT(Count(original) - Count(eroded), 600);
  options = DegradationOptions();
  options.dilate_px = 3;
  const cv::Mat dilated = Degraded(options, 0);
  EXPECT_EQ(Extra(original, dilated), 0);
  EXPECT_GT(Count(dilated) - Count(original), 600);
}

TEST(Degradation, OccludersOnlyRemoveObjectPixels) {
  const cv::Mat original = Silhouette();
  DegradationOptions options;
  options.occluders = 3;
  for (int frame = 0; frame < 20; ++frame) {
    const cv::Mat occluded = Degraded(options, frame);
    EXPECT_EQ(Extra(occluded, original), 0) << "frame " << frame;
    EXPECT_GT(Count(original) - Count(occluded), 0) << "frame " << frame;
  }
}

TEST(Degradation, ClutterOnlyAddsPixels) {
  const cv::Mat original = Silhouette();
  DegradationOptions options;
  options.clutter_blobs = 4;
  int added = 0;
  for (int frame = 0; frame < 20; ++frame) {
    const cv::Mat cluttered = Degraded(options, frame);
    EXPECT_EQ(Extra(original, cluttered), 0) << "frame " << frame;
    added += Extra(cluttered, original);
  }
  EXPECT_GT(added, 20 * 4 * 10);
}

TEST(Degradation, MissedFramesAreEmpty) {
  DegradationOptions options;
  options.missed_probability = 1.0;
  options.noise_fraction = 0.2;  // not applied to a missed frame
  options.clutter_blobs = 3;
  FrameDegradation kind = FrameDegradation::kNone;
  EXPECT_EQ(Count(Degraded(options, 5, &kind)), 0);
  EXPECT_EQ(kind, FrameDegradation::kMissed);
}

TEST(Degradation, FrameKindsFollowTheirProbabilities) {
  DegradationOptions options;
  options.missed_probability = 0.2;
  options.bad_probability = 0.3;
  int missed = 0;
  int bad = 0;
  constexpr int kFrames = 2000;
  for (int frame = 0; frame < kFrames; ++frame) {
    const FrameDegradation kind = ChooseFrameDegradation(options, frame);
    missed += kind == FrameDegradation::kMissed;
    bad += kind == FrameDegradation::kBad;
  }
  EXPECT_NEAR(missed, 0.2 * kFrames, 5.0 * std::sqrt(kFrames * 0.2 * 0.8));
  EXPECT_NEAR(bad, 0.3 * kFrames, 5.0 * std::sqrt(kFrames * 0.3 * 0.7));
  // The choice depends on nothing but the seed, the frame and the probabilities.
  DegradationOptions noisy = options;
  noisy.noise_fraction = 0.3;
  noisy.occluders = 2;
  for (int frame = 0; frame < 100; ++frame) {
    EXPECT_EQ(ChooseFrameDegradation(options, frame), ChooseFrameDegradation(noisy, frame));
  }
}

TEST(Degradation, BadFramesAreStronglyDegraded) {
  const cv::Mat original = Silhouette();
  DegradationOptions options;
  options.bad_probability = 1.0;
  for (int frame = 0; frame < 30; ++frame) {
    FrameDegradation kind = FrameDegradation::kNone;
    const cv::Mat bad = Degraded(options, frame, &kind);
    EXPECT_EQ(kind, FrameDegradation::kBad);
    EXPECT_GT(Different(bad, original), Count(original) / 10) << "frame " << frame;
  }
}

TEST(Degradation, IsDeterministicPerSeedAndFrame) {
  DegradationOptions options;
  options.noise_fraction = 0.05;
  options.erode_px = 1;
  options.occluders = 2;
  options.clutter_blobs = 2;
  options.bad_probability = 0.5;
  const cv::Mat a = Degraded(options, 7);
  EXPECT_EQ(Different(a, Degraded(options, 7)), 0);
  EXPECT_GT(Different(a, Degraded(options, 8)), 100);
  DegradationOptions other = options;
  other.seed = 2;
  EXPECT_GT(Different(a, Degraded(other, 7)), 100);
}

TEST(Degradation, AnEmptyMaskStaysUsable) {
  DegradationOptions options;
  options.occluders = 3;
  options.clutter_blobs = 2;
  options.bad_probability = 1.0;
  cv::Mat mask(60, 80, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(DegradeMask(options, 0, &mask), FrameDegradation::kBad);
  EXPECT_GT(Count(mask), 0);  // only clutter
}

TEST(Degradation, InvalidOptionsAndMasksAreRefused) {
  std::string error;
  DegradationOptions options;
  options.noise_fraction = 1.5;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("noise"), std::string::npos);
  options = DegradationOptions();
  options.missed_probability = 0.6;
  options.bad_probability = 0.6;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("sum"), std::string::npos);
  options = DegradationOptions();
  options.erode_px = -1;
  EXPECT_FALSE(options.Check(&error));
  cv::Mat mask = Silhouette();
  EXPECT_THROW(DegradeMask(options, 0, &mask), Error);
  cv::Mat colour(10, 10, CV_8UC3);
  EXPECT_THROW(DegradeMask(DegradationOptions(), 0, &colour), Error);
}

TEST(Degradation, NamesRoundTrip) {
  for (FrameDegradation d :
       {FrameDegradation::kNone, FrameDegradation::kMissed, FrameDegradation::kBad}) {
    FrameDegradation parsed = FrameDegradation::kNone;
    EXPECT_TRUE(ParseFrameDegradation(FrameDegradationName(d), &parsed));
    EXPECT_EQ(parsed, d);
  }
  FrameDegradation parsed = FrameDegradation::kNone;
  EXPECT_FALSE(ParseFrameDegradation("occluded", &parsed));
}

// ----- imperfect masks of a colour threshold ----------------------------------------------------

// A 320 x 240 mask with a filled ellipse (semi-axes 60 x 40) in the middle: size 120 px.
cv::Mat LargeSilhouette() {
  cv::Mat mask(240, 320, CV_8UC1, cv::Scalar(0));
  cv::ellipse(mask, cv::Point(160, 110), cv::Size(60, 40), 15.0, 0.0, 360.0, cv::Scalar(255),
              cv::FILLED);
  return mask;
}

cv::Mat DegradedLarge(const DegradationOptions& options, int frame) {
  cv::Mat mask = LargeSilhouette();
  DegradeMask(options, frame, &mask);
  return mask;
}

// Number of 8-connected components of a mask.
int Components(const cv::Mat& mask) {
  cv::Mat labels;
  return cv::connectedComponents(mask, labels, 8) - 1;
}

// Distance of every pixel to the outline of `mask` (to the nearest pixel of the other kind).
cv::Mat DistanceToOutline(const cv::Mat& mask) {
  cv::Mat inside;
  cv::Mat outside;
  cv::distanceTransform(mask, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(mask == 0, outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return inside + outside;
}

cv::Point2d Centroid(const cv::Mat& mask) {
  const cv::Moments m = cv::moments(mask, true);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

TEST(ThresholdEffects, RaggedBoundaryMovesTheOutlineByAFewCorrelatedPixels) {
  const cv::Mat original = LargeSilhouette();
  const cv::Mat distance = DistanceToOutline(original);
  DegradationOptions options;
  options.ragged_px = 2.0;
  options.ragged_scale_px = 6.0;
  for (int frame = 0; frame < 5; ++frame) {
    const cv::Mat ragged = DegradedLarge(options, frame);
    const cv::Mat changed = ragged != original;
    // Only near the outline (4 standard deviations), in and out.
    double farthest = 0.0;
    cv::minMaxLoc(distance, nullptr, &farthest, nullptr, nullptr, changed);
    EXPECT_LE(farthest, 4.0 * options.ragged_px + 1.0) << "frame " << frame;
    EXPECT_GT(Extra(ragged, original), 80) << "frame " << frame;
    EXPECT_GT(Extra(original, ragged), 80) << "frame " << frame;
    // Spatially correlated: bumps of several pixels, not single flipped pixels.
    EXPECT_GT(Count(changed) / Components(changed), 8) << "frame " << frame;
    // Still one silhouette of about the same area.
    EXPECT_NEAR(Count(ragged), Count(original), 0.08 * Count(original)) << "frame " << frame;
  }
}

TEST(ThresholdEffects, HolesRemovePixelsInsideOnly) {
  const cv::Mat original = LargeSilhouette();
  DegradationOptions options;
  options.holes = 5;
  options.hole_radius_px = 4.0;
  for (int frame = 0; frame < 5; ++frame) {
    const cv::Mat holed = DegradedLarge(options, frame);
    EXPECT_EQ(Extra(holed, original), 0) << "frame " << frame;
    const cv::Mat removed = original & ~holed;
    EXPECT_GT(Count(removed), 5) << "frame " << frame;
    EXPECT_LE(Components(removed), 5) << "frame " << frame;
    EXPECT_LE(Count(removed), 5 * 3.15 * 5 * 5) << "frame " << frame;  // 5 discs of radius <= 5
    // The outline is untouched: the outer contour, filled, is the original silhouette.
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(holed.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    ASSERT_EQ(contours.size(), 1u) << "frame " << frame;
    cv::Mat filled(holed.size(), CV_8UC1, cv::Scalar(0));
    cv::drawContours(filled, contours, 0, cv::Scalar(255), cv::FILLED);
    EXPECT_EQ(Different(filled, original), 0) << "frame " << frame;
  }
}

TEST(ThresholdEffects, StickAndFingersAddBarsOutsideTouchingTheSilhouetteOnOneSide) {
  const cv::Mat original = LargeSilhouette();
  const cv::Point2d centre = Centroid(original);
  DegradationOptions stick;
  stick.stick = true;
  stick.stick_width_px = 5.0;
  stick.stick_length = 0.6;
  DegradationOptions fingers;
  fingers.fingers = 3;
  for (int frame = 0; frame < 6; ++frame) {
    for (const DegradationOptions& options : {stick, fingers}) {
      const cv::Mat held = DegradedLarge(options, frame);
      EXPECT_EQ(Extra(original, held), 0) << "frame " << frame;  // adds only
      const cv::Mat added = held & ~original;
      EXPECT_GT(Count(added), 100) << "frame " << frame;
      EXPECT_EQ(Components(held), 1) << "frame " << frame;  // attached
      // Pointing away from the silhouette, on the hand's side (down in the image, +-75 degrees).
      const cv::Point2d away = Centroid(added) - centre;
      EXPECT_GT(away.y, 0.25 * std::hypot(away.x, away.y)) << "frame " << frame;
      EXPECT_GT(std::hypot(away.x, away.y), 40.0) << "frame " << frame;
    }
    // The stick is thin and long: its added area is about width x length (more with the round
    // end and the wedge between the bar and a curved outline).
    const int stick_area = Extra(DegradedLarge(stick, frame), original);
    EXPECT_GT(stick_area, 0.8 * 5.0 * 0.6 * 120.0) << "frame " << frame;
    EXPECT_LT(stick_area, 1.6 * 5.0 * 0.6 * 120.0) << "frame " << frame;
    // Fingers stand apart outside the silhouette.
    const cv::Mat finger_parts = DegradedLarge(fingers, frame) & ~original;
    EXPECT_GE(Components(finger_parts), 2) << "frame " << frame;
  }
}

TEST(ThresholdEffects, ShadowAddsARegionAdjoiningOneSide) {
  const cv::Mat original = LargeSilhouette();
  DegradationOptions options;
  options.shadow = 0.1;  // 12 px
  cv::Point2d first_side;
  for (int frame = 0; frame < 6; ++frame) {
    const cv::Mat shadowed = DegradedLarge(options, frame);
    EXPECT_EQ(Extra(original, shadowed), 0) << "frame " << frame;
    EXPECT_EQ(Components(shadowed), 1) << "frame " << frame;
    const cv::Mat added = shadowed & ~original;
    // A crescent of about shift x extent across (12 px x ~80..120 px).
    EXPECT_GT(Count(added), 600) << "frame " << frame;
    EXPECT_LT(Count(added), 12 * 130) << "frame " << frame;
    // On one side, the same side in every frame (the light does not move).
    cv::Point2d side = Centroid(added) - Centroid(original);
    side /= std::hypot(side.x, side.y);
    if (frame == 0) first_side = side;
    EXPECT_GT(side.dot(first_side), std::cos(25.0 * 3.14159 / 180.0)) << "frame " << frame;
    EXPECT_GT(std::hypot(Centroid(added).x - Centroid(original).x,
                         Centroid(added).y - Centroid(original).y),
              25.0);
  }
}

TEST(ThresholdEffects, SpecksAreSmallFalsePositivesAroundTheObject) {
  const cv::Mat original = LargeSilhouette();
  DegradationOptions options;
  options.specks = 20;
  options.speck_radius_px = 2.0;
  const cv::Mat specked = DegradedLarge(options, 3);
  EXPECT_EQ(Extra(original, specked), 0);
  const cv::Mat added = specked & ~original;
  cv::Mat labels;
  cv::Mat stats;
  cv::Mat centroids;
  const int n = cv::connectedComponentsWithStats(added, labels, stats, centroids, 8) - 1;
  EXPECT_GE(n, 8);  // some land on the object or on each other
  EXPECT_LE(n, 20);
  for (int i = 1; i <= n; ++i) EXPECT_LE(stats.at<int>(i, cv::CC_STAT_AREA), 2 * 13);
  EXPECT_GT(Components(specked), 5);  // most stand apart from the silhouette
}

TEST(ThresholdEffects, AreDeterministicPerSeedAndFrame) {
  const DegradationOptions options = WithMaskQuality(DegradationOptions(), MaskQuality::kThreshold);
  const cv::Mat a = DegradedLarge(options, 4);
  EXPECT_EQ(Different(a, DegradedLarge(options, 4)), 0);
  EXPECT_GT(Different(a, DegradedLarge(options, 5)), 50);
  DegradationOptions other = options;
  other.seed = 9;
  EXPECT_GT(Different(a, DegradedLarge(other, 4)), 50);
  // One effect's draws do not depend on the others being on.
  DegradationOptions holes_only;
  holes_only.holes = 4;
  DegradationOptions with_specks = holes_only;
  with_specks.specks = 10;
  const cv::Mat original = LargeSilhouette();
  EXPECT_EQ(Different(original & ~DegradedLarge(holes_only, 2),
                      original & ~DegradedLarge(with_specks, 2)),
            0);
}

TEST(ThresholdEffects, PresetIsPerfectOrThreshold) {
  MaskQuality quality = MaskQuality::kPerfect;
  EXPECT_TRUE(ParseMaskQuality("threshold", &quality));
  EXPECT_EQ(quality, MaskQuality::kThreshold);
  EXPECT_STREQ(MaskQualityName(MaskQuality::kPerfect), "perfect");
  EXPECT_FALSE(ParseMaskQuality("good", &quality));
  DegradationOptions base;
  base.missed_probability = 0.1;
  base.seed = 5;
  const DegradationOptions perfect = WithMaskQuality(base, MaskQuality::kPerfect);
  EXPECT_EQ(Different(DegradedLarge(perfect, 0), DegradedLarge(base, 0)), 0);
  const DegradationOptions threshold = WithMaskQuality(base, MaskQuality::kThreshold);
  EXPECT_TRUE(threshold.Check());
  EXPECT_EQ(threshold.seed, 5u);
  EXPECT_EQ(threshold.missed_probability, 0.1);
  EXPECT_EQ(AppliedMaskEffects(threshold, 0) &
                (kMaskEffectRagged | kMaskEffectHoles | kMaskEffectFingers | kMaskEffectShadow |
                 kMaskEffectSpecks),
            kMaskEffectRagged | kMaskEffectHoles | kMaskEffectFingers | kMaskEffectShadow |
                kMaskEffectSpecks);
}

TEST(ThresholdEffects, LabelsRecordKindAndEffectsAndReadOldValues) {
  EXPECT_EQ(DegradationLabel(FrameDegradation::kNone, 0), "none");
  EXPECT_EQ(DegradationLabel(FrameDegradation::kBad, 0), "bad");
  EXPECT_EQ(DegradationLabel(FrameDegradation::kMissed, kMaskEffectHoles), "missed");
  EXPECT_EQ(DegradationLabel(FrameDegradation::kNone, kMaskEffectHoles | kMaskEffectRagged),
            "ragged+holes");
  EXPECT_EQ(DegradationLabel(FrameDegradation::kBad, kMaskEffectShadow | kMaskEffectSpecks),
            "bad+shadow+specks");
  // Every combination of kind and effects reads back.
  for (FrameDegradation kind : {FrameDegradation::kNone, FrameDegradation::kBad}) {
    for (uint32_t effects = 0; effects < (1u << AllMaskEffects().size()); effects += 37) {
      FrameDegradation read_kind = FrameDegradation::kMissed;
      uint32_t read_effects = 12345;
      ASSERT_TRUE(ParseDegradationLabel(DegradationLabel(kind, effects), &read_kind, &read_effects))
          << DegradationLabel(kind, effects);
      EXPECT_EQ(read_kind, kind);
      EXPECT_EQ(read_effects, effects);
    }
  }
  FrameDegradation kind = FrameDegradation::kNone;
  uint32_t effects = 1;
  for (const char* old : {"none", "missed", "bad"}) {
    ASSERT_TRUE(ParseDegradationLabel(old, &kind, &effects)) << old;
    EXPECT_STREQ(FrameDegradationName(kind), old);
    EXPECT_EQ(effects, 0u);
  }
  for (const char* wrong :
       {"", "blurred", "ragged+", "holes+holes", "missed+holes", "bad+none", "ragged++holes"}) {
    EXPECT_FALSE(ParseDegradationLabel(wrong, &kind, &effects)) << wrong;
  }
}

TEST(ThresholdEffects, AppliedEffectsAreThoseSwitchedOnExceptOnMissedFrames) {
  DegradationOptions options;
  options.erode_px = 1;
  options.stick = true;
  options.specks = 3;
  options.missed_probability = 0.5;
  int missed = 0;
  for (int frame = 0; frame < 40; ++frame) {
    const uint32_t effects = AppliedMaskEffects(options, frame);
    if (ChooseFrameDegradation(options, frame) == FrameDegradation::kMissed) {
      EXPECT_EQ(effects, 0u);
      ++missed;
    } else {
      EXPECT_EQ(effects, kMaskEffectErode | kMaskEffectStick | kMaskEffectSpecks);
    }
  }
  EXPECT_GT(missed, 5);
}

TEST(ThresholdEffects, InvalidValuesAreRefusedWithTheirName) {
  DegradationOptions options;
  options.ragged_px = 30.0;
  ExpectRefused(options, "ragged");
  options = DegradationOptions();
  options.holes = -1;
  ExpectRefused(options, "holes");
  options = DegradationOptions();
  options.fingers = 6;
  ExpectRefused(options, "fingers");
  options = DegradationOptions();
  options.shadow = 1.5;
  ExpectRefused(options, "shadow");
  options = DegradationOptions();
  options.specks = 5000;
  ExpectRefused(options, "specks");
  options = DegradationOptions();
  options.stick_width_px = 0.0;
  ExpectRefused(options, "stick");
}

}  // namespace
}  // namespace silpose

// ----- an occluder passing in front of the object
// -------------------------------------------------

namespace silpose {
namespace {

TEST(PassingOccluder, PassesAreRunsOfPassFramesCoveringTheRequestedShare) {
  DegradationOptions options;
  options.passing_share = 0.3;
  options.pass_frames = 20;
  EXPECT_TRUE(options.Any());
  const int frames = 67 * 30;  // windows of round(20 / 0.3) = 67 frames
  int covered = 0, runs = 0;
  double previous = -1.0;
  for (int frame = 0; frame < frames; ++frame) {
    const double phase = PassPhase(options, frame);
    const uint32_t effects = AppliedMaskEffects(options, frame);
    EXPECT_EQ((effects & kMaskEffectPassing) != 0, phase >= 0.0) << frame;
    if (phase >= 0.0) {
      ++covered;
      EXPECT_LT(phase, 1.0);
      if (previous < 0.0) {
        ++runs;
        EXPECT_DOUBLE_EQ(phase, 0.5 / 20.0) << "a pass starts at its beginning, frame " << frame;
      } else {
        EXPECT_NEAR(phase - previous, 1.0 / 20.0, 1e-12) << frame;
      }
    } else if (previous >= 0.0) {
      EXPECT_DOUBLE_EQ(previous, 19.5 / 20.0) << "a pass ends at its end, frame " << frame;
    }
    previous = phase;
  }
  EXPECT_EQ(runs, 30);
  EXPECT_EQ(covered, 30 * 20);
  // The passes do not all sit at the same place in their windows.
  std::set<int> starts;
  for (int frame = 1; frame < frames; ++frame) {
    if (PassPhase(options, frame) >= 0.0 && PassPhase(options, frame - 1) < 0.0) {
      starts.insert(frame % 67);
    }
  }
  EXPECT_GT(starts.size(), 10u);
  options.passing_share = 0.0;
  EXPECT_LT(PassPhase(options, 5), 0.0);
  EXPECT_FALSE(options.Any());
}

TEST(PassingOccluder, EntersCrossesAndLeavesRemovingObjectPixelsOnly) {
  DegradationOptions options;
  options.passing_share = 0.5;
  options.pass_frames = 16;
  options.pass_size = 0.3;
  const cv::Mat original = LargeSilhouette();
  int passes_seen = 0;
  for (int first = 1; first < 400 && passes_seen < 5; ++first) {
    if (!(PassPhase(options, first) >= 0.0 && PassPhase(options, first - 1) < 0.0)) continue;
    ++passes_seen;
    std::vector<int> removed;
    std::vector<cv::Point2d> where;
    for (int j = 0; j < options.pass_frames; ++j) {
      const cv::Mat mask = DegradedLarge(options, first + j);
      EXPECT_EQ(Extra(mask, original), 0) << "frame " << first + j;
      cv::Mat gone;
      cv::bitwise_and(original, ~mask, gone);
      removed.push_back(cv::countNonZero(gone));
      where.push_back(removed.back() > 0 ? Centroid(gone) : cv::Point2d(0, 0));
    }
    // Enters from outside and leaves: little is covered at the ends, much in the middle.
    const int middle = *std::max_element(removed.begin() + 6, removed.begin() + 10);
    EXPECT_GT(middle, 200) << "pass at frame " << first;
    EXPECT_LT(removed.front(), middle / 3) << "pass at frame " << first;
    EXPECT_LT(removed.back(), middle / 3) << "pass at frame " << first;
    // It moves one way: the covered part's centre advances along the pass.
    const cv::Point2d direction = where[11] - where[4];
    ASSERT_GT(cv::norm(direction), 10.0) << "pass at frame " << first;
    EXPECT_GT((where[8] - where[4]).dot(direction), 0.0);
    EXPECT_GT((where[11] - where[8]).dot(direction), 0.0);
    // Outside the pass nothing changes.
    EXPECT_EQ(Different(DegradedLarge(options, first - 1), original), 0);
    first += options.pass_frames;
  }
  EXPECT_EQ(passes_seen, 5);
}

TEST(PassingOccluder, IsRecordedInTheLabelAndChecked) {
  DegradationOptions options;
  options.passing_share = 0.4;
  int frame = 0;
  while (PassPhase(options, frame) < 0.0) ++frame;
  const std::string label =
      DegradationLabel(FrameDegradation::kNone, AppliedMaskEffects(options, frame));
  EXPECT_EQ(label, "passing");
  FrameDegradation kind;
  uint32_t effects = 0;
  ASSERT_TRUE(ParseDegradationLabel("occluders+passing", &kind, &effects));
  EXPECT_EQ(effects, kMaskEffectOccluders | kMaskEffectPassing);
  DegradationOptions bad;
  bad.passing_share = 1.5;
  ExpectRefused(bad, "passing occluder");
  bad = DegradationOptions();
  bad.pass_frames = 1;
  ExpectRefused(bad, "frames per pass");
  bad = DegradationOptions();
  bad.pass_size = 0.0;
  ExpectRefused(bad, "passing occluder's size");
}

}  // namespace
}  // namespace silpose
