#include "silpose/eval/tracking_experiment.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "silpose/database/database_builder.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

std::vector<std::string> ReadLines(const std::filesystem::path& path) {
  std::ifstream file(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(file, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  for (std::string cell; std::getline(stream, cell, ',');) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// Three sample models (a symmetric anchor among them), 300 views at 256 px (about 12 degrees
// between views, to keep the test fast), and one experiment on a short flight of two of them, run
// once for all tests.
class TrackingExperimentTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::vector<std::filesystem::path> paths;
    for (const char* name : {"anchor", "bunny", "hand"}) {
      paths.push_back(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) /
                      (std::string(name) + ".obj"));
    }
    DatabaseBuildOptions build;
    build.parameters.view_sphere.num_views = 300;
    build.parameters.render.resolution_px = 256;
    database_ = new ViewDatabase(BuildViewDatabase(paths, build));
    meshes_ = new std::vector<TriangleMesh>();
    for (const auto& path : paths) meshes_->push_back(LoadMesh(path));
    result_ = new TrackingExperimentResult(RunTrackingExperiment(*database_, *meshes_, Options()));
  }
  static void TearDownTestSuite() {
    delete result_;
    delete meshes_;
    delete database_;
  }
  static TrackingExperimentOptions Options() {
    TrackingExperimentOptions options;
    options.flown_models = {"anchor", "hand"};
    options.frames = 90;
    options.particle_counts = {60, 20};
    options.repeats = 2;
    options.num_threads = 1;
    return options;
  }

  static ViewDatabase* database_;
  static std::vector<TriangleMesh>* meshes_;
  static TrackingExperimentResult* result_;
};

ViewDatabase* TrackingExperimentTest::database_ = nullptr;
std::vector<TriangleMesh>* TrackingExperimentTest::meshes_ = nullptr;
TrackingExperimentResult* TrackingExperimentTest::result_ = nullptr;

TEST(SpreadModelIndices, SpreadsEvenlyAndCaps) {
  EXPECT_EQ(SpreadModelIndices(20, 5), (std::vector<int>{2, 6, 10, 14, 18}));
  EXPECT_EQ(SpreadModelIndices(5, 2), (std::vector<int>{1, 3}));
  EXPECT_EQ(SpreadModelIndices(5, 5), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(SpreadModelIndices(3, 5), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(SpreadModelIndices(1, 1), (std::vector<int>{0}));
}

TEST(TrackingExperimentOptions, ChecksItsValues) {
  TrackingExperimentOptions options;
  EXPECT_TRUE(options.Check());
  std::string error;
  options.particle_counts = {10, 0};
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("particle counts"), std::string::npos);
  options = {};
  options.particle_counts = {10, 10};
  EXPECT_FALSE(options.Check());
  options = {};
  options.repeats = 0;
  EXPECT_FALSE(options.Check());
  options = {};
  options.frames = 0;
  EXPECT_FALSE(options.Check());
  options = {};
  options.particle_counts.clear();
  EXPECT_TRUE(options.Check());  // brute force alone
  options.brute_force = false;
  EXPECT_FALSE(options.Check());
  // Fewer particles than the filter's floor: the floor is capped, not an error.
  options = {};
  options.particle_counts = {3};
  EXPECT_TRUE(options.Check(&error)) << error;
}

TEST_F(TrackingExperimentTest, HasOneRowPerParticleCountAndABruteForceRow) {
  const TrackingExperimentResult& r = *result_;
  EXPECT_EQ(r.flown_models, (std::vector<std::string>{"anchor", "hand"}));
  EXPECT_EQ(r.frames_per_flight, 90);
  EXPECT_EQ(r.num_models, 3);
  EXPECT_EQ(r.num_threads, 1);
  ASSERT_EQ(r.rows.size(), 3u);
  EXPECT_EQ(r.rows[0].particles, 20);  // ascending
  EXPECT_EQ(r.rows[1].particles, 60);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(r.rows[i].method, "particle-filter");
    EXPECT_EQ(r.rows[i].stats.runs, 4);  // 2 models x 2 seeds
    EXPECT_EQ(r.rows[i].stats.frames, 4 * 90);
  }
  const TrackingRow* brute = r.BruteForce();
  ASSERT_NE(brute, nullptr);
  EXPECT_EQ(brute, &r.rows[2]);
  EXPECT_EQ(brute->method, "brute-force");
  EXPECT_EQ(brute->particles, 0);
  EXPECT_EQ(brute->stats.runs, 2);
  EXPECT_EQ(brute->stats.frames, 2 * 90);
  EXPECT_EQ(r.runs.size(), 2u * 2u * 2u + 2u);
  EXPECT_EQ(TrackingRunCount(Options(), 2), static_cast<int>(r.runs.size()));
  for (const TrackingRun& run : r.runs) {
    EXPECT_EQ(run.frames.size(), 90u);
    for (const TrackingFrameResult& f : run.frames) {
      EXPECT_TRUE(f.measured);  // clean renders
      EXPECT_GE(f.object, 0);
      EXPECT_GE(f.pose_error, 0.0);
      EXPECT_LE(f.pose_error, 2.0);
      EXPECT_GT(f.time_ms, 0.0);
    }
  }
}

TEST_F(TrackingExperimentTest, PoseErrorIsTheDistanceBetweenEstimatedAndTrueViewDirections) {
  // The truth, independently: the same orbit as the experiment's.
  TrajectoryOptions trajectory;
  trajectory.num_frames = 90;
  const std::vector<TrajectoryFrame> truth = GenerateTrajectory(trajectory);
  for (const TrackingRun& run : result_->runs) {
    for (size_t k = 0; k < run.frames.size(); ++k) {
      const TrackingFrameResult& f = run.frames[k];
      const Eigen::Vector3d& estimated = database_->sphere.directions[static_cast<size_t>(f.view)];
      ASSERT_NEAR(f.pose_error, (estimated - truth[k].view_dir_in_object).norm(), 1e-12);
    }
  }
}

// Bounds. A database of 300 views is coarse: the nearest view lies on average about 0.08 from a
// true direction (covering radius 0.77 sqrt(4 pi / 300) = 0.16), which is what the brute force
// reaches here (measured 0.083, 100 % right object: these three silhouettes are not ambiguous at
// this resolution, so the brute force is the precision limit and the filter cannot beat it). The
// filter, seeds 1 and 2: right object 100 % at both counts, mean pose error 0.101 (20 particles)
// and 0.086 (60), the excess over the limit coming from the first frames before it settles (at most
// frame 2). The bounds keep a margin for another standard library's random streams: right object
// >= 97 % (at most 5 of 180 frames per count wrong), mean pose error < 0.13 (0.05 above the limit),
// settled by frame 15.
TEST_F(TrackingExperimentTest, TheFilterIdentifiesTheObjectAndTracksTheView) {
  const TrackingRow* brute = result_->BruteForce();
  for (int particles : {20, 60}) {
    const TrackingRow* row = result_->Filter(particles);
    ASSERT_NE(row, nullptr);
    std::cout << particles << " particles: pose error " << row->stats.pose_error_mean << " +- "
              << row->stats.pose_error_std << ", right object " << row->stats.right_object_percent()
              << " %, " << row->stats.ms_per_frame_mean << " ms\n";
    EXPECT_GE(row->stats.right_object_percent(), 97.0);
    EXPECT_LT(row->stats.pose_error_mean, 0.13);
  }
  std::cout << "brute force: pose error " << brute->stats.pose_error_mean << " +- "
            << brute->stats.pose_error_std << ", right object "
            << brute->stats.right_object_percent() << " %, " << brute->stats.ms_per_frame_mean
            << " ms\n";
  // The brute force finds the nearest view or a neighbour: within the coarse sphere's reach.
  EXPECT_LT(brute->stats.pose_error_mean, 0.1);
  EXPECT_GE(brute->stats.right_object_percent(), 97.0);
  for (const TrackingRun& run : result_->runs) {
    if (run.brute_force()) continue;
    EXPECT_LT(run.SettledFrame(run.model), 15) << run.model_name << " seed " << run.seed;
  }
}

TEST_F(TrackingExperimentTest, SameSeedGivesTheSameRunsAndAnotherSeedOthers) {
  TrackingExperimentOptions options = Options();
  options.flown_models = {"hand"};
  options.brute_force = false;
  options.particle_counts = {20};
  const TrackingExperimentResult again = RunTrackingExperiment(*database_, *meshes_, options);
  options.num_threads = 2;
  const TrackingExperimentResult threaded = RunTrackingExperiment(*database_, *meshes_, options);
  // Another seed gives other runs. (With the guided start and the data-driven proposal, runs on
  // this easy 3-model database converge to the same views whatever the seed; without them, the
  // paper's filter, the random start shows.)
  options.num_threads = 1;
  options.filter.guided_start = false;
  options.filter.data_driven_proposal = false;
  const TrackingExperimentResult unguided = RunTrackingExperiment(*database_, *meshes_, options);
  options.first_seed = 7;
  const TrackingExperimentResult other = RunTrackingExperiment(*database_, *meshes_, options);
  // The original runs of the hand at 20 particles, seeds 1 and 2.
  std::vector<const TrackingRun*> original;
  for (const TrackingRun& run : result_->runs) {
    if (run.model_name == "hand" && run.particles == 20) original.push_back(&run);
  }
  ASSERT_EQ(original.size(), 2u);
  ASSERT_EQ(again.runs.size(), 2u);
  int differing_frames = 0;
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(again.runs[i].seed, original[i]->seed);
    EXPECT_EQ(other.runs[i].seed, 7u + i);
    for (size_t k = 0; k < 90; ++k) {
      for (const TrackingFrameResult* same :
           {&again.runs[i].frames[k], &threaded.runs[i].frames[k]}) {
        ASSERT_EQ(same->object, original[i]->frames[k].object) << k;
        ASSERT_EQ(same->view, original[i]->frames[k].view) << k;
        ASSERT_EQ(same->pose_error, original[i]->frames[k].pose_error) << k;
      }
      differing_frames += other.runs[i].frames[k].view != unguided.runs[i].frames[k].view;
    }
  }
  EXPECT_GT(differing_frames, 0);
}

TEST_F(TrackingExperimentTest, WritesTheDocumentedCsvColumns) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() /
                                       ("silpose_tracking_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  WriteTrackingTable(folder / "tracking.csv", *result_);
  const std::vector<std::string> table = ReadLines(folder / "tracking.csv");
  ASSERT_EQ(table.size(), 4u);
  EXPECT_EQ(table[0],
            "method,particles,runs,frames,pose_error_mean,pose_error_std,right_object_percent,"
            "ms_per_frame_mean,symmetric_pose_error_mean,symmetric_pose_error_std");
  for (size_t i = 1; i < table.size(); ++i) {
    const std::vector<std::string> cells = SplitCsv(table[i]);
    ASSERT_EQ(cells.size(), 10u) << table[i];
    const TrackingRow& row = result_->rows[i - 1];
    EXPECT_EQ(cells[0], row.method);
    EXPECT_EQ(std::stoi(cells[1]), row.particles);
    EXPECT_EQ(std::stoi(cells[2]), row.stats.runs);
    EXPECT_EQ(std::stoi(cells[3]), row.stats.frames);
    EXPECT_NEAR(std::stod(cells[4]), row.stats.pose_error_mean, 1e-8);
    EXPECT_NEAR(std::stod(cells[5]), row.stats.pose_error_std, 1e-8);
    EXPECT_NEAR(std::stod(cells[6]), row.stats.right_object_percent(), 1e-6);
    EXPECT_NEAR(std::stod(cells[7]), row.stats.ms_per_frame_mean, 1e-6);
    EXPECT_NEAR(std::stod(cells[8]), row.stats.symmetric_pose_error_mean, 1e-8);
    EXPECT_NEAR(std::stod(cells[9]), row.stats.symmetric_pose_error_std, 1e-8);
    // Neither flown model turns onto itself (the anchor has a mirror plane only): the error
    // modulo symmetry is the paper's.
    EXPECT_NEAR(row.stats.symmetric_pose_error_mean, row.stats.pose_error_mean, 1e-12);
  }
  EXPECT_EQ(SplitCsv(table.back())[0], "brute-force");

  WriteTrackingRuns(folder / "tracking_runs.csv", *result_);
  const std::vector<std::string> runs = ReadLines(folder / "tracking_runs.csv");
  ASSERT_EQ(runs.size(), 1u + result_->runs.size());
  EXPECT_EQ(runs[0], TrackingRunsHeader());
  const size_t columns = SplitCsv(runs[0]).size();
  EXPECT_EQ(columns, 14u);
  for (size_t i = 1; i < runs.size(); ++i) EXPECT_EQ(SplitCsv(runs[i]).size(), columns) << runs[i];

  WriteTrackingFrames(folder / "frames.csv", *result_, *database_);
  const std::vector<std::string> frames = ReadLines(folder / "frames.csv");
  ASSERT_EQ(frames.size(), 1u + 90u * result_->runs.size());
  EXPECT_EQ(SplitCsv(frames[0]).size(), 13u);
  for (size_t i = 1; i < frames.size(); ++i) {
    ASSERT_EQ(SplitCsv(frames[i]).size(), 13u) << frames[i];
  }
  // The first filter run's first frame, cell by cell.
  const TrackingRun& run = result_->runs.front();
  const std::vector<std::string> cells = SplitCsv(frames[1]);
  EXPECT_EQ(cells[0], "particle-filter");
  EXPECT_EQ(cells[1], run.model_name);
  EXPECT_EQ(std::stoi(cells[6]), run.frames[0].view);
  EXPECT_NEAR(std::stod(cells[9]), run.frames[0].score, 1e-6);
  EXPECT_NEAR(std::stod(cells[10]), run.frames[0].pose_error, 1e-8);

  EXPECT_THROW(WriteTrackingTable(folder / "missing" / "tracking.csv", *result_), Error);
  std::filesystem::remove_all(folder);
}

TEST_F(TrackingExperimentTest, FigureHasBothPanelsWithTheBruteForceLevels) {
  const Figure figure = TrackingFigure(*result_);
  ASSERT_EQ(figure.panels.size(), 2u);
  for (const PlotPanel& panel : figure.panels) {
    ASSERT_EQ(panel.series.size(), 1u);
    EXPECT_EQ(panel.series[0].x, (std::vector<double>{20, 60}));
    ASSERT_EQ(panel.reference_lines.size(), 1u);
  }
  EXPECT_DOUBLE_EQ(figure.panels[0].reference_lines[0].y,
                   result_->BruteForce()->stats.pose_error_mean);
  EXPECT_DOUBLE_EQ(figure.panels[1].reference_lines[0].y,
                   result_->BruteForce()->stats.right_object_percent());
  EXPECT_EQ(figure.panels[0].series[0].y_error.size(), 2u);
  const std::string svg = figure.ToSvg();
  EXPECT_NE(svg.find("brute force"), std::string::npos);
}

TEST_F(TrackingExperimentTest, RefusesUnknownModelsAndMismatchedMeshes) {
  TrackingExperimentOptions options = Options();
  options.flown_models = {"teapot"};
  try {
    (void)RunTrackingExperiment(*database_, *meshes_, options);
    ADD_FAILURE() << "no error for an unknown model";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("teapot"), std::string::npos) << e.what();
  }
  options.flown_models = {"hand", "hand"};
  EXPECT_THROW((void)RunTrackingExperiment(*database_, *meshes_, options), Error);
  std::vector<TriangleMesh> swapped = *meshes_;
  std::swap(swapped[0], swapped[1]);
  EXPECT_THROW((void)RunTrackingExperiment(*database_, swapped, Options()), Error);
  swapped.pop_back();
  EXPECT_THROW((void)RunTrackingExperiment(*database_, swapped, Options()), Error);
}

}  // namespace
}  // namespace silpose
