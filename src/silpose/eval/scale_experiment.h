#pragma once
// Cost curves: how the database and the cost of a frame grow with the number of objects and with
// the number of views per object (docs/PERFORMANCE.md, "Cost curves").
//
// Two sweeps: the object count varies at a fixed number of views per object, and the views per
// object vary at a fixed object count. For each point a database is built as `silpose build-db`
// builds it (DatabaseParameters, by default one distance shell at 3 radii, with stored spectra),
// written to a file and read back memory-mapped, as `silpose track` reads it. A few of its objects
// are then flown around (the paper's orbit at the database's first distance, 2 degrees per frame,
// tracking_experiment.h) and each flight is tracked three ways, one thread: by brute force against
// the whole database (top 1), by the filter with a fixed particle count per object, and by the
// adaptive filter (KLD-sampling). Each frame's time covers signature extraction from the mask plus
// the match (as in the tracking experiment); the figures count the frames from skip_frames on, when
// the filter has settled and every view it meets has been paged in.
//
// Catalogue. More objects than meshes come from stretching the meshes along their own axes:
// object i of the catalogue is mesh i % n (n meshes) scaled by kScaleStretches[i / n], named
// "<mesh>_<i / n>". The ten factor triples are pairwise non-proportional (any two differ by at
// least 0.14 along some axis once each is divided by its mean): proportional stretches would give
// the same silhouettes up to size, which no silhouette method can tell apart. So n meshes give up
// to 10 n objects. scripts/stretch-models.py writes the same catalogue as OBJ files.
//
// Files. The stretched meshes and each point's database are written into a folder made inside
// options.work_dir, removed when the experiment ends (also on an error).

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/plot/figure.h"

namespace silpose {

/// The ten stretches of the catalogue (x, y, z factors); the first leaves a mesh unchanged.
inline constexpr std::array<std::array<double, 3>, 10> kScaleStretches = {{{1.0, 1.0, 1.0},
                                                                           {1.6, 1.0, 1.0},
                                                                           {1.0, 1.6, 1.0},
                                                                           {1.0, 1.0, 1.6},
                                                                           {1.6, 1.6, 1.0},
                                                                           {1.6, 1.0, 1.6},
                                                                           {1.0, 1.6, 1.6},
                                                                           {1.6, 1.3, 1.0},
                                                                           {1.0, 1.6, 1.3},
                                                                           {1.3, 1.0, 1.6}}};

/// The first `count` objects of the catalogue made from `meshes` (see the file comment). Throws
/// silpose::Error if `meshes` is empty or count > 10 * meshes.size().
std::vector<TriangleMesh> StretchedCatalogue(const std::vector<TriangleMesh>& meshes, int count);

/// Writes `mesh` as a Wavefront OBJ file (vertices and triangles only). Throws silpose::Error
/// naming the file if it cannot be written.
void WriteObj(const TriangleMesh& mesh, const std::filesystem::path& path);

struct ScaleExperimentOptions {
  /// The object-count sweep, at views_per_object views per object. Each in [1, 10 * meshes].
  std::vector<int> object_counts = {10, 20, 50, 100, 200};
  int views_per_object = 1000;
  /// The view-count sweep, at `objects` objects.
  std::vector<int> view_counts = {500, 1000, 2000, 5000};
  int objects = 20;
  /// The databases' parameters; view_sphere.num_views is set per point.
  DatabaseParameters parameters = OneShellParameters();
  /// Worker threads building each database; 0 = all cores. Tracking always runs on one thread.
  int build_threads = 0;
  /// Show the build's progress bar (on a terminal).
  bool show_progress = false;
  /// Objects flown per point (spread over the catalogue), frames per flight, degrees per frame.
  int num_flown = 3;
  int frames = 60;
  double step_deg = 2.0;
  /// Frames left out of the figures at the start of each flight.
  int skip_frames = 10;
  /// Particles per object of the fixed-count filter, and the adaptive filter's starting count.
  int particles_per_object = 60;
  /// Where the temporary folder is made (must exist).
  std::filesystem::path work_dir = std::filesystem::temp_directory_path();

  static DatabaseParameters OneShellParameters();
  /// Checks the options against `num_meshes` meshes; on failure writes the reason to `error`.
  bool Check(int num_meshes, std::string* error = nullptr) const;
};

/// One way of tracking, over the counted frames of every flight of a point.
struct ScaleMethodStats {
  int frames = 0;
  int right_object_frames = 0;
  double ms_per_frame_mean = 0.0;
  double ms_per_frame_median = 0.0;
  /// Mean particle count of all objects (filters; 0 for brute force).
  double particles_mean = 0.0;
  double RightObjectPercent() const;
};

/// One database size: what it costs and how fast and well it tracks.
struct ScalePoint {
  int objects = 0;
  int views_per_object = 0;
  int shells = 0;
  /// The database file, bytes.
  double file_bytes = 0.0;
  /// Building it as build-db does: rendering and describing every view, the symmetries, the stored
  /// spectra and writing the file, on build_threads threads.
  double build_seconds = 0.0;
  /// The flown objects' names.
  std::vector<std::string> flown;
  ScaleMethodStats brute_force;
  ScaleMethodStats filter;
  ScaleMethodStats adaptive;
  int total_views() const { return objects * views_per_object; }
};

struct ScaleExperimentResult {
  ScaleExperimentOptions options;
  /// Every distinct (objects, views per object) of the two sweeps, by objects, then views.
  std::vector<ScalePoint> points;
  int build_threads = 1;
  double seconds = 0.0;
  /// The points of the object sweep (views_per_object == options.views_per_object) and of the view
  /// sweep (objects == options.objects), in increasing order.
  std::vector<const ScalePoint*> ObjectSweep() const;
  std::vector<const ScalePoint*> ViewSweep() const;
};

/// Runs both sweeps on the catalogue made from `meshes` (see the file comment). `on_point` is
/// called after each point, `on_building(objects, views)` before each build. Throws silpose::Error
/// for invalid options, or if a database cannot be built, written or read.
ScaleExperimentResult RunScaleExperiment(
    const std::vector<TriangleMesh>& meshes, const ScaleExperimentOptions& options,
    const std::function<void(int, int)>& on_building = {},
    const std::function<void(const ScalePoint&)>& on_point = {});

/// One row per point: objects,views_per_object,shells,total_views,file_mb,build_s,
/// brute_force_ms,filter_ms,adaptive_ms,adaptive_particles,brute_force_right_percent,
/// filter_right_percent,adaptive_right_percent,frames,flown,brute_force_mean_ms,filter_mean_ms,
/// adaptive_mean_ms (ms: median, then mean, over the counted frames; flown: names separated by
/// spaces). Throws silpose::Error naming the file if it cannot be written.
void WriteScaleTable(const std::filesystem::path& path, const ScaleExperimentResult& result);

/// Four panels: median time per frame against the object count and against the views per object
/// (brute force, filter, adaptive filter); the database file size and the build time against the
/// total number of views, one series per sweep. Throws silpose::Error if a sweep has no point.
Figure ScaleFigure(const ScaleExperimentResult& result);

}  // namespace silpose
