#include "silpose/synth/degradation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

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

}  // namespace
}  // namespace silpose
