// Soak run of `silpose track`: a 1000-frame mask video (lossless PNG-in-AVI, a random walk showing
// three models in turn) is looped, reopened at its end, into one tracker with the default options
// until SILPOSE_SOAK_FRAMES frames (default 100000) have been tracked. Every 1000 frames the
// resident memory (/proc/self/statm) and the mean time per frame of the last 1000 frames are
// sampled (CPU time of the process, and wall time) and printed (stderr, and the CSV file
// $SILPOSE_SOAK_CSV if set). The counters compare every later sample with the one at frame 1000
// (after the warm-up): rss_growth_pct and cpu_ms_per_frame_change_pct are the largest relative
// differences, in percent.
//
//   build/release/bench/silpose_soak_bench           # 100000 frames
//   SILPOSE_SOAK_FRAMES=5000 build/release/bench/silpose_soak_bench

#include <benchmark/benchmark.h>
#include <malloc.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <opencv2/core/utility.hpp>
#include <string>
#include <vector>

#include "bench_models.h"
#include "silpose/database/database_builder.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/video_writer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/tracker.h"

namespace silpose {
namespace {

constexpr int kVideoFrames = 1000;
constexpr int kSampleEvery = 1000;

double ResidentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long size_pages = 0;
  long resident_pages = 0;
  statm >> size_pages >> resident_pages;
  return static_cast<double>(resident_pages) * static_cast<double>(::sysconf(_SC_PAGESIZE)) /
         (1024.0 * 1024.0);
}

// Heap bytes in use (malloc), MB: what resident memory would be without freed blocks kept.
double HeapInUseMegabytes() {
  const struct mallinfo2 info = ::mallinfo2();
  return static_cast<double>(info.uordblks + info.hblkhd) / (1024.0 * 1024.0);
}

void PrintStage(const char* stage) {
  std::fprintf(stderr, "soak: %-40s rss %8.1f MB  heap in use %8.1f MB\n", stage,
               ResidentMegabytes(), HeapInUseMegabytes());
}

int SoakFrames() {
  const char* env = std::getenv("SILPOSE_SOAK_FRAMES");
  const int frames = env != nullptr ? std::atoi(env) : 100000;
  return frames >= 2 * kSampleEvery ? frames : 2 * kSampleEvery;
}

// CPU time of this process, milliseconds (the tracker runs on this thread only; on a shared
// machine wall time mostly measures the other processes).
double ProcessCpuMs() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

struct Sample {
  int frame = 0;
  double rss_mb = 0.0;
  double ms_per_frame = 0.0;  // CPU time
  double wall_ms_per_frame = 0.0;
};

void BM_SoakTrackMaskVideo(benchmark::State& state) {
  const std::vector<std::filesystem::path> models = BenchModels();
  DatabaseBuildOptions build;
  build.num_threads = 0;
  PrintStage("start");
  const ViewDatabase database = BuildViewDatabase(models, build);
  PrintStage("database built");
  {
    size_t signatures = 0, records = 0, meshes = 0;
    for (const ModelViews& m : database.models) {
      signatures += m.signatures.owned_bytes();
      records += m.views.capacity() * sizeof(ViewRecord);
      meshes += m.mesh.vertices.capacity() * sizeof(m.mesh.vertices[0]) +
                m.mesh.triangles.capacity() * sizeof(m.mesh.triangles[0]);
    }
    std::fprintf(
        stderr, "soak: database: %zu models, signatures %.1f MB, records %.1f MB, meshes %.1f MB\n",
        database.models.size(), static_cast<double>(signatures) / 1048576.0,
        static_cast<double>(records) / 1048576.0, static_cast<double>(meshes) / 1048576.0);
  }
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("silpose_soak_bench_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  const std::filesystem::path video = folder / "masks.avi";
  // The meshes and the synthetic sequence are needed only to write the video: they are gone before
  // the tracker is made, so that the resident memory below is what `silpose track` holds.
  PinholeCamera camera;
  {
    std::vector<TriangleMesh> shown;
    for (size_t i = 0; i < models.size() && shown.size() < 3;
         i += std::max<size_t>(1, models.size() / 3))
      shown.push_back(LoadMesh(models[i]));
    SequenceOptions options;
    options.trajectory.kind = TrajectoryKind::kWalk;
    options.trajectory.num_frames = kVideoFrames;
    options.trajectory.object_switches =
        CyclicObjectSwitches(static_cast<int>(shown.size()), kVideoFrames, 250);
    const SyntheticSequence sequence(std::move(shown), options);
    camera = sequence.camera();
    VideoWriterOptions lossless;
    lossless.avi_codec = AviCodec::kPng;
    auto writer = OpenVideoWriter(video, {camera.width_px, camera.height_px}, 30.0, lossless);
    for (int k = 0; k < kVideoFrames; ++k) writer->Write(sequence.Generate(k).mask);
    writer->Close();
    PrintStage("video written");
  }
  PrintStage("sequence and meshes released");
  // Building the database and rendering leave freed heap that a process reading a database file
  // would not have (kept by malloc, much of it in the worker threads' arenas): give it back.
  ::malloc_trim(0);
  PrintStage("freed set-up memory returned");

  cv::setNumThreads(1);
  const int total = SoakFrames();
  std::vector<Sample> samples;
  int with_pose = 0;
  for (auto _ : state) {
    Tracker tracker(database, camera, TrackerOptions());
    PrintStage("tracker made");
    std::unique_ptr<FrameSource> source;
    auto block_start = std::chrono::steady_clock::now();
    double block_cpu_start = ProcessCpuMs();
    for (int frame = 0; frame < total;) {
      cv::Mat image;
      if (!source || !source->Read(&image)) {
        source = OpenFrameSource(video.string());
        continue;
      }
      with_pose += tracker.Process(image).result.camera_from_object.has_value();
      ++frame;
      if (frame % kSampleEvery == 0) {
        const auto now = std::chrono::steady_clock::now();
        const double wall = std::chrono::duration<double, std::milli>(now - block_start).count();
        const double cpu = ProcessCpuMs() - block_cpu_start;
        samples.push_back({frame, ResidentMegabytes(), cpu / kSampleEvery, wall / kSampleEvery});
        std::fprintf(
            stderr,
            "soak: frame %6d  rss %8.1f MB  heap %8.1f MB  %7.3f ms/frame CPU  %7.3f wall\n", frame,
            samples.back().rss_mb, HeapInUseMegabytes(), samples.back().ms_per_frame,
            samples.back().wall_ms_per_frame);
        block_start = std::chrono::steady_clock::now();
        block_cpu_start = ProcessCpuMs();
      }
    }
  }
  std::filesystem::remove_all(folder);

  if (const char* csv = std::getenv("SILPOSE_SOAK_CSV")) {
    std::ofstream out(csv);
    out << "frame,rss_mb,cpu_ms_per_frame,wall_ms_per_frame\n";
    for (const Sample& s : samples)
      out << s.frame << ',' << s.rss_mb << ',' << s.ms_per_frame << ',' << s.wall_ms_per_frame
          << '\n';
  }
  // Reference: the sample at frame 1000 (memory) and the block 1000..2000 (time), after warm-up.
  const Sample& first = samples.front();
  const double ms_reference = samples[1].ms_per_frame;
  double rss_growth = 0.0;
  double time_change = 0.0;
  double rss_max = first.rss_mb;
  for (size_t i = 1; i < samples.size(); ++i) {
    rss_growth = std::max(rss_growth, std::abs(samples[i].rss_mb / first.rss_mb - 1.0));
    rss_max = std::max(rss_max, samples[i].rss_mb);
    time_change = std::max(time_change, std::abs(samples[i].ms_per_frame / ms_reference - 1.0));
  }
  state.SetItemsProcessed(static_cast<int64_t>(total) * state.iterations());
  state.counters["frames"] = total;
  state.counters["frames_with_pose"] = with_pose;
  state.counters["rss_at_1000_mb"] = first.rss_mb;
  state.counters["rss_last_mb"] = samples.back().rss_mb;
  state.counters["rss_max_mb"] = rss_max;
  state.counters["rss_growth_pct"] = 100.0 * rss_growth;
  state.counters["cpu_ms_per_frame_1000_2000"] = ms_reference;
  state.counters["cpu_ms_per_frame_last"] = samples.back().ms_per_frame;
  state.counters["cpu_ms_per_frame_change_pct"] = 100.0 * time_change;
}
BENCHMARK(BM_SoakTrackMaskVideo)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace silpose

BENCHMARK_MAIN();
