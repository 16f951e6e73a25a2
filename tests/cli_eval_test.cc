// `silpose eval ...`: the evaluation commands as a user runs them (tracking: the paper's experiment
// 5.1 in its --quick form; self-match with a given database).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliEvalTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ =
        std::filesystem::temp_directory_path() / ("silpose_cli_eval_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    models_ = std::string(SILPOSE_SAMPLE_MODELS_DIR);
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static inline std::filesystem::path directory_;
  static inline std::string models_;
};

TEST_F(CliEvalTest, TrackingQuickWritesTablesAndFigures) {
  const std::string out = Path("tracking");
  const CommandResult run = Silpose("eval tracking --quick -o " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");  // no terminal: no progress bar

  // tracking.csv: the documented columns, one row per particle count (20, 60) and brute force.
  const std::vector<std::string> table = ReadLines(out + "/tracking.csv");
  ASSERT_EQ(table.size(), 4u);
  EXPECT_EQ(table[0],
            "method,particles,runs,frames,pose_error_mean,pose_error_std,right_object_percent,"
            "ms_per_frame_mean,symmetric_pose_error_mean,symmetric_pose_error_std");
  EXPECT_EQ(table[1].rfind("particle-filter,20,4,240,", 0), 0u) << table[1];
  EXPECT_EQ(table[2].rfind("particle-filter,60,4,240,", 0), 0u) << table[2];
  EXPECT_EQ(table[3].rfind("brute-force,0,2,120,", 0), 0u) << table[3];
  // Clean renders of the sample models: the filter keeps the right object nearly always.
  for (size_t i = 1; i <= 2; ++i) {
    std::stringstream row(table[i]);
    std::vector<std::string> cells;
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 10u);
    EXPECT_GE(std::stod(cells[6]), 95.0) << table[i];
    EXPECT_LT(std::stod(cells[4]), 0.15) << table[i];
    // Modulo symmetry the error is never larger.
    EXPECT_LE(std::stod(cells[8]), std::stod(cells[4]) + 1e-9) << table[i];
  }
  // tracking_runs.csv: 2 flights x 2 counts x 2 seeds + 2 brute-force runs.
  const std::vector<std::string> runs = ReadLines(out + "/tracking_runs.csv");
  ASSERT_EQ(runs.size(), 1u + 10u);
  EXPECT_EQ(runs[0].rfind("method,model,particles,seed,frames,", 0), 0u);

  const std::string svg = ReadText(out + "/tracking.svg");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  EXPECT_NE(svg.find("brute force"), std::string::npos);
  const cv::Mat png = cv::imread(out + "/tracking.png");
  ASSERT_FALSE(png.empty());
  EXPECT_GT(png.cols, png.rows);

  // The screen: the table with the paper's brute-force figures beside ours.
  EXPECT_NE(run.out.find("particle-filter"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("brute-force"), std::string::npos);
  EXPECT_NE(run.out.find("0.149"), std::string::npos);
  EXPECT_NE(run.out.find("96.3"), std::string::npos);
  EXPECT_NE(run.out.find("one thread"), std::string::npos);
}

TEST_F(CliEvalTest, TrackingWithAGivenDatabaseAndNamedFlights) {
  const std::string database = Path("two.db");
  const CommandResult build = Silpose("build-db " + models_ + "/bunny.obj " + models_ +
                                      "/hand.obj -o " + database + " --views 200 --threads 2");
  ASSERT_EQ(build.exit_code, 0) << build.err;
  const std::string out = Path("named");
  const CommandResult run =
      Silpose("eval tracking " + models_ + "/bunny.obj " + models_ + "/hand.obj -d " + database +
              " --flown hand --frames 20 --particles 10 --repeats 1 --no-brute-force --threads 2" +
              " -o " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> table = ReadLines(out + "/tracking.csv");
  ASSERT_EQ(table.size(), 2u);  // no brute-force row
  EXPECT_EQ(table[1].rfind("particle-filter,10,1,20,", 0), 0u) << table[1];
  EXPECT_NE(run.out.find("hand"), std::string::npos);
  EXPECT_NE(run.out.find("--threads 1"), std::string::npos);  // times are not single-thread

  // The database must have been built from the meshes given.
  const CommandResult mismatch = Silpose("eval tracking " + models_ + "/hand.obj " + models_ +
                                         "/bunny.obj -d " + database + " --frames 5 -o " + out);
  EXPECT_NE(mismatch.exit_code, 0);
  EXPECT_NE(mismatch.err.find(database), std::string::npos) << mismatch.err;

  // Self-match reads the same way.
  const CommandResult self_match = Silpose("eval self-match " + models_ + "/bunny.obj " + models_ +
                                           "/hand.obj -d " + database + " --stride 20");
  EXPECT_EQ(self_match.exit_code, 0) << self_match.err;
  EXPECT_NE(self_match.out.find("passed"), std::string::npos);
}

TEST_F(CliEvalTest, TrackingRefusesBadArgumentsWithOneLine) {
  const std::string out = Path("bad");
  const std::string blocker = Path("blocker");  // a file where a folder should go
  std::ofstream(blocker) << "x";
  for (const auto& [arguments, expected] : std::vector<std::pair<std::string, std::string>>{
           {"eval tracking --quick --particles 10,abc -o " + out, "--particles"},
           {"eval tracking --quick --particles 0 -o " + out, "particle counts"},
           {"eval tracking --quick --flown teapot -o " + out, "teapot"},
           {"eval tracking --quick --repeats 0 -o " + out, "repeats"},
           {"eval tracking --quick", "--output"},
           {"eval tracking --quick -o " + blocker + "/sub", blocker + "/sub"},
       }) {
    const CommandResult run = Silpose(arguments);
    EXPECT_NE(run.exit_code, 0) << arguments;
    EXPECT_NE(run.err.find(expected), std::string::npos) << arguments << ": " << run.err;
    EXPECT_LE(Lines(run.err), 1) << arguments << ": " << run.err;
  }
  // A model to fly that is not among the meshes is refused before anything is built or written.
  const CommandResult teapot = Silpose("eval tracking --quick --flown bunny,teapot -o " + out);
  EXPECT_NE(teapot.exit_code, 0);
  EXPECT_NE(teapot.err.find("'teapot' is not in the database (anchor, bunny, cow, elephant, hand)"),
            std::string::npos)
      << teapot.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  const CommandResult help = Silpose("eval tracking --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--quick"), std::string::npos);
  EXPECT_NE(help.out.find("--particles"), std::string::npos);
}

TEST_F(CliEvalTest, VideoQuickTracksColourVideosWithBackgroundSubtraction) {
  const std::string out = Path("video");
  const CommandResult run = Silpose("eval video --quick --threads 2 -o " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("targets:"), std::string::npos) << run.out;
  std::ifstream table(out + "/video.csv");
  std::string line;
  std::getline(table, line);
  EXPECT_EQ(line.substr(0, 46), "model,frames,counted,right_object_percent,rota");
  int rows = 0;
  while (std::getline(table, line)) {
    std::stringstream fields(line);
    std::vector<std::string> values;
    for (std::string value; std::getline(fields, value, ',');) values.push_back(value);
    ASSERT_EQ(values.size(), 11u) << line;
    ++rows;
    EXPECT_EQ(values[1], "40");
    // A coarse database (300 views, ~11 deg apart): the right object after 10 frames, rotation
    // within the view spacing plus a few degrees, distance within a few percent.
    EXPECT_GE(std::stod(values[3]), 95.0) << line;
    EXPECT_LT(std::stod(values[4]), 15.0) << line;
    EXPECT_LT(std::stod(values[6]), 6.0) << line;
  }
  EXPECT_EQ(rows, 2);
  for (const char* file : {"bunny/video.avi", "bunny/POSES.csv", "hand/error.png"}) {
    EXPECT_TRUE(std::filesystem::is_regular_file(out + "/" + file)) << file;
  }
}

}  // namespace
}  // namespace silpose
