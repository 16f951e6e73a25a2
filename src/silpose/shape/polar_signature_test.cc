#include "silpose/shape/polar_signature.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "silpose/geometry/view_frame.h"
#include "silpose/match/circular_correlator.h"
#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

// A concave, asymmetric silhouette whose outline is partly hidden from its centre: a disc (the
// body) with a bump, and a thick arc (a hook) around it joined to the body by a bar, so rays
// leaving the body first cross the body's edge and the arc behind it is hidden (paper Fig. 3 c, d).
// `rotation_deg` turns the content as a positive camera roll would (image angle phi -> phi - r).
cv::Mat HookShape(double scale, double rotation_deg, cv::Size size) {
  cv::Mat mask = cv::Mat::zeros(size, CV_8UC1);
  const cv::Point2d c(0.5 * (size.width - 1), 0.5 * (size.height - 1));
  constexpr int kShift = 8;  // fixed-point vertices: the polygon scales exactly
  auto at = [&](double radius, double angle_deg, const cv::Point2d& origin) {
    const double a = (angle_deg - rotation_deg) * kPi / 180.0;
    return cv::Point(
        static_cast<int>(std::lround((origin.x + scale * radius * std::cos(a)) * 256)),
        static_cast<int>(std::lround((origin.y + scale * radius * std::sin(a)) * 256)));
  };
  auto disc = [&](const cv::Point2d& centre, double radius) {
    std::vector<cv::Point> polygon;
    for (int i = 0; i < 360; ++i) polygon.push_back(at(radius, i, centre));
    cv::fillConvexPoly(mask, polygon, cv::Scalar(255), cv::LINE_8, kShift);
  };
  auto point = [&](double radius, double angle_deg) {
    const double a = (angle_deg - rotation_deg) * kPi / 180.0;
    return cv::Point2d(c.x + scale * radius * std::cos(a), c.y + scale * radius * std::sin(a));
  };
  disc(c, 0.55);                  // body
  disc(point(0.55, 150.0), 0.2);  // bump
  std::vector<cv::Point> band;    // the hook: a thick arc around the body
  for (double angle = -100.0; angle <= 60.0; angle += 1.0) band.push_back(at(1.03, angle, c));
  for (double angle = 60.0; angle >= -100.0; angle -= 1.0) band.push_back(at(0.87, angle, c));
  cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{band}, cv::Scalar(255), cv::LINE_8,
               kShift);
  // The bar joining hook and body.
  const cv::Point2d inner = point(0.3, -100.0);
  const cv::Point2d outer = point(0.95, -100.0);
  const cv::Point2d across = point(0.08, -10.0) - c;
  std::vector<cv::Point> bar;
  for (const cv::Point2d& p : {inner + across, outer + across, outer - across, inner - across}) {
    bar.emplace_back(static_cast<int>(std::lround(p.x * 256)),
                     static_cast<int>(std::lround(p.y * 256)));
  }
  cv::fillConvexPoly(mask, bar, cv::Scalar(255), cv::LINE_8, kShift);
  return mask;
}

// The naive polar signature the paper warns about (its Fig. 3 a, b): every contour point in polar
// form, sorted by angle and resampled to M bins by linear interpolation (no star-convex selection).
std::vector<float> NaivePolarSignature(const cv::Mat& mask, int length) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const auto& contour = *std::max_element(
      contours.begin(), contours.end(),
      [](const auto& a, const auto& b) { return cv::contourArea(a) < cv::contourArea(b); });
  const cv::Moments m = cv::moments(contour);
  const double cx = m.m10 / m.m00;
  const double cy = m.m01 / m.m00;
  std::vector<std::pair<double, double>> polar;
  for (const auto& p : contour) {
    double angle = std::atan2(p.y - cy, p.x - cx);
    if (angle < 0) angle += 2 * kPi;
    polar.emplace_back(angle, std::hypot(p.x - cx, p.y - cy));
  }
  std::sort(polar.begin(), polar.end());
  std::vector<float> radii(static_cast<size_t>(length));
  size_t j = 0;
  for (int k = 0; k < length; ++k) {
    const double angle = 2 * kPi * k / length;
    while (j + 1 < polar.size() && polar[j + 1].first < angle) ++j;
    const auto& a = polar[j];
    const auto& b = polar[(j + 1) % polar.size()];
    double span = b.first - a.first;
    if (span <= 0) span += 2 * kPi;
    double offset = angle - a.first;
    if (offset < 0) offset += 2 * kPi;
    const double w = std::clamp(offset / span, 0.0, 1.0);
    radii[static_cast<size_t>(k)] = static_cast<float>((1 - w) * a.second + w * b.second);
  }
  double mean = 0;
  for (float r : radii) mean += r;
  mean /= length;
  for (float& r : radii) r = static_cast<float>(r / mean);
  return radii;
}

// Number of bins where `query`, aligned to `reference` by the correlation peak, differs from it by
// more than 0.1 (relative radius): the error peaks of the paper's difference plots, Fig. 3 e, f.
int AlignedErrorPeakBins(std::span<const float> reference, std::span<const float> query,
                         double* roll_deg) {
  const int m = static_cast<int>(reference.size());
  CircularCorrelator correlator(m);
  const CorrelationPeak peak =
      correlator.Peak(correlator.Transform(query), correlator.Transform(reference));
  *roll_deg = peak.RollDeg(m);
  const int shift = static_cast<int>(std::lround(peak.shift_bins)) % m;
  int bins = 0;
  for (int x = 0; x < m; ++x) {
    bins += std::abs(static_cast<double>(query[static_cast<size_t>(x)]) -
                     reference[static_cast<size_t>((x + shift) % m)]) > 0.1;
  }
  return bins;
}

TEST(PolarSignature, DiscHasConstantRadiiAndIsReportedNearlyCircular) {
  cv::Mat mask = cv::Mat::zeros(300, 300, CV_8UC1);
  cv::circle(mask, {150, 140}, 100, cv::Scalar(255), cv::FILLED);
  const SignatureResult result = ExtractSignature(mask);
  ASSERT_TRUE(result.ok()) << result.Describe();
  const PolarSignature& s = result.signature;
  EXPECT_NEAR(s.centroid_px.x(), 150.0, 0.05);
  EXPECT_NEAR(s.centroid_px.y(), 140.0, 0.05);
  EXPECT_NEAR(s.mean_radius_px, 100.5, 0.6);  // pixel outline of a radius-100 disc
  EXPECT_NEAR(s.area_px, kPi * 100 * 100, 0.02 * kPi * 100 * 100);
  ASSERT_EQ(s.radii.size(), 1000u);
  for (float r : s.radii) EXPECT_NEAR(r, 1.0, 0.01);
  EXPECT_TRUE(result.flags & kSilhouetteNearlyCircular);
  EXPECT_EQ(result.flags & ~kSilhouetteNearlyCircular, 0u) << DescribeSilhouetteFlags(result.flags);
}

TEST(PolarSignature, SquareMatchesTheAnalyticStarConvexRadii) {
  // Square polygon of half-size a centred at the origin: r(phi) = a / max(|cos|, |sin|).
  const double a = 50.0;
  const std::vector<Eigen::Vector2d> square = {{-a, -a}, {a, -a}, {a, a}, {-a, a}};
  int missed = -1;
  const std::vector<float> radii = StarConvexRadii(square, {0, 0}, 360, &missed);
  EXPECT_EQ(missed, 0);
  for (int k = 0; k < 360; ++k) {
    const double phi = 2 * kPi * k / 360;
    const double expected = a / std::max(std::abs(std::cos(phi)), std::abs(std::sin(phi)));
    EXPECT_NEAR(radii[static_cast<size_t>(k)], expected, 1e-3 * expected) << "bin " << k;
  }
}

TEST(PolarSignature, RadiiStopAtTheFirstCrossingOfAConcaveOutline) {
  const cv::Mat mask = HookShape(100.0, 0.0, {260, 260});
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  ASSERT_EQ(contours.size(), 1u);
  std::vector<Eigen::Vector2d> polygon;
  for (const auto& p : contours[0]) polygon.emplace_back(p.x - 129.5, p.y - 129.5);
  const std::vector<float> radii = StarConvexRadii(polygon, {0, 0}, 1000);
  std::vector<cv::Point2f> contour;
  for (const auto& p : polygon)
    contour.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  int bins_hiding_outline = 0;
  for (int k = 0; k < 1000; ++k) {
    const double phi = 2 * kPi * k / 1000;
    const double r = radii[static_cast<size_t>(k)];
    ASSERT_GT(r, 0.0);
    // Everything between the centre and the crossing is inside the shape (star-convex part) ...
    for (double f = 0.02; f < 0.98; f += 0.02) {
      const cv::Point2f p(static_cast<float>(f * r * std::cos(phi)),
                          static_cast<float>(f * r * std::sin(phi)));
      ASSERT_GE(cv::pointPolygonTest(contour, p, false), 0) << "bin " << k << " fraction " << f;
    }
    // ... and further out along some rays the outline comes back: those parts are hidden.
    for (double f = 1.05; f < 2.5; f += 0.05) {
      const cv::Point2f p(static_cast<float>(f * r * std::cos(phi)),
                          static_cast<float>(f * r * std::sin(phi)));
      if (cv::pointPolygonTest(contour, p, false) > 0) {
        ++bins_hiding_outline;
        break;
      }
    }
  }
  EXPECT_GT(bins_hiding_outline, 5) << "the test shape should have a hidden concavity";
}

// Paper Fig. 3: a concave shape and its rotated copy. With the star-convex selection the aligned
// signatures differ only by pixel noise; the naive polar resampling shows large error peaks.
TEST(PolarSignature, PaperFigure3RotatedConcaveShapeAlignsWithoutErrorPeaks) {
  const cv::Size size(400, 400);
  const cv::Mat original = HookShape(150.0, 0.0, size);
  for (double rotation : {37.0, 100.0, -145.0}) {
    const cv::Mat rotated = HookShape(150.0, rotation, size);
    const SignatureResult a = ExtractSignature(original);
    const SignatureResult b = ExtractSignature(rotated);
    ASSERT_TRUE(a.ok() && b.ok());
    double roll = 0.0;
    const int star_peaks = AlignedErrorPeakBins(a.signature.radii, b.signature.radii, &roll);
    EXPECT_NEAR(WrapDegrees(roll - rotation), 0.0, 0.72) << "rotation " << rotation;
    double naive_roll = 0.0;
    const int naive_peaks = AlignedErrorPeakBins(NaivePolarSignature(original, 1000),
                                                 NaivePolarSignature(rotated, 1000), &naive_roll);
    std::cout << "rotation " << rotation << ": bins off by > 0.1: star-convex " << star_peaks
              << ", naive " << naive_peaks << "\n";
    // Only bins at jumps of the radius (rays tangent to the outline) may differ, not whole regions.
    EXPECT_LE(star_peaks, 5) << "rotation " << rotation;
    EXPECT_GE(naive_peaks, 10 * std::max(star_peaks, 3)) << "rotation " << rotation;
  }
}

TEST(PolarSignature, RollingTheSilhouetteShiftsTheSignature) {
  const cv::Size size(400, 400);
  const SignatureResult a = ExtractSignature(HookShape(150.0, 0.0, size));
  ASSERT_TRUE(a.ok());
  CircularCorrelator correlator(1000);
  const SignatureSpectrum reference = correlator.Transform(a.signature.radii);
  for (double rotation : {0.0, 0.36, 10.0, 90.0, 179.0, -60.0}) {
    const SignatureResult b = ExtractSignature(HookShape(150.0, rotation, size));
    ASSERT_TRUE(b.ok());
    const CorrelationPeak peak =
        correlator.Peak(correlator.Transform(b.signature.radii), reference);
    EXPECT_GT(peak.score, 0.99);
    EXPECT_NEAR(WrapDegrees(peak.RollDeg(1000) - rotation), 0.0, 0.72) << "2 bins";
  }
}

TEST(PolarSignature, ScalingTheSilhouetteKeepsTheSignature) {
  const SignatureResult large = ExtractSignature(HookShape(300.0, 0.0, {750, 750}));
  const SignatureResult small = ExtractSignature(HookShape(100.0, 0.0, {250, 250}));
  ASSERT_TRUE(large.ok() && small.ok());
  EXPECT_NEAR(large.signature.mean_radius_px / small.signature.mean_radius_px, 3.0, 0.03);
  CircularCorrelator correlator(1000);
  const CorrelationPeak peak = correlator.Peak(correlator.Transform(small.signature.radii),
                                               correlator.Transform(large.signature.radii));
  EXPECT_GT(peak.score, 0.99);
  EXPECT_NEAR(WrapDegrees(peak.RollDeg(1000)), 0.0, 0.72);
}

TEST(PolarSignature, HolesAreIgnoredAndReported) {
  cv::Mat solid = cv::Mat::zeros(200, 200, CV_8UC1);
  cv::ellipse(solid, {100, 100}, {80, 40}, 20, 0, 360, cv::Scalar(255), cv::FILLED);
  cv::Mat holed = solid.clone();
  cv::circle(holed, {100, 100}, 15, cv::Scalar(0), cv::FILLED);
  const SignatureResult a = ExtractSignature(solid);
  const SignatureResult b = ExtractSignature(holed);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_FALSE(a.flags & kSilhouetteHasHoles);
  EXPECT_TRUE(b.flags & kSilhouetteHasHoles);
  EXPECT_NEAR(b.hole_area_px, kPi * 15 * 15, 0.1 * kPi * 15 * 15);
  EXPECT_EQ(a.signature.radii, b.signature.radii);
}

TEST(PolarSignature, SeveralComponentsUseTheLargestOrTheNearest) {
  cv::Mat mask = cv::Mat::zeros(200, 300, CV_8UC1);
  cv::rectangle(mask, cv::Rect(20, 20, 100, 60), cv::Scalar(255), cv::FILLED);  // large
  cv::circle(mask, {230, 140}, 30, cv::Scalar(255), cv::FILLED);                // smaller
  SignatureResult largest = ExtractSignature(mask);
  ASSERT_TRUE(largest.ok());
  EXPECT_TRUE(largest.flags & kSilhouetteSeveralComponents);
  EXPECT_EQ(largest.num_components, 2);
  EXPECT_NEAR(largest.signature.centroid_px.x(), 69.5, 1.0);
  SignatureOptions options;
  options.component = ComponentChoice::kNearestTo;
  options.nearest_to_px = {250, 150};
  const SignatureResult nearest = ExtractSignature(mask, options);
  ASSERT_TRUE(nearest.ok());
  EXPECT_NEAR(nearest.signature.centroid_px.x(), 230.0, 1.0);
  EXPECT_NEAR(nearest.signature.centroid_px.y(), 140.0, 1.0);
}

TEST(PolarSignature, ALongThinLineDoesNotHideASmallObject) {
  cv::Mat mask = cv::Mat::zeros(120, 400, CV_8UC1);
  cv::circle(mask, {40, 60}, 9, cv::Scalar(255), cv::FILLED);  // ~250 px, describable
  cv::line(mask, {60, 100}, {390, 100}, cv::Scalar(255));      // 331 px, encloses nothing
  const SignatureResult result = ExtractSignature(mask);
  ASSERT_TRUE(result.ok()) << result.Describe();
  EXPECT_NEAR(result.signature.centroid_px.x(), 40.0, 0.5);
  EXPECT_TRUE(result.flags & kSilhouetteSeveralComponents);
}

TEST(PolarSignature, CentroidOutsideTheShapeIsReported) {
  cv::Mat mask = cv::Mat::zeros(300, 300, CV_8UC1);
  cv::ellipse(mask, {150, 150}, {100, 100}, 0, 40, 320, cv::Scalar(255), 25);  // a thick "C"
  const SignatureResult result = ExtractSignature(mask);
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result.flags & kSilhouetteCentroidOutside);
  EXPECT_GT(result.signature.missed_directions, 0);
}

TEST(PolarSignature, TouchingTheBorderIsReported) {
  cv::Mat mask = cv::Mat::zeros(100, 100, CV_8UC1);
  cv::rectangle(mask, cv::Rect(0, 30, 50, 40), cv::Scalar(255), cv::FILLED);
  const SignatureResult result = ExtractSignature(mask);
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result.flags & kSilhouetteTouchesBorder);
}

TEST(PolarSignature, EmptyAndTooSmallSilhouettesAreStatusesNotErrors) {
  cv::Mat mask = cv::Mat::zeros(100, 100, CV_8UC1);
  EXPECT_EQ(ExtractSignature(mask).status, SignatureStatus::kEmpty);
  cv::rectangle(mask, cv::Rect(10, 10, 5, 5), cv::Scalar(255), cv::FILLED);
  EXPECT_EQ(ExtractSignature(mask).status, SignatureStatus::kTooSmall);
  mask.at<uint8_t>(80, 80) = 255;  // a single pixel
  EXPECT_EQ(ExtractSignature(mask).status, SignatureStatus::kTooSmall);
  cv::line(mask, {20, 50}, {90, 50}, cv::Scalar(255));  // a one-pixel line: no area
  EXPECT_EQ(ExtractSignature(mask).status, SignatureStatus::kTooSmall);
}

TEST(PolarSignature, BadInputThrowsWithAClearMessage) {
  EXPECT_THROW(ExtractSignature(cv::Mat()), Error);
  EXPECT_THROW(ExtractSignature(cv::Mat::zeros(10, 10, CV_8UC3)), Error);
  EXPECT_THROW(ExtractSignature(cv::Mat::zeros(10, 10, CV_32FC1)), Error);
  SignatureOptions options;
  options.length = 999;
  try {
    ExtractSignature(cv::Mat::zeros(10, 10, CV_8UC1), options);
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("999"), std::string::npos);
  }
}

TEST(PolarSignature, NonBinaryMasksCountEveryNonZeroPixel) {
  cv::Mat a = cv::Mat::zeros(200, 200, CV_8UC1);
  cv::ellipse(a, {100, 100}, {70, 30}, 10, 0, 360, cv::Scalar(255), cv::FILLED);
  cv::Mat b = a / 255;  // values 0/1
  EXPECT_EQ(ExtractSignature(a).signature.radii, ExtractSignature(b).signature.radii);
}

// NonZeroBoundingBox against OpenCV on random masks and layouts.
void ExpectBoundingBoxesAreOpenCVs() {
  cv::RNG rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    const int width = 1 + rng.uniform(0, trial % 2 == 0 ? 70 : 150);
    const int height = 1 + rng.uniform(0, 40);
    cv::Mat canvas = cv::Mat::zeros(height + 6, width + 9, CV_8UC1);
    cv::Mat mask = canvas(cv::Rect(4, 3, width, height));
    const int pixels = trial % 10 == 0 ? 0 : rng.uniform(1, 6);
    for (int i = 0; i < pixels; ++i) {
      mask.at<uint8_t>(rng.uniform(0, height), rng.uniform(0, width)) =
          static_cast<uint8_t>(rng.uniform(1, 256));
    }
    // Pixels around the view must not count.
    canvas.row(0).setTo(255);
    canvas.col(canvas.cols - 1).setTo(255);
    std::vector<cv::Point> points;
    cv::findNonZero(mask, points);
    const cv::Rect expected = points.empty() ? cv::Rect() : cv::boundingRect(points);
    EXPECT_EQ(NonZeroBoundingBox(mask), expected)
        << width << " x " << height << ", trial " << trial;
  }
}

TEST(PolarSignature, NonZeroBoundingBoxIsOpenCVsOnEveryLayout) {
  // Widths that are and are not multiples of the 32-byte blocks scanned at once, objects touching
  // every edge, single pixels, views into a larger image (rows not contiguous); with the baseline
  // build of the scan and, where the processor has it, the AVX2 build (util/cpu_features.h).
  const bool had_avx2 = Avx2Enabled();
  for (const bool avx2 : {false, true}) {
    if (SetAvx2Enabled(avx2) != avx2) continue;
    SCOPED_TRACE(avx2 ? "AVX2" : "baseline");
    ExpectBoundingBoxesAreOpenCVs();
  }
  SetAvx2Enabled(had_avx2);
}

TEST(PolarSignature, TheAvx2AndBaselineBuildsDescribeAMaskAlike) {
  // The pixel sums and the box scan have an AVX2 build; the signature, area and centre must be
  // the baseline's bit for bit, on masks of widths around the vector lengths.
  const bool had_avx2 = Avx2Enabled();
  if (!SetAvx2Enabled(true)) GTEST_SKIP() << "this processor has no AVX2";
  for (const int width : {97, 128, 131, 640}) {
    cv::Mat mask = cv::Mat::zeros(120, width, CV_8UC1);
    cv::ellipse(mask, {width / 2, 60}, {width / 3, 40}, 17, 0, 360, cv::Scalar(255), cv::FILLED);
    cv::rectangle(mask, {width / 2, 10}, {width / 2 + 4, 60}, cv::Scalar(1), cv::FILLED);
    SetAvx2Enabled(true);
    const SignatureResult vector = ExtractSignature(mask);
    SetAvx2Enabled(false);
    const SignatureResult baseline = ExtractSignature(mask);
    ASSERT_TRUE(baseline.ok()) << baseline.Describe();
    EXPECT_EQ(vector.signature.radii, baseline.signature.radii) << "width " << width;
    EXPECT_EQ(vector.signature.area_px, baseline.signature.area_px) << "width " << width;
    EXPECT_EQ(vector.signature.centroid_px, baseline.signature.centroid_px) << "width " << width;
    Eigen::Vector2d vector_centroid;
    Eigen::Vector2d baseline_centroid;
    SetAvx2Enabled(true);
    const double vector_area = PixelAreaCentroid(mask, &vector_centroid);
    SetAvx2Enabled(false);
    EXPECT_EQ(vector_area, PixelAreaCentroid(mask, &baseline_centroid)) << "width " << width;
    EXPECT_EQ(vector_centroid, baseline_centroid) << "width " << width;
  }
  SetAvx2Enabled(had_avx2);
}

TEST(PolarSignature, DescriptionDoesNotDependOnWhereTheMaskLiesInTheImage) {
  // The same silhouette in a small image, moved within a large one, and in a view of a larger
  // image: the same radii, and the centre moved by the offset.
  const cv::Mat small = HookShape(90.0, 25.0, {240, 220});
  const SignatureResult reference = ExtractSignature(small);
  ASSERT_TRUE(reference.ok()) << reference.Describe();
  cv::Mat large = cv::Mat::zeros(600, 800, CV_8UC1);
  const cv::Point offset(333, 141);
  small.copyTo(large(cv::Rect(offset, small.size())));
  const SignatureResult moved = ExtractSignature(large);
  ASSERT_TRUE(moved.ok());
  EXPECT_EQ(moved.signature.radii, reference.signature.radii);
  EXPECT_EQ(moved.signature.area_px, reference.signature.area_px);
  EXPECT_NEAR(moved.signature.centroid_px.x(), reference.signature.centroid_px.x() + offset.x,
              1e-9);
  EXPECT_NEAR(moved.signature.centroid_px.y(), reference.signature.centroid_px.y() + offset.y,
              1e-9);
  // A view whose rows are not contiguous, with object pixels just outside it.
  cv::Mat padded = cv::Mat::zeros(small.rows + 20, small.cols + 20, CV_8UC1);
  padded.setTo(255);
  small.copyTo(padded(cv::Rect(10, 10, small.cols, small.rows)));
  const SignatureResult viewed = ExtractSignature(padded(cv::Rect(10, 10, small.cols, small.rows)));
  ASSERT_TRUE(viewed.ok());
  EXPECT_EQ(viewed.signature.radii, reference.signature.radii);
  EXPECT_EQ(viewed.signature.centroid_px, reference.signature.centroid_px);
}

TEST(PolarSignature, AreaAndCentreAreThePixelMoments) {
  // One component without holes: the description's area and centre are OpenCV's moments of the
  // mask's pixels.
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8UC1);
  cv::ellipse(mask, {401, 187}, {120, 57}, 33, 0, 360, cv::Scalar(255), cv::FILLED);
  cv::rectangle(mask, cv::Rect(380, 150, 150, 20), cv::Scalar(255), cv::FILLED);
  const cv::Moments moments = cv::moments(mask, /*binaryImage=*/true);
  const SignatureResult result = ExtractSignature(mask);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.signature.area_px, moments.m00);
  EXPECT_NEAR(result.signature.centroid_px.x(), moments.m10 / moments.m00, 1e-9);
  EXPECT_NEAR(result.signature.centroid_px.y(), moments.m01 / moments.m00, 1e-9);
}

TEST(PolarSignature, AreaAndCentreAreThoseOfTheFilledOutline) {
  // The area and centre are those of the chosen component with its holes filled. A mask with a
  // single component and no hole is summed as it is (no filled copy is drawn): on random masks of
  // thin spurs and diagonal steps, at the borders too, both ways must give the pixels the filled
  // outline covers.
  cv::RNG rng(29);
  int single = 0;
  int several = 0;
  for (int trial = 0; trial < 600; ++trial) {
    cv::Mat mask(rng.uniform(20, 90), rng.uniform(20, 90), CV_8UC1, cv::Scalar(0));
    const int kind = trial % 3;
    auto random_point = [&] {
      return cv::Point(rng.uniform(0, mask.cols), rng.uniform(0, mask.rows));
    };
    if (kind == 0) {  // a blob with spurs of one to three pixels' width, diagonal steps included
      const cv::Point centre = random_point();
      cv::ellipse(mask, centre, {rng.uniform(4, 25), rng.uniform(4, 25)}, rng.uniform(0, 180), 0,
                  360, cv::Scalar(255), cv::FILLED);
      for (int i = 0; i < 5; ++i) {
        cv::line(mask, centre, random_point(), cv::Scalar(255), rng.uniform(1, 4));
      }
    } else if (kind == 1) {  // a path of thin segments, which may close loops (holes)
      cv::Point from = random_point();
      for (int i = 0; i < 8; ++i) {
        const cv::Point to = random_point();
        cv::line(mask, from, to, cv::Scalar(255), rng.uniform(1, 4));
        from = to;
      }
    } else {  // noise: many components with holes
      for (auto it = mask.begin<uint8_t>(); it != mask.end<uint8_t>(); ++it) {
        *it = rng.uniform(0, 100) < 60 ? 255 : 0;
      }
    }
    const SignatureResult result = ExtractSignature(mask);
    if (!result.ok()) continue;
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    cv::findContours(mask.clone(), contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
    (contours.size() == 1 ? single : several) += 1;
    // The chosen component's contour is the outline the result reports.
    int chosen = -1;
    for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
      const auto& contour = contours[static_cast<size_t>(i)];
      if (contour.size() != result.outline_px.size()) continue;
      if (std::equal(contour.begin(), contour.end(), result.outline_px.begin(),
                     [](const cv::Point& p, const Eigen::Vector2d& q) {
                       return p.x == q.x() && p.y == q.y();
                     })) {
        chosen = i;
      }
    }
    ASSERT_GE(chosen, 0) << "trial " << trial;
    cv::Mat filled(mask.size(), CV_8UC1, cv::Scalar(0));
    cv::drawContours(filled, contours, chosen, cv::Scalar(255), cv::FILLED, cv::LINE_8);
    const cv::Moments moments = cv::moments(filled, /*binaryImage=*/true);
    EXPECT_EQ(result.signature.area_px, moments.m00) << "trial " << trial;
    EXPECT_NEAR(result.signature.centroid_px.x(), moments.m10 / moments.m00, 1e-9)
        << "trial " << trial;
    EXPECT_NEAR(result.signature.centroid_px.y(), moments.m01 / moments.m00, 1e-9)
        << "trial " << trial;
  }
  // Both ways were taken often.
  EXPECT_GE(single, 100);
  EXPECT_GE(several, 100);
  std::cout << single << " masks of one component, " << several << " of several or with holes\n";
}

TEST(PolarSignature, PixelAreaCentroidIsOpenCVsMomentsExactly) {
  cv::RNG rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    cv::Mat canvas = cv::Mat::zeros(rng.uniform(1, 120), rng.uniform(1, 200), CV_8UC1);
    for (int i = 0; i < 4; ++i) {
      cv::ellipse(canvas, {rng.uniform(0, canvas.cols), rng.uniform(0, canvas.rows)},
                  {rng.uniform(0, 40), rng.uniform(0, 40)}, rng.uniform(0, 180), 0, 360,
                  cv::Scalar(rng.uniform(1, 256)), cv::FILLED);
    }
    // Also a view whose rows are not contiguous.
    const cv::Mat mask = trial % 2 == 0 || canvas.cols < 3
                             ? canvas
                             : canvas(cv::Rect(1, 0, canvas.cols - 2, canvas.rows));
    const cv::Moments moments = cv::moments(mask, /*binaryImage=*/true);
    Eigen::Vector2d centroid(-1.0, -1.0);
    EXPECT_EQ(PixelAreaCentroid(mask, &centroid), moments.m00);
    if (moments.m00 > 0.0) {
      EXPECT_EQ(centroid.x(), moments.m10 / moments.m00) << "trial " << trial;
      EXPECT_EQ(centroid.y(), moments.m01 / moments.m00) << "trial " << trial;
    } else {
      EXPECT_EQ(centroid, Eigen::Vector2d(-1.0, -1.0));  // left as it was
    }
  }
}

}  // namespace
}  // namespace silpose
