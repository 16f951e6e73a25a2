// What is shared between threads (README, "As a library"): one database read by several
// trackers at once, one ViewSpectra (whose spectra are made on first use) shared by several
// trackers, and one ViewSpectra searched by one ViewMatcher per thread; and what runs on several
// threads inside: building a database, writing a sequence and the eval experiments' tasks. Each
// must give what it gives alone. These tests are also run under ThreadSanitizer (the 'tsan'
// preset, scripts/run-sanitizers.sh), where the parallel loops run on std::thread
// (util/parallel.h).

#include <gtest/gtest.h>
#include <unistd.h>

#include <any>
#include <atomic>
#include <fstream>
#include <iterator>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "silpose/database/database_builder.h"
#include "silpose/eval/confidence_experiment.h"
#include "silpose/eval/handheld_experiment.h"
#include "silpose/eval/self_match.h"
#include "silpose/eval/tracking_experiment.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/read_ahead_source.h"
#include "silpose/match/view_matcher.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/segment_ahead.h"
#include "silpose/track/tracker.h"

namespace silpose {
namespace {

const std::filesystem::path kModels(SILPOSE_SAMPLE_MODELS_DIR);

const ViewDatabase& Database() {
  static const ViewDatabase* database = [] {
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 200;
    options.parameters.render.resolution_px = 128;
    options.parameters.distances_in_radii = {3.0, 7.5};
    options.num_threads = 1;
    return new ViewDatabase(
        BuildViewDatabase({kModels / "cow.obj", kModels / "hand.obj"}, options));
  }();
  return *database;
}

const std::vector<TriangleMesh>& Meshes() {
  static const auto* meshes =
      new std::vector<TriangleMesh>{LoadMesh(kModels / "cow.obj"), LoadMesh(kModels / "hand.obj")};
  return *meshes;
}

const SyntheticSequence& Sequence() {
  static const SyntheticSequence* sequence = [] {
    SequenceOptions options;
    options.trajectory.kind = TrajectoryKind::kWalk;
    options.trajectory.num_frames = 16;
    options.trajectory.walk.seed = 3;
    options.trajectory.object_switches = {{0, 0}, {8, 1}};
    return new SyntheticSequence({LoadMesh(kModels / "cow.obj"), LoadMesh(kModels / "hand.obj")},
                                 options);
  }();
  return *sequence;
}

// A frame's status, object, roll, view and translation, printed exactly.
std::string EstimateLine(const FrameResult& result) {
  std::ostringstream line;
  line.precision(17);
  line << result.status << ' ' << result.object << ' ' << result.roll_deg;
  if (result.view_dir_in_object) line << ' ' << result.view_dir_in_object->transpose();
  if (result.camera_from_object) line << ' ' << result.camera_from_object->translation.transpose();
  return line.str();
}

// Per frame: status, object, roll, view and translation, printed exactly. With `shared`, the
// tracker matches with those spectra instead of its own.
std::vector<std::string> Track(const TrackerOptions& options = {},
                               const ViewSpectra* shared = nullptr) {
  std::unique_ptr<Tracker> own;
  if (shared != nullptr) {
    own = std::make_unique<Tracker>(*shared, Sequence().camera(), options);
    EXPECT_EQ(&own->spectra(), shared);
  } else {
    own = std::make_unique<Tracker>(Database(), Sequence().camera(), options);
  }
  Tracker& tracker = *own;
  std::vector<std::string> estimates;
  for (int f = 0; f < Sequence().num_frames(); ++f) {
    estimates.push_back(EstimateLine(tracker.Process(Sequence().Generate(f).mask).result));
  }
  return estimates;
}

// OpenCV's own worker threads are TBB's here (Debian's OpenCV), which ThreadSanitizer cannot see
// synchronise (libtbb is not instrumented): the threads under test are only these tests' own.
class SharedBetweenThreads : public ::testing::Test {
 protected:
  void SetUp() override {
    opencv_threads_ = cv::getNumThreads();
    cv::setNumThreads(1);
  }
  void TearDown() override { cv::setNumThreads(opencv_threads_); }
  int opencv_threads_ = 0;
};

TEST_F(SharedBetweenThreads, TrackersOnOneDatabaseGiveWhatEachGivesAlone) {
  (void)Sequence();
  const std::vector<std::string> alone = Track();
  ASSERT_EQ(alone.size(), 16u);
  std::vector<std::vector<std::string>> together(2);
  std::vector<std::thread> threads;
  for (auto& result : together) threads.emplace_back([&result] { result = Track(); });
  for (auto& thread : threads) thread.join();
  for (const auto& result : together) EXPECT_EQ(result, alone);
}

TEST_F(SharedBetweenThreads, TrackersSharingOneViewSpectraGiveWhatEachGivesAlone) {
  // Streams with other options (another seed, brute force) tracked at once, one tracker per
  // thread, all matching with one ViewSpectra whose spectra are made on first use.
  (void)Sequence();
  std::vector<TrackerOptions> streams(3);
  streams[0].filter.seed = 3;
  streams[1].filter.seed = 5;
  streams[2].brute_force = true;
  std::vector<std::vector<std::string>> alone;
  for (const TrackerOptions& options : streams) alone.push_back(Track(options));
  EXPECT_NE(alone[0], alone[2]);  // the streams do different work
  const ViewSpectra spectra(Database());
  std::vector<std::vector<std::string>> together(streams.size());
  std::vector<std::thread> threads;
  for (size_t s = 0; s < streams.size(); ++s) {
    threads.emplace_back([&, s] { together[s] = Track(streams[s], &spectra); });
  }
  for (auto& thread : threads) thread.join();
  for (size_t s = 0; s < streams.size(); ++s) EXPECT_EQ(together[s], alone[s]) << "stream " << s;
  EXPECT_GT(spectra.num_computed(), 0u);  // the trackers matched with the shared spectra
}

// Every view of every model and shell, matched against the database: best candidate per query.
std::vector<std::string> MatchAllViews(const ViewSpectra& spectra, int first, int step) {
  ViewMatcher matcher(spectra);
  const ViewDatabase& database = Database();
  std::vector<std::string> best;
  for (int m = 0; m < static_cast<int>(database.models.size()); ++m) {
    for (int s = 0; s < database.num_shells(); ++s) {
      for (int v = first; v < database.num_views(); v += step) {
        if (database.models[m].Record(v, s).status != SignatureStatus::kOk) continue;
        MatchOptions options;
        options.top_k = 1;
        options.apparent_radius = database.ApparentRadius(m, v, s);
        const MatchCandidate c = matcher.Match(database.models[m].Signature(v, s), options).at(0);
        std::ostringstream line;
        line.precision(9);
        line << m << ' ' << s << ' ' << v << ": " << c.model << ' ' << c.view << ' ' << c.shell
             << ' ' << c.roll_deg << ' ' << c.score;
        best.push_back(line.str());
      }
    }
  }
  return best;
}

TEST_F(SharedBetweenThreads, MatchersOnOneSpectraGiveWhatEachGivesAlone) {
  std::vector<std::string> alone;
  {
    const ViewSpectra spectra(Database());
    alone = MatchAllViews(spectra, 0, 1);
  }
  ASSERT_GT(alone.size(), 100u);
  // A fresh ViewSpectra, so that the two threads make its spectra on first use concurrently; each
  // takes every other view, then both check all of them.
  const ViewSpectra spectra(Database());
  std::vector<std::vector<std::string>> halves(2);
  std::vector<std::vector<std::string>> wholes(2);
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) {
    threads.emplace_back([&, t] {
      halves[t] = MatchAllViews(spectra, t, 2);
      wholes[t] = MatchAllViews(spectra, 0, 1);
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(halves[0].size() + halves[1].size(), alone.size());
  EXPECT_EQ(wholes[0], alone);
  EXPECT_EQ(wholes[1], alone);
}

TEST_F(SharedBetweenThreads, ADatabaseBuiltOnTwoThreadsIsTheOneBuiltOnOne) {
  DatabaseBuildOptions options;
  options.parameters.view_sphere.num_views = 120;
  options.parameters.render.resolution_px = 128;
  options.parameters.distances_in_radii = {3.0, 7.5};
  std::atomic<int> reported{0};
  options.num_threads = 2;
  const std::vector<std::filesystem::path> models = {kModels / "cow.obj", kModels / "anchor.obj"};
  const ViewDatabase two = BuildViewDatabase(models, options);
  options.num_threads = 1;
  const ViewDatabase one = BuildViewDatabase(models, options);
  // Every view rendered, described and stored in its place, the symmetries found beside them:
  // the same bytes.
  EXPECT_EQ(two.Serialize(), one.Serialize());
  ASSERT_EQ(two.models.size(), 2u);
  EXPECT_FALSE(two.models[0].symmetry.mirrors.empty());  // the cow's mirror plane
  // The progress callback of one model's views, called from both threads.
  ModelViews model;
  DescribeModelViews(
      LoadMesh(kModels / "cow.obj"), two.sphere, options.parameters, 2,
      [&](int done) { reported += done; }, &model);
  EXPECT_EQ(reported.load(), 2 * 120);
}

TEST_F(SharedBetweenThreads, ASequenceWrittenOnTwoThreadsIsTheOneWrittenOnOne) {
  const std::filesystem::path base = std::filesystem::temp_directory_path() /
                                     ("silpose_threads_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(base);
  SequenceWriteOptions options;
  options.num_threads = 2;
  WriteSequence(Sequence(), base / "two", options);
  options.num_threads = 1;
  WriteSequence(Sequence(), base / "one", options);
  const auto bytes = [](const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(file), {});
  };
  EXPECT_EQ(bytes(base / "two" / "groundtruth.csv"), bytes(base / "one" / "groundtruth.csv"));
  int masks = 0;
  for (const auto& entry : std::filesystem::directory_iterator(base / "one" / "masks")) {
    EXPECT_EQ(bytes(base / "two" / "masks" / entry.path().filename()), bytes(entry.path()))
        << entry.path();
    ++masks;
  }
  EXPECT_EQ(masks, 16);
  std::filesystem::remove_all(base);
}

TEST_F(SharedBetweenThreads, FramesReadAndSegmentedAheadAreTrackedAsFramesReadInTurn) {
  // `silpose track` reads and segments each frame on a second thread (ReadAheadSource with
  // SegmentAhead) while the tracker works on the frame before.
  const std::filesystem::path base =
      std::filesystem::temp_directory_path() / ("silpose_read_ahead_" + std::to_string(::getpid()));
  std::filesystem::remove_all(base);
  SequenceWriteOptions write;
  write.num_threads = 1;
  WriteSequence(Sequence(), base, write);
  const std::vector<std::string> in_turn = Track();
  ASSERT_EQ(in_turn.size(), 16u);
  const TrackerOptions options;
  for (const int depth : {1, 2, 5}) {
    ReadAheadSource source(OpenFrameSource(base.string()), depth,
                           SegmentAhead(options.segmentation));
    Tracker tracker(Database(), Sequence().camera(), options);
    std::vector<std::string> ahead;
    for (cv::Mat frame; source.Read(&frame);) {
      auto& segmented = std::any_cast<AheadSegmentation&>(source.work_result());
      ahead.push_back(
          EstimateLine(tracker.Process(frame, std::move(segmented.result), segmented.ms).result));
    }
    EXPECT_EQ(ahead, in_turn) << "depth " << depth;
  }
  // Stopped after a few frames, the reading thread still ends (the destructor joins it).
  {
    ReadAheadSource source(OpenFrameSource(base.string()), 2, SegmentAhead(options.segmentation));
    cv::Mat frame;
    for (int f = 0; f < 3; ++f) ASSERT_TRUE(source.Read(&frame));
  }
  std::filesystem::remove_all(base);
}

TEST_F(SharedBetweenThreads, TheTrackingExperimentOnTwoThreadsGivesWhatItGivesOnOne) {
  // Its three parallel loops: rendering the flight, the filter runs, the brute-force frames (with
  // matchers handed from chunk to chunk).
  TrackingExperimentOptions options;
  options.flown_models = {"hand"};
  options.frames = 24;
  options.particle_counts = {20, 40};
  options.repeats = 2;
  std::atomic<int> reported{0};
  options.num_threads = 2;
  const TrackingExperimentResult two =
      RunTrackingExperiment(Database(), Meshes(), options, [&](int done) { reported += done; });
  options.num_threads = 1;
  const TrackingExperimentResult one = RunTrackingExperiment(Database(), Meshes(), options);
  EXPECT_EQ(reported.load(), TrackingRunCount(options, 1));
  ASSERT_EQ(two.runs.size(), 5u);  // 2 particle counts x 2 seeds, and brute force
  ASSERT_EQ(two.runs.size(), one.runs.size());
  int measured = 0;
  for (size_t r = 0; r < one.runs.size(); ++r) {
    ASSERT_EQ(two.runs[r].frames.size(), 24u);
    ASSERT_EQ(two.runs[r].frames.size(), one.runs[r].frames.size());
    for (size_t k = 0; k < one.runs[r].frames.size(); ++k) {
      const TrackingFrameResult& a = two.runs[r].frames[k];
      const TrackingFrameResult& b = one.runs[r].frames[k];
      EXPECT_EQ(a.object, b.object) << r << " " << k;
      EXPECT_EQ(a.view, b.view) << r << " " << k;
      EXPECT_EQ(a.score, b.score) << r << " " << k;
      EXPECT_EQ(a.pose_error, b.pose_error) << r << " " << k;
      measured += a.object == 1;  // the hand
    }
  }
  EXPECT_GT(measured, 5 * 24 / 2);
}

TEST_F(SharedBetweenThreads, TheSelfMatchOnTwoThreadsGivesWhatItGivesOnOne) {
  SelfMatchOptions options;
  options.view_stride = 5;  // 40 of each model's 200 views, at two scales
  options.num_threads = 2;
  const std::vector<SelfMatchModelResult> two = RunSelfMatch(Database(), Meshes(), options);
  options.num_threads = 1;
  const std::vector<SelfMatchModelResult> one = RunSelfMatch(Database(), Meshes(), options);
  ASSERT_EQ(two.size(), 2u);
  ASSERT_EQ(one.size(), 2u);
  for (size_t m = 0; m < 2; ++m) {
    EXPECT_EQ(two[m].queries, 80);
    EXPECT_EQ(two[m].queries, one[m].queries);
    EXPECT_EQ(two[m].right_model, one[m].right_model);
    EXPECT_EQ(two[m].own_view, one[m].own_view);
    EXPECT_EQ(two[m].passed, one[m].passed);
    EXPECT_GT(two[m].right_model, 60);
    ASSERT_EQ(two[m].failures.size(), one[m].failures.size());
    for (size_t f = 0; f < one[m].failures.size(); ++f) {
      EXPECT_EQ(two[m].failures[f].view, one[m].failures[f].view);
      EXPECT_EQ(two[m].failures[f].found_view, one[m].failures[f].found_view);
    }
  }
}

TEST_F(SharedBetweenThreads, TheHandheldExperimentOnTwoThreadsGivesWhatItGivesOnOne) {
  // Its parallel loop: one task per sequence and mask quality, each with its own trackers.
  HandheldExperimentOptions options;
  options.models = {"hand"};
  options.sequences_per_model = 1;
  options.frames = 10;
  options.orbit_distances_radii = {3.0};
  options.orbit_frames = 8;
  options.skip_frames = 2;
  std::atomic<int> reported{0};
  options.num_threads = 2;
  const HandheldExperimentResult two =
      RunHandheldExperiment(Database(), Meshes(), options, [&](int done) { reported += done; });
  options.num_threads = 1;
  const HandheldExperimentResult one = RunHandheldExperiment(Database(), Meshes(), options);
  EXPECT_EQ(reported.load(), HandheldTaskCount(options, 1));
  // (hand-held, orbit) x (perfect, threshold) x (filter, brute force)
  ASSERT_EQ(two.runs.size(), 8u);
  ASSERT_EQ(two.runs.size(), one.runs.size());
  int right = 0;
  for (size_t r = 0; r < one.runs.size(); ++r) {
    EXPECT_EQ(two.runs[r].seed, one.runs[r].seed) << r;
    EXPECT_EQ(two.runs[r].tracker, one.runs[r].tracker) << r;
    ASSERT_EQ(two.runs[r].frames.size(), one.runs[r].frames.size()) << r;
    for (size_t k = 0; k < one.runs[r].frames.size(); ++k) {
      const HandheldFrame& a = two.runs[r].frames[k];
      const HandheldFrame& b = one.runs[r].frames[k];
      EXPECT_EQ(a.object, b.object) << r << " " << k;
      EXPECT_EQ(a.has_pose, b.has_pose) << r << " " << k;
      if (a.has_pose && b.has_pose) {
        EXPECT_EQ(a.rotation_error_deg, b.rotation_error_deg) << r << " " << k;
        EXPECT_EQ(a.translation_error_percent, b.translation_error_percent) << r << " " << k;
      }
      right += a.right_object;
    }
  }
  EXPECT_GT(right, 0);
}

TEST_F(SharedBetweenThreads, TheConfidenceExperimentOnTwoThreadsGivesWhatItGivesOnOne) {
  // Its parallel loop: one task per model, condition and sequence (the cow left out of the fit
  // set and evaluated with the shipped model; the bunny, not in the database, as unknown).
  ConfidenceExperimentOptions options;
  options.fit = false;
  options.eval_models = {"cow"};
  options.sequences = 1;
  options.frames = 8;
  const std::vector<TriangleMesh> unknown = {LoadMesh(kModels / "bunny.obj")};
  options.num_threads = 2;
  const ConfidenceExperimentResult two =
      RunConfidenceExperiment(Database(), Meshes(), unknown, options);
  options.num_threads = 1;
  const ConfidenceExperimentResult one =
      RunConfidenceExperiment(Database(), Meshes(), unknown, options);
  ASSERT_GE(two.runs.size(), 4u);  // clean, degraded, occluded for the cow; the bunny
  ASSERT_EQ(two.runs.size(), one.runs.size());
  int with_features = 0;
  for (size_t r = 0; r < one.runs.size(); ++r) {
    EXPECT_EQ(two.runs[r].model, one.runs[r].model) << r;
    EXPECT_EQ(two.runs[r].seed, one.runs[r].seed) << r;
    ASSERT_EQ(two.runs[r].frames.size(), one.runs[r].frames.size()) << r;
    for (size_t k = 0; k < one.runs[r].frames.size(); ++k) {
      const ConfidenceFrame& a = two.runs[r].frames[k];
      const ConfidenceFrame& b = one.runs[r].frames[k];
      EXPECT_EQ(a.state, b.state) << r << " " << k;
      EXPECT_EQ(a.confidence, b.confidence) << r << " " << k;
      EXPECT_EQ(a.correct, b.correct) << r << " " << k;
      with_features += a.has_features;
    }
  }
  EXPECT_GT(with_features, 0);
}

}  // namespace
}  // namespace silpose
