// `silpose eval bop DIR`: the evaluation on a dataset in the BOP format, run as a user runs it, on
// a small dataset the test renders itself (eval/synthetic_bop_dataset_testing.h).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "silpose/eval/synthetic_bop_dataset_testing.h"

namespace silpose {
namespace {

class CliEvalBopTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_eval_bop_" + std::to_string(::getpid()));
    std::filesystem::remove_all(directory_);
    WriteSyntheticBopDataset(directory_ / "dataset");
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static inline std::filesystem::path directory_;
};

TEST_F(CliEvalBopTest, QuickRunWritesTables) {
  const std::string out = Path("out");
  const CommandResult run = Silpose("eval bop " + Path("dataset") + " --quick -o " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");  // no terminal: no progress bar
  EXPECT_NE(run.out.find("split test, 1 scenes, 2 models in the database (300 views"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("obj_000002"), std::string::npos) << run.out;

  // Summary: the two objects and all, documented columns.
  const std::vector<std::string> summary = ReadLines(out + "/bop_summary.csv");
  ASSERT_EQ(summary.size(), 4u);
  EXPECT_EQ(summary[0],
            "object,obj_id,instances,frames,with_pose,right_object_percent,"
            "rotation_error_median_deg,translation_error_median_mm,"
            "translation_error_median_percent,recall_add_s,ar_mssd,ar_mspd,ar,ms_per_frame");
  const std::vector<std::string> all = CsvCells(summary[3]);
  ASSERT_EQ(all.size(), 14u) << summary[3];
  EXPECT_EQ(all[0], "all");
  EXPECT_EQ(all[2], "2");
  EXPECT_EQ(all[3], "36");
  // Measured: 100 % right object, ADD(-S) recall and AR 1 at 300 views.
  EXPECT_GE(std::stod(all[5]), 90.0);
  EXPECT_GE(std::stod(all[9]), 0.85);
  EXPECT_GE(std::stod(all[12]), 0.8);

  // One row per frame; the BOP19 results of the frames with a pose.
  const std::vector<std::string> frames = ReadLines(out + "/bop_frames.csv");
  ASSERT_EQ(frames.size(), 37u);
  EXPECT_EQ(frames[1].rfind("1,0,1,0,0,", 0), 0u) << frames[1];
  const std::vector<std::string> results = ReadLines(out + "/bop_results.csv");
  ASSERT_GE(results.size(), 30u);
  EXPECT_EQ(results[0], "scene_id,im_id,obj_id,score,R,t,time");
  const std::vector<std::string> row = CsvCells(results[1]);
  ASSERT_EQ(row.size(), 7u);
  std::stringstream rotation(row[4]);
  int numbers = 0;
  for (double value; rotation >> value;) ++numbers;
  EXPECT_EQ(numbers, 9);
}

TEST_F(CliEvalBopTest, OneObjectFromFullMasksByBruteForce) {
  const std::string out = Path("out_full");
  const CommandResult run = Silpose("eval bop " + Path("dataset") +
                                    " --quick --objects 2 --masks full --brute-force "
                                    "--max-frames 6 -o " +
                                    out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("brute-force"), std::string::npos) << run.out;
  const std::vector<std::string> summary = ReadLines(out + "/bop_summary.csv");
  ASSERT_EQ(summary.size(), 3u);
  EXPECT_EQ(summary[1].rfind("obj_000002,2,1,6,", 0), 0u) << summary[1];
}

TEST_F(CliEvalBopTest, BadInputIsOneLineNamingIt) {
  // Missing dataset folder.
  CommandResult run = Silpose("eval bop " + Path("nowhere") + " --quick -o " + Path("o1"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find(Path("nowhere") + ": dataset folder not found"), std::string::npos)
      << run.err;
  EXPECT_EQ(Lines(run.err), 1) << run.err;

  // A corrupt scene_gt.json.
  const std::filesystem::path broken = directory_ / "broken";
  std::filesystem::copy(directory_ / "dataset", broken, std::filesystem::copy_options::recursive);
  const std::filesystem::path gt = broken / "test" / "000001" / "scene_gt.json";
  {
    std::ofstream file(gt);
    file << "{\"0\": [{\"obj_id\": 1, \"cam_R_m2c\": [1, 0, 0";
  }
  run = Silpose("eval bop " + broken.string() + " --quick -o " + Path("o2"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find(gt.string() + ": not valid JSON"), std::string::npos) << run.err;
  EXPECT_EQ(Lines(run.err), 1) << run.err;

  // Options.
  run = Silpose("eval bop " + Path("dataset") + " --masks some -o " + Path("o3"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("--masks must be visib or full"), std::string::npos) << run.err;
  run = Silpose("eval bop " + Path("dataset") + " --split val -o " + Path("o4"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("val: split folder not found"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace silpose
