// `silpose eval confidence`: the confidence experiment as a user runs it, in its --quick form.

#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliEvalConfidenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_eval_confidence_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    out_ = (directory_ / "quick").string();
    quick_ = new CommandResult(Silpose("eval confidence --quick --threads 2 -o " + out_));
  }
  static void TearDownTestSuite() {
    delete quick_;
    std::filesystem::remove_all(directory_);
  }

  static inline std::filesystem::path directory_;
  static inline std::string out_;
  static inline CommandResult* quick_ = nullptr;
};

TEST_F(CliEvalConfidenceTest, QuickRunFitsOnTuningModelsAndSeparatesHeldOutFrames) {
  ASSERT_EQ(quick_->exit_code, 0) << quick_->err;
  // Sample models: fit on bunny and cow, held out anchor and elephant, hand not in the database.
  EXPECT_NE(quick_->out.find("fit on bunny, cow; held out: anchor, elephant; not in the "
                             "database: hand"),
            std::string::npos)
      << quick_->out;
  const std::vector<std::string> summary = ReadLines(out_ + "/summary.csv");
  ASSERT_EQ(summary.size(), 6u);
  EXPECT_EQ(summary[0],
            "set,frames,correct,auc,tracking,tracking_wrong_percent,correct_tracking_percent,"
            "unknown_frames,unknown_reported_percent,tracking,ambiguous,unknown-object,"
            "bad-segmentation,lost,no-silhouette");
  const std::vector<std::string> held_out = CsvCells(summary[2]);
  ASSERT_EQ(held_out.size(), 15u);
  EXPECT_EQ(held_out[0], "held-out");
  // The confidence ranks right frames above wrong ones far better than chance, and the object
  // that is not in the database is mostly reported as unknown.
  EXPECT_GT(std::stod(held_out[3]), 0.85) << summary[2];
  EXPECT_EQ(held_out[7], "80");  // hand: clean and degraded, 40 frames each (all with silhouette)
  EXPECT_GT(std::stod(held_out[8]), 50.0) << summary[2];

  const std::vector<std::string> frames = ReadLines(out_ + "/frames.csv");
  ASSERT_FALSE(frames.empty());
  EXPECT_EQ(frames[0],
            "model,unknown,fit,condition,seed,frame,silhouette,correct,confidence,state,"
            "object_probability,mode_mass,runner_up_ratio,score_sharpness,has_fit,iou,"
            "outline_rms,area_change,recent_iou,recent_outline_rms,twin_gap,pose_gap");
  // Fit: 2 models x (3 conditions + 2 look-alike ones); held out: 2 x 3 + hand x 2; 40 frames.
  EXPECT_EQ(frames.size(), 1u + (2u * 5u + 2u * 3u + 2u) * 40u);
  std::set<std::string> models;
  int unknown = 0, trusted_unknown = 0;
  for (size_t i = 1; i < frames.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(frames[i]);
    ASSERT_EQ(cells.size(), 22u) << frames[i];
    models.insert(cells[0]);
    const double confidence = std::stod(cells[8]);
    EXPECT_GE(confidence, 0.0);
    EXPECT_LE(confidence, 1.0);
    if (cells[1] == "1" && cells[2] == "0") {  // held out and not in the database: the hand
      ++unknown;
      trusted_unknown += cells[9] == "tracking";
    }
  }
  // The object that is not in the database is rarely trusted.
  EXPECT_EQ(unknown, 80);
  EXPECT_LE(trusted_unknown, 8);
  EXPECT_EQ(models, (std::set<std::string>{"anchor", "bunny", "bunny-lookalike", "cow",
                                           "cow-lookalike", "elephant", "hand"}));
  EXPECT_EQ(ReadLines(out_ + "/reliability.csv").size(), 11u);
  EXPECT_EQ(ReadLines(out_ + "/model.txt").size(), 13u);  // bias and 12 weights
  EXPECT_NE(quick_->out.find("lowest threshold with at most 1 %"), std::string::npos);
  EXPECT_GT(std::filesystem::file_size(out_ + "/confidence.png"), 1000u);
}

TEST_F(CliEvalConfidenceTest, BadArgumentsAreRefusedWithOneLine) {
  const CommandResult unknown_model =
      Silpose("eval confidence --quick --fit nosuch -o " + (directory_ / "bad").string());
  EXPECT_NE(unknown_model.exit_code, 0);
  EXPECT_NE(unknown_model.err.find("no model 'nosuch'"), std::string::npos) << unknown_model.err;
  const CommandResult clash = Silpose("eval confidence --quick --fit bunny --unknown bunny -o " +
                                      (directory_ / "bad").string());
  EXPECT_NE(clash.exit_code, 0);
  EXPECT_NE(clash.err.find("also a fit model"), std::string::npos) << clash.err;
}

}  // namespace
}  // namespace silpose
