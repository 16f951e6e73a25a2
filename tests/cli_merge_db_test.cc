// `silpose merge-db`: shards built with the same options merge into the file build-db of all their
// models writes, byte for byte; other parameters, a model twice, bad files are one-line errors.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliMergeDbTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_merge_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  std::string Path(const std::string& name) const { return (directory_ / name).string(); }
  static std::string Model(const std::string& name) {
    return std::string(SILPOSE_SAMPLE_MODELS_DIR) + "/" + name + ".obj";
  }
  // build-db of `models` (space-separated names) with tiny options into `output`.
  void Build(const std::string& models, const std::string& output,
             const std::string& views = "40") {
    std::string paths;
    std::istringstream names(models);
    for (std::string name; names >> name;) paths += Model(name) + " ";
    const CommandResult run =
        Silpose("build-db " + paths + "-o " + Path(output) + " --views " + views +
                " --resolution 64 --signature-length 64 --distances 3,7 "
                "--bins 4 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
  }
  std::string Bytes(const std::string& name) const {
    std::ifstream file(Path(name), std::ios::binary);
    std::stringstream bytes;
    bytes << file.rdbuf();
    return bytes.str();
  }

  std::filesystem::path directory_;
};

TEST_F(CliMergeDbTest, TwoShardsAreByteIdenticalToBuildDbOfBoth) {
  Build("cow hand", "both.db");
  Build("cow", "cow.db");
  Build("hand", "hand.db");
  const CommandResult run =
      Silpose("merge-db " + Path("cow.db") + " " + Path("hand.db") + " -o " + Path("merged.db"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("2 models from 2 files"), std::string::npos) << run.out;
  const std::string both = Bytes("both.db");
  ASSERT_GT(both.size(), 1000u);
  EXPECT_TRUE(Bytes("merged.db") == both);
}

TEST_F(CliMergeDbTest, BadInputIsOneLineNamingTheFile) {
  Build("cow", "cow.db");
  Build("hand", "hand50.db", "50");
  CommandResult run =
      Silpose("merge-db " + Path("cow.db") + " " + Path("hand50.db") + " -o " + Path("out.db"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find(Path("hand50.db") + ": built with other parameters than " +
                         Path("cow.db") + " (--views: 40 vs 50)"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(std::filesystem::exists(Path("out.db")));

  run = Silpose("merge-db " + Path("cow.db") + " " + Path("cow.db") + " -o " + Path("out.db"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("model 'cow' is also in"), std::string::npos) << run.err;

  run = Silpose("merge-db " + Path("cow.db") + " " + Path("missing.db") + " -o " + Path("out.db"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find(Path("missing.db") + ": no such file"), std::string::npos) << run.err;

  run = Silpose("merge-db " + Path("cow.db") + " -o " + Path("cow.db"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("the output is also an input"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(Path("out.db")));
}

}  // namespace
}  // namespace silpose
