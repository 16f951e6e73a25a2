#include "silpose/eval/scale_experiment.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <set>
#include <system_error>
#include <utility>

#include "silpose/database/database_builder.h"
#include "silpose/eval/tracking_experiment.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"
#include "silpose/util/threads.h"

namespace silpose {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// A folder made for the experiment, removed with everything in it when this goes out of scope.
class TemporaryFolder {
 public:
  explicit TemporaryFolder(const std::filesystem::path& parent) {
    std::error_code error;
    if (!std::filesystem::is_directory(parent, error)) {
      ThrowError(parent.string(),
                 ": not a folder (the scale experiment writes its databases there)");
    }
    for (int attempt = 0; attempt < 1000; ++attempt) {
      const std::filesystem::path candidate =
          parent / ("silpose-scale-" + std::to_string(getpid()) + "-" + std::to_string(attempt));
      if (std::filesystem::create_directory(candidate, error)) {
        path_ = candidate;
        return;
      }
      if (error) {
        ThrowError(candidate.string(), ": cannot create a temporary folder: ", error.message());
      }
    }
    ThrowError(parent.string(), ": cannot create a temporary folder (all names taken)");
  }
  ~TemporaryFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TemporaryFolder(const TemporaryFolder&) = delete;
  TemporaryFolder& operator=(const TemporaryFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// The counted frames (from `skip` on) of the given runs of one method.
ScaleMethodStats MethodStats(const std::vector<const TrackingRun*>& runs, int skip) {
  ScaleMethodStats stats;
  std::vector<double> times;
  double particles = 0.0;
  for (const TrackingRun* run : runs) {
    for (size_t k = static_cast<size_t>(skip); k < run->frames.size(); ++k) {
      const TrackingFrameResult& frame = run->frames[k];
      ++stats.frames;
      stats.right_object_frames += frame.object == run->model;
      times.push_back(frame.time_ms);
      particles += frame.particles;
    }
  }
  if (times.empty()) return stats;
  double sum = 0.0;
  for (double t : times) sum += t;
  stats.ms_per_frame_mean = sum / static_cast<double>(times.size());
  const auto middle = times.begin() + static_cast<std::ptrdiff_t>(times.size() / 2);
  std::nth_element(times.begin(), middle, times.end());
  stats.ms_per_frame_median = *middle;
  stats.particles_mean = particles / static_cast<double>(stats.frames);
  return stats;
}

std::vector<const TrackingRun*> Runs(const TrackingExperimentResult& result, bool brute_force) {
  std::vector<const TrackingRun*> runs;
  for (const TrackingRun& run : result.runs) {
    if (run.brute_force() == brute_force) runs.push_back(&run);
  }
  return runs;
}

ScalePoint MeasurePoint(const std::vector<TriangleMesh>& catalogue,
                        const std::vector<std::filesystem::path>& catalogue_paths, int objects,
                        int views, const ScaleExperimentOptions& options,
                        const std::filesystem::path& folder) {
  ScalePoint point;
  point.objects = objects;
  point.views_per_object = views;
  point.shells = options.parameters.num_shells();

  DatabaseBuildOptions build;
  build.parameters = options.parameters;
  build.parameters.view_sphere.num_views = views;
  build.num_threads = options.build_threads;
  build.show_progress = options.show_progress;
  const std::vector<std::filesystem::path> paths(
      catalogue_paths.begin(), catalogue_paths.begin() + static_cast<std::ptrdiff_t>(objects));
  const std::filesystem::path file = folder / "scale.db";
  {
    const Clock::time_point start = Clock::now();
    ViewDatabase built = BuildViewDatabase(paths, build);
    StoreViewSpectra(&built, CorrelationOptions{}, options.build_threads);
    if (!build.keep_signatures) built.DropSignatures();
    built.Write(file);
    point.build_seconds = Seconds(start);
  }
  point.file_bytes = static_cast<double>(std::filesystem::file_size(file));

  const ViewDatabase database = ViewDatabase::Read(file);
  const std::vector<TriangleMesh> meshes(catalogue.begin(),
                                         catalogue.begin() + static_cast<std::ptrdiff_t>(objects));
  TrackingExperimentOptions tracking;
  tracking.num_flown = options.num_flown;
  tracking.frames = options.frames;
  tracking.orbit.step_deg = options.step_deg;
  tracking.orbit.distance_in_radii = options.parameters.distances_in_radii.front();
  tracking.particle_counts = {options.particles_per_object};
  tracking.repeats = 1;
  tracking.num_threads = 1;
  tracking.brute_force = true;
  const TrackingExperimentResult fixed = RunTrackingExperiment(database, meshes, tracking);
  tracking.adaptive = true;
  tracking.brute_force = false;
  const TrackingExperimentResult adaptive = RunTrackingExperiment(database, meshes, tracking);

  point.flown = fixed.flown_models;
  point.brute_force = MethodStats(Runs(fixed, true), options.skip_frames);
  point.filter = MethodStats(Runs(fixed, false), options.skip_frames);
  point.adaptive = MethodStats(Runs(adaptive, false), options.skip_frames);
  std::error_code ignored;
  std::filesystem::remove(file, ignored);
  return point;
}

std::string Mb(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", bytes / 1e6);
  return text;
}

}  // namespace

std::vector<TriangleMesh> StretchedCatalogue(const std::vector<TriangleMesh>& meshes, int count) {
  if (meshes.empty()) ThrowError("a stretched catalogue needs at least one mesh");
  const int most = static_cast<int>(kScaleStretches.size() * meshes.size());
  if (count < 0 || count > most) {
    ThrowError("a catalogue of ", count, " objects needs at least ", (count + 9) / 10,
               " meshes (ten stretches of each), got ", meshes.size());
  }
  std::vector<TriangleMesh> catalogue;
  catalogue.reserve(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    const TriangleMesh& base = meshes[static_cast<size_t>(i) % meshes.size()];
    const size_t k = static_cast<size_t>(i) / meshes.size();
    const auto& factors = kScaleStretches[k];
    TriangleMesh mesh;
    mesh.name = base.name + "_" + std::to_string(k);
    mesh.triangles = base.triangles;
    mesh.vertices.reserve(base.vertices.size());
    for (const Eigen::Vector3f& v : base.vertices) {
      mesh.vertices.emplace_back(static_cast<float>(v.x() * factors[0]),
                                 static_cast<float>(v.y() * factors[1]),
                                 static_cast<float>(v.z() * factors[2]));
    }
    catalogue.push_back(std::move(mesh));
  }
  return catalogue;
}

void WriteObj(const TriangleMesh& mesh, const std::filesystem::path& path) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(9);
  for (const Eigen::Vector3f& v : mesh.vertices) {
    file << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  }
  for (const auto& t : mesh.triangles) {
    file << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  }
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

DatabaseParameters ScaleExperimentOptions::OneShellParameters() {
  DatabaseParameters parameters;
  parameters.distances_in_radii = {3.0};
  return parameters;
}

bool ScaleExperimentOptions::Check(int num_meshes, std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (object_counts.empty() || view_counts.empty()) {
    return fail("both sweeps need at least one point (object counts and view counts)");
  }
  const int most = 10 * num_meshes;
  for (int n : object_counts) {
    if (n < 1 || n > most) {
      return fail("object counts must be in [1, " + std::to_string(most) + "] (ten per mesh, " +
                  std::to_string(num_meshes) + " meshes), got " + std::to_string(n));
    }
  }
  if (objects < 1 || objects > most) {
    return fail("the view sweep's object count must be in [1, " + std::to_string(most) + "], got " +
                std::to_string(objects));
  }
  DatabaseBuildOptions probe;
  probe.parameters = parameters;
  probe.num_threads = build_threads;
  std::string problem;
  std::vector<int> views = view_counts;
  views.push_back(views_per_object);
  for (int v : views) {
    probe.parameters.view_sphere.num_views = v;
    if (!probe.Check(&problem)) return fail("database options: " + problem);
  }
  if (num_flown < 1) return fail("at least one object must be flown");
  if (frames < 1 || frames > 100000) return fail("frames per flight must be in [1, 100000]");
  if (skip_frames < 0 || skip_frames >= frames) {
    return fail("skipped frames must be in [0, frames per flight)");
  }
  TrackingExperimentOptions tracking;
  tracking.num_flown = num_flown;
  tracking.frames = frames;
  tracking.orbit.step_deg = step_deg;
  tracking.orbit.distance_in_radii =
      parameters.distances_in_radii.empty() ? 3.0 : parameters.distances_in_radii.front();
  tracking.particle_counts = {particles_per_object};
  tracking.adaptive = true;
  if (!tracking.Check(&problem)) return fail(problem);
  return true;
}

double ScaleMethodStats::RightObjectPercent() const {
  return frames > 0 ? 100.0 * right_object_frames / frames : 0.0;
}

std::vector<const ScalePoint*> ScaleExperimentResult::ObjectSweep() const {
  std::vector<const ScalePoint*> sweep;
  for (const ScalePoint& p : points) {
    if (p.views_per_object == options.views_per_object &&
        std::count(options.object_counts.begin(), options.object_counts.end(), p.objects) > 0) {
      sweep.push_back(&p);
    }
  }
  return sweep;
}

std::vector<const ScalePoint*> ScaleExperimentResult::ViewSweep() const {
  std::vector<const ScalePoint*> sweep;
  for (const ScalePoint& p : points) {
    if (p.objects == options.objects &&
        std::count(options.view_counts.begin(), options.view_counts.end(), p.views_per_object) >
            0) {
      sweep.push_back(&p);
    }
  }
  std::sort(sweep.begin(), sweep.end(), [](const ScalePoint* a, const ScalePoint* b) {
    return a->views_per_object < b->views_per_object;
  });
  return sweep;
}

ScaleExperimentResult RunScaleExperiment(const std::vector<TriangleMesh>& meshes,
                                         const ScaleExperimentOptions& options,
                                         const std::function<void(int, int)>& on_building,
                                         const std::function<void(const ScalePoint&)>& on_point) {
  std::string problem;
  if (!options.Check(static_cast<int>(meshes.size()), &problem)) {
    ThrowError("invalid scale experiment options: ", problem);
  }
  const Clock::time_point start = Clock::now();
  std::set<std::pair<int, int>> configurations;
  for (int n : options.object_counts) configurations.insert({n, options.views_per_object});
  for (int v : options.view_counts) configurations.insert({options.objects, v});
  int most_objects = 0;
  for (const auto& [objects, views] : configurations)
    most_objects = std::max(most_objects, objects);

  const TemporaryFolder folder(options.work_dir);
  const std::vector<TriangleMesh> catalogue = StretchedCatalogue(meshes, most_objects);
  std::vector<std::filesystem::path> paths;
  for (const TriangleMesh& mesh : catalogue) {
    paths.push_back(folder.path() / (mesh.name + ".obj"));
    WriteObj(mesh, paths.back());
  }

  ScaleExperimentResult result;
  result.options = options;
  result.build_threads = WorkerThreads(options.build_threads);
  for (const auto& [objects, views] : configurations) {
    if (on_building) on_building(objects, views);
    result.points.push_back(MeasurePoint(catalogue, paths, objects, views, options, folder.path()));
    if (on_point) on_point(result.points.back());
  }
  result.seconds = Seconds(start);
  return result;
}

void WriteScaleTable(const std::filesystem::path& path, const ScaleExperimentResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(9);
  file << "objects,views_per_object,shells,total_views,file_mb,build_s,brute_force_ms,filter_ms,"
          "adaptive_ms,adaptive_particles,brute_force_right_percent,filter_right_percent,"
          "adaptive_right_percent,frames,flown,brute_force_mean_ms,filter_mean_ms,"
          "adaptive_mean_ms\n";
  for (const ScalePoint& p : result.points) {
    std::string flown;
    for (const std::string& name : p.flown) flown += (flown.empty() ? "" : " ") + name;
    file << p.objects << ',' << p.views_per_object << ',' << p.shells << ',' << p.total_views()
         << ',' << Mb(p.file_bytes) << ',' << p.build_seconds << ','
         << p.brute_force.ms_per_frame_median << ',' << p.filter.ms_per_frame_median << ','
         << p.adaptive.ms_per_frame_median << ',' << p.adaptive.particles_mean << ','
         << p.brute_force.RightObjectPercent() << ',' << p.filter.RightObjectPercent() << ','
         << p.adaptive.RightObjectPercent() << ',' << p.filter.frames << ',' << flown << ','
         << p.brute_force.ms_per_frame_mean << ',' << p.filter.ms_per_frame_mean << ','
         << p.adaptive.ms_per_frame_mean << '\n';
  }
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

Figure ScaleFigure(const ScaleExperimentResult& result) {
  const std::vector<const ScalePoint*> by_objects = result.ObjectSweep();
  const std::vector<const ScalePoint*> by_views = result.ViewSweep();
  if (by_objects.empty() || by_views.empty()) {
    ThrowError("the cost figure needs points in both sweeps");
  }
  auto time_panel = [&](const std::vector<const ScalePoint*>& sweep, bool x_is_objects) {
    PlotPanel panel;
    char title[96];
    if (x_is_objects) {
      std::snprintf(title, sizeof title, "Time per frame, %d views per object",
                    result.options.views_per_object);
      panel.x_axis.label = "objects in the database";
    } else {
      std::snprintf(title, sizeof title, "Time per frame, %d objects", result.options.objects);
      panel.x_axis.label = "views per object";
    }
    panel.title = title;
    panel.y_axis.label = "ms per frame, median (one thread)";
    panel.y_axis.min = 0.0;
    panel.x_axis.min = 0.0;
    panel.legend = LegendPosition::kBest;
    PlotSeries brute, filter, adaptive;
    brute.label = "brute force";
    filter.label = "filter, " + std::to_string(result.options.particles_per_object) + "/object";
    adaptive.label = "filter, adaptive (KLD)";
    adaptive.marker = Marker::kSquare;
    filter.marker = Marker::kCross;
    for (const ScalePoint* p : sweep) {
      const double x = x_is_objects ? p->objects : p->views_per_object;
      for (auto [series, stats] :
           {std::pair{&brute, &p->brute_force}, std::pair{&filter, &p->filter},
            std::pair{&adaptive, &p->adaptive}}) {
        series->x.push_back(x);
        series->y.push_back(stats->ms_per_frame_median);
      }
    }
    panel.series = {brute, filter, adaptive};
    return panel;
  };
  auto database_panel = [&](bool size) {
    PlotPanel panel;
    panel.title = size ? "Database file" : "Database build";
    panel.x_axis.label = "views in the database (thousands)";
    panel.x_axis.min = 0.0;
    panel.y_axis.min = 0.0;
    panel.y_axis.label =
        size ? "MB" : "seconds (" + std::to_string(result.build_threads) + " threads)";
    panel.legend = LegendPosition::kBest;
    PlotSeries objects, views;
    objects.label = "more objects (" + std::to_string(result.options.views_per_object) + " views)";
    views.label = "more views (" + std::to_string(result.options.objects) + " objects)";
    views.marker = Marker::kSquare;
    for (auto [series, sweep] : {std::pair{&objects, &by_objects}, std::pair{&views, &by_views}}) {
      for (const ScalePoint* p : *sweep) {
        series->x.push_back(p->total_views() / 1000.0);
        series->y.push_back(size ? p->file_bytes / 1e6 : p->build_seconds);
      }
    }
    panel.series = {objects, views};
    return panel;
  };
  Figure figure;
  figure.width_px = 1800;
  figure.height_px = 440;
  figure.panels = {time_panel(by_objects, true), time_panel(by_views, false), database_panel(true),
                   database_panel(false)};
  return figure;
}

}  // namespace silpose
