#include "silpose/segment/gaussian_background.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <string>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// The rule of the header, written out per pixel: the reference the vector loop must match.
uchar ExpectedClass(const uchar* x, const uchar* mu, int channels, double variance,
                    const GaussianBackgroundOptions& options) {
  double distance2 = 0.0;
  for (int c = 0; c < channels; ++c) distance2 += std::pow(double(x[c]) - mu[c], 2);
  const double scale = options.threshold * channels * variance;
  if (distance2 <= scale) return 0;
  if (!options.detect_shadows) return 255;
  double dot = 0.0, norm2 = 0.0;
  for (int c = 0; c < channels; ++c) {
    dot += double(x[c]) * mu[c];
    norm2 += double(mu[c]) * mu[c];
  }
  if (norm2 <= 0.0) return 255;
  const double a = dot / norm2;
  if (a < options.shadow_ratio || a > 1.0) return 255;
  double off = 0.0;
  for (int c = 0; c < channels; ++c) off += std::pow(a * mu[c] - x[c], 2);
  return off <= scale * a * a ? 127 : 255;
}

// Frozen after one frame (mean = that frame, variance = the initial one): every pixel of random
// frames, in widths that are and are not multiples of the vector loop's 16 pixels, grey and
// colour, with and without shadows, is classified as the rule says. The frames mix pixels near
// the background, far from it and darker copies of it, so all three classes occur.
TEST(GaussianBackgroundTest, ClassifiesEveryPixelByTheRule) {
  cv::RNG random(11);
  for (const int channels : {1, 3})
    for (const int width : {16, 37, 64, 5})
      for (const bool shadows : {true, false}) {
        SCOPED_TRACE(std::to_string(channels) + " channel(s), width " + std::to_string(width) +
                     (shadows ? ", shadows" : ""));
        GaussianBackgroundOptions options;
        options.detect_shadows = shadows;
        GaussianBackground model(options);
        cv::Mat background(23, width, CV_MAKETYPE(CV_8U, channels));
        random.fill(background, cv::RNG::UNIFORM, 20, 250);
        cv::Mat mask;
        model.apply(background, mask, 0.0);
        EXPECT_EQ(cv::countNonZero(mask), 0);
        cv::Mat frame = background.clone();
        int counts[256] = {};
        for (int y = 0; y < frame.rows; ++y) {
          for (int x = 0; x < frame.cols; ++x) {
            uchar* p = frame.ptr<uchar>(y) + channels * x;
            const int kind = random.uniform(0, 3);
            for (int c = 0; c < channels; ++c) {
              if (kind == 0) {  // near: noise of about the threshold
                p[c] = cv::saturate_cast<uchar>(p[c] + random.gaussian(18.0));
              } else if (kind == 1) {  // far
                p[c] = static_cast<uchar>(random.uniform(0, 256));
              } else {  // darker copy, with a little noise
                p[c] = cv::saturate_cast<uchar>(p[c] * 0.7 + random.gaussian(2.0));
              }
            }
          }
        }
        model.apply(frame, mask, 0.0);
        ASSERT_EQ(mask.type(), CV_8UC1);
        for (int y = 0; y < frame.rows; ++y) {
          for (int x = 0; x < frame.cols; ++x) {
            const uchar expected = ExpectedClass(frame.ptr<uchar>(y) + channels * x,
                                                 background.ptr<uchar>(y) + channels * x, channels,
                                                 options.initial_variance, options);
            ASSERT_EQ(mask.at<uchar>(y, x), expected) << "pixel " << x << ", " << y;
            ++counts[expected];
          }
        }
        if (width >= 37) {
          EXPECT_GT(counts[0], 0);
          EXPECT_GT(counts[255], 0);
          if (shadows && channels == 3) {
            EXPECT_GT(counts[127], 0);
          }
        }
      }
}

// A darker copy of the background is a shadow (127) with shadow detection, foreground without;
// a brighter one is foreground either way, and so is one darker than shadow_ratio.
TEST(GaussianBackgroundTest, ShadowsAreDarkerCopies) {
  const cv::Mat background(8, 40, CV_8UC3, cv::Scalar(90, 140, 200));
  for (const bool shadows : {true, false}) {
    GaussianBackgroundOptions options;
    options.detect_shadows = shadows;
    GaussianBackground model(options);
    cv::Mat mask;
    model.apply(background, mask, 0.0);
    model.apply(cv::Mat(background * 0.7), mask, 0.0);
    EXPECT_EQ(cv::countNonZero(mask == (shadows ? 127 : 255)), mask.total()) << shadows;
    model.apply(cv::Mat(background * 1.2), mask, 0.0);
    EXPECT_EQ(cv::countNonZero(mask == 255), mask.total()) << shadows;
    model.apply(cv::Mat(background * 0.3), mask, 0.0);
    EXPECT_EQ(cv::countNonZero(mask == 255), mask.total()) << shadows;
  }
}

// The automatic rate averages the frames: after 60 frames of a scene with camera noise of sigma
// 4, the mean is the scene's to within half a level and the variance is sigma^2 to within 25 %.
// Rate 0 then changes nothing, whatever the frame.
TEST(GaussianBackgroundTest, LearnsMeanAndVarianceThenStaysFrozen) {
  cv::RNG random(5);
  cv::Mat scene(48, 64, CV_8UC3);
  random.fill(scene, cv::RNG::UNIFORM, 40, 220);
  GaussianBackgroundOptions options;
  options.history = 60;
  GaussianBackground model(options);
  EXPECT_TRUE(model.empty());
  cv::Mat mask;
  cv::Mat noise(scene.size(), CV_16SC3);
  cv::Mat noisy;
  for (int i = 0; i < 60; ++i) {
    random.fill(noise, cv::RNG::NORMAL, 0.0, 4.0);
    cv::add(scene, noise, noisy, cv::noArray(), CV_8U);
    model.apply(noisy, mask, -1.0);
  }
  EXPECT_FALSE(model.empty());
  cv::Mat learned;
  model.getBackgroundImage(learned);
  ASSERT_EQ(learned.type(), CV_8UC3);
  cv::Mat difference;
  cv::absdiff(learned, scene, difference);
  EXPECT_LE(cv::mean(difference)[0], 1.0);
  const double variance = cv::mean(model.variance())[0];
  EXPECT_NEAR(variance, 16.0, 4.0);
  const cv::Mat variance_before = model.variance().clone();
  model.apply(cv::Mat(scene.size(), CV_8UC3, cv::Scalar(0, 255, 0)), mask, 0.0);
  EXPECT_EQ(cv::countNonZero(mask == 255), mask.total());
  cv::Mat after;
  model.getBackgroundImage(after);
  EXPECT_EQ(cv::norm(after, learned, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(model.variance(), variance_before, cv::NORM_INF), 0.0);
  model.clear();
  EXPECT_TRUE(model.empty());
}

// rate > 0 learns only the pixels classified as background: a patch that differs stays
// foreground however long it stays, while the rest follows the frames.
TEST(GaussianBackgroundTest, ExplicitRateLearnsOnlyTheBackground) {
  const cv::Mat scene(20, 32, CV_8UC1, cv::Scalar(100));
  GaussianBackground model;
  cv::Mat mask;
  model.apply(scene, mask, -1.0);
  cv::Mat frame = scene.clone();
  frame(cv::Rect(4, 4, 8, 8)).setTo(200);   // an object
  frame(cv::Rect(20, 4, 8, 8)).setTo(104);  // a small change of the background
  for (int i = 0; i < 100; ++i) model.apply(frame, mask, 0.2);
  EXPECT_EQ(cv::countNonZero(mask), 64);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(4, 4, 8, 8))), 64);
  cv::Mat learned;
  model.getBackgroundImage(learned);
  EXPECT_EQ(learned.at<uchar>(8, 8), 100);
  EXPECT_EQ(learned.at<uchar>(8, 24), 104);
}

// The limit of one Gaussian (docs/segmentation.md): a pixel that flickers between two colours (of
// the same brightness) while the model learns is learned as one colour between them with the
// largest variance allowed, so both colours stay foreground.
TEST(GaussianBackgroundTest, AFlickeringPixelStaysForeground) {
  const cv::Mat dark(8, 24, CV_8UC3, cv::Scalar(60, 100, 140));
  const cv::Mat light(8, 24, CV_8UC3, cv::Scalar(140, 100, 60));
  GaussianBackground model;
  cv::Mat mask;
  for (int i = 0; i < 30; ++i) model.apply(i % 2 == 0 ? dark : light, mask, -1.0);
  EXPECT_NEAR(cv::mean(model.variance())[0], model.options().max_variance, 1e-3);
  model.apply(dark, mask, 0.0);
  EXPECT_EQ(cv::countNonZero(mask == 255), mask.total());
  model.apply(light, mask, 0.0);
  EXPECT_EQ(cv::countNonZero(mask == 255), mask.total());
}

TEST(GaussianBackgroundTest, BadOptionsAndFramesAreErrors) {
  const auto expect_error = [](GaussianBackgroundOptions options, const std::string& text) {
    try {
      GaussianBackground model(options);
      FAIL() << "no error for " << text;
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(text), std::string::npos) << error.what();
    }
  };
  GaussianBackgroundOptions options;
  options.history = 0;
  expect_error(options, "history");
  options = {};
  options.threshold = std::nan("");
  expect_error(options, "threshold");
  options = {};
  options.shadow_ratio = 1.0;
  expect_error(options, "shadow_ratio");
  options = {};
  options.min_variance = 0.0;
  expect_error(options, "variances");
  options = {};
  options.initial_variance = 1000.0;
  expect_error(options, "variances");

  GaussianBackground model;
  cv::Mat mask;
  EXPECT_THROW(model.apply(cv::Mat(), mask), Error);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_16UC1, cv::Scalar(0)), mask), Error);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_8UC4, cv::Scalar(0)), mask), Error);
  model.apply(cv::Mat(4, 4, CV_8UC3, cv::Scalar(0)), mask);
  EXPECT_THROW(model.apply(cv::Mat(4, 5, CV_8UC3, cv::Scalar(0)), mask), Error);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), mask), Error);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_8UC3, cv::Scalar(0)), mask, 1.5), Error);
  EXPECT_THROW(model.apply(cv::Mat(4, 4, CV_8UC3, cv::Scalar(0)), mask, std::nan("")), Error);
}

}  // namespace
}  // namespace silpose
