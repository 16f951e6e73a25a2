#include "silpose/segment/segmenter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// A generated colour scene: a textured background of muted greens, blues and greys (low
// saturation, none of the object's orange hue), an object (an irregular polygon of saturated orange
// with its own texture) moving and turning across the frame, and camera noise on every frame.
class Scene {
 public:
  explicit Scene(cv::Size size = cv::Size(320, 240), uint64_t seed = 7)
      : size_(size), random_(seed) {
    background_.create(size, CV_8UC3);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        background_.at<cv::Vec3b>(y, x) =
            cv::Vec3b(static_cast<uchar>(120 + 60 * x / size.width),
                      static_cast<uchar>(130 + 50 * y / size.height), 110);
      }
    }
    for (int i = 0; i < 40; ++i) {  // blobs of other muted colours
      const cv::Point centre(random_.uniform(0, size.width), random_.uniform(0, size.height));
      const cv::Size axes(random_.uniform(5, size.width / 6), random_.uniform(5, size.height / 6));
      const int grey = random_.uniform(70, 200);
      const cv::Scalar colour(grey + random_.uniform(0, 40), grey + random_.uniform(0, 30), grey);
      cv::ellipse(background_, centre, axes, random_.uniform(0, 180), 0, 360, colour, cv::FILLED);
    }
    cv::Mat texture(size, CV_16SC3);
    random_.fill(texture, cv::RNG::NORMAL, 0, 12);
    cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0);
    cv::add(background_, texture, background_, cv::noArray(), CV_8U);
    cv::GaussianBlur(background_, background_, cv::Size(3, 3), 0);
  }

  const cv::Mat& background() const { return background_; }
  cv::Size size() const { return size_; }

  // The object's outline in frame t: it crosses the frame from left to right while turning.
  std::vector<cv::Point> Outline(int t) const {
    const double cx = size_.width * (0.25 + 0.5 * std::min(1.0, t / 60.0));
    const double cy = size_.height * 0.5 + 10.0 * std::sin(t * 0.2);
    const double angle = t * 0.05;
    const double s = size_.height / 240.0;
    // An "L" with a notch: concave, not symmetric.
    const double shape[][2] = {{-40, -35}, {-5, -35}, {-5, 0},  {20, 0},
                               {20, -10},  {40, -10}, {40, 30}, {-40, 30}};
    std::vector<cv::Point> points;
    for (const auto& p : shape) {
      const double x = s * (p[0] * std::cos(angle) - p[1] * std::sin(angle));
      const double y = s * (p[0] * std::sin(angle) + p[1] * std::cos(angle));
      points.emplace_back(static_cast<int>(std::lround(cx + x)),
                          static_cast<int>(std::lround(cy + y)));
    }
    return points;
  }

  cv::Mat TruthMask(int t) const {
    cv::Mat mask = cv::Mat::zeros(size_, CV_8UC1);
    cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{Outline(t)}, cv::Scalar(255));
    return mask;
  }

  // Frame t with the object (or without: empty scene) and camera noise of `noise` grey levels.
  cv::Mat Frame(int t, bool with_object = true, double noise = 4.0,
                cv::Scalar object_colour = cv::Scalar(30, 120, 230)) {
    cv::Mat frame = background_.clone();
    if (with_object) {
      cv::Mat object(size_, CV_8UC3, object_colour);
      cv::Mat texture(size_, CV_16SC3);
      random_.fill(texture, cv::RNG::NORMAL, 0, 10);
      cv::add(object, texture, object, cv::noArray(), CV_8U);
      object.copyTo(frame, TruthMask(t));
    }
    cv::Mat camera(size_, CV_16SC3);
    random_.fill(camera, cv::RNG::NORMAL, 0, noise);
    cv::add(frame, camera, frame, cv::noArray(), CV_8U);
    return frame;
  }

 private:
  cv::Size size_;
  cv::RNG random_;
  cv::Mat background_;
};

double IoU(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat both;
  cv::Mat either;
  cv::bitwise_and(a, b, both);
  cv::bitwise_or(a, b, either);
  const int union_px = cv::countNonZero(either);
  return union_px == 0 ? 1.0 : double(cv::countNonZero(both)) / union_px;
}

struct IouStats {
  double min = 1.0;
  double mean = 0.0;
  int frames = 0;
  void Add(double iou) {
    min = std::min(min, iou);
    mean += iou;
    ++frames;
  }
  double Mean() const { return frames == 0 ? 0.0 : mean / frames; }
};

// Learning from the first learning_frames frames (the tests of the model itself); the default,
// until-object learning, has its own tests below.
SegmenterOptions BackgroundOptions(BackgroundMethod method, int downscale) {
  SegmenterOptions options;
  options.kind = SegmenterKind::kBackground;
  options.background_method = method;
  options.background_learning = BackgroundLearning::kFrames;
  options.downscale = downscale;
  return options;
}

// ---- background subtraction --------------------------------------------------------------------

struct BackgroundCase {
  BackgroundMethod method;
  int downscale;
  // Bounds for LowContrastObject, per case (measured min / mean in the comment there).
  double low_contrast_min_iou;
  double low_contrast_mean_iou;
};

class BackgroundTest : public testing::TestWithParam<BackgroundCase> {};

std::string CaseName(const testing::TestParamInfo<BackgroundCase>& info) {
  return std::string(ToString(info.param.method)) + "_downscale" +
         std::to_string(info.param.downscale);
}

// Bounds, measured on this scene (320 x 240, camera noise 4 levels, object ~5000 px, empty scene
// during learning): per-frame IoU after learning, min / mean over 40 frames, the same for mog2,
// knn and gauss, learned from frames or from the image: 0.994 / 0.996 at downscale 1, 0.943 / 0.952
// at downscale 2. What is missed is the outline: the morphology rounds the polygon's corners, and
// at downscale 2 the outline is decided per 2 x 2 block (~0.5 px error along a ~300 px outline).
// Asserted with a margin: min >= 0.90, mean >= 0.93.
constexpr double kMinIou = 0.90;
constexpr double kMeanIou = 0.93;

TEST_P(BackgroundTest, LearnsFromFirstFramesThenRecoversTheObject) {
  const BackgroundCase param = GetParam();
  Scene scene;
  auto segmenter = CreateSegmenter(BackgroundOptions(param.method, param.downscale));
  const int learning = segmenter->options().learning_frames;
  for (int t = 0; t < learning; ++t) {
    const SegmentationResult result = segmenter->Segment(scene.Frame(t, /*with_object=*/false));
    ASSERT_EQ(result.status, SegmentationStatus::kLearning) << t << ": " << result.message;
    EXPECT_NE(result.message.find("learning"), std::string::npos);
    EXPECT_EQ(cv::countNonZero(result.mask), 0);
  }
  IouStats stats;
  for (int t = 0; t < 40; ++t) {
    const SegmentationResult result = segmenter->Segment(scene.Frame(t));
    ASSERT_EQ(result.status, SegmentationStatus::kOk) << t << ": " << result.message;
    EXPECT_EQ(result.mask.size(), scene.size());
    EXPECT_EQ(result.mask.type(), CV_8UC1);
    stats.Add(IoU(result.mask, scene.TruthMask(t)));
    const cv::Moments truth = cv::moments(scene.TruthMask(t), true);
    EXPECT_NEAR(result.centroid_px.x(), truth.m10 / truth.m00, 1.5);
    EXPECT_NEAR(result.centroid_px.y(), truth.m01 / truth.m00, 1.5);
  }
  std::printf("[ IoU      ] %s downscale %d: min %.3f mean %.3f\n", ToString(param.method),
              param.downscale, stats.min, stats.Mean());
  EXPECT_GE(stats.min, kMinIou);
  EXPECT_GE(stats.Mean(), kMeanIou);
}

TEST_P(BackgroundTest, LearnsFromBackgroundImage) {
  const BackgroundCase param = GetParam();
  Scene scene;
  const std::filesystem::path path = std::filesystem::path(testing::TempDir()) /
                                     ("silpose_background_" + CaseName({param, 0}) + ".png");
  ASSERT_TRUE(cv::imwrite(path.string(), scene.background()));
  SegmenterOptions options = BackgroundOptions(param.method, param.downscale);
  options.background_image_path = path.string();
  auto segmenter = CreateSegmenter(options);
  IouStats stats;
  for (int t = 0; t < 40; ++t) {  // the object is there from the first frame
    const SegmentationResult result = segmenter->Segment(scene.Frame(t));
    ASSERT_EQ(result.status, SegmentationStatus::kOk) << t << ": " << result.message;
    stats.Add(IoU(result.mask, scene.TruthMask(t)));
  }
  std::printf("[ IoU      ] %s downscale %d, from image: min %.3f mean %.3f\n",
              ToString(param.method), param.downscale, stats.min, stats.Mean());
  EXPECT_GE(stats.min, kMinIou);
  EXPECT_GE(stats.Mean(), kMeanIou);
  std::filesystem::remove(path);
}

// Harder: an object whose colour is close to the background's (greenish grey, ~10-30 levels from
// the background colours, texture of 10 levels): many of its pixels fall inside the model and the
// closing must fill the holes. Measured min / mean IoU over 40 frames: mog2 0.93 / 0.96 (downscale
// 1), 0.91 / 0.94 (2); knn 0.97 / 0.98 (1), 0.47-0.56 / 0.80-0.82 (2, varying with OpenCV's global
// RNG: averaging shrinks the object's differences below KNN's fixed 20-level distance, while MOG2's
// threshold follows the variance, which shrinks too); gauss 0.92 / 0.96 (1), 0.91 / 0.94 (2).
// Bounds a margin below.
TEST_P(BackgroundTest, LowContrastObject) {
  const BackgroundCase param = GetParam();
  Scene scene;
  auto segmenter = CreateSegmenter(BackgroundOptions(param.method, param.downscale));
  for (int t = 0; t < segmenter->options().learning_frames; ++t) {
    segmenter->Segment(scene.Frame(t, false));
  }
  IouStats stats;
  for (int t = 0; t < 40; ++t) {
    const SegmentationResult result =
        segmenter->Segment(scene.Frame(t, true, 4.0, cv::Scalar(150, 165, 120)));
    ASSERT_EQ(result.status, SegmentationStatus::kOk) << t << ": " << result.message;
    stats.Add(IoU(result.mask, scene.TruthMask(t)));
  }
  std::printf("[ IoU      ] %s downscale %d, low contrast: min %.3f mean %.3f\n",
              ToString(param.method), param.downscale, stats.min, stats.Mean());
  EXPECT_GE(stats.min, param.low_contrast_min_iou);
  EXPECT_GE(stats.Mean(), param.low_contrast_mean_iou);
}

TEST_P(BackgroundTest, LightingJumpIsTooLargeNotAWrongMask) {
  const BackgroundCase param = GetParam();
  Scene scene;
  auto segmenter = CreateSegmenter(BackgroundOptions(param.method, param.downscale));
  for (int t = 0; t < segmenter->options().learning_frames; ++t) {
    segmenter->Segment(scene.Frame(t, false));
  }
  ASSERT_TRUE(segmenter->Segment(scene.Frame(0)).ok());
  // The lights go up: every pixel brighter (not a shadow, which is darker).
  cv::Mat bright;
  scene.Frame(1).convertTo(bright, CV_8U, 1.3, 40);
  const SegmentationResult result = segmenter->Segment(bright);
  EXPECT_EQ(result.status, SegmentationStatus::kTooLarge) << result.message;
  EXPECT_GT(result.foreground_fraction, 0.5);
  EXPECT_EQ(cv::countNonZero(result.mask), 0);
  EXPECT_NE(result.message.find("max_foreground_fraction"), std::string::npos) << result.message;
  // The model is frozen: the normal scene is still recognised after the jump.
  EXPECT_TRUE(segmenter->Segment(scene.Frame(2)).ok());
}

TEST_P(BackgroundTest, EmptySceneAfterLearningIsEmpty) {
  const BackgroundCase param = GetParam();
  Scene scene;
  auto segmenter = CreateSegmenter(BackgroundOptions(param.method, param.downscale));
  for (int t = 0; t < segmenter->options().learning_frames; ++t) {
    segmenter->Segment(scene.Frame(t, false));
  }
  for (int t = 0; t < 5; ++t) {
    const SegmentationResult result = segmenter->Segment(scene.Frame(t, false));
    EXPECT_EQ(result.status, SegmentationStatus::kEmpty) << result.message;
    EXPECT_EQ(cv::countNonZero(result.mask), 0);
  }
}

// The default learning: the object appears after an empty stretch whose length the segmenter is
// not told (15 frames, half the frames mode's 30).
TEST_P(BackgroundTest, UntilObjectLearnsTheEmptySceneHoweverLongItLasts) {
  const BackgroundCase param = GetParam();
  Scene scene;
  SegmenterOptions options;
  options.kind = SegmenterKind::kBackground;
  options.background_method = param.method;
  options.downscale = param.downscale;
  ASSERT_EQ(options.background_learning, BackgroundLearning::kUntilObject);
  auto segmenter = CreateSegmenter(options);
  for (int t = 0; t < 15; ++t) {
    const SegmentationResult result = segmenter->Segment(scene.Frame(t, /*with_object=*/false));
    ASSERT_EQ(result.status, SegmentationStatus::kLearning) << t << ": " << result.message;
    EXPECT_EQ(cv::countNonZero(result.mask), 0);
  }
  IouStats stats;
  for (int t = 15; t < 55; ++t) {
    const SegmentationResult result = segmenter->Segment(scene.Frame(t));
    ASSERT_EQ(result.status, SegmentationStatus::kOk) << t << ": " << result.message;
    stats.Add(IoU(result.mask, scene.TruthMask(t)));
  }
  std::printf(
      "[ IoU      ] %s downscale %d, until-object after 15 empty frames: min %.3f mean "
      "%.3f\n",
      ToString(param.method), param.downscale, stats.min, stats.Mean());
  EXPECT_GE(stats.min, kMinIou);
  EXPECT_GE(stats.Mean(), kMeanIou);
  // Learning is over (the object was found in 3 frames in a row): an empty scene is empty now.
  const SegmentationResult empty = segmenter->Segment(scene.Frame(60, false));
  EXPECT_EQ(empty.status, SegmentationStatus::kEmpty) << empty.message;
}

INSTANTIATE_TEST_SUITE_P(Methods, BackgroundTest,
                         testing::Values(BackgroundCase{BackgroundMethod::kMog2, 1, 0.85, 0.92},
                                         BackgroundCase{BackgroundMethod::kMog2, 2, 0.85, 0.90},
                                         BackgroundCase{BackgroundMethod::kKnn, 1, 0.90, 0.94},
                                         BackgroundCase{BackgroundMethod::kKnn, 2, 0.40, 0.70},
                                         BackgroundCase{BackgroundMethod::kGaussian, 1, 0.85, 0.92},
                                         BackgroundCase{BackgroundMethod::kGaussian, 2, 0.85,
                                                        0.90}),
                         CaseName);

TEST_P(BackgroundTest, StillObjectStaysForegroundWithFrozenModel) {
  Scene scene;
  auto segmenter = CreateSegmenter(BackgroundOptions(GetParam().method, GetParam().downscale));
  for (int t = 0; t < segmenter->options().learning_frames; ++t) {
    segmenter->Segment(scene.Frame(t, false));
  }
  double last_iou = 0.0;
  for (int i = 0; i < 100; ++i) {  // the object stops at frame 10's place for 100 frames
    const SegmentationResult result = segmenter->Segment(scene.Frame(10));
    ASSERT_TRUE(result.ok()) << i << ": " << result.message;
    last_iou = IoU(result.mask, scene.TruthMask(10));
  }
  EXPECT_GE(last_iou, GetParam().downscale == 1 ? kMinIou : 0.85);
}

// Learning after the model is frozen (learning_rate > 0, to follow slow light drift) must not
// learn a still object into the background. MOG2 and KNN do after ~0.1 / rate frames (see
// SegmenterOptions::learning_rate); the gauss model learns only the pixels it classifies as
// background.
TEST(SegmenterTest, GaussLearningRateDoesNotLearnAStillObject) {
  Scene scene;
  SegmenterOptions options = BackgroundOptions(BackgroundMethod::kGaussian, 1);
  options.learning_rate = 0.05;
  auto segmenter = CreateSegmenter(options);
  for (int t = 0; t < options.learning_frames; ++t) segmenter->Segment(scene.Frame(t, false));
  SegmentationResult result;
  for (int i = 0; i < 200; ++i) result = segmenter->Segment(scene.Frame(10));
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_GE(IoU(result.mask, scene.TruthMask(10)), kMinIou);
  // The background does follow a slow drift: 2 grey levels brighter every 10 frames, 40 levels
  // in all (alone, as a jump, 40 levels would be foreground).
  cv::Mat drifted;
  for (int i = 1; i <= 200; ++i) {
    scene.Frame(20, false).convertTo(drifted, CV_8U, 1.0, 0.2 * i);
    result = segmenter->Segment(drifted);
  }
  EXPECT_EQ(result.status, SegmentationStatus::kEmpty) << result.message;
  auto frozen = CreateSegmenter(BackgroundOptions(BackgroundMethod::kGaussian, 1));
  for (int t = 0; t < options.learning_frames; ++t) frozen->Segment(scene.Frame(t, false));
  EXPECT_EQ(frozen->Segment(drifted).status, SegmentationStatus::kTooLarge);
}

TEST(SegmenterTest, FramesLearningAbsorbsAnObjectThatAppearsEarly) {
  // Why until-object is the default: with 30 learning frames and the object still from frame 15
  // on, the frames mode learns it as background; until-object finds it.
  Scene scene;
  SegmenterOptions frames = BackgroundOptions(BackgroundMethod::kMog2, 1);
  SegmenterOptions until_object = frames;
  until_object.background_learning = BackgroundLearning::kUntilObject;
  auto absorbing = CreateSegmenter(frames);
  auto finding = CreateSegmenter(until_object);
  SegmentationResult absorbed, found;
  for (int t = 0; t < 40; ++t) {
    const cv::Mat frame = t < 15 ? scene.Frame(t, false) : scene.Frame(15);
    absorbed = absorbing->Segment(frame);
    found = finding->Segment(frame);
  }
  ASSERT_TRUE(found.ok()) << found.message;
  EXPECT_GE(IoU(found.mask, scene.TruthMask(15)), kMinIou);
  EXPECT_LT(absorbed.ok() ? IoU(absorbed.mask, scene.TruthMask(15)) : 0.0, 0.5) << absorbed.message;
}

TEST(SegmenterTest, UntilObjectIsolatedDetectionOnlyPausesLearning) {
  Scene scene;
  SegmenterOptions options = BackgroundOptions(BackgroundMethod::kMog2, 1);
  options.background_learning = BackgroundLearning::kUntilObject;
  options.min_learning_frames = 10;
  options.object_confirm_frames = 3;
  auto segmenter = CreateSegmenter(options);
  for (int t = 0; t < 12; ++t) segmenter->Segment(scene.Frame(t, false));
  // One frame with an object (segmented), then the empty scene again: still learning.
  EXPECT_TRUE(segmenter->Segment(scene.Frame(12)).ok());
  const SegmentationResult after = segmenter->Segment(scene.Frame(13, false));
  EXPECT_EQ(after.status, SegmentationStatus::kLearning) << after.message;
  EXPECT_NE(after.message.find("until an object appears"), std::string::npos) << after.message;
  // Three frames in a row with the object end the learning.
  for (int t = 14; t < 17; ++t) ASSERT_TRUE(segmenter->Segment(scene.Frame(t)).ok()) << t;
  EXPECT_EQ(segmenter->Segment(scene.Frame(17, false)).status, SegmentationStatus::kEmpty);
  // Reset learns again.
  segmenter->Reset();
  EXPECT_EQ(segmenter->Segment(scene.Frame(18, false)).status, SegmentationStatus::kLearning);
}

TEST(SegmenterTest, RelearnsAfterPersistentChange) {
  Scene scene;
  SegmenterOptions options = BackgroundOptions(BackgroundMethod::kMog2, 2);
  options.learning_frames = 10;
  options.relearn_after_frames = 3;
  auto segmenter = CreateSegmenter(options);
  for (int t = 0; t < 10; ++t) segmenter->Segment(scene.Frame(t, false));
  const auto brighter = [](const cv::Mat& frame) {
    cv::Mat bright;
    frame.convertTo(bright, CV_8U, 1.3, 40);
    return bright;
  };
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(segmenter->Segment(brighter(scene.Frame(0))).status, SegmentationStatus::kTooLarge);
  }
  for (int t = 0; t < 10; ++t) {
    EXPECT_EQ(segmenter->Segment(brighter(scene.Frame(t, false))).status,
              SegmentationStatus::kLearning);
  }
  const SegmentationResult result = segmenter->Segment(brighter(scene.Frame(5)));
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_GE(IoU(result.mask, scene.TruthMask(5)), kMinIou);
}

TEST(SegmenterTest, GreyAndFourChannelFramesAreAccepted) {
  Scene scene;
  for (const int channels : {1, 4})
    for (const BackgroundMethod method : {BackgroundMethod::kMog2, BackgroundMethod::kGaussian}) {
      SCOPED_TRACE(ToString(method));
      auto segmenter = CreateSegmenter(BackgroundOptions(method, 1));
      const auto convert = [&](const cv::Mat& frame) {
        cv::Mat out;
        cv::cvtColor(frame, out, channels == 1 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGR2BGRA);
        return out;
      };
      for (int t = 0; t < 30; ++t) segmenter->Segment(convert(scene.Frame(t, false)));
      // A dark object: the orange one has the grey level of the background (143).
      const SegmentationResult result =
          segmenter->Segment(convert(scene.Frame(3, true, 4.0, cv::Scalar(30, 40, 60))));
      ASSERT_TRUE(result.ok()) << channels << ": " << result.message;
      EXPECT_GE(IoU(result.mask, scene.TruthMask(3)), kMinIou) << channels;
    }
}

TEST(SegmenterTest, FrameOfAnotherSizeIsAnError) {
  Scene scene;
  for (const BackgroundMethod method : {BackgroundMethod::kMog2, BackgroundMethod::kGaussian}) {
    SCOPED_TRACE(ToString(method));
    auto segmenter = CreateSegmenter(BackgroundOptions(method, 1));
    segmenter->Segment(scene.Frame(0, false));
    EXPECT_THROW(segmenter->Segment(cv::Mat(100, 100, CV_8UC3, cv::Scalar::all(0))), Error);
    EXPECT_THROW(segmenter->Segment(cv::Mat(scene.size(), CV_8UC1, cv::Scalar(0))), Error);
    EXPECT_THROW(segmenter->Segment(cv::Mat()), Error);
    EXPECT_THROW(segmenter->Segment(cv::Mat(10, 10, CV_64FC1, cv::Scalar(0))), Error);
  }
}

TEST(SegmenterTest, BackgroundImageErrorsNameTheFile) {
  SegmenterOptions options = BackgroundOptions(BackgroundMethod::kMog2, 1);
  options.background_image_path = "/nonexistent/empty_scene.png";
  try {
    CreateSegmenter(options);
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/empty_scene.png"), std::string::npos);
  }
  Scene scene;
  const std::filesystem::path path =
      std::filesystem::path(testing::TempDir()) / "silpose_background_small.png";
  cv::Mat small;
  cv::resize(scene.background(), small, cv::Size(160, 120));
  ASSERT_TRUE(cv::imwrite(path.string(), small));
  options.background_image_path = path.string();
  auto segmenter = CreateSegmenter(options);
  try {
    segmenter->Segment(scene.Frame(0));
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("160 x 120"), std::string::npos) << error.what();
  }
  std::filesystem::remove(path);
}

// ---- threshold ---------------------------------------------------------------------------------

TEST(SegmenterTest, HsvRangeRecoversTheObject) {
  Scene scene;
  for (const int downscale : {1, 2}) {
    SegmenterOptions options;
    options.kind = SegmenterKind::kThreshold;
    options.threshold_method = ThresholdMethod::kHsvRange;
    options.hsv_lower = cv::Scalar(5, 100, 100);  // the object's orange is H 13.5, S 222, V 230
    options.hsv_upper = cv::Scalar(25, 255, 255);
    options.downscale = downscale;
    auto segmenter = CreateSegmenter(options);
    for (int t = 0; t < 10; ++t) {
      const SegmentationResult result = segmenter->Segment(scene.Frame(t));
      ASSERT_TRUE(result.ok()) << result.message;
      EXPECT_GE(IoU(result.mask, scene.TruthMask(t)), kMinIou) << t << " downscale " << downscale;
    }
    const SegmentationResult empty = segmenter->Segment(scene.Frame(0, false));
    EXPECT_EQ(empty.status, SegmentationStatus::kEmpty) << empty.message;
  }
}

TEST(SegmenterTest, HsvRangeWrapsThroughRed) {
  Scene scene;
  SegmenterOptions options;
  options.kind = SegmenterKind::kThreshold;
  options.threshold_method = ThresholdMethod::kHsvRange;
  options.hsv_lower = cv::Scalar(170, 100, 100);
  options.hsv_upper = cv::Scalar(10, 255, 255);
  auto segmenter = CreateSegmenter(options);
  // Pure red has H = 0: only the wrapped range holds it.
  const SegmentationResult result =
      segmenter->Segment(scene.Frame(4, true, 4.0, cv::Scalar(40, 30, 220)));
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_GE(IoU(result.mask, scene.TruthMask(4)), kMinIou);
}

TEST(SegmenterTest, OtsuRecoversDarkAndBrightObjects) {
  Scene scene;
  for (const ObjectPolarity polarity : {ObjectPolarity::kDarker, ObjectPolarity::kBrighter}) {
    // A plain table (the controlled lighting this rule is for) and a darker or brighter object.
    SegmenterOptions options;
    options.kind = SegmenterKind::kThreshold;
    options.threshold_method = ThresholdMethod::kOtsu;
    options.otsu_object = polarity;
    auto segmenter = CreateSegmenter(options);
    const cv::Scalar table =
        polarity == ObjectPolarity::kDarker ? cv::Scalar::all(180) : cv::Scalar::all(60);
    const cv::Scalar object =
        polarity == ObjectPolarity::kDarker ? cv::Scalar(40, 50, 60) : cv::Scalar(210, 220, 230);
    for (int t = 0; t < 10; ++t) {
      // Uneven light on the table: -20 .. +20 levels across the frame.
      cv::Mat frame(scene.size(), CV_8UC3);
      for (int x = 0; x < frame.cols; ++x) {
        frame.col(x).setTo(table + cv::Scalar::all(40.0 * x / frame.cols - 20.0));
      }
      frame.setTo(object, scene.TruthMask(t));
      cv::Mat noise(scene.size(), CV_16SC3);
      cv::randn(noise, 0, 6);
      cv::add(frame, noise, frame, cv::noArray(), CV_8U);
      const SegmentationResult result = segmenter->Segment(frame);
      ASSERT_TRUE(result.ok()) << result.message;
      EXPECT_GE(IoU(result.mask, scene.TruthMask(t)), 0.95) << ToString(polarity) << " " << t;
    }
  }
}

// ---- mask --------------------------------------------------------------------------------------

TEST(SegmenterTest, MaskFramesFollowDesignRuleAndThreshold) {
  Scene scene;
  cv::Mat truth = scene.TruthMask(0);
  auto segmenter = CreateSegmenter(SegmenterOptions{});
  SegmentationResult result = segmenter->Segment(truth);
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_EQ(IoU(result.mask, truth), 1.0);
  EXPECT_EQ(result.area_px, cv::countNonZero(truth));

  // Any non-zero value of any channel is object (the mask rule in README.md); 16-bit and colour
  // masks too.
  cv::Mat faint = truth / 255;  // values 0 / 1
  EXPECT_EQ(IoU(segmenter->Segment(faint).mask, truth), 1.0);
  cv::Mat colour = cv::Mat::zeros(truth.size(), CV_8UC3);
  std::vector<cv::Mat> planes;
  cv::split(colour, planes);
  planes[2] = truth;  // only the red channel set
  cv::merge(planes, colour);
  EXPECT_EQ(IoU(segmenter->Segment(colour).mask, truth), 1.0);
  cv::Mat wide;
  truth.convertTo(wide, CV_16U, 257.0);
  EXPECT_EQ(IoU(segmenter->Segment(wide).mask, truth), 1.0);

  // A JPEG-stored mask: the rule "non-zero" keeps the compression noise around the outline,
  // mask_threshold 127 does not.
  std::vector<uchar> bytes;
  cv::imencode(".jpg", truth, bytes, {cv::IMWRITE_JPEG_QUALITY, 50});
  const cv::Mat jpeg = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  const double loose = IoU(segmenter->Segment(jpeg).mask, truth);
  SegmenterOptions options;
  options.mask_threshold = 127;
  const double cut = IoU(CreateSegmenter(options)->Segment(jpeg).mask, truth);
  EXPECT_GT(cut, loose);
  EXPECT_GE(cut, 0.97);

  const SegmentationResult empty = segmenter->Segment(cv::Mat::zeros(truth.size(), CV_8UC1));
  EXPECT_EQ(empty.status, SegmentationStatus::kEmpty);
  EXPECT_EQ(empty.message, "no foreground");
  const SegmentationResult full =
      segmenter->Segment(cv::Mat(truth.size(), CV_8UC1, cv::Scalar(255)));
  EXPECT_EQ(full.status, SegmentationStatus::kTooLarge);
}

TEST(SegmenterTest, MorphologyRemovesSaltNoise) {
  Scene scene;
  const cv::Mat truth = scene.TruthMask(20);
  cv::Mat noisy = truth.clone();
  cv::Mat flip(truth.size(), CV_32F);
  cv::randu(flip, 0, 1);
  noisy.setTo(255, flip < 0.02);  // 2 % salt: specks around the object
  noisy.setTo(0, flip > 0.99);    // 1 % pepper: holes in it

  SegmenterOptions options;
  options.min_area_fraction = 0.0;
  options.morphology_px = 0;
  const SegmentationResult raw = CreateSegmenter(options)->Segment(noisy);
  ASSERT_TRUE(raw.ok());
  EXPECT_GT(raw.num_components, 100);

  options.morphology_px = 2;
  const SegmentationResult clean = CreateSegmenter(options)->Segment(noisy);
  ASSERT_TRUE(clean.ok());
  EXPECT_EQ(clean.num_components, 1);
  EXPECT_GE(IoU(clean.mask, truth), 0.95);
  EXPECT_NEAR(clean.foreground_fraction, cv::countNonZero(truth) / double(truth.total()), 0.005);
}

TEST(SegmenterTest, SmallComponentsAreEmpty) {
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8UC1);
  cv::circle(mask, cv::Point(100, 100), 3, cv::Scalar(255), cv::FILLED);  // 29 px < 61 px
  const SegmentationResult result = CreateSegmenter(SegmenterOptions{})->Segment(mask);
  EXPECT_EQ(result.status, SegmentationStatus::kEmpty);
  EXPECT_NE(result.message.find("min_area_fraction"), std::string::npos) << result.message;
}

// An object 30 radii from a 525 px lens: its bounding sphere projects to a 17.5 px radius and a
// slender part casts a few hundred pixels. The default keeps it, for every kind of segmentation,
// and the mask is the object's.
TEST(SegmenterTest, FarObjectIsKeptByDefault) {
  cv::Mat mask = cv::Mat::zeros(480, 640, CV_8UC1);
  cv::ellipse(mask, cv::Point(420, 130), cv::Size(16, 5), 30.0, 0.0, 360.0, cv::Scalar(255),
              cv::FILLED);
  const int area = cv::countNonZero(mask);
  ASSERT_GT(area, 200);
  ASSERT_LT(area, 307);  // below the 0.1 % of the frame that was once the default
  const SegmentationResult result = CreateSegmenter(SegmenterOptions{})->Segment(mask);
  ASSERT_EQ(result.status, SegmentationStatus::kOk) << result.message;
  EXPECT_EQ(cv::countNonZero(result.mask), area);
  EXPECT_EQ(IoU(result.mask, mask), 1.0);

  // The same object in a colour frame, against the empty scene's image (default clean-up: the
  // opening with a 2 px disc keeps a 10 px wide object).
  const Scene scene(mask.size());
  const std::filesystem::path path =
      std::filesystem::path(testing::TempDir()) / "silpose_far_object_background.png";
  ASSERT_TRUE(cv::imwrite(path.string(), scene.background()));
  ASSERT_EQ(scene.background().size(), mask.size());
  cv::Mat frame = scene.background().clone();
  frame.setTo(cv::Scalar(40, 200, 230), mask);
  for (const BackgroundMethod method :
       {BackgroundMethod::kMog2, BackgroundMethod::kKnn, BackgroundMethod::kGaussian}) {
    SegmenterOptions options = BackgroundOptions(method, 1);
    options.background_image_path = path.string();
    const SegmentationResult colour = CreateSegmenter(options)->Segment(frame);
    ASSERT_EQ(colour.status, SegmentationStatus::kOk) << ToString(method) << ": " << colour.message;
    EXPECT_GE(IoU(colour.mask, mask), 0.8) << ToString(method);
  }
  std::filesystem::remove(path);
}

// The segmenter measures the components itself (area, box and centre from one pass over the
// labels) instead of cv::connectedComponentsWithStats: on random masks of blobs, specks and lines
// (equal areas included), the component it chooses, largest or nearest to the previous one, is the
// one OpenCV's statistics choose, and the counts agree.
TEST(SegmenterTest, ChosenComponentIsTheOneOpenCvStatisticsChoose) {
  cv::RNG random(21);
  for (const SegmentComponent rule :
       {SegmentComponent::kLargest, SegmentComponent::kNearestPrevious}) {
    SegmenterOptions options;
    options.component = rule;
    options.min_area_fraction = 0.0005;  // 38 px of 320 x 240
    auto segmenter = CreateSegmenter(options);
    bool has_previous = false;
    cv::Point2d previous;
    for (int trial = 0; trial < 150; ++trial) {
      SCOPED_TRACE(std::string(ToString(rule)) + " trial " + std::to_string(trial));
      cv::Mat mask = cv::Mat::zeros(240, 320, CV_8UC1);
      const int blobs = random.uniform(1, 7);
      for (int b = 0; b < blobs; ++b) {
        const cv::Point centre(random.uniform(0, 320), random.uniform(0, 240));
        if (random.uniform(0, 3) == 0) {  // a square: several of equal area
          const int half = random.uniform(3, 12);
          cv::rectangle(mask, cv::Rect(centre.x - half, centre.y - half, 2 * half, 2 * half),
                        cv::Scalar(255), cv::FILLED);
        } else {
          cv::ellipse(mask, centre, cv::Size(random.uniform(2, 40), random.uniform(2, 30)),
                      random.uniform(0, 180), 0, 360, cv::Scalar(255), cv::FILLED);
        }
      }
      for (int k = 0; k < 30; ++k)
        mask.at<uchar>(random.uniform(0, 240), random.uniform(0, 320)) = 255;
      cv::line(mask, cv::Point(random.uniform(0, 320), 0), cv::Point(random.uniform(0, 320), 239),
               cv::Scalar(255));

      cv::Mat labels, stats, centroids;
      const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
      int chosen = -1, kept = 0;
      double best = 0.0;
      for (int label = 1; label < count; ++label) {
        const int area = stats.at<int>(label, cv::CC_STAT_AREA);
        if (area < options.min_area_fraction * static_cast<double>(mask.total())) continue;
        ++kept;
        const cv::Point2d centre(centroids.at<double>(label, 0), centroids.at<double>(label, 1));
        double score = area;
        if (rule == SegmentComponent::kNearestPrevious && has_previous) {
          const cv::Point2d d = centre - previous;
          score = -(d.x * d.x + d.y * d.y);
        }
        if (chosen < 0 || score > best) {
          chosen = label;
          best = score;
        }
      }
      const SegmentationResult result = segmenter->Segment(mask);
      if (chosen < 0) {
        EXPECT_EQ(result.status, SegmentationStatus::kEmpty) << result.message;
        continue;
      }
      ASSERT_TRUE(result.ok()) << result.message;
      EXPECT_EQ(result.num_components, kept);
      EXPECT_EQ(cv::countNonZero(result.mask != (labels == chosen)), 0);
      EXPECT_EQ(result.area_px, stats.at<int>(chosen, cv::CC_STAT_AREA));
      EXPECT_NEAR(result.centroid_px.x(), centroids.at<double>(chosen, 0), 1e-9);
      EXPECT_NEAR(result.centroid_px.y(), centroids.at<double>(chosen, 1), 1e-9);
      previous = cv::Point2d(result.centroid_px.x(), result.centroid_px.y());
      has_previous = true;
    }
  }
}

TEST(SegmenterTest, NearestComponentFollowsTheObject) {
  // A small object moving right; from frame 5 a larger blob appears elsewhere.
  const auto frame = [](int t) {
    cv::Mat mask = cv::Mat::zeros(240, 320, CV_8UC1);
    cv::circle(mask, cv::Point(60 + 5 * t, 80), 15, cv::Scalar(255), cv::FILLED);
    if (t >= 5) cv::rectangle(mask, cv::Rect(150, 140, 80, 60), cv::Scalar(255), cv::FILLED);
    return mask;
  };
  SegmenterOptions options;
  options.component = SegmentComponent::kNearestPrevious;
  auto nearest = CreateSegmenter(options);
  auto largest = CreateSegmenter(SegmenterOptions{});
  for (int t = 0; t < 15; ++t) {
    const SegmentationResult followed = nearest->Segment(frame(t));
    ASSERT_TRUE(followed.ok());
    EXPECT_NEAR(followed.centroid_px.x(), 60 + 5 * t, 0.5) << t;
    EXPECT_NEAR(followed.centroid_px.y(), 80, 0.5) << t;
    EXPECT_EQ(followed.num_components, t >= 5 ? 2 : 1);
    const SegmentationResult biggest = largest->Segment(frame(t));
    EXPECT_NEAR(biggest.centroid_px.y(), t >= 5 ? 169.5 : 80, 0.5) << t;
  }
  // After Reset there is no previous centre: the largest is taken.
  nearest->Reset();
  EXPECT_NEAR(nearest->Segment(frame(6)).centroid_px.y(), 169.5, 0.5);
}

// ---- options -----------------------------------------------------------------------------------

TEST(SegmenterTest, BadOptionsNameTheOption) {
  const auto expect_error = [](const SegmenterOptions& options, const std::string& name) {
    std::string message;
    EXPECT_FALSE(options.Check(&message)) << name;
    EXPECT_NE(message.find(name), std::string::npos) << message;
    try {
      CreateSegmenter(options);
      ADD_FAILURE() << "no error for " << name;
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
    }
  };
  EXPECT_TRUE(SegmenterOptions{}.Check());
  SegmenterOptions options;
  options.learning_frames = 0;
  expect_error(options, "learning_frames");
  options = {};
  options.min_learning_frames = 0;
  expect_error(options, "min_learning_frames");
  options = {};
  options.object_confirm_frames = 0;
  expect_error(options, "object_confirm_frames");
  options = {};
  options.learning_rate = 1.0;
  expect_error(options, "learning_rate");
  options = {};
  options.downscale = 0;
  expect_error(options, "downscale");
  options = {};
  options.max_foreground_fraction = 0.0;
  expect_error(options, "max_foreground_fraction");
  options = {};
  options.min_area_fraction = -0.1;
  expect_error(options, "min_area_fraction");
  options = {};
  options.morphology_px = 51;
  expect_error(options, "morphology_px");
  options = {};
  options.mask_threshold = 255;
  expect_error(options, "mask_threshold");
  options = {};
  options.hsv_upper = cv::Scalar(200, 255, 255);
  expect_error(options, "hsv_");
  options = {};
  options.kind = SegmenterKind::kThreshold;
  options.threshold_method = ThresholdMethod::kHsvRange;
  expect_error(options, "hsv_lower / hsv_upper");
  options = {};
  options.background_image_path = "empty.png";
  expect_error(options, "background_image_path");
  options = {};
  options.background_image_noise = -1;
  expect_error(options, "background_image_noise");
  options = {};
  options.gauss_variance_threshold = 0;
  expect_error(options, "gauss_variance_threshold");
}

TEST(SegmenterTest, ParseNamesListTheChoices) {
  EXPECT_EQ(ParseSegmenterKind("mask"), SegmenterKind::kMask);
  EXPECT_EQ(ParseSegmenterKind("bgsub"), SegmenterKind::kBackground);
  EXPECT_EQ(ParseSegmenterKind("threshold"), SegmenterKind::kThreshold);
  EXPECT_EQ(ParseBackgroundLearning("until-object"), BackgroundLearning::kUntilObject);
  EXPECT_EQ(ParseBackgroundLearning("frames"), BackgroundLearning::kFrames);
  EXPECT_THROW(ParseBackgroundLearning("first"), Error);
  EXPECT_EQ(ParseBackgroundMethod("knn"), BackgroundMethod::kKnn);
  EXPECT_EQ(ParseBackgroundMethod("gauss"), BackgroundMethod::kGaussian);
  EXPECT_EQ(ParseThresholdMethod("hsv"), ThresholdMethod::kHsvRange);
  EXPECT_EQ(ParseObjectPolarity("brighter"), ObjectPolarity::kBrighter);
  EXPECT_EQ(ParseSegmentComponent("nearest"), SegmentComponent::kNearestPrevious);
  try {
    ParseSegmenterKind("grabcut");
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_STREQ(error.what(),
                 "unknown segmentation kind 'grabcut'; choose one of: mask, bgsub, threshold");
  }
  EXPECT_THROW(ParseBackgroundMethod("mog"), Error);
}

}  // namespace
}  // namespace silpose
