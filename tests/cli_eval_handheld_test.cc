// `silpose eval handheld`: the hand-held accuracy experiment as a user runs it, in its --quick
// form.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

class CliEvalHandheldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_eval_handheld_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    out_ = (directory_ / "quick").string();
    quick_ = new CommandResult(Silpose("eval handheld --quick --threads 2 -o " + out_));
  }
  static void TearDownTestSuite() {
    delete quick_;
    std::filesystem::remove_all(directory_);
  }

  static inline std::filesystem::path directory_;
  static inline std::string out_;
  static inline CommandResult* quick_ = nullptr;
};

TEST_F(CliEvalHandheldTest, QuickRunWritesTheDocumentedSummary) {
  ASSERT_EQ(quick_->exit_code, 0) << quick_->err;
  EXPECT_EQ(quick_->err, "");  // no terminal: no progress bar
  const std::vector<std::string> summary = ReadLines(out_ + "/summary.csv");
  ASSERT_FALSE(summary.empty());
  EXPECT_EQ(summary[0],
            "kind,mask_quality,tracker,sequences,frames,right_object_percent,no_estimate_frames,"
            "no_pose_frames,rotation_median_deg,rotation_mean_deg,rotation_p90_deg,"
            "translation_median_percent,view_error_mean,roll_median_deg,all_frames,"
            "all_right_object_percent,all_rotation_median_deg,rotation_median_symmetric_deg,"
            "view_error_symmetric_mean,wrong_twin_frames");
  // handheld, orbit-3, orbit-7, orbit-15 x perfect, threshold x filter, brute-force.
  ASSERT_EQ(summary.size(), 1u + 4u * 2u * 2u);
  std::set<std::string> kinds;
  for (size_t i = 1; i < summary.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(summary[i]);
    ASSERT_EQ(cells.size(), 20u) << summary[i];
    kinds.insert(cells[0]);
    // Two models (bunny, hand), one sequence each: 40 - 10 hand-held frames, 30 - 10 per orbit.
    EXPECT_EQ(cells[3], "2");
    EXPECT_EQ(cells[4], cells[0] == "handheld" ? "60" : "40") << summary[i];
    if (cells[2] == "filter" && cells[1] == "perfect") {
      EXPECT_GE(std::stod(cells[5]), 90.0) << summary[i];
    }
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"handheld", "orbit-3", "orbit-7", "orbit-15"}));
  // The table on screen and the note on what the errors cover.
  EXPECT_NE(quick_->out.find("summary"), std::string::npos);
  EXPECT_NE(quick_->out.find("by speed"), std::string::npos);
}

TEST_F(CliEvalHandheldTest, QuickRunWritesEachSequenceAndComparesItWithBruteForce) {
  ASSERT_EQ(quick_->exit_code, 0) << quick_->err;
  const std::vector<std::string> sequences = ReadLines(out_ + "/sequences.csv");
  ASSERT_FALSE(sequences.empty());
  EXPECT_EQ(sequences[0],
            "model,kind,sequence,seed,mask_quality,tracker,frames,right_object_percent,"
            "rotation_median_symmetric_deg,translation_median_percent,view_error_symmetric_mean,"
            "wrong_twin_frames");
  // 2 models x (1 hand-held + 3 orbits) x 2 mask qualities x 2 trackers.
  ASSERT_EQ(sequences.size(), 1u + 2u * 4u * 2u * 2u);
  int filter_above = 0;
  std::map<std::string, double> brute_force;
  std::vector<std::pair<std::string, double>> filter;
  for (size_t i = 1; i < sequences.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(sequences[i]);
    ASSERT_EQ(cells.size(), 12u) << sequences[i];
    EXPECT_EQ(cells[6], cells[1] == "handheld" ? "30" : "20") << sequences[i];
    const std::string key = cells[0] + "," + cells[1] + "," + cells[2] + "," + cells[4];
    const double view_error = cells[10].empty() ? std::nan("") : std::stod(cells[10]);
    if (cells[5] == "brute-force") brute_force[key] = view_error;
    if (cells[5] == "filter") filter.emplace_back(key, view_error);
  }
  ASSERT_EQ(filter.size(), 16u);
  // The file holds 7 significant digits: pairs that close may fall either way.
  int undecided = 0;
  for (const auto& [key, view_error] : filter) {
    ASSERT_EQ(brute_force.count(key), 1u) << key;
    const double reference = brute_force[key];
    if (!std::isfinite(reference)) continue;
    if (std::isfinite(view_error) && view_error != reference &&
        std::abs(view_error - reference) <= 1e-6 * std::abs(reference)) {
      ++undecided;
    } else if (!(view_error <= reference)) {
      ++filter_above;
    }
  }
  // The line on screen counts the same sequences.
  const std::string prefix =
      "filter above brute force in mean view error modulo symmetry (frames 10 and later) on ";
  const size_t at = quick_->out.find(prefix);
  ASSERT_NE(at, std::string::npos) << quick_->out;
  const int printed = std::stoi(quick_->out.substr(at + prefix.size()));
  EXPECT_GE(printed, filter_above);
  EXPECT_LE(printed, filter_above + undecided);
  EXPECT_NE(quick_->out.find(" of 16 sequences (sequences.csv)", at), std::string::npos);
}

TEST_F(CliEvalHandheldTest, QuickRunWritesFramesBinsFigureAndReadme) {
  ASSERT_EQ(quick_->exit_code, 0) << quick_->err;
  const std::vector<std::string> frames = ReadLines(out_ + "/frames.csv");
  ASSERT_FALSE(frames.empty());
  EXPECT_EQ(frames[0],
            "model,kind,sequence,seed,mask_quality,tracker,frame,distance_radii,off_axis_deg,"
            "speed_deg_per_frame,cut,estimated_object,right_object,has_pose,rotation_error_deg,"
            "translation_error_percent,view_error,roll_error_deg,time_ms,wrong_twin,"
            "rotation_error_symmetric_deg,view_error_symmetric");
  // 2 models x (40 + 3 x 30 frames) x 2 mask qualities x 2 trackers.
  EXPECT_EQ(frames.size(), 1u + 2u * 130u * 2u * 2u);
  std::set<std::string> seeds;
  for (size_t i = 1; i < frames.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(frames[i]);
    ASSERT_EQ(cells.size(), 22u) << frames[i];
    seeds.insert(cells[3]);
    // The error modulo the object's symmetry is never above the plain one.
    if (cells[13] == "1") {
      EXPECT_LE(std::stod(cells[20]), std::stod(cells[14]) + 1e-6) << frames[i];
      EXPECT_LE(std::stod(cells[21]), std::stod(cells[16]) + 1e-6) << frames[i];
    }
  }
  // Two hand-held sequences and six orbits, each with its own seed.
  EXPECT_EQ(seeds.size(), 8u);

  const std::vector<std::string> bins = ReadLines(out_ + "/bins.csv");
  ASSERT_FALSE(bins.empty());
  EXPECT_EQ(bins[0],
            "axis,bin,mask_quality,tracker,frames,right_object_percent,rotation_median_deg,"
            "rotation_mean_deg,translation_median_percent,rotation_median_symmetric_deg");
  std::set<std::string> axes, speed_bins;
  for (size_t i = 1; i < bins.size(); ++i) {
    const std::vector<std::string> cells = CsvCells(bins[i]);
    ASSERT_EQ(cells.size(), 10u) << bins[i];
    axes.insert(cells[0]);
    if (cells[0] == "speed") speed_bins.insert(cells[1]);
  }
  EXPECT_EQ(axes, (std::set<std::string>{"distance", "off_axis", "speed", "mask_quality"}));
  EXPECT_EQ(speed_bins, (std::set<std::string>{"0-2", "2-5", "5-10", "10-15", ">15", "orbit"}));

  const std::string svg = ReadText(out_ + "/handheld.svg");
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("brute-force"), std::string::npos);
  EXPECT_GT(std::filesystem::file_size(out_ + "/handheld.png"), 1000u);
  // README.txt: the command line and every seed, to reproduce the figures.
  const std::string readme = ReadText(out_ + "/README.txt");
  EXPECT_NE(readme.find("eval handheld --quick --threads 2 -o " + out_), std::string::npos);
  for (const std::string& seed : seeds) EXPECT_NE(readme.find(" " + seed), std::string::npos);
}

TEST_F(CliEvalHandheldTest, BadOptionsGiveOneErrorLine) {
  for (const std::string& bad :
       {std::string("--mask-quality shiny"), std::string("--distances 3,far"),
        std::string("--frames 0"), std::string("--evaluate teapot"),
        std::string("--models /nonexistent/models")}) {
    const CommandResult run =
        Silpose("eval handheld --quick " + bad + " -o " + (directory_ / "bad").string());
    EXPECT_NE(run.exit_code, 0) << bad;
    EXPECT_EQ(Lines(run.err), 1) << bad << ": " << run.err;
    EXPECT_NE(run.err.find("error"), std::string::npos) << run.err;
  }
  const CommandResult unknown = Silpose("eval handheld --bogus-option");
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_EQ(Lines(unknown.err), 1) << unknown.err;
}

}  // namespace
}  // namespace silpose
