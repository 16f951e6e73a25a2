// Throughput of `silpose track` on a 640 x 480 video, single thread, decoding included:
// the frames of an AVI file are read, segmented, described, filtered (20 objects x 60 particles
// with the 20 reference models) and turned into a 6-DOF pose, as the command does per frame.
//  - BM_TrackMaskVideo/0: a mask video (lossless PNG frames), --segment mask; /1: the same with
//    the filter keeping its particle histories (as with --lag or --smooth)
//  - BM_TrackColourVideo: a colour video (MJPEG, camera noise), --segment bgsub (/0 MOG2, /1 KNN,
//    /2 gauss, learned from the empty scene's image)
//  - BM_SegmentColourVideo: the segmentation alone of that video's first 100 frames (decoded
//    beforehand), same methods; the counter mean_iou compares the masks with the rendered ones
//  - BM_TrackReadAhead: as `silpose track` runs by default, the frames decoded and segmented two
//    ahead on a second thread (/0 the mask video, /1 the colour video with MOG2); wall-clock time
//  - BM_TrackStreams/N: N mask videos tracked at once on N threads, one Tracker each, sharing the
//    database and one ViewSpectra (items_per_second: frames per second of all streams together)
// items_per_second is frames per second. The videos (300 frames of a random walk around the
// elephant, or the first model) are rendered once into a temporary folder.

#include <benchmark/benchmark.h>

#include <any>
#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>
#include <vector>

#include "bench_models.h"
#include "silpose/database/database_builder.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/image_codec.h"
#include "silpose/io/read_ahead_source.h"
#include "silpose/io/video_writer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/segment_ahead.h"
#include "silpose/track/tracker.h"

namespace silpose {
namespace {

constexpr int kFrames = 300;

struct Fixture {
  ViewDatabase database;
  // Shared by the trackers of BM_TrackStreams.
  std::unique_ptr<ViewSpectra> spectra;
  PinholeCamera camera;
  std::filesystem::path folder;
};

const Fixture& GetFixture() {
  static const Fixture* fixture = [] {
    auto* f = new Fixture;
    const std::vector<std::filesystem::path> models = BenchModels();
    DatabaseBuildOptions build;
    build.num_threads = 0;
    f->folder = std::filesystem::temp_directory_path() / "silpose_track_bench";
    std::filesystem::create_directories(f->folder);
    {
      // As `silpose build-db` writes it (spectra stored, signatures not), read back mapped.
      ViewDatabase built = BuildViewDatabase(models, build);
      StoreViewSpectra(&built, CorrelationOptions{}, 0);
      built.DropSignatures();
      built.Write(f->folder / "database.db");
    }
    f->database = ViewDatabase::Read(f->folder / "database.db");
    f->spectra = std::make_unique<ViewSpectra>(f->database);
    std::filesystem::path flown = models.front();
    for (const auto& model : models)
      if (model.stem() == "elephant") flown = model;
    SequenceOptions options;
    options.trajectory.kind = TrajectoryKind::kWalk;
    options.trajectory.num_frames = kFrames;
    options.colour.enabled = true;
    options.colour.noise_sigma = 3.0;
    const SyntheticSequence sequence({LoadMesh(flown)}, options);
    f->camera = sequence.camera();
    const cv::Size size(f->camera.width_px, f->camera.height_px);
    VideoWriterOptions lossless;
    lossless.avi_codec = AviCodec::kPng;
    auto masks = OpenVideoWriter(f->folder / "masks.avi", size, 30.0, lossless);
    auto colour = OpenVideoWriter(f->folder / "video.avi", size, 30.0);
    for (int k = 0; k < kFrames; ++k) {
      const SyntheticFrame frame = sequence.Generate(k);
      masks->Write(frame.mask);
      colour->Write(frame.colour);
    }
    masks->Close();
    colour->Close();
    WriteImage((f->folder / "background.png").string(), sequence.background());
    // One thread per stream: OpenCV's own threads off (before any benchmark thread starts).
    cv::setNumThreads(1);
    return f;
  }();
  return *fixture;
}

// read_ahead > 0: the frames are decoded and segmented on a second thread, that many ahead (track
// --read-ahead).
void RunVideo(benchmark::State& state, const std::string& video, const TrackerOptions& options,
              int read_ahead = 0) {
  const Fixture& fixture = GetFixture();
  cv::setNumThreads(1);
  int64_t frames = 0;
  int measured = 0;
  for (auto _ : state) {
    std::unique_ptr<FrameSource> source = OpenFrameSource((fixture.folder / video).string());
    ReadAheadSource* ahead = nullptr;
    if (read_ahead > 0) {
      auto reader = std::make_unique<ReadAheadSource>(std::move(source), read_ahead,
                                                      SegmentAhead(options.segmentation));
      ahead = reader.get();
      source = std::move(reader);
    }
    Tracker tracker(fixture.database, fixture.camera, options);
    for (cv::Mat frame; source->Read(&frame);) {
      TrackedFrame tracked;
      if (ahead != nullptr) {
        auto& segmented = std::any_cast<AheadSegmentation&>(ahead->work_result());
        tracked = tracker.Process(frame, std::move(segmented.result), segmented.ms);
      } else {
        tracked = tracker.Process(frame);
      }
      measured += tracked.result.camera_from_object.has_value();
      ++frames;
    }
  }
  state.SetItemsProcessed(frames);
  state.counters["frames_with_pose"] =
      benchmark::Counter(static_cast<double>(measured) / static_cast<double>(state.iterations()));
}

// The options `silpose track` uses without --smooth or --lag: the filter keeps no particle
// histories (nothing reads them).
TrackerOptions TrackCommandOptions() {
  TrackerOptions options;
  options.filter.keep_history = false;
  return options;
}

// Arg 1: the filter keeps 100 frames of particle histories (Tracker's default, what smoothing
// needs) instead.
void BM_TrackMaskVideo(benchmark::State& state) {
  TrackerOptions options = TrackCommandOptions();
  if (state.range(0) != 0) {
    options.filter.keep_history = true;
    state.SetLabel("with particle histories");
  }
  RunVideo(state, "masks.avi", options);
}
BENCHMARK(BM_TrackMaskVideo)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

// The bgsub options of the colour benchmarks: arg 0 MOG2, 1 KNN, 2 gauss.
SegmenterOptions ColourSegmentation(int64_t method) {
  SegmenterOptions options;
  options.kind = SegmenterKind::kBackground;
  options.background_method = method == 0   ? BackgroundMethod::kMog2
                              : method == 1 ? BackgroundMethod::kKnn
                                            : BackgroundMethod::kGaussian;
  options.background_image_path = (GetFixture().folder / "background.png").string();
  return options;
}

void BM_TrackColourVideo(benchmark::State& state) {
  TrackerOptions options = TrackCommandOptions();
  options.segmentation = ColourSegmentation(state.range(0));
  state.SetLabel(std::string("bgsub ") + ToString(options.segmentation.background_method));
  RunVideo(state, "video.avi", options);
}
BENCHMARK(BM_TrackColourVideo)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// As `silpose track` runs by default: the frames decoded and segmented two ahead on a second
// thread while the tracking thread works. Arg 0: the mask video; 1: the colour video with MOG2.
void BM_TrackReadAhead(benchmark::State& state) {
  TrackerOptions options = TrackCommandOptions();
  std::string video = "masks.avi";
  if (state.range(0) != 0) {
    options.segmentation = ColourSegmentation(0);
    video = "video.avi";
  }
  state.SetLabel(video + ", frames read ahead on a second thread");
  RunVideo(state, video, options, 2);
}
BENCHMARK(BM_TrackReadAhead)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();

void BM_SegmentColourVideo(benchmark::State& state) {
  const Fixture& fixture = GetFixture();
  cv::setNumThreads(1);
  std::vector<cv::Mat> frames, truths;
  {
    std::unique_ptr<FrameSource> video = OpenFrameSource((fixture.folder / "video.avi").string());
    std::unique_ptr<FrameSource> masks = OpenFrameSource((fixture.folder / "masks.avi").string());
    cv::Mat frame, mask;
    while (frames.size() < 100 && video->Read(&frame) && masks->Read(&mask)) {
      frames.push_back(frame.clone());
      cv::Mat grey = mask;
      if (mask.channels() == 3) cv::extractChannel(mask, grey, 0);
      truths.push_back(grey > 127);
    }
  }
  const SegmenterOptions options = ColourSegmentation(state.range(0));
  std::unique_ptr<Segmenter> segmenter = CreateSegmenter(options);
  segmenter->Segment(frames.front());  // learns the background image
  double iou_sum = 0.0;
  int64_t segmented = 0;
  size_t next = 0;
  for (auto _ : state) {
    const SegmentationResult result = segmenter->Segment(frames[next]);
    state.PauseTiming();
    const double both = cv::countNonZero(result.mask & truths[next]);
    const double either = cv::countNonZero(result.mask | truths[next]);
    iou_sum += either > 0 ? both / either : 1.0;
    ++segmented;
    next = (next + 1) % frames.size();
    state.ResumeTiming();
  }
  state.SetItemsProcessed(segmented);
  state.counters["mean_iou"] = benchmark::Counter(iou_sum / static_cast<double>(segmented));
  state.SetLabel(std::string("bgsub ") + ToString(options.background_method) + ", 640x480");
}
BENCHMARK(BM_SegmentColourVideo)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

// Several streams in one process: each benchmark thread tracks the mask video with a tracker of its
// own; all share the database and its spectra. Real time, so that items_per_second is the
// throughput of the process.
void BM_TrackStreams(benchmark::State& state) {
  const Fixture& fixture = GetFixture();
  int64_t frames = 0;
  for (auto _ : state) {
    std::unique_ptr<FrameSource> source = OpenFrameSource((fixture.folder / "masks.avi").string());
    Tracker tracker(*fixture.spectra, fixture.camera, TrackCommandOptions());
    for (cv::Mat frame; source->Read(&frame);) {
      benchmark::DoNotOptimize(tracker.Process(frame));
      ++frames;
    }
  }
  state.SetItemsProcessed(frames);
  state.SetLabel(std::to_string(state.threads()) + " stream(s), " +
                 std::to_string(std::thread::hardware_concurrency()) + " cores");
}
BENCHMARK(BM_TrackStreams)
    ->Threads(1)
    ->Threads(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

}  // namespace
}  // namespace silpose

BENCHMARK_MAIN();
