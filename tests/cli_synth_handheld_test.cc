// `silpose synth --trajectory handheld`: an object turned by hand in front of a static camera.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliSynthHandheldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_synth_handheld_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    models_ = std::string(SILPOSE_SAMPLE_MODELS_DIR);
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  // groundtruth.csv as rows of fields, the header first.
  static std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream file(path);
    for (std::string line; std::getline(file, line);) {
      std::vector<std::string> fields;
      std::stringstream stream(line);
      for (std::string field; std::getline(stream, field, ',');) fields.push_back(field);
      rows.push_back(fields);
    }
    return rows;
  }

  static size_t Column(const std::vector<std::string>& header, const std::string& name) {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }

  static inline std::filesystem::path directory_;
  static inline std::string models_;
};

TEST_F(CliSynthHandheldTest, WritesAnOffAxisSequenceWithinTheGivenRanges) {
  const std::string sequence = Path("hand");
  const CommandResult run =
      Silpose("synth " + models_ + "/bunny.obj -o " + sequence +
              " --trajectory handheld --frames 30 --seed 3 --speed-range 5,20 "
              "--distance-range 5,8 --max-off-axis-deg 15 --cut-probability 0 --threads 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("handheld trajectory"), std::string::npos) << run.out;
  EXPECT_EQ(run.err.find("cut by the image border"), std::string::npos) << run.err;
  const std::vector<std::vector<std::string>> rows = ReadCsv(sequence + "/groundtruth.csv");
  ASSERT_EQ(rows.size(), 31u);
  const std::vector<std::string>& header = rows[0];
  const size_t distance = Column(header, "distance");
  const size_t off_axis = Column(header, "off_axis_deg");
  const size_t ray_z = Column(header, "centre_ray_z");
  double widest = 0.0;
  for (size_t k = 1; k < rows.size(); ++k) {
    ASSERT_EQ(rows[k].size(), header.size());
    const double d = std::stod(rows[k][distance]);
    EXPECT_GE(d, 5.0);
    EXPECT_LE(d, 8.0);
    const double angle = std::stod(rows[k][off_axis]);
    EXPECT_LE(angle, 15.0 + 1e-9);
    EXPECT_NEAR(std::cos(angle * std::numbers::pi / 180.0), std::stod(rows[k][ray_z]), 1e-9);
    widest = std::max(widest, angle);
    // Every mask is there and shows the object.
    char name[32];
    std::snprintf(name, sizeof(name), "/masks/%06zu.png", k - 1);
    const cv::Mat mask = cv::imread(sequence + name, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(mask.empty()) << name;
    EXPECT_GT(cv::countNonZero(mask), 500) << name;
  }
  EXPECT_GT(widest, 1.0);  // off the axis
  // The same seed gives the same sequence.
  const std::string again = Path("hand_again");
  ASSERT_EQ(Silpose("synth " + models_ + "/bunny.obj -o " + again +
                    " --trajectory handheld --frames 30 --seed 3 --speed-range 5,20 "
                    "--distance-range 5,8 --max-off-axis-deg 15 --cut-probability 0")
                .exit_code,
            0);
  EXPECT_EQ(ReadCsv(again + "/groundtruth.csv"), rows);
}

TEST_F(CliSynthHandheldTest, BadOrMisplacedOptionsGiveOneLineNamingTheOption) {
  const std::string model = models_ + "/bunny.obj";
  const struct {
    std::string arguments;
    std::string option;
  } cases[] = {
      {"--trajectory handheld --speed-range 10,5", "--speed-range"},
      {"--trajectory handheld --speed-range 0,60", "--speed-range"},
      {"--trajectory handheld --cut-probability 1.5", "--cut-probability"},
      {"--trajectory handheld --pause-probability -1", "--pause-probability"},
      {"--trajectory handheld --reverse-probability 2", "--reverse-probability"},
      {"--trajectory handheld --distance-range 1,3", "--distance-range"},
      {"--trajectory handheld --max-off-axis-deg 80", "--max-off-axis-deg"},
      {"--trajectory handheld --tilt-deg 10", "--tilt-deg"},
      {"--trajectory handheld --step-deg 3", "--step-deg"},
      {"--trajectory walk --speed-range 1,2", "--speed-range"},
      {"--cut-probability 0.1", "--cut-probability"},
  };
  for (const auto& c : cases) {
    const CommandResult run =
        Silpose("synth " + model + " -o " + Path("bad") + " --frames 3 " + c.arguments);
    EXPECT_NE(run.exit_code, 0) << c.arguments;
    EXPECT_EQ(Lines(run.err), 1) << c.arguments << ": " << run.err;
    EXPECT_NE(run.err.find(c.option), std::string::npos) << c.arguments << ": " << run.err;
  }
  EXPECT_FALSE(std::filesystem::exists(Path("bad") + "/groundtruth.csv"));
}

TEST_F(CliSynthHandheldTest, ThresholdMaskQualityDegradesTheMasksAndRecordsTheEffects) {
  const std::string perfect = Path("perfect");
  const std::string threshold = Path("threshold");
  const std::string common = "synth " + models_ + "/bunny.obj --trajectory handheld --frames 6 " +
                             "--seed 4 --distance-range 4,5 -o ";
  ASSERT_EQ(Silpose(common + perfect).exit_code, 0);
  const CommandResult run = Silpose(common + threshold + " --mask-quality threshold --stick");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::vector<std::string>> rows = ReadCsv(threshold + "/groundtruth.csv");
  ASSERT_EQ(rows.size(), 7u);
  const size_t degradation = Column(rows[0], "degradation");
  for (size_t k = 1; k < rows.size(); ++k) {
    EXPECT_EQ(rows[k][degradation], "shadow+stick+fingers+ragged+holes+specks") << k;
    char name[32];
    std::snprintf(name, sizeof(name), "/masks/%06zu.png", k - 1);
    const cv::Mat truth = cv::imread(perfect + name, cv::IMREAD_GRAYSCALE);
    const cv::Mat mask = cv::imread(threshold + name, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(truth.empty());
    ASSERT_FALSE(mask.empty());
    const double iou =
        static_cast<double>(cv::countNonZero(truth & mask)) / cv::countNonZero(truth | mask);
    EXPECT_GT(iou, 0.7) << name;  // the stick on top of the preset
    EXPECT_LT(iou, 0.95) << name;
  }
  // The perfect masks carry no effect.
  const std::vector<std::vector<std::string>> clean = ReadCsv(perfect + "/groundtruth.csv");
  EXPECT_EQ(clean[1][Column(clean[0], "degradation")], "none");

  for (const auto& [arguments, option] :
       std::vector<std::pair<std::string, std::string>>{{"--mask-quality good", "--mask-quality"},
                                                        {"--holes 500", "--holes"},
                                                        {"--ragged 50", "--ragged"},
                                                        {"--fingers 9", "--fingers"},
                                                        {"--shadow 2", "--shadow"}}) {
    const CommandResult bad = Silpose(common + Path("bad_quality") + " " + arguments);
    EXPECT_NE(bad.exit_code, 0) << arguments;
    EXPECT_EQ(Lines(bad.err), 1) << arguments << ": " << bad.err;
    EXPECT_NE(bad.err.find(option), std::string::npos) << arguments << ": " << bad.err;
  }
}

TEST_F(CliSynthHandheldTest, PassingOccludersCoverRunsOfFramesRecordedInTheGroundTruth) {
  const std::string out = Path("passing");
  const std::string common = "synth " + models_ + "/bunny.obj --trajectory handheld --frames 80 " +
                             "--seed 6 --distance-range 4,5 -o ";
  const CommandResult run = Silpose(common + out + " --passing 0.25 --pass-frames 10");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::vector<std::string>> rows = ReadCsv(out + "/groundtruth.csv");
  ASSERT_EQ(rows.size(), 81u);
  const size_t degradation = Column(rows[0], "degradation");
  // Windows of 40 frames, one pass of 10 consecutive frames in each.
  std::vector<int> runs;
  for (size_t k = 1; k < rows.size(); ++k) {
    const bool passing = rows[k][degradation] == "passing";
    EXPECT_TRUE(passing || rows[k][degradation] == "none") << rows[k][degradation];
    if (!passing) continue;
    if (k == 1 || rows[k - 1][degradation] != "passing") runs.push_back(0);
    ++runs.back();
  }
  EXPECT_EQ(runs, (std::vector<int>{10, 10}));

  for (const auto& [arguments, option] : std::vector<std::pair<std::string, std::string>>{
           {"--passing 1.5", "--passing"},
           {"--passing 0.2 --pass-frames 1", "--pass-frames"},
           {"--passing 0.2 --pass-size 0", "--pass-size"}}) {
    const CommandResult bad = Silpose(common + Path("bad_passing") + " " + arguments);
    EXPECT_NE(bad.exit_code, 0) << arguments;
    EXPECT_EQ(Lines(bad.err), 1) << arguments << ": " << bad.err;
    EXPECT_NE(bad.err.find(option), std::string::npos) << arguments << ": " << bad.err;
  }
}

TEST_F(CliSynthHandheldTest, HelpDescribesTheHandheldOptions) {
  const CommandResult run = Silpose("synth --help");
  ASSERT_EQ(run.exit_code, 0);
  for (const char* option :
       {"handheld", "--speed-range", "--pause-probability", "--reverse-probability",
        "--cut-probability", "--max-off-axis-deg", "--mask-quality", "--ragged", "--holes",
        "--stick", "--fingers", "--shadow", "--specks"}) {
    EXPECT_NE(run.out.find(option), std::string::npos) << option;
  }
}

}  // namespace
}  // namespace silpose
