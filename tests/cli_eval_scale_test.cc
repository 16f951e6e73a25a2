// `silpose eval scale`: the cost curves as a user runs them, in their --quick form, and the errors
// of bad sweeps.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliEvalScaleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_eval_scale_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string Path(const std::string& name) const { return (directory_ / name).string(); }

  std::filesystem::path directory_;
};

TEST_F(CliEvalScaleTest, QuickRunWritesOneRowPerDatabaseAndThePlots) {
  const std::string out = Path("quick");
  const CommandResult run = Silpose("eval scale --quick -o " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<std::string> rows = ReadLines(out + "/costs.csv");
  // Objects 2 and 6 at 60 views, views 60 and 120 at 2 objects: (2, 60) measured once.
  ASSERT_EQ(rows.size(), 4u);
  ASSERT_EQ(CsvCells(rows[0]).size(), 18u);
  EXPECT_EQ(CsvCells(rows[0])[4], "file_mb");
  std::vector<double> file_mb;
  for (size_t i = 1; i < rows.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(rows[i]);
    ASSERT_EQ(cells.size(), 18u) << rows[i];
    file_mb.push_back(std::stod(cells[4]));
    EXPECT_GT(std::stod(cells[6]), 0.0) << rows[i];  // brute force ms
    EXPECT_GT(std::stod(cells[7]), 0.0) << rows[i];  // filter ms
  }
  // Rows by objects, then views: (2, 60), (2, 120), (6, 60); the file grows with the views.
  EXPECT_EQ(CsvCells(rows[1])[0] + "x" + CsvCells(rows[1])[1], "2x60");
  EXPECT_EQ(CsvCells(rows[3])[0] + "x" + CsvCells(rows[3])[1], "6x60");
  EXPECT_GT(file_mb[1], 1.5 * file_mb[0]);
  EXPECT_GT(file_mb[2], 2.5 * file_mb[0]);
  for (const char* file : {"costs.svg", "costs.png", "README.txt"}) {
    EXPECT_GT(std::filesystem::file_size(out + "/" + file), 0u) << file;
  }
  // Nothing of the temporary databases and meshes is left.
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    EXPECT_EQ(entry.path().filename().string().rfind("silpose-scale-", 0), std::string::npos)
        << entry.path();
  }
  EXPECT_NE(run.out.find("objects  views"), std::string::npos) << run.out;
}

TEST_F(CliEvalScaleTest, ImpossibleSweepsAreRefusedBeforeBuilding) {
  // One mesh makes at most ten objects.
  const std::string bunny = std::string(SILPOSE_SAMPLE_MODELS_DIR) + "/bunny.obj";
  CommandResult run =
      Silpose("eval scale --quick --models " + bunny + " --objects 2,11 -o " + Path("a"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("[1, 10]"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("11"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(Path("a") + "/costs.csv"));

  run = Silpose("eval scale --quick --views 60,2 -o " + Path("b"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("database options"), std::string::npos) << run.err;

  run = Silpose("eval scale --quick --work-dir " + Path("missing") + " -o " + Path("c"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find(Path("missing")), std::string::npos) << run.err;
}

}  // namespace
}  // namespace silpose
