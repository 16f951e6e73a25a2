#pragma once
// The paper's experiment 5.1, "Number of Particles": some database models are flown around (the
// camera moves along an orbit at 1 degree per frame, synth/trajectory.h), and the particle filter
// (filter/particle_filter.h, adaptive count off) tracks each flight with 10, 20, ..., 100 particles
// per database object, every run repeated with seeds 1..5. The brute-force baseline matches every
// frame on its own against the whole database (match/view_matcher.h, top 1).
//
// Frames. Each flight is rendered once (synth/synthetic_sequence.h: DefaultSynthCamera, 640 x 480,
// orbit at distance 3 object radii) and its masks are reused by every run. Every run extracts the
// signature from each mask itself (ExtractSignature with the database's signature options), so a
// frame's time covers what `silpose track` does with a mask in memory: signature extraction plus
// the filter step (Step, or Predict for a frame without a usable silhouette), or plus the
// brute-force match. Masks are not read from files.
//
// Metrics, per frame:
//  - right object: the estimate's object is the flown model;
//  - pose error: |d_est - d_true|, the Euclidean distance between the estimated view direction
//    (the database view's unit direction, ViewSphere::directions) and the true one
//    (TrajectoryFrame::view_dir_in_object), both in the model frame (docs/conventions.md), in [0,
//    2]. Every frame counts, as in the paper: a frame whose estimate names a wrong object gets the
//    distance between that object's estimated view direction and the true one (both unit vectors in
//    their own model frames, so the distance is defined, if not meaningful); a frame without any
//    estimate (brute force on a frame without a usable silhouette) counts as wrong object with
//    pose error 2, the largest possible;
//  - time, milliseconds (steady clock).
// Aggregates (TrackingStats): mean and standard deviation (population, over frames) of the pose
// error over every frame of every run, percentage of frames with the right object, mean time per
// frame.
//
// Determinism and threads. A run's estimates depend only on the database, the flight and the seed,
// not on the thread count. Times do: with more than one thread the runs share the cores (and their
// caches), so honest per-frame times need num_threads = 1 (the default).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/filter/particle_filter.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/plot/figure.h"
#include "silpose/synth/trajectory.h"

namespace silpose {

/// The paper's brute-force figures (5.1): pose error 0.149 +- 0.342, 96.3 % of frames with the
/// right object; and the filter's at 60 particles per object: 99.8 % right object.
struct PaperTrackingFigures {
  static constexpr double kBruteForcePoseErrorMean = 0.149;
  static constexpr double kBruteForcePoseErrorStd = 0.342;
  static constexpr double kBruteForceRightObjectPercent = 96.3;
  static constexpr double kFilterRightObjectPercentAt60 = 99.8;
};

/// The models flown by default when the database has them all (the reference set's): five without
/// rotational symmetry. A rotationally symmetric object (a bottle, a bearing) shows the same
/// silhouette from a whole ring of view directions, so the paper's pose error (the distance
/// between view directions) measures its symmetry rather than the method; docs/eval/README.md
/// gives the figures of a set with two such objects too.
inline const std::vector<std::string> kDefaultFlownModels = {"bunny", "cow", "dino", "elephant",
                                                             "rotor"};

struct TrackingExperimentOptions {
  /// Names of the models flown around (database model names); empty: kDefaultFlownModels if
  /// num_flown is 5 and the database has them all, else num_flown models spread evenly over the
  /// database's list (SpreadModelIndices).
  std::vector<std::string> flown_models;
  /// Models flown when flown_models is empty, in [1, number of models] (capped there).
  int num_flown = 5;
  /// Frames per flight (paper: one loop at 1 degree per frame = 360). >= 1.
  int frames = 360;
  /// The flight: orbit options (default: 1 degree per frame, tilt 30 degrees, distance 3 radii).
  OrbitOptions orbit;
  /// Particles per object of the filter runs, each >= 1 (paper: 10, 20, ..., 100).
  std::vector<int> particle_counts = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100};
  /// Runs per (model, particle count), seeds first_seed, first_seed + 1, ... >= 1.
  int repeats = 5;
  uint64_t first_seed = 1;
  /// The filter's other options; particles_per_object and seed are set per run, adaptive is set
  /// from `adaptive` below, min_particles_per_object is capped at the run's particle count and
  /// max_particles_per_object raised to it.
  ParticleFilterOptions filter;
  /// Run the filter with KLD-sampling (ParticleFilterOptions::adaptive): each object starts with
  /// the run's particle count and adapts within [min_particles_per_object,
  /// max_particles_per_object]. Off in the paper's experiment, which fixes the count.
  bool adaptive = false;
  /// Also run the brute-force baseline (one run per flight: it is deterministic).
  bool brute_force = true;
  /// Worker threads: runs (and brute-force frames) in parallel; 0 = all cores. 1 (default) keeps
  /// the per-frame times honest.
  int num_threads = 1;

  bool Check(std::string* error = nullptr) const;
};

/// One frame of one run.
struct TrackingFrameResult {
  /// Estimated object (database model index) and view; -1 without an estimate.
  int object = -1;
  int view = -1;
  /// The frame had a usable silhouette (else the filter predicted only).
  bool measured = false;
  /// Correlation of the frame with the estimate's view at its roll, in [-1, 1] (the filter's
  /// FilterEstimate::score, the brute force's MatchCandidate::score); 0 without an estimate.
  float score = 0.0f;
  /// See the file comment; 2 without an estimate.
  double pose_error = 2.0;
  /// The same modulo the flown model's symmetry (ViewErrorModuloSymmetry with the database's
  /// symmetries of the model) when the estimate names that model; pose_error otherwise.
  double pose_error_symmetric = 2.0;
  double time_ms = 0.0;
  /// Particles of all objects after the frame's step (filter runs; 0 for brute force).
  int particles = 0;
};

/// Aggregates over frames (see the file comment).
struct TrackingStats {
  int runs = 0;
  int frames = 0;
  int right_object_frames = 0;
  double pose_error_mean = 0.0;
  double pose_error_std = 0.0;
  double pose_error_max = 0.0;
  /// Mean and standard deviation of pose_error_symmetric.
  double symmetric_pose_error_mean = 0.0;
  double symmetric_pose_error_std = 0.0;
  double ms_per_frame_mean = 0.0;

  double right_object_percent() const;
};

/// One run: one flight tracked by one filter (one seed), or matched by brute force.
struct TrackingRun {
  /// The flown model: database index and name.
  int model = -1;
  std::string model_name;
  /// Particles per object; 0 for brute force.
  int particles = 0;
  /// The filter's seed; 0 for brute force.
  uint64_t seed = 0;
  std::vector<TrackingFrameResult> frames;

  bool brute_force() const { return particles == 0; }
  /// First frame from which on every frame has the right object; frames.size() if the last is
  /// wrong.
  int SettledFrame(int flown_model) const;
  TrackingStats Stats() const;
};

/// One row of the table: a particle count, or the brute-force baseline (particles 0).
struct TrackingRow {
  /// "particle-filter" or "brute-force".
  std::string method;
  int particles = 0;
  TrackingStats stats;
};

struct TrackingExperimentResult {
  std::vector<std::string> flown_models;
  int frames_per_flight = 0;
  int num_models = 0;
  int num_threads = 1;
  /// Filter runs by flight, particle count, seed; then brute-force runs by flight.
  std::vector<TrackingRun> runs;
  /// Filter rows by increasing particle count, then the brute-force row (if run).
  std::vector<TrackingRow> rows;
  double seconds = 0.0;

  /// The brute-force row, or null.
  const TrackingRow* BruteForce() const;
  /// The filter row for this particle count, or null.
  const TrackingRow* Filter(int particles) const;
};

/// `count` indices spread evenly over 0..num_models-1: floor((2i + 1) num_models / (2 count)),
/// i = 0..count-1 (20 models, 5: 2, 6, 10, 14, 18). count is capped at num_models.
std::vector<int> SpreadModelIndices(int num_models, int count);

/// The database model indices of the models to fly (options.flown_models resolved, or spread).
/// Throws silpose::Error naming an unknown or repeated model.
std::vector<int> FlownModelIndices(const ViewDatabase& database,
                                   const TrackingExperimentOptions& options);

/// Number of runs RunTrackingExperiment makes for `num_flown` flights (for a progress bar).
int TrackingRunCount(const TrackingExperimentOptions& options, int num_flown);

/// Runs the experiment. `meshes` are the database's models, in the same order and with the same
/// names. `on_progress(n)` is called as n more runs are done (from worker threads: it must be
/// thread-safe). Throws silpose::Error for invalid options or mismatched meshes.
TrackingExperimentResult RunTrackingExperiment(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const TrackingExperimentOptions& options,
                                               const std::function<void(int)>& on_progress = {});

/// Column names of the table CSV, in order.
const char* TrackingTableHeader();
/// Column names of the per-run CSV, in order.
const char* TrackingRunsHeader();

/// tracking.csv: one row per particle count and one brute-force row:
/// method,particles,runs,frames,pose_error_mean,pose_error_std,right_object_percent,
/// ms_per_frame_mean,symmetric_pose_error_mean,symmetric_pose_error_std. Throws silpose::Error
/// naming the file if it cannot be written.
void WriteTrackingTable(const std::filesystem::path& path, const TrackingExperimentResult& result);
/// tracking_runs.csv: one row per run: method,model,particles,seed,frames,right_object_frames,
/// right_object_percent,settled_frame,pose_error_mean,pose_error_std,pose_error_max,
/// ms_per_frame_mean,symmetric_pose_error_mean,symmetric_pose_error_std (settled_frame:
/// TrackingRun::SettledFrame).
void WriteTrackingRuns(const std::filesystem::path& path, const TrackingExperimentResult& result);
/// Every frame of every run: method,model,particles,seed,frame,estimated_object,estimated_view,
/// measured,right_object,score,pose_error,time_ms,pose_error_symmetric (estimated_object: name,
/// empty without an estimate).
void WriteTrackingFrames(const std::filesystem::path& path, const TrackingExperimentResult& result,
                         const ViewDatabase& database);

/// The paper's Fig. 4: left, pose error mean +- std against particles per object; right, % of
/// frames with the right object; the brute-force levels as reference lines. Throws
/// silpose::Error if there is no filter row.
Figure TrackingFigure(const TrackingExperimentResult& result);

}  // namespace silpose
