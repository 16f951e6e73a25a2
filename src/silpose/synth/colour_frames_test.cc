#include "silpose/synth/colour_frames.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "silpose/render/silhouette_renderer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

double MaxDifference(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF); }

const TriangleMesh& Model(const std::string& name) {
  static const TriangleMesh bunny =
      LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / "bunny.obj");
  static const TriangleMesh hand =
      LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / "hand.obj");
  return name == "bunny" ? bunny : hand;
}

// 160 x 120 orbit with colour frames, no noise.
SequenceOptions ColourOrbit(int frames) {
  SequenceOptions options;
  options.camera = PinholeCamera::Centered(160, 120, 155.0);
  options.trajectory.num_frames = frames;
  options.trajectory.orbit.step_deg = 10.0;
  options.colour.enabled = true;
  return options;
}

// Mean and standard deviation, over all channels, of a - b.
void DifferenceStatistics(const cv::Mat& a, const cv::Mat& b, double* mean, double* deviation) {
  cv::Mat difference;
  cv::subtract(a, b, difference, cv::noArray(), CV_32F);
  cv::Scalar mean_channels;
  cv::Scalar deviation_channels;
  cv::meanStdDev(difference.reshape(1), mean_channels, deviation_channels);
  *mean = mean_channels[0];
  *deviation = deviation_channels[0];
}

TEST(GenerateBackgroundTexture, IsDeterministicTexturedAndSeedable) {
  const cv::Mat texture = GenerateBackgroundTexture(320, 240, 5);
  ASSERT_EQ(texture.type(), CV_8UC3);
  ASSERT_EQ(texture.size(), cv::Size(320, 240));
  EXPECT_EQ(MaxDifference(texture, GenerateBackgroundTexture(320, 240, 5)), 0.0);
  EXPECT_GT(MaxDifference(texture, GenerateBackgroundTexture(320, 240, 6)), 10.0);
  // Textured everywhere: no large flat areas, intensities leave room for noise.
  cv::Mat grey;
  cv::cvtColor(texture, grey, cv::COLOR_BGR2GRAY);
  cv::Scalar mean;
  cv::Scalar deviation;
  cv::meanStdDev(grey, mean, deviation);
  EXPECT_GT(deviation[0], 8.0);
  double low = 0.0;
  double high = 0.0;
  cv::minMaxLoc(grey, &low, &high);
  EXPECT_GE(low, 15.0);
  EXPECT_LE(high, 235.0);
  // The table (lower part) differs from the wall (upper part).
  const cv::Scalar wall = cv::mean(texture.rowRange(0, 80));
  const cv::Scalar table = cv::mean(texture.rowRange(160, 240));
  EXPECT_GT(std::abs(wall[0] - table[0]), 20.0);
  EXPECT_THROW(GenerateBackgroundTexture(0, 10, 1), Error);
}

TEST(FitBackground, ScalesToCoverAndCropsTheCentre) {
  // 400 x 100: columns 0..119 black, the rest white, a red band 198..201 at the centre.
  cv::Mat image(100, 400, CV_8UC3, cv::Scalar::all(255));
  image.colRange(0, 120).setTo(cv::Scalar::all(0));
  image.colRange(198, 202).setTo(cv::Scalar(0, 0, 255));
  // To 100 x 50: scaled by 1/2 to 200 x 50 (black to column 59, red at 99 and 100), then the
  // centre 100 columns (50..149) kept.
  const cv::Mat fitted = FitBackground(image, 100, 50);
  ASSERT_EQ(fitted.size(), cv::Size(100, 50));
  ASSERT_EQ(fitted.type(), CV_8UC3);
  EXPECT_EQ(fitted.at<cv::Vec3b>(25, 0), cv::Vec3b(0, 0, 0));         // column 50: black
  EXPECT_EQ(fitted.at<cv::Vec3b>(25, 99), cv::Vec3b(255, 255, 255));  // column 149: white
  EXPECT_GT(fitted.at<cv::Vec3b>(25, 49)[2], 200);                    // the red column
  EXPECT_LT(fitted.at<cv::Vec3b>(25, 49)[1], 100);
  // Enlarging: 40 x 10 to 160 x 120 scales by 12 and crops the width.
  EXPECT_EQ(FitBackground(cv::Mat(10, 40, CV_8UC3, cv::Scalar(1, 2, 3)), 160, 120).size(),
            cv::Size(160, 120));
  EXPECT_THROW(FitBackground(cv::Mat(), 10, 10), Error);
  EXPECT_THROW(FitBackground(cv::Mat(10, 10, CV_8UC1), 10, 10), Error);
}

TEST(ReadBackgroundImage, ReadsImagesAndNamesMissingFiles) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("silpose_background_" + std::to_string(::getpid()) + ".png");
  cv::Mat grey(20, 30, CV_8UC1, cv::Scalar(77));
  ASSERT_TRUE(cv::imwrite(path.string(), grey));
  const cv::Mat image = ReadBackgroundImage(path);
  std::filesystem::remove(path);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.at<cv::Vec3b>(5, 5), cv::Vec3b(77, 77, 77));
  try {
    ReadBackgroundImage("/nonexistent/wall.png");
    FAIL() << "no exception";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/wall.png"), std::string::npos);
  }
}

TEST(ApplyCameraEffects, NoiseHasTheAskedDeviationAndIsReproduciblePerFrame) {
  const cv::Mat clean(240, 320, CV_8UC3, cv::Scalar(100, 120, 140));
  ColourOptions options;
  options.noise_sigma = 6.0;
  options.seed = 9;
  cv::Mat noisy = clean.clone();
  ApplyCameraEffects(options, 3, &noisy);
  double mean = 0.0;
  double deviation = 0.0;
  DifferenceStatistics(noisy, clean, &mean, &deviation);
  EXPECT_NEAR(mean, 0.0, 0.05);
  // Rounding to integers adds 1/12 to the variance.
  EXPECT_NEAR(deviation, std::sqrt(36.0 + 1.0 / 12.0), 0.1);
  cv::Mat again = clean.clone();
  ApplyCameraEffects(options, 3, &again);
  EXPECT_EQ(MaxDifference(noisy, again), 0.0);
  cv::Mat other_frame = clean.clone();
  ApplyCameraEffects(options, 4, &other_frame);
  EXPECT_GT(MaxDifference(noisy, other_frame), 0.0);
  // Off: unchanged.
  cv::Mat untouched = clean.clone();
  ApplyCameraEffects(ColourOptions{}, 3, &untouched);
  EXPECT_EQ(MaxDifference(untouched, clean), 0.0);
}

TEST(ApplyCameraEffects, FlickerScalesWholeFramesWithinItsAmplitude) {
  const cv::Mat clean(20, 20, CV_8UC3, cv::Scalar::all(100));
  ColourOptions options;
  options.flicker = 0.2;
  double lowest = 255.0;
  double highest = 0.0;
  for (int frame = 0; frame < 40; ++frame) {
    cv::Mat image = clean.clone();
    ApplyCameraEffects(options, frame, &image);
    double low = 0.0;
    double high = 0.0;
    cv::minMaxLoc(image.reshape(1), &low, &high);
    EXPECT_EQ(low, high) << "a global change, the same for every pixel";
    EXPECT_GE(low, 80.0);
    EXPECT_LE(high, 120.0);
    lowest = std::min(lowest, low);
    highest = std::max(highest, high);
  }
  EXPECT_LT(lowest, 90.0);
  EXPECT_GT(highest, 110.0);
}

TEST(ColourOptions, CheckNamesTheInvalidField) {
  std::string error;
  EXPECT_TRUE(ColourOptions{}.Check(&error)) << error;
  ColourOptions options;
  options.noise_sigma = -1.0;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("noise"), std::string::npos) << error;
  options = {};
  options.flicker = 0.9;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("flicker"), std::string::npos) << error;
  options = {};
  options.object_colours_bgr = {{0, 0, 0}, {0, 256, 0}};
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("object colour 2"), std::string::npos) << error;
  options = {};
  options.background_image = cv::Mat(4, 4, CV_8UC1);
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("background"), std::string::npos) << error;
}

TEST(ColourSequence, FramesShowTheObjectOverTheBackgroundExactlyOnItsSilhouette) {
  const SyntheticSequence sequence({Model("bunny")}, ColourOrbit(6));
  ASSERT_TRUE(sequence.has_colour());
  const cv::Mat& background = sequence.background();
  ASSERT_EQ(background.size(), cv::Size(160, 120));
  for (int k = 0; k < sequence.num_frames(); ++k) {
    const SyntheticFrame frame = sequence.Generate(k);
    ASSERT_EQ(frame.colour.type(), CV_8UC3);
    ASSERT_EQ(frame.colour.size(), cv::Size(160, 120));
    cv::Mat silhouette;
    RenderSilhouette(Model("bunny"), sequence.camera(), frame.truth.camera_from_object,
                     &silhouette);
    EXPECT_EQ(MaxDifference(frame.mask, silhouette), 0.0) << k;
    cv::Mat changed;
    cv::absdiff(frame.colour, background, changed);
    cv::cvtColor(changed, changed, cv::COLOR_BGR2GRAY);
    cv::Mat outside_changed;
    cv::bitwise_and(changed, ~silhouette, outside_changed);
    EXPECT_EQ(cv::countNonZero(outside_changed), 0) << k;
    // The blue bunny stands out: most of its pixels differ clearly from the background.
    cv::Mat clearly_changed = changed > 20;
    cv::bitwise_and(clearly_changed, silhouette, clearly_changed);
    EXPECT_GT(cv::countNonZero(clearly_changed), cv::countNonZero(silhouette) * 8 / 10) << k;
  }
}

TEST(ColourSequence, FramesDoNotDependOnTheGenerationOrder) {
  SequenceOptions options = ColourOrbit(8);
  options.colour.noise_sigma = 4.0;
  options.colour.flicker = 0.1;
  const SyntheticSequence forward({Model("bunny")}, options);
  const SyntheticSequence backward({Model("bunny")}, options);
  std::vector<cv::Mat> frames(8);
  SyntheticFrame reused;
  for (int k = 0; k < 8; ++k) {
    forward.Generate(k, &reused);
    frames[static_cast<size_t>(k)] = reused.colour.clone();
  }
  for (int k = 7; k >= 0; --k) {
    backward.Generate(k, &reused);
    EXPECT_EQ(MaxDifference(reused.colour, frames[static_cast<size_t>(k)]), 0.0) << k;
  }
  EXPECT_GT(MaxDifference(frames[0], frames[1]), 0.0);
}

TEST(ColourSequence, CameraNoiseHasTheAskedDeviation) {
  SequenceOptions options = ColourOrbit(3);
  const SyntheticSequence clean({Model("bunny")}, options);
  options.colour.noise_sigma = 5.0;
  const SyntheticSequence noisy({Model("bunny")}, options);
  for (int k = 0; k < 3; ++k) {
    const SyntheticFrame clean_frame = clean.Generate(k);
    const SyntheticFrame noisy_frame = noisy.Generate(k);
    double mean = 0.0;
    double deviation = 0.0;
    DifferenceStatistics(noisy_frame.colour, clean_frame.colour, &mean, &deviation);
    EXPECT_NEAR(mean, 0.0, 0.1) << k;
    EXPECT_NEAR(deviation, 5.0, 0.25) << k;
    // The noise is only in the picture: the mask stays the clean silhouette.
    EXPECT_EQ(MaxDifference(noisy_frame.mask, clean_frame.mask), 0.0) << k;
  }
}

TEST(ColourSequence, MaskDegradationsLeaveTheColourFramesAlone) {
  SequenceOptions options = ColourOrbit(4);
  const SyntheticSequence plain({Model("bunny")}, options);
  options.degradation.erode_px = 3;
  options.degradation.occluders = 2;
  const SyntheticSequence degraded({Model("bunny")}, options);
  for (int k = 0; k < 4; ++k) {
    const SyntheticFrame a = plain.Generate(k);
    const SyntheticFrame b = degraded.Generate(k);
    EXPECT_EQ(MaxDifference(a.colour, b.colour), 0.0) << k;
    EXPECT_LT(cv::countNonZero(b.mask), cv::countNonZero(a.mask)) << k;
  }
}

TEST(ColourSequence, ObjectColoursDefaultToDistinctOnesOrFollowTheOptions) {
  std::vector<TriangleMesh> models = {Model("bunny"), Model("hand")};
  SequenceOptions options = ColourOrbit(4);
  const SyntheticSequence defaults(models, options);
  EXPECT_EQ(defaults.object_colour_bgr(0), DefaultObjectColour(0));
  EXPECT_EQ(defaults.object_colour_bgr(1), DefaultObjectColour(1));
  EXPECT_GT((DefaultObjectColour(0) - DefaultObjectColour(1)).norm(), 100.0);
  options.colour.object_colours_bgr = {{10, 20, 30}};
  const SyntheticSequence one(models, options);
  EXPECT_EQ(one.object_colour_bgr(1), Eigen::Vector3d(10, 20, 30));
  options.colour.object_colours_bgr = {{10, 20, 30}, {1, 2, 3}, {4, 5, 6}};
  EXPECT_THROW(SyntheticSequence(models, options), Error);
}

TEST(ColourSequence, BackgroundImageIsFittedToTheCamera) {
  SequenceOptions options = ColourOrbit(2);
  options.colour.background_image = cv::Mat(300, 200, CV_8UC3, cv::Scalar(90, 60, 30));
  const SyntheticSequence sequence({Model("bunny")}, options);
  ASSERT_EQ(sequence.background().size(), cv::Size(160, 120));
  const SyntheticFrame frame = sequence.Generate(0);
  EXPECT_EQ(frame.colour.at<cv::Vec3b>(0, 0), cv::Vec3b(90, 60, 30));
}

TEST(ColourSequence, WriteSequenceWritesFramesAndFeedsTheSinkInOrder) {
  const auto folder = std::filesystem::temp_directory_path() /
                      ("silpose_colour_sequence_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  SequenceOptions options = ColourOrbit(40);
  options.colour.noise_sigma = 3.0;
  const SyntheticSequence sequence({Model("bunny")}, options);
  std::vector<int> order;
  std::vector<cv::Mat> received;
  SequenceWriteOptions write;
  write.num_threads = 2;
  write.colour_frame_sink = [&](int frame, const cv::Mat& colour) {
    order.push_back(frame);
    received.push_back(colour.clone());
  };
  const SequenceSummary summary = WriteSequence(sequence, folder, write);
  EXPECT_TRUE(summary.colour);
  EXPECT_NE(summary.BriefReport().find("colour"), std::string::npos);
  ASSERT_EQ(order.size(), 40u);
  for (int k = 0; k < 40; ++k) {
    EXPECT_EQ(order[static_cast<size_t>(k)], k);
    const cv::Mat expected = sequence.Generate(k).colour;
    EXPECT_EQ(MaxDifference(received[static_cast<size_t>(k)], expected), 0.0) << k;
    const cv::Mat written = cv::imread(SequenceFramePath(folder, k).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(written.type(), CV_8UC3) << k;
    EXPECT_EQ(MaxDifference(written, expected), 0.0) << k;
  }
  EXPECT_FALSE(std::filesystem::exists(SequenceFramePath(folder, 40)));

  // Replacing it with a sequence without colour removes the old frames.
  SequenceOptions no_colour = ColourOrbit(5);
  no_colour.colour.enabled = false;
  EXPECT_THROW(WriteSequence(SyntheticSequence({Model("bunny")}, no_colour), folder), Error);
  SequenceWriteOptions overwrite;
  overwrite.overwrite = true;
  const SequenceSummary replaced =
      WriteSequence(SyntheticSequence({Model("bunny")}, no_colour), folder, overwrite);
  EXPECT_FALSE(replaced.colour);
  EXPECT_FALSE(std::filesystem::exists(SequenceFramePath(folder, 0)));
  EXPECT_TRUE(std::filesystem::exists(SequenceMaskPath(folder, 4)));
  // A sink needs colour.
  overwrite.colour_frame_sink = [](int, const cv::Mat&) {};
  EXPECT_THROW(WriteSequence(SyntheticSequence({Model("bunny")}, no_colour), folder, overwrite),
               Error);
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace silpose
