// Runtime benchmarks of the single-frame pipeline:
//   - one circular correlation (sweep of M),
//   - signature extraction from a mask,
//   - rendering one database view,
//   - brute-force match of one signature against 20 models x 1000 views (pruned and exhaustive),
//   - building the database of the 20 reference models (1 and 2 threads).
// The reference models are read from ../shared/models beside the checkout (or
// SILPOSE_BENCH_MODELS); without them the sample models stand in, and the labels say so.
// Run: build/release/bench/silpose_bench [--benchmark_filter=Match]

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>

#include "bench_models.h"
#include "silpose/database/database_builder.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/match/view_matcher.h"

namespace silpose {
namespace {

// The database of all benchmark models at the default parameters, built once.
const ViewDatabase& BenchDatabase() {
  static const ViewDatabase database = [] {
    DatabaseBuildOptions options;
    return BuildViewDatabase(BenchModels(), options);
  }();
  return database;
}

std::vector<float> RandomSignature(std::mt19937& rng, int length) {
  std::uniform_real_distribution<double> amplitude(-0.2, 0.2);
  std::vector<double> terms(24);
  for (double& t : terms) t = amplitude(rng);
  std::vector<float> radii(static_cast<size_t>(length));
  for (int x = 0; x < length; ++x) {
    const double t = 2 * std::numbers::pi * x / length;
    double r = 1.0;
    for (int k = 0; k < 12; ++k) {
      r += terms[static_cast<size_t>(2 * k)] / (k + 1) * std::cos((k + 1) * t) +
           terms[static_cast<size_t>(2 * k + 1)] / (k + 1) * std::sin((k + 1) * t);
    }
    radii[static_cast<size_t>(x)] = static_cast<float>(r);
  }
  return radii;
}

void BM_Correlation(benchmark::State& state) {
  const int length = static_cast<int>(state.range(0));
  CorrelationOptions options;
  options.backend = static_cast<FftBackend>(state.range(1));
  CircularCorrelator correlator(length, options);
  std::mt19937 rng(1);
  const SignatureSpectrum a = correlator.Transform(RandomSignature(rng, length));
  const SignatureSpectrum b = correlator.Transform(RandomSignature(rng, length));
  for (auto _ : state) benchmark::DoNotOptimize(correlator.Peak(a, b));
  state.SetLabel(ToString(static_cast<FftBackend>(state.range(1))));
}
void CorrelationArguments(benchmark::internal::Benchmark* b) {
  for (FftBackend backend : AvailableFftBackends()) {
    for (int length : {256, 512, 1000, 2000, 4096}) b->Args({length, static_cast<int>(backend)});
  }
}
BENCHMARK(BM_Correlation)->Apply(CorrelationArguments);

void BM_SignatureTransform(benchmark::State& state) {
  CircularCorrelator correlator(1000);
  std::mt19937 rng(1);
  const std::vector<float> radii = RandomSignature(rng, 1000);
  SignatureSpectrum spectrum;
  for (auto _ : state) {
    correlator.Transform(radii, &spectrum, true);
    benchmark::DoNotOptimize(spectrum.coefficients.data());
  }
}
BENCHMARK(BM_SignatureTransform);

void BM_ExtractSignature640x480(benchmark::State& state) {
  const std::vector<std::filesystem::path> models = BenchModels();
  const TriangleMesh mesh = LoadMesh(models.front());
  cv::Mat mask;
  RenderSilhouette(mesh, PinholeCamera::Centered(640, 480, 600.0),
                   CameraFromObjectAtView({1, 1, 1}, 20.0, 4.0 * mesh.Radius(), mesh.Centre()),
                   &mask);
  for (auto _ : state) benchmark::DoNotOptimize(ExtractSignature(mask));
  state.SetLabel(mesh.name + ", " + std::to_string(cv::countNonZero(mask)) + " px");
}
BENCHMARK(BM_ExtractSignature640x480)->Unit(benchmark::kMicrosecond);

void BM_RenderDatabaseView(benchmark::State& state) {
  const std::vector<std::filesystem::path> models = BenchModels();
  // The largest model.
  TriangleMesh mesh;
  for (const auto& path : models) {
    TriangleMesh candidate = LoadMesh(path);
    if (candidate.triangles.size() > mesh.triangles.size()) mesh = std::move(candidate);
  }
  ViewRenderOptions options;
  options.resolution_px = static_cast<int>(state.range(0));
  cv::Mat mask;
  int view = 0;
  const std::vector<Eigen::Vector3d> directions = FibonacciSphere(100);
  for (auto _ : state) {
    RenderView(mesh, directions[static_cast<size_t>(view++ % 100)], 0.0, options, &mask);
    benchmark::DoNotOptimize(mask.data);
  }
  state.SetLabel(mesh.name + ", " + std::to_string(mesh.triangles.size()) + " triangles");
}
BENCHMARK(BM_RenderDatabaseView)->Arg(256)->Arg(512)->Unit(benchmark::kMicrosecond);

// Brute-force match of silhouettes of real views (not random signatures: pruning depends on how
// alike the database views are) against the whole database.
void BM_MatchDatabase(benchmark::State& state) {
  const ViewDatabase& database = BenchDatabase();
  const ViewSpectra spectra(database);
  ViewMatcher matcher(spectra);
  // Query signatures: database views rendered again at another roll and size.
  std::vector<TriangleMesh> meshes;
  for (const auto& path : BenchModels()) meshes.push_back(LoadMesh(path));
  std::vector<std::vector<float>> queries;
  std::mt19937 rng(3);
  for (int q = 0; q < 64; ++q) {
    const auto& mesh = meshes[static_cast<size_t>(q) % meshes.size()];
    ViewRenderOptions options = database.parameters.render;
    options.resolution_px /= 2;
    cv::Mat mask;
    RenderView(mesh, database.sphere.directions[static_cast<size_t>(rng() % 1000)],
               std::uniform_real_distribution<double>(-180, 180)(rng), options, &mask);
    const SignatureResult result = ExtractSignature(mask);
    if (result.ok()) queries.push_back(result.signature.radii);
  }
  MatchOptions options;
  options.top_k = static_cast<int>(state.range(1));
  options.exhaustive = state.range(0) != 0;
  size_t q = 0;
  int64_t correlated = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(matcher.Match(queries[q++ % queries.size()], options));
    correlated += matcher.last_stats().views_correlated;
  }
  state.counters["views"] = static_cast<double>(database.models.size()) * database.num_views();
  state.counters["correlated"] =
      static_cast<double>(correlated) / static_cast<double>(state.iterations());
  state.SetLabel(std::string(options.exhaustive ? "exhaustive" : "pruned") + ", " +
                 std::to_string(database.models.size()) + " models");
}
BENCHMARK(BM_MatchDatabase)
    ->Args({0, 1})
    ->Args({0, 5})
    ->Args({1, 5})
    ->Unit(benchmark::kMillisecond);

// Every view's spectrum at once (ViewSpectra::ComputeAll, what a tracker can do in its constructor
// instead of making each spectrum on first use), on 1 and 2 threads; spectra_MB is what they hold.
void BM_ViewSpectraComputeAll(benchmark::State& state) {
  const ViewDatabase& database = BenchDatabase();
  size_t bytes = 0;
  size_t computed = 0;
  for (auto _ : state) {
    const ViewSpectra spectra(database);
    spectra.ComputeAll(static_cast<int>(state.range(0)));
    bytes = spectra.MemoryBytes();
    computed = spectra.num_computed();
  }
  state.counters["spectra"] = static_cast<double>(computed);
  state.counters["spectra_MB"] = static_cast<double>(bytes) / (1024.0 * 1024.0);
  state.SetLabel(std::to_string(database.models.size()) + " models x " +
                 std::to_string(database.num_shells()) + " shells x 1000 views");
}
BENCHMARK(BM_ViewSpectraComputeAll)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_BuildDatabase(benchmark::State& state) {
  const std::vector<std::filesystem::path> models = BenchModels();
  DatabaseBuildOptions options;
  options.num_threads = static_cast<int>(state.range(0));
  size_t bytes = 0;
  for (auto _ : state) {
    // What `silpose build-db` does: render and describe every view in every distance shell, then
    // store each view's spectrum.
    ViewDatabase database = BuildViewDatabase(models, options);
    StoreViewSpectra(&database, CorrelationOptions{}, options.num_threads);
    bytes = database.Serialize().size();
  }
  state.counters["file_MB"] = static_cast<double>(bytes) / 1e6;
  state.SetLabel(std::to_string(models.size()) + " models x 1000 views x " +
                 std::to_string(options.parameters.num_shells()) + " shells");
}
BENCHMARK(BM_BuildDatabase)->Arg(1)->Arg(2)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
}  // namespace silpose

BENCHMARK_MAIN();
