#include "silpose/eval/tracking_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <set>

#include "silpose/match/view_matcher.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/util/error.h"
#include "silpose/util/parallel.h"
#include "silpose/util/threads.h"

namespace silpose {
namespace {

using Clock = std::chrono::steady_clock;

double Milliseconds(Clock::time_point start, Clock::time_point end) {
  return std::chrono::duration<double, std::milli>(end - start).count();
}

// One flight, rendered once: the masks and the true view directions.
struct Flight {
  int model = -1;
  std::vector<cv::Mat> masks;
  std::vector<Eigen::Vector3d> true_view_dirs;
  // The flown model's symmetry transforms (geometry/symmetry.h), for the error modulo symmetry.
  std::vector<Rigid3> symmetries;
};

Flight RenderFlight(const TriangleMesh& mesh, int model, const ObjectSymmetry& symmetry,
                    const TrackingExperimentOptions& options, int num_threads) {
  SequenceOptions sequence_options;
  sequence_options.trajectory.kind = TrajectoryKind::kOrbit;
  sequence_options.trajectory.num_frames = options.frames;
  sequence_options.trajectory.orbit = options.orbit;
  const SyntheticSequence sequence({mesh}, sequence_options);
  Flight flight;
  flight.model = model;
  flight.symmetries = SymmetryTransforms(symmetry);
  flight.masks.resize(static_cast<size_t>(options.frames));
  for (const TrajectoryFrame& frame : sequence.trajectory()) {
    flight.true_view_dirs.push_back(frame.view_dir_in_object);
  }
  ParallelFor(0, options.frames, 1, num_threads, [&](int first, int last) {
    for (int k = first; k < last; ++k) {
      SyntheticFrame frame;
      sequence.Generate(k, &frame);
      flight.masks[static_cast<size_t>(k)] = frame.mask;
    }
  });
  return flight;
}

double PoseError(const ViewDatabase& database, int view, const Eigen::Vector3d& truth) {
  return (database.sphere.directions[static_cast<size_t>(view)] - truth).norm();
}

// The frame's errors: the paper's, and modulo the flown model's symmetry when the estimate names
// that model (another object's view is as wrong with or without the symmetry).
void SetPoseErrors(const ViewDatabase& database, const Flight& flight, size_t k,
                   TrackingFrameResult* frame) {
  frame->pose_error = PoseError(database, frame->view, flight.true_view_dirs[k]);
  frame->pose_error_symmetric =
      frame->object == flight.model
          ? ViewErrorModuloSymmetry(database.sphere.directions[static_cast<size_t>(frame->view)],
                                    flight.true_view_dirs[k], flight.symmetries)
          : frame->pose_error;
}

void RunFilter(const ViewDatabase& database, const ViewSpectra& spectra, const Flight& flight,
               const TrackingExperimentOptions& options, TrackingRun* run) {
  ParticleFilterOptions filter_options = options.filter;
  filter_options.particles_per_object = run->particles;
  filter_options.seed = run->seed;
  filter_options.adaptive = options.adaptive;
  filter_options.min_particles_per_object =
      std::min(filter_options.min_particles_per_object, run->particles);
  filter_options.max_particles_per_object =
      std::max(filter_options.max_particles_per_object, run->particles);
  ParticleFilter filter(database.sphere, spectra, filter_options);
  run->frames.resize(flight.masks.size());
  for (size_t k = 0; k < flight.masks.size(); ++k) {
    TrackingFrameResult& frame = run->frames[k];
    const Clock::time_point start = Clock::now();
    const SignatureResult silhouette =
        ExtractSignature(flight.masks[k], database.parameters.signature);
    const FilterEstimate estimate =
        silhouette.ok() ? filter.Step(silhouette.signature.radii) : filter.Predict();
    frame.time_ms = Milliseconds(start, Clock::now());
    frame.particles = static_cast<int>(filter.particles().size());
    frame.measured = silhouette.ok();
    frame.object = estimate.object;
    frame.view = estimate.view;
    frame.score = estimate.score;
    if (frame.view >= 0) SetPoseErrors(database, flight, k, &frame);
  }
}

void RunBruteForceFrame(const ViewDatabase& database, ViewMatcher& matcher, const Flight& flight,
                        size_t k, TrackingFrameResult* frame) {
  const Clock::time_point start = Clock::now();
  const SignatureResult silhouette =
      ExtractSignature(flight.masks[k], database.parameters.signature);
  std::vector<MatchCandidate> top;
  if (silhouette.ok()) top = matcher.Match(silhouette.signature.radii, {.top_k = 1});
  frame->time_ms = Milliseconds(start, Clock::now());
  frame->measured = silhouette.ok();
  if (!top.empty()) {
    frame->object = top.front().model;
    frame->view = top.front().view;
    frame->score = top.front().score;
    SetPoseErrors(database, flight, k, frame);
  }
}

TrackingStats Aggregate(const std::vector<const TrackingRun*>& runs) {
  TrackingStats stats;
  double sum = 0.0, time = 0.0, symmetric_sum = 0.0;
  for (const TrackingRun* run : runs) {
    ++stats.runs;
    for (const TrackingFrameResult& f : run->frames) {
      ++stats.frames;
      stats.right_object_frames += f.object == run->model;
      sum += f.pose_error;
      symmetric_sum += f.pose_error_symmetric;
      time += f.time_ms;
      stats.pose_error_max = std::max(stats.pose_error_max, f.pose_error);
    }
  }
  if (stats.frames == 0) return stats;
  stats.pose_error_mean = sum / stats.frames;
  stats.symmetric_pose_error_mean = symmetric_sum / stats.frames;
  stats.ms_per_frame_mean = time / stats.frames;
  // Second pass for the spread (no cancellation).
  double squares = 0.0, symmetric_squares = 0.0;
  for (const TrackingRun* run : runs) {
    for (const TrackingFrameResult& f : run->frames) {
      squares += (f.pose_error - stats.pose_error_mean) * (f.pose_error - stats.pose_error_mean);
      const double d = f.pose_error_symmetric - stats.symmetric_pose_error_mean;
      symmetric_squares += d * d;
    }
  }
  stats.pose_error_std = std::sqrt(squares / stats.frames);
  stats.symmetric_pose_error_std = std::sqrt(symmetric_squares / stats.frames);
  return stats;
}

std::ofstream OpenCsv(const std::filesystem::path& path) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(9);
  return file;
}

void CloseCsv(std::ofstream& file, const std::filesystem::path& path) {
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

const char* MethodName(const TrackingRun& run) {
  return run.brute_force() ? "brute-force" : "particle-filter";
}

}  // namespace

bool TrackingExperimentOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (flown_models.empty() && num_flown < 1) return fail("at least one model must be flown");
  if (frames < 1 || frames > 1000000) return fail("frames per flight must be in [1, 1000000]");
  std::string problem;
  if (!orbit.Check(&problem)) return fail("orbit: " + problem);
  if (particle_counts.empty() && !brute_force) {
    return fail("nothing to run: no particle counts and no brute force");
  }
  for (int n : particle_counts) {
    if (n < 1) return fail("particle counts must be >= 1");
  }
  if (std::set<int>(particle_counts.begin(), particle_counts.end()).size() !=
      particle_counts.size()) {
    return fail("particle counts must not repeat");
  }
  if (repeats < 1) return fail("repeats must be >= 1");
  if (num_threads < 0) return fail("thread count must be >= 0");
  ParticleFilterOptions probe = filter;
  probe.adaptive = adaptive;
  for (int n : particle_counts) {
    probe.particles_per_object = n;
    probe.min_particles_per_object = std::min(filter.min_particles_per_object, n);
    probe.max_particles_per_object = std::max(filter.max_particles_per_object, n);
    if (!probe.Check(&problem)) return fail("filter options: " + problem);
  }
  return true;
}

double TrackingStats::right_object_percent() const {
  return frames > 0 ? 100.0 * right_object_frames / frames : 0.0;
}

int TrackingRun::SettledFrame(int flown_model) const {
  int settled = static_cast<int>(frames.size());
  while (settled > 0 && frames[static_cast<size_t>(settled - 1)].object == flown_model) --settled;
  return settled;
}

TrackingStats TrackingRun::Stats() const { return Aggregate({this}); }

const TrackingRow* TrackingExperimentResult::BruteForce() const {
  for (const TrackingRow& row : rows) {
    if (row.particles == 0) return &row;
  }
  return nullptr;
}

const TrackingRow* TrackingExperimentResult::Filter(int particles) const {
  for (const TrackingRow& row : rows) {
    if (row.particles == particles && particles > 0) return &row;
  }
  return nullptr;
}

std::vector<int> SpreadModelIndices(int num_models, int count) {
  count = std::min(count, num_models);
  std::vector<int> indices;
  for (int i = 0; i < count; ++i) {
    indices.push_back(static_cast<int>((2 * static_cast<int64_t>(i) + 1) * num_models /
                                       (2 * static_cast<int64_t>(count))));
  }
  return indices;
}

std::vector<int> FlownModelIndices(const ViewDatabase& database,
                                   const TrackingExperimentOptions& options) {
  if (options.flown_models.empty()) {
    std::vector<int> preferred;
    for (const std::string& name : kDefaultFlownModels) {
      const int index = database.FindModel(name);
      if (index >= 0) preferred.push_back(index);
    }
    if (options.num_flown == static_cast<int>(kDefaultFlownModels.size()) &&
        preferred.size() == kDefaultFlownModels.size()) {
      return preferred;
    }
    return SpreadModelIndices(static_cast<int>(database.models.size()), options.num_flown);
  }
  std::vector<int> indices;
  for (const std::string& name : options.flown_models) {
    const int index = database.FindModel(name);
    if (index < 0) {
      std::string known;
      for (const ModelViews& m : database.models) known += (known.empty() ? "" : ", ") + m.name;
      ThrowError("model to fly '", name, "' is not in the database (", known, ")");
    }
    if (std::find(indices.begin(), indices.end(), index) != indices.end()) {
      ThrowError("model to fly '", name, "' is named twice");
    }
    indices.push_back(index);
  }
  return indices;
}

int TrackingRunCount(const TrackingExperimentOptions& options, int num_flown) {
  return num_flown * (static_cast<int>(options.particle_counts.size()) * options.repeats +
                      (options.brute_force ? 1 : 0));
}

TrackingExperimentResult RunTrackingExperiment(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const TrackingExperimentOptions& options,
                                               const std::function<void(int)>& on_progress) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid tracking experiment options: ", error);
  if (meshes.size() != database.models.size()) {
    ThrowError("the tracking experiment needs one mesh per database model (",
               database.models.size(), "), got ", meshes.size());
  }
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (meshes[m].name != database.models[m].name) {
      ThrowError("mesh '", meshes[m].name, "' does not match database model '",
                 database.models[m].name, "'");
    }
  }
  const std::vector<int> flown = FlownModelIndices(database, options);
  const int num_threads = WorkerThreads(options.num_threads);
  const Clock::time_point start = Clock::now();

  TrackingExperimentResult result;
  result.frames_per_flight = options.frames;
  result.num_models = static_cast<int>(database.models.size());
  result.num_threads = num_threads;
  for (int m : flown) result.flown_models.push_back(database.models[static_cast<size_t>(m)].name);

  const ViewSpectra spectra(database);
  std::vector<int> counts = options.particle_counts;
  std::sort(counts.begin(), counts.end());
  std::vector<TrackingRun> filter_runs, brute_runs;
  // Brute-force matchers, one per chunk of frames in flight, reused by the chunks after it.
  std::mutex matchers_mutex;
  std::vector<std::unique_ptr<ViewMatcher>> matchers;
  for (int model : flown) {
    const Flight flight =
        RenderFlight(meshes[static_cast<size_t>(model)], model,
                     database.models[static_cast<size_t>(model)].symmetry, options, num_threads);
    std::vector<TrackingRun> runs;
    for (int particles : counts) {
      for (int r = 0; r < options.repeats; ++r) {
        TrackingRun run;
        run.model = model;
        run.model_name = database.models[static_cast<size_t>(model)].name;
        run.particles = particles;
        run.seed = options.first_seed + static_cast<uint64_t>(r);
        runs.push_back(std::move(run));
      }
    }
    auto run_filter = [&](size_t i) {
      RunFilter(database, spectra, flight, options, &runs[i]);
      if (on_progress) on_progress(1);
    };
    if (num_threads == 1) {
      // In the calling thread: nothing else runs beside it, so the times are single-core times.
      for (size_t i = 0; i < runs.size(); ++i) run_filter(i);
    } else {
      ParallelFor(0, static_cast<int>(runs.size()), 1, num_threads, [&](int first, int last) {
        for (int i = first; i < last; ++i) run_filter(static_cast<size_t>(i));
      });
    }
    for (TrackingRun& run : runs) filter_runs.push_back(std::move(run));

    if (options.brute_force) {
      TrackingRun run;
      run.model = model;
      run.model_name = database.models[static_cast<size_t>(model)].name;
      run.frames.resize(flight.masks.size());
      auto match_frames = [&](int first, int last) {
        std::unique_ptr<ViewMatcher> matcher;
        {
          const std::lock_guard<std::mutex> lock(matchers_mutex);
          if (!matchers.empty()) {
            matcher = std::move(matchers.back());
            matchers.pop_back();
          }
        }
        if (!matcher) matcher = std::make_unique<ViewMatcher>(spectra);
        for (int k = first; k < last; ++k) {
          RunBruteForceFrame(database, *matcher, flight, static_cast<size_t>(k),
                             &run.frames[static_cast<size_t>(k)]);
        }
        const std::lock_guard<std::mutex> lock(matchers_mutex);
        matchers.push_back(std::move(matcher));
      };
      const int frames = static_cast<int>(flight.masks.size());
      if (num_threads == 1) {
        match_frames(0, frames);
      } else {
        ParallelFor(0, frames, 4, num_threads, match_frames);
      }
      brute_runs.push_back(std::move(run));
      if (on_progress) on_progress(1);
    }
  }
  result.runs = std::move(filter_runs);
  for (TrackingRun& run : brute_runs) result.runs.push_back(std::move(run));

  for (int particles : counts) {
    std::vector<const TrackingRun*> selected;
    for (const TrackingRun& run : result.runs) {
      if (run.particles == particles) selected.push_back(&run);
    }
    result.rows.push_back({"particle-filter", particles, Aggregate(selected)});
  }
  if (options.brute_force) {
    std::vector<const TrackingRun*> selected;
    for (const TrackingRun& run : result.runs) {
      if (run.brute_force()) selected.push_back(&run);
    }
    result.rows.push_back({"brute-force", 0, Aggregate(selected)});
  }
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

const char* TrackingTableHeader() {
  return "method,particles,runs,frames,pose_error_mean,pose_error_std,right_object_percent,"
         "ms_per_frame_mean,symmetric_pose_error_mean,symmetric_pose_error_std";
}

const char* TrackingRunsHeader() {
  return "method,model,particles,seed,frames,right_object_frames,right_object_percent,"
         "settled_frame,pose_error_mean,pose_error_std,pose_error_max,ms_per_frame_mean,"
         "symmetric_pose_error_mean,symmetric_pose_error_std";
}

void WriteTrackingTable(const std::filesystem::path& path, const TrackingExperimentResult& result) {
  std::ofstream csv = OpenCsv(path);
  csv << TrackingTableHeader() << '\n';
  for (const TrackingRow& row : result.rows) {
    const TrackingStats& s = row.stats;
    csv << row.method << ',' << row.particles << ',' << s.runs << ',' << s.frames << ','
        << s.pose_error_mean << ',' << s.pose_error_std << ',' << s.right_object_percent() << ','
        << s.ms_per_frame_mean << ',' << s.symmetric_pose_error_mean << ','
        << s.symmetric_pose_error_std << '\n';
  }
  CloseCsv(csv, path);
}

void WriteTrackingRuns(const std::filesystem::path& path, const TrackingExperimentResult& result) {
  std::ofstream csv = OpenCsv(path);
  csv << TrackingRunsHeader() << '\n';
  for (const TrackingRun& run : result.runs) {
    const TrackingStats s = run.Stats();
    csv << MethodName(run) << ',' << run.model_name << ',' << run.particles << ',' << run.seed
        << ',' << s.frames << ',' << s.right_object_frames << ',' << s.right_object_percent() << ','
        << run.SettledFrame(run.model) << ',' << s.pose_error_mean << ',' << s.pose_error_std << ','
        << s.pose_error_max << ',' << s.ms_per_frame_mean << ',' << s.symmetric_pose_error_mean
        << ',' << s.symmetric_pose_error_std << '\n';
  }
  CloseCsv(csv, path);
}

void WriteTrackingFrames(const std::filesystem::path& path, const TrackingExperimentResult& result,
                         const ViewDatabase& database) {
  std::ofstream csv = OpenCsv(path);
  csv << "method,model,particles,seed,frame,estimated_object,estimated_view,measured,right_object,"
         "score,pose_error,time_ms,pose_error_symmetric\n";
  for (const TrackingRun& run : result.runs) {
    for (size_t k = 0; k < run.frames.size(); ++k) {
      const TrackingFrameResult& f = run.frames[k];
      csv << MethodName(run) << ',' << run.model_name << ',' << run.particles << ',' << run.seed
          << ',' << k << ','
          << (f.object >= 0 ? database.models[static_cast<size_t>(f.object)].name : "") << ','
          << f.view << ',' << (f.measured ? 1 : 0) << ',' << (f.object == run.model ? 1 : 0) << ','
          << f.score << ',' << f.pose_error << ',' << f.time_ms << ',' << f.pose_error_symmetric
          << '\n';
    }
  }
  CloseCsv(csv, path);
}

Figure TrackingFigure(const TrackingExperimentResult& result) {
  PlotSeries error_series, right_series;
  error_series.label = right_series.label = "particle filter";
  error_series.marker = right_series.marker = Marker::kCross;
  error_series.marker_radius_px = right_series.marker_radius_px = 4.0;
  for (const TrackingRow& row : result.rows) {
    if (row.particles == 0) continue;
    error_series.x.push_back(row.particles);
    error_series.y.push_back(row.stats.pose_error_mean);
    error_series.y_error.push_back(row.stats.pose_error_std);
    right_series.x.push_back(row.particles);
    right_series.y.push_back(row.stats.right_object_percent());
  }
  if (error_series.x.empty()) ThrowError("the tracking figure needs at least one filter row");

  const std::string x_label = "particles per object";
  PlotPanel error;
  error.title = "Pose error (mean \xC2\xB1 std over all frames)";
  error.x_axis.label = x_label;
  error.y_axis.label = "pose error (unit sphere)";
  error.y_axis.min = 0.0;
  error.series.push_back(error_series);
  PlotPanel right;
  right.title = "Frames with the right object";
  right.x_axis.label = x_label;
  right.y_axis.label = "right object (%)";
  // Up to 100 %, with a little room for the markers there.
  double lowest = 100.0;
  for (const TrackingRow& row : result.rows) {
    lowest = std::min(lowest, row.stats.right_object_percent());
  }
  right.y_axis.max = 100.0 + std::max(0.05, (100.0 - lowest) / 20.0);
  right.series.push_back(right_series);
  if (const TrackingRow* brute = result.BruteForce()) {
    char label[96];
    std::snprintf(label, sizeof label, "brute force (%.3f)", brute->stats.pose_error_mean);
    error.reference_lines.push_back({.y = brute->stats.pose_error_mean, .label = label});
    std::snprintf(label, sizeof label, "brute force (%.2f %%)",
                  brute->stats.right_object_percent());
    right.reference_lines.push_back({.y = brute->stats.right_object_percent(), .label = label});
  }
  // Show the x range from 0 when the counts start near it, as the paper's figure does.
  for (PlotPanel* panel : {&error, &right}) {
    panel->x_axis.min = 0.0;
    panel->x_axis.max = std::max(10.0, error_series.x.back() + 0.05 * error_series.x.back());
  }
  Figure figure;
  figure.width_px = 1100;
  figure.height_px = 420;
  figure.panels = {error, right};
  return figure;
}

}  // namespace silpose
