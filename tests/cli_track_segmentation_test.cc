// `silpose track` segmentation as a user tunes it: background learning that needs no knowledge of
// how long the scene is empty (the default), --masks-out, the segmentation options and --config.
//
// The video: the empty scene for 15 frames (the synth sequence's background with camera noise),
// then the object. Held out: the sample model and seed here (elephant, seed 11) were not used
// while the until-object learning was developed (that used the bunny, seed 3, and the unit tests'
// synthetic scene).

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "silpose/io/video_writer.h"

namespace silpose {
namespace {

constexpr const char* kObject = "elephant";
constexpr int kEmptyFrames = 15;
constexpr int kObjectFrames = 60;
constexpr int kFrames = kEmptyFrames + kObjectFrames;

// Share of the object frames (from the first frame with the object on) whose row names `object`.
struct Rate {
  int frames = 0;
  int right = 0;
  double Percent() const { return frames == 0 ? 0.0 : 100.0 * right / frames; }
};
Rate RightObject(const std::string& poses, const std::string& object) {
  const std::vector<std::string> rows = ReadLines(poses);
  Rate rate;
  for (size_t r = 1; r < rows.size(); ++r) {
    const std::vector<std::string> fields = CsvCells(rows[r]);
    if (fields.size() < 2 || std::stoi(fields[0]) < kEmptyFrames) continue;
    ++rate.frames;
    rate.right += fields[1] == object;
  }
  return rate;
}

class CliTrackSegmentationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_track_segmentation_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
    database_ = Path("five.db");
    CommandResult run = Silpose("build-db " + models + "/anchor.obj " + models + "/bunny.obj " +
                                models + "/cow.obj " + models + "/elephant.obj " + models +
                                "/hand.obj -o " + database_ + " --views 300 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    sequence_ = Path("sequence");
    run = Silpose("synth " + models + "/elephant.obj -o " + sequence_ + " --frames " +
                  std::to_string(kObjectFrames) +
                  " --trajectory walk --colour --camera-noise 3 --seed 11 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    // The video a camera records: the empty scene, then the object walking in front of it.
    const cv::Mat background = cv::imread(sequence_ + "/background.png", cv::IMREAD_COLOR);
    ASSERT_FALSE(background.empty());
    video_ = Path("late_object.avi");
    auto writer = OpenVideoWriter(video_, background.size(), 30.0);
    cv::RNG random(11);
    cv::Mat noise(background.size(), CV_16SC3);
    for (int t = 0; t < kEmptyFrames; ++t) {
      random.fill(noise, cv::RNG::NORMAL, 0.0, 3.0);
      cv::Mat frame;
      cv::add(background, noise, frame, cv::noArray(), CV_8U);
      writer->Write(frame);
    }
    for (int t = 0; t < kObjectFrames; ++t) {
      char name[32];
      std::snprintf(name, sizeof(name), "/frames/%06d.png", t);
      const cv::Mat frame = cv::imread(sequence_ + name, cv::IMREAD_COLOR);
      ASSERT_FALSE(frame.empty()) << name;
      writer->Write(frame);
    }
    writer->Close();
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }
  static std::string Track(const std::string& options) {
    return "track -d " + database_ + " " + video_ + " --camera " + sequence_ + "/camera.yml " +
           options;
  }

  static inline std::filesystem::path directory_;
  static inline std::string database_;
  static inline std::string sequence_;
  static inline std::string video_;
};

TEST_F(CliTrackSegmentationTest, ObjectAfterFifteenEmptyFramesIsFoundWithDefaultOptions) {
  const std::string poses = Path("default.csv");
  const CommandResult run =
      Silpose(Track("--segment bgsub -o " + poses + " --masks-out " + Path("masks")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Rate rate = RightObject(poses, kObject);
  std::printf("[ default  ] right object %.1f %% of %d frames\n", rate.Percent(), rate.frames);
  EXPECT_EQ(rate.frames, kObjectFrames);
  EXPECT_GE(rate.Percent(), 98.0);

  // --masks-out: one PNG per frame, named by the frame's index; black while learning, the object
  // afterwards.
  int pngs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(Path("masks"))) {
    pngs += entry.path().extension() == ".png";
  }
  EXPECT_EQ(pngs, kFrames);
  const cv::Mat learning = cv::imread(Path("masks") + "/000005.png", cv::IMREAD_UNCHANGED);
  const cv::Mat object = cv::imread(Path("masks") + "/000030.png", cv::IMREAD_UNCHANGED);
  const cv::Mat truth = cv::imread(sequence_ + "/masks/000015.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(learning.type(), CV_8UC1);
  ASSERT_EQ(object.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(learning), 0);
  ASSERT_FALSE(truth.empty());
  const double overlap = cv::countNonZero(object & truth);
  const double either = cv::countNonZero(object | truth);
  EXPECT_GE(overlap / either, 0.8) << "IoU of frame 30's mask with the truth";
}

// The one-Gaussian background model on the same video, learned the default way: the object is
// found as with MOG2, and frame 30's mask matches the rendered one as well.
TEST_F(CliTrackSegmentationTest, GaussianBackgroundFindsTheObjectAsMog2Does) {
  const std::string poses = Path("gauss.csv");
  const CommandResult run = Silpose(Track("--segment bgsub --bg-method gauss -o " + poses +
                                          " --masks-out " + Path("gauss_masks")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Rate rate = RightObject(poses, kObject);
  std::printf("[ gauss    ] right object %.1f %% of %d frames\n", rate.Percent(), rate.frames);
  EXPECT_EQ(rate.frames, kObjectFrames);
  EXPECT_GE(rate.Percent(), 98.0);
  const cv::Mat learning = cv::imread(Path("gauss_masks") + "/000005.png", cv::IMREAD_UNCHANGED);
  const cv::Mat object = cv::imread(Path("gauss_masks") + "/000030.png", cv::IMREAD_UNCHANGED);
  const cv::Mat truth = cv::imread(sequence_ + "/masks/000015.png", cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(learning.empty());
  ASSERT_FALSE(object.empty());
  ASSERT_FALSE(truth.empty());
  EXPECT_EQ(cv::countNonZero(learning), 0);
  const double overlap = cv::countNonZero(object & truth);
  const double either = cv::countNonZero(object | truth);
  EXPECT_GE(overlap / either, 0.8) << "IoU of frame 30's mask with the truth";
}

TEST_F(CliTrackSegmentationTest, LearningTheFirstThirtyFramesAbsorbsTheObject) {
  // What until-object fixes: the frames mode learns frames 15..29 too, the object with them.
  const std::string poses = Path("frames.csv");
  const CommandResult run = Silpose(Track("--segment bgsub --bg-learning frames -o " + poses));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Rate rate = RightObject(poses, kObject);
  std::printf("[ frames   ] right object %.1f %% of %d frames\n", rate.Percent(), rate.frames);
  EXPECT_LT(rate.Percent(), 90.0);
  // Learning exactly the empty frames works in that mode.
  const std::string exact = Path("frames15.csv");
  ASSERT_EQ(Silpose(Track("--segment bgsub --bg-learning frames --learning-frames 15 -o " + exact))
                .exit_code,
            0);
  EXPECT_GE(RightObject(exact, kObject).Percent(), 98.0);
}

TEST_F(CliTrackSegmentationTest, ConfigFileGivesTheSameResultAsTheCommandLine) {
  const std::string config = Path("track.toml");
  {
    std::ofstream file(config);
    file << "# tuned options\n"
         << "database = \"" << database_ << "\"\n"
         << "camera = \"" << sequence_ << "/camera.yml\"\n"
         << "output = \"" << Path("from_config.csv") << "\"\n"
         << "segment = \"bgsub\"\n"
         << "bg-learning = \"frames\"\n"
         << "learning-frames = 15\n"
         << "mog2-threshold = 12.5\n"
         << "min-area = 0.002\n";
  }
  CommandResult run = Silpose("track --config " + config + " " + video_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  run = Silpose(Track("-o " + Path("from_line.csv") +
                      " --segment bgsub --bg-learning frames --learning-frames 15 "
                      "--mog2-threshold 12.5 --min-area 0.002"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> a = ReadLines(Path("from_config.csv"));
  const std::vector<std::string> b = ReadLines(Path("from_line.csv"));
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), static_cast<size_t>(kFrames + 1));
  ASSERT_EQ(a[0], b[0]);
  const std::vector<std::string> header = CsvCells(a[0]);
  for (size_t r = 1; r < a.size(); ++r) {
    // The same row but for the time columns (time_ms and time_*_ms).
    const std::vector<std::string> x = CsvCells(a[r]), y = CsvCells(b[r]);
    ASSERT_EQ(x.size(), header.size()) << r;
    ASSERT_EQ(y.size(), header.size()) << r;
    for (size_t c = 0; c < header.size(); ++c) {
      if (header[c].starts_with("time_")) continue;
      EXPECT_EQ(x[c], y[c]) << "row " << r << ", " << header[c];
    }
  }
  // The command line wins over the file: learning 30 frames instead of 15.
  run = Silpose("track --config " + config + " " + video_ + " --learning-frames 30 -o " +
                Path("override.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> rows = ReadLines(Path("override.csv"));
  ASSERT_GT(rows.size(), 30u);
  EXPECT_NE(rows[25].find("learning"), std::string::npos) << rows[25];
  EXPECT_EQ(a[25].find("learning"), std::string::npos) << a[25];
}

TEST_F(CliTrackSegmentationTest, BadSegmentationOptionsAndConfigFilesAreOneClearLine) {
  const std::string bad_config = Path("bad.toml");
  {
    std::ofstream file(bad_config);
    file << "segment = \"bgsub\"\nmog2-threshhold = 9\n";
  }
  const std::string base = Track("-o " + Path("bad.csv") + " ");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--segment bgsub --bg-learning sometimes", "sometimes"},
      {"--segment bgsub --min-learning-frames 0", "min_learning_frames"},
      {"--segment bgsub --confirm-frames 0", "object_confirm_frames"},
      {"--segment bgsub --learning-rate 1.5", "learning_rate"},
      {"--segment bgsub --mog2-threshold -1", "mog2_variance_threshold"},
      {"--segment bgsub --bg-method gauss --gauss-threshold 0", "gauss_variance_threshold"},
      {"--segment bgsub --bg-method gaussian", "gaussian"},
      {"--gauss-threshold 9", "--gauss-threshold"},
      {"--segment bgsub --min-area 1", "min_area_fraction"},
      {"--segment bgsub --max-foreground 0", "max_foreground_fraction"},
      {"--mog2-threshold 9", "--mog2-threshold"},
      {"--segment threshold --bg-learning frames", "--bg-learning"},
      {"--segment mask --no-shadows", "--no-shadows"},
      {"--config " + Path("missing.toml"), "missing.toml"},
      {"--config " + bad_config, "mog2-threshhold"},
  };
  for (const auto& [options, named] : cases) {
    const CommandResult run = Silpose(base + options);
    EXPECT_NE(run.exit_code, 0) << options;
    EXPECT_EQ(Lines(run.err), 1) << options << ": " << run.err;
    EXPECT_NE(run.err.find(named), std::string::npos) << options << ": " << run.err;
  }
}

}  // namespace
}  // namespace silpose
