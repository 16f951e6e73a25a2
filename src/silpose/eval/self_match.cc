#include "silpose/eval/self_match.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <random>

#include "silpose/geometry/view_frame.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"
#include "silpose/util/parallel.h"
#include "silpose/util/threads.h"

namespace silpose {

void SelfMatchModelResult::Add(const SelfMatchModelResult& other) {
  queries += other.queries;
  right_model += other.right_model;
  own_view += other.own_view;
  own_or_neighbour += other.own_or_neighbour;
  passed += other.passed;
  failed_but_indistinguishable += other.failed_but_indistinguishable;
  nearly_circular += other.nearly_circular;
  not_describable += other.not_describable;
  failures.insert(failures.end(), other.failures.begin(), other.failures.end());
}

bool SelfMatchOptions::Check(std::string* error) const {
  auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (scales.empty()) return fail("at least one scale is needed");
  for (double s : scales) {
    if (!(s > 0.0) || !std::isfinite(s)) return fail("scales must be positive");
  }
  if (!(roll_tolerance_bins >= 0.0)) return fail("roll tolerance must be >= 0");
  if (view_stride < 1) return fail("view stride must be >= 1");
  if (num_threads < 0) return fail("thread count must be >= 0");
  return true;
}

std::vector<SelfMatchModelResult> RunSelfMatch(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const SelfMatchOptions& options,
                                               const std::function<void(int)>& on_progress) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid self-match options: ", error);
  if (meshes.size() != database.models.size()) {
    ThrowError("self-match needs one mesh per database model (", database.models.size(), "), got ",
               meshes.size());
  }
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (meshes[m].name != database.models[m].name) {
      ThrowError("mesh '", meshes[m].name, "' does not match database model '",
                 database.models[m].name, "'");
    }
  }
  const ViewSpectra spectra(database);
  const int length = database.signature_length();
  const double bins_per_degree = length / 360.0;
  const int num_views = database.num_views();

  struct Worker {
    explicit Worker(const ViewSpectra& spectra) : matcher(spectra) {}
    ViewMatcher matcher;
    cv::Mat mask;
  };
  // One worker (matcher and mask buffer) per chunk of views in flight, reused by later chunks.
  std::vector<std::unique_ptr<Worker>> workers;
  std::vector<SelfMatchModelResult> results(meshes.size());
  std::mutex results_mutex;

  for (size_t m = 0; m < meshes.size(); ++m) {
    SelfMatchModelResult& result = results[m];
    result.name = meshes[m].name;
    // Per model, not per query: the mesh's centre and radius, the camera of each scale.
    const Eigen::Vector3d centre = meshes[m].Centre();
    // Queries are rendered like the first shell (the matcher's shell without an apparent size).
    const double distance = database.parameters.distances_in_radii.front() * meshes[m].Radius();
    std::vector<PinholeCamera> cameras;
    for (double scale : options.scales) {
      ViewRenderOptions render = database.parameters.ShellRender(0);
      render.resolution_px =
          std::max(32, static_cast<int>(std::lround(render.resolution_px * scale)));
      cameras.push_back(ViewCamera(render));
    }
    auto run_views = [&](int first, int last) {
      std::unique_ptr<Worker> worker;
      {
        std::lock_guard lock(results_mutex);
        if (!workers.empty()) {
          worker = std::move(workers.back());
          workers.pop_back();
        }
      }
      if (!worker) worker = std::make_unique<Worker>(spectra);
      SelfMatchModelResult local;
      int done = 0;
      for (int v = first; v != last; ++v) {
        if (v % options.view_stride != 0) continue;
        ++done;
        const Eigen::Vector3d& direction = database.sphere.directions[static_cast<size_t>(v)];
        for (size_t s = 0; s < options.scales.size(); ++s) {
          std::mt19937_64 rng(options.seed ^ (0x9e3779b97f4a7c15ULL *
                                              (m * 1000003 + static_cast<size_t>(v) * 17 + s + 1)));
          const double roll = std::uniform_real_distribution<double>(-180.0, 180.0)(rng);
          RenderSilhouette(meshes[m], cameras[s],
                           CameraFromObjectAtView(direction, roll, distance, centre),
                           &worker->mask);
          SignatureOptions signature_options = database.parameters.signature;
          const SignatureResult described = ExtractSignature(worker->mask, signature_options);
          ++local.queries;
          if (!described.ok()) {
            ++local.not_describable;
            continue;
          }
          if (described.flags & kSilhouetteNearlyCircular) ++local.nearly_circular;
          const std::vector<MatchCandidate> top =
              worker->matcher.Match(described.signature.radii, {.top_k = 1});
          if (top.empty()) {  // no database view of any model has a usable silhouette
            local.failures.push_back({v, options.scales[s], roll, -1, -1, 0.0, 0.0f, 0.0f});
            continue;
          }
          const MatchCandidate& best = top.front();
          const bool right_model = best.model == static_cast<int>(m);
          bool near = false;
          double roll_error_deg = 180.0;
          if (right_model) {
            if (best.view == v) {
              near = true;
              ++local.own_view;
              roll_error_deg = std::abs(WrapDegrees(best.roll_deg - roll));
            } else {
              for (uint32_t n : database.sphere.Neighbours(v))
                near |= static_cast<int>(n) == best.view;
              if (near) {
                const double expected = TransportRoll(
                    direction, roll, database.sphere.directions[static_cast<size_t>(best.view)]);
                roll_error_deg = std::abs(WrapDegrees(best.roll_deg - expected));
              }
            }
          }
          local.right_model += right_model;
          local.own_or_neighbour += near;
          if (near && roll_error_deg * bins_per_degree <= options.roll_tolerance_bins) {
            ++local.passed;
            continue;
          }
          SelfMatchFailure failure;
          failure.view = v;
          failure.scale = options.scales[s];
          failure.true_roll_deg = roll;
          failure.found_model = best.model;
          failure.found_view = best.view;
          failure.found_roll_deg = best.roll_deg;
          failure.found_score = best.score;
          failure.silhouette_agreement = worker->matcher.correlator().ScoreAtShift(
              spectra.Get(static_cast<int>(m), v), spectra.Get(best.model, best.view),
              (best.roll_deg - roll) * bins_per_degree);
          if (failure.silhouette_agreement >= 0.99f) ++local.failed_but_indistinguishable;
          local.failures.push_back(failure);
        }
      }
      std::lock_guard lock(results_mutex);
      result.Add(local);
      workers.push_back(std::move(worker));
      if (on_progress) on_progress(done);
    };
    ParallelFor(0, num_views, 16, WorkerThreads(options.num_threads), run_views);
    std::sort(result.failures.begin(), result.failures.end(),
              [](const SelfMatchFailure& a, const SelfMatchFailure& b) {
                return a.view != b.view ? a.view < b.view : a.scale < b.scale;
              });
  }
  return results;
}

}  // namespace silpose
