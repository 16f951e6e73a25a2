// Runtime of the contour refinement (pose/contour_refinement.h) on 640 x 480 frames, one thread:
// the per-frame FrameOutline, the refinement from a pose 3-6 degrees and 3 % off, and both together
// (the tracker's per-frame cost). Models: the sample models cow and bunny (data/models), and the
// 12-13k-triangle bull and fandisk of ../shared/models when present.
// Run: build/release/bench/silpose_refine_bench [--benchmark_filter=Refine]

#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/pose/contour_refinement.h"
#include "silpose/pose/pose_from_silhouette.h"
#include "silpose/render/silhouette_renderer.h"

namespace silpose {
namespace {

// Model names by benchmark argument, and where to find them.
const char* const kModels[] = {"cow", "bunny", "bull", "fandisk"};

std::filesystem::path ModelFile(const std::string& name) {
  for (const char* directory : {SILPOSE_SAMPLE_MODELS_DIR, SILPOSE_SHARED_MODELS_DIR}) {
    const std::filesystem::path path = std::filesystem::path(directory) / (name + ".obj");
    std::error_code error;
    if (std::filesystem::is_regular_file(path, error)) return path;
  }
  return {};
}

// Frames of one model: masks at known poses (5 object radii, up to 15 degrees off axis) and
// starting poses 3-6 degrees and 3 % of the distance away.
struct ModelFrames {
  std::unique_ptr<ContourModel> model;
  PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.0);
  std::vector<cv::Mat> masks;
  std::vector<Rigid3> starts;
  std::string label;
};

const ModelFrames* Frames(int index) {
  static std::map<int, std::unique_ptr<ModelFrames>> cache;
  std::unique_ptr<ModelFrames>& frames = cache[index];
  if (frames) return frames.get();
  const std::filesystem::path path = ModelFile(kModels[index]);
  if (path.empty()) return nullptr;
  frames = std::make_unique<ModelFrames>();
  const TriangleMesh mesh = LoadMesh(path);
  frames->model = std::make_unique<ContourModel>(mesh);
  frames->label = mesh.name + " (" + std::to_string(mesh.triangles.size()) + " triangles)";
  std::mt19937 random(11);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const auto random_unit = [&] {
    return Eigen::Vector3d(gauss(random), gauss(random), gauss(random)).normalized();
  };
  for (int i = 0; i < 16; ++i) {
    const Rigid3 on_axis = CameraFromObjectAtView(random_unit(), 360.0 * uniform(random),
                                                  5.0 * mesh.Radius(), mesh.Centre());
    const double off = 15.0 * uniform(random) * std::numbers::pi / 180.0;
    const double azimuth = 2.0 * std::numbers::pi * uniform(random);
    const Eigen::Vector3d ray(std::sin(off) * std::cos(azimuth), std::sin(off) * std::sin(azimuth),
                              std::cos(off));
    const Eigen::Matrix3d q = RotationFromOpticalAxisTo(ray);
    const Rigid3 truth{q * on_axis.rotation, q * on_axis.translation};
    cv::Mat mask;
    RenderSilhouette(mesh, frames->camera, truth, &mask);
    frames->masks.push_back(mask);
    Eigen::Matrix<double, 6, 1> update;
    update << (3.0 + 3.0 * uniform(random)) * std::numbers::pi / 180.0 * random_unit(),
        0.03 * (truth * mesh.Centre()).norm() * random_unit();
    frames->starts.push_back(ApplyContourUpdate(truth, mesh.Centre(), update));
  }
  return frames.get();
}

// range(0): model; range(1): 0 = refinement only, 1 = FrameOutline only, 2 = both.
void BM_RefineToContour(benchmark::State& state) {
  const ModelFrames* frames = Frames(static_cast<int>(state.range(0)));
  if (frames == nullptr) {
    state.SkipWithError("model not found");
    return;
  }
  const int part = static_cast<int>(state.range(1));
  std::vector<std::unique_ptr<FrameOutline>> outlines;
  for (const cv::Mat& mask : frames->masks)
    outlines.push_back(std::make_unique<FrameOutline>(mask));
  ContourRefinementOptions options;
  size_t frame = 0;
  double iterations = 0.0, rms = 0.0;
  for (auto _ : state) {
    const size_t i = frame++ % frames->masks.size();
    if (part == 1) {
      benchmark::DoNotOptimize(FrameOutline(frames->masks[i]));
      continue;
    }
    ContourRefinementResult result;
    if (part == 0) {
      result = RefinePoseToContour(*frames->model, frames->camera, *outlines[i], frames->starts[i],
                                   options);
    } else {
      const FrameOutline outline(frames->masks[i]);
      result =
          RefinePoseToContour(*frames->model, frames->camera, outline, frames->starts[i], options);
    }
    iterations += result.iterations;
    rms += result.final_rms_px;
  }
  if (part != 1) {
    state.counters["iterations"] = iterations / static_cast<double>(state.iterations());
    state.counters["rms_px"] = rms / static_cast<double>(state.iterations());
  }
  state.SetLabel(frames->label + (part == 0 ? ", refinement" : part == 1 ? ", outline" : ", both"));
}
BENCHMARK(BM_RefineToContour)
    ->ArgNames({"model", "part"})
    ->ArgsProduct({{0, 1, 2, 3}, {0, 1, 2}})
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace silpose

BENCHMARK_MAIN();
