// Runtime of the particle filter: one Step with 20 objects x 60 particles, signature
// extraction from a 640 x 480 mask included (target <= 3 ms, one thread).
// The reference models are read from ../shared/models beside the checkout (or
// SILPOSE_BENCH_MODELS); without them the sample models stand in, and the labels say so.
// Run: build/release/bench/silpose_filter_bench [--benchmark_filter=Step]

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <random>

#include "bench_models.h"
#include "silpose/database/database_builder.h"
#include "silpose/filter/particle_filter.h"
#include "silpose/geometry/view_frame.h"

namespace silpose {
namespace {

// The database of all benchmark models at the default parameters (1000 views, 512 px), built once.
struct BenchData {
  ViewDatabase database;
  std::unique_ptr<ViewSpectra> spectra;
  // 640 x 480 masks of one model along a smooth orbit (1 degree per frame).
  std::vector<cv::Mat> masks;
  std::string label;
};

const BenchData& Data() {
  static const BenchData data = [] {
    BenchData out;
    const std::vector<std::filesystem::path> models = BenchModels();
    out.database = BuildViewDatabase(models, DatabaseBuildOptions{});
    out.spectra = std::make_unique<ViewSpectra>(out.database);
    const TriangleMesh mesh = LoadMesh(models.front());
    const Eigen::Vector3d axis = Eigen::Vector3d(0.3, 1.0, 0.2).normalized();
    const Eigen::Matrix3d start = CameraFromObjectRotation({1.0, 0.4, 0.6}, 20.0);
    for (int t = 0; t < 200; ++t) {
      const Eigen::Matrix3d orbit = Eigen::AngleAxisd(t * std::numbers::pi / 180.0, axis).matrix();
      Eigen::Vector3d view;
      double roll = 0.0;
      ViewAndRollFromRotation(start * orbit.transpose(), &view, &roll);
      cv::Mat mask;
      RenderSilhouette(mesh, PinholeCamera::Centered(640, 480, 600.0),
                       CameraFromObjectAtView(view, roll, 4.0 * mesh.Radius(), mesh.Centre()),
                       &mask);
      out.masks.push_back(mask);
    }
    out.label = std::to_string(models.size()) + " models (" +
                models.front().parent_path().string() + "), tracking " + mesh.name;
    return out;
  }();
  return data;
}

// Steady tracking: the filter runs along the orbit (wrapping around); each iteration is one frame,
// signature extraction included. range(0): particles per object; range(1): 1 = adaptive;
// range(2): 1 = guided reseeding (the default), 0 = uniform only; range(3): 1 = the particles keep
// their pose histories (the library's default, needed by smoothing), 0 = none (`track` without
// --smooth or --lag).
void BM_FilterStep(benchmark::State& state) {
  const BenchData& data = Data();
  ParticleFilterOptions options;
  options.particles_per_object = static_cast<int>(state.range(0));
  options.adaptive = state.range(1) != 0;
  options.guided_reseeding = state.range(2) != 0;
  options.keep_history = state.range(3) != 0;
  ParticleFilter filter(data.database.sphere, *data.spectra, options);
  // Converge first: the timed frames are the steady state, not the start.
  size_t frame = 0;
  for (; frame < 30; ++frame) {
    filter.Step(ExtractSignature(data.masks[frame]).signature.radii);
  }
  double particles = 0.0;
  double resampled = 0.0;
  for (auto _ : state) {
    const SignatureResult signature = ExtractSignature(data.masks[frame++ % data.masks.size()]);
    const FilterEstimate estimate = filter.Step(signature.signature.radii);
    particles += estimate.num_particles;
    resampled += estimate.resampled ? 1.0 : 0.0;
  }
  const auto iterations = static_cast<double>(state.iterations());
  state.counters["particles"] = particles / iterations;
  state.counters["resampled"] = resampled / iterations;
  state.SetLabel(data.label);
}
BENCHMARK(BM_FilterStep)
    ->ArgNames({"per_object", "adaptive", "guided", "history"})
    ->Args({60, 0, 1, 1})
    ->Args({60, 0, 1, 0})
    ->Args({60, 0, 0, 1})
    ->Args({60, 1, 1, 1})
    ->Args({60, 1, 1, 0})
    ->Args({20, 0, 1, 1})
    ->Args({100, 0, 1, 1})
    ->Unit(benchmark::kMillisecond);

// The first frames, when the particles are still spread over every object's sphere (each needs a
// global peak search, as no particle has a roll yet on frame 0).
void BM_FilterFirstFrames(benchmark::State& state) {
  const BenchData& data = Data();
  ParticleFilterOptions options;
  options.particles_per_object = static_cast<int>(state.range(0));
  std::vector<std::vector<float>> signatures;
  for (int t = 0; t < 5; ++t)
    signatures.push_back(ExtractSignature(data.masks[static_cast<size_t>(t)]).signature.radii);
  for (auto _ : state) {
    state.PauseTiming();
    ParticleFilter filter(data.database.sphere, *data.spectra, options);
    state.ResumeTiming();
    for (const auto& signature : signatures) benchmark::DoNotOptimize(filter.Step(signature));
  }
  state.SetLabel("5 frames; " + data.label);
}
BENCHMARK(BM_FilterFirstFrames)->Arg(60)->Unit(benchmark::kMillisecond);

// Signature extraction alone, for reference (included in BM_FilterStep).
void BM_ExtractSignatureForFilter(benchmark::State& state) {
  const BenchData& data = Data();
  size_t frame = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ExtractSignature(data.masks[frame++ % data.masks.size()]));
  }
}
BENCHMARK(BM_ExtractSignatureForFilter)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace silpose

BENCHMARK_MAIN();
