// `silpose synth --colour`: shaded colour frames next to the masks, for testing segmentation.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliSynthColourTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_synth_colour_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    models_ = std::string(SILPOSE_SAMPLE_MODELS_DIR);
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static int CountPngs(const std::filesystem::path& folder) {
    if (!std::filesystem::is_directory(folder)) return 0;
    int count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      count += entry.path().extension() == ".png";
    }
    return count;
  }

  static cv::Mat ReadImage(const std::string& sequence, const char* kind, int frame) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", frame);
    return cv::imread((std::filesystem::path(sequence) / kind / name).string(),
                      cv::IMREAD_UNCHANGED);
  }

  static inline std::filesystem::path directory_;
  static inline std::string models_;
};

TEST_F(CliSynthColourTest, WritesOneColourFramePerMaskOfTheCameraSize) {
  const std::string sequence = Path("colour");
  const CommandResult run = Silpose("synth " + models_ + "/bunny.obj -o " + sequence +
                                    " --colour --frames 12 --step-deg 30 --camera-noise 3");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("colour frames"), std::string::npos) << run.out;
  EXPECT_EQ(CountPngs(std::filesystem::path(sequence) / "frames"), 12);
  EXPECT_EQ(CountPngs(std::filesystem::path(sequence) / "masks"), 12);
  for (int frame = 0; frame < 12; frame += 5) {
    const cv::Mat colour = ReadImage(sequence, "frames", frame);
    const cv::Mat mask = ReadImage(sequence, "masks", frame);
    ASSERT_EQ(colour.type(), CV_8UC3) << frame;
    EXPECT_EQ(colour.size(), cv::Size(640, 480)) << frame;
    ASSERT_EQ(mask.size(), colour.size()) << frame;
    // The first model is blue by default: its pixels are bluer than the background's.
    const cv::Scalar object = cv::mean(colour, mask);
    const cv::Scalar background = cv::mean(colour, mask == 0);
    EXPECT_GT(object[0] - object[2], 60.0) << frame;
    EXPECT_LT(background[0] - background[2], 20.0) << frame;
  }
}

TEST_F(CliSynthColourTest, FramesTakeTheCameraSizeTheBackgroundAndTheObjectColour) {
  const std::string camera = Path("small_camera.yml");
  {
    cv::FileStorage file(camera, cv::FileStorage::WRITE);
    file << "image_width" << 320 << "image_height" << 240;
    file << "camera_matrix" << (cv::Mat_<double>(3, 3) << 260, 0, 159.5, 0, 260, 119.5, 0, 0, 1);
    file << "distortion_coefficients" << cv::Mat::zeros(1, 5, CV_64F);
  }
  const std::string background = Path("plain.png");
  ASSERT_TRUE(cv::imwrite(background, cv::Mat(90, 100, CV_8UC3, cv::Scalar(30, 60, 90))));
  const std::string sequence = Path("plain_background");
  const CommandResult run =
      Silpose("synth " + models_ + "/hand.obj -o " + sequence + " --camera " + camera +
              " --colour --frames 3 --background " + background + " --object-colour 0,0,255");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_EQ(CountPngs(std::filesystem::path(sequence) / "frames"), 3);
  const cv::Mat colour = ReadImage(sequence, "frames", 1);
  const cv::Mat mask = ReadImage(sequence, "masks", 1);
  ASSERT_EQ(colour.size(), cv::Size(320, 240));
  ASSERT_GT(cv::countNonZero(mask), 1000);
  // Outside the object: the background image, untouched (no noise asked for).
  int outside_changed = 0;
  for (int v = 0; v < colour.rows; ++v) {
    for (int u = 0; u < colour.cols; ++u) {
      outside_changed +=
          mask.at<uint8_t>(v, u) == 0 && colour.at<cv::Vec3b>(v, u) != cv::Vec3b(30, 60, 90);
    }
  }
  EXPECT_EQ(outside_changed, 0);
  // The object: red.
  const cv::Scalar object = cv::mean(colour, mask);
  EXPECT_GT(object[2], 100.0);
  EXPECT_EQ(object[0], 0.0);
  EXPECT_EQ(object[1], 0.0);
}

TEST_F(CliSynthColourTest, FramesAreReproducible) {
  const std::string arguments =
      "synth " + models_ + "/bunny.obj --colour --frames 4 --camera-noise 5 --flicker 0.1";
  ASSERT_EQ(Silpose(arguments + " -o " + Path("first") + " --threads 1").exit_code, 0);
  ASSERT_EQ(Silpose(arguments + " -o " + Path("second") + " --threads 2").exit_code, 0);
  for (int frame = 0; frame < 4; ++frame) {
    EXPECT_EQ(cv::norm(ReadImage(Path("first"), "frames", frame),
                       ReadImage(Path("second"), "frames", frame), cv::NORM_INF),
              0.0)
        << frame;
  }
}

TEST_F(CliSynthColourTest, ColourOptionsNeedColourAndValidValues) {
  const std::string model = models_ + "/bunny.obj --frames 2 -o " + Path("refused");
  for (const char* option :
       {"--camera-noise 3", "--flicker 0.1", "--object-colour 1,2,3", "--background x.png"}) {
    const CommandResult run = Silpose("synth " + model + " " + option);
    EXPECT_NE(run.exit_code, 0) << option;
    EXPECT_NE(run.err.find("needs --colour"), std::string::npos) << option << ": " << run.err;
  }
  const CommandResult bad_colour = Silpose("synth " + model + " --colour --object-colour 1,2");
  EXPECT_NE(bad_colour.exit_code, 0);
  EXPECT_NE(bad_colour.err.find("--object-colour"), std::string::npos) << bad_colour.err;
  const CommandResult bad_noise = Silpose("synth " + model + " --colour --camera-noise -1");
  EXPECT_NE(bad_noise.exit_code, 0);
  EXPECT_NE(bad_noise.err.find("noise"), std::string::npos) << bad_noise.err;
  const CommandResult missing =
      Silpose("synth " + model + " --colour --background " + Path("missing.png"));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("missing.png"), std::string::npos) << missing.err;
  EXPECT_EQ(Lines(missing.err), 1) << missing.err;
}

TEST_F(CliSynthColourTest, WithoutColourThereAreNoFramesAndOverwritingRemovesOldOnes) {
  const std::string sequence = Path("replaced");
  ASSERT_EQ(
      Silpose("synth " + models_ + "/bunny.obj -o " + sequence + " --colour --frames 3").exit_code,
      0);
  ASSERT_EQ(CountPngs(std::filesystem::path(sequence) / "frames"), 3);
  const CommandResult refused =
      Silpose("synth " + models_ + "/bunny.obj -o " + sequence + " --frames 2");
  EXPECT_NE(refused.exit_code, 0);
  const CommandResult replaced =
      Silpose("synth " + models_ + "/bunny.obj -o " + sequence + " --frames 2 --overwrite");
  ASSERT_EQ(replaced.exit_code, 0) << replaced.err;
  EXPECT_EQ(CountPngs(std::filesystem::path(sequence) / "frames"), 0);
  EXPECT_EQ(CountPngs(std::filesystem::path(sequence) / "masks"), 2);
}

}  // namespace
}  // namespace silpose
