#pragma once
// Accuracy where users film: objects turned by hand in front of a static camera, and the paper's
// orbits at several distances, tracked end to end (track/tracker.h: on-axis matching, filter or
// brute force, 6-DOF pose, contour refinement), with the errors binned by distance, off-axis
// angle, rotation speed and mask quality. `silpose eval handheld` runs it.
//
// Sequences (synth/synthetic_sequence.h, DefaultSynthCamera: 640 x 480, f = 525 px). For each
// evaluation model:
//  - `sequences_per_model` hand-held sequences (TrajectoryKind::kHandheld, `handheld` options:
//    by default 4-10 radii, up to 25 degrees off the axis, 2-15 degrees per frame with pauses,
//    reversals and cuts), `frames` frames each. Sequence k (0-based) of the i-th evaluation model
//    (in the order of HandheldExperimentOptions::models, or the database's) has the seed
//    first_seed + i * sequences_per_model + k; it seeds the trajectory, the mask degradation and
//    the tracker's filter.
//  - one orbit per distance in `orbit_distances_radii` (by default 3, 7, 15 and 30 radii;
//    TrajectoryKind::kOrbit, the paper's 1 degree per frame, tilt 30 degrees, roll 0),
//    `orbit_frames` frames each; its degradation and filter seed is
//    first_seed + 500000 + i * (number of distances) + j.
// Each sequence is rendered once per mask quality (kPerfect: the rendered mask; kThreshold: the
// flaws of a colour threshold's mask, synth/degradation.h), and every tracker of `trackers` sees
// the same masks. A sequence with all its trackers is one task; tasks run in parallel on
// `num_threads` threads, each with its own Tracker objects sharing the read-only database.
//
// Per frame (HandheldFrame), against the truth of synthetic_sequence.h:
//  - right object: the tracker names the shown model (a frame without an estimate is wrong);
//  - rotation error: angle between the estimated and true camera_from_object rotations (degrees,
//    pose/pose_error.h), for frames with the right object and a 6-DOF pose;
//  - translation error: |t_est - t_true| as a percentage of the true distance from the camera
//    centre to the object centre, same frames;
//  - view error: the paper's distance between the estimated and true unit view directions (of
//    the virtual on-axis camera, FrameResult::view_dir_in_object), [0, 2], for every frame with an
//    estimate, wrong object included (as in the paper);
//  - roll error: the estimated roll carried to the true view direction (TransportRoll, so the
//    roll reference's turning near the poles does not count) minus the true roll, absolute,
//    degrees in [0, 180], for frames with the right object and a view;
// and the true conditions: distance (object radii), off-axis angle of the object centre's ray
// (degrees), speed (the angle between this and the previous frame's true camera_from_object
// rotations, degrees; 0 for frame 0) and whether the frame is a cut (handheld only).
//
// Aggregates count the frames from skip_frames on (the filter identifies the object first) and,
// separately, all frames. Medians and means are over the frames that have the error; frames
// without any estimate and right-object frames without a pose are counted.
//
// Bins (HandheldBinAxis): every frame falls in exactly one bin per axis. Distance: hand-held
// frames in 4-5, 5-6.5, 6.5-8, 8-10 radii (the end bins are open: below 5, 8 and beyond), orbit
// frames in one bin per orbit distance ("orbit 3", ...). Off-axis: hand-held frames in 0-5, 5-10,
// 10-15, 15-25 degrees (the last open), orbit frames (always on the axis, 1 degree per frame) in
// "orbit". Speed: hand-held frames in 0-2, 2-5, 5-10, 10-15, >15 degrees per frame (cuts are jumps
// and mostly land in the last), orbit frames in "orbit". Mask quality: perfect, threshold.
//
// Determinism: the result depends on the database, the meshes and the options, not on the thread
// count.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/plot/figure.h"
#include "silpose/synth/degradation.h"
#include "silpose/synth/trajectory.h"
#include "silpose/track/tracker.h"

namespace silpose {

/// The trackers compared.
enum class HandheldTracker {
  /// TrackerOptions{}: the particle filter with its defaults (adaptive motion model, data-driven
  /// proposal, on-axis matching, contour refinement).
  kFilter,
  /// TrackerOptions{} with brute_force: every frame matched alone against the whole database.
  kBruteForce,
  /// The filter without contour refinement (refine = false).
  kFilterNoRefine,
  /// The filter with the paper's motion model (MotionModel::kNeighbour) and no data-driven
  /// proposal.
  kFilterPaperMotion,
  /// The filter, each frame reported 10 frames late from the particle histories (TrackSmoother,
  /// track/smoother.h; `silpose track --lag 10`).
  kFilterLag10,
  /// The filter, every frame reported at the end from the particle history that explains the
  /// whole sequence best (TrackSmoother::kOffline; `silpose track --smooth`).
  kFilterSmooth,
  /// The filter with the adaptive particle count (KLD-sampling; `silpose track --adaptive`).
  kFilterAdaptive,
};

/// "filter", "brute-force", "filter-no-refine", "filter-paper-motion", "filter-lag-10",
/// "filter-smooth", "filter-adaptive".
const char* HandheldTrackerName(HandheldTracker tracker);
/// Inverse of HandheldTrackerName; false if `name` is none of them.
bool ParseHandheldTracker(const std::string& name, HandheldTracker* tracker);
/// The smoothing lag of a tracker (frames, or TrackSmoother::kOffline); nullopt without smoothing.
std::optional<int> HandheldTrackerLag(HandheldTracker tracker);
/// The tracker's options (the defaults of TrackerOptions changed as described above), with the
/// filter seeded by `seed`.
TrackerOptions HandheldTrackerOptions(HandheldTracker tracker, uint64_t seed);

/// Sequence kinds: hand-held, or an orbit (with its distance).
enum class HandheldSequenceKind { kHandheld, kOrbit };

struct HandheldExperimentOptions {
  /// Database model names to film; empty: every model of the database.
  std::vector<std::string> models;
  /// Hand-held sequences per model (>= 0) and their frames (>= 1).
  int sequences_per_model = 3;
  int frames = 120;
  /// The hand-held motion; `seed` is set per sequence (see the file comment).
  HandheldOptions handheld;
  /// Orbit distances, object radii (each > 1, no repeats; empty: no orbits), and frames per orbit.
  std::vector<double> orbit_distances_radii = {3.0, 7.0, 15.0, 30.0};
  int orbit_frames = 120;
  /// Mask qualities, each sequence rendered with each (non-empty, no repeats).
  std::vector<MaskQuality> mask_qualities = {MaskQuality::kPerfect, MaskQuality::kThreshold};
  /// Trackers run on every sequence (non-empty, no repeats).
  std::vector<HandheldTracker> trackers = {HandheldTracker::kFilter, HandheldTracker::kBruteForce};
  /// First seed; far from the seeds the project's tuning used (1, 2, ...).
  uint64_t first_seed = 1000;
  /// Frames left out at the start of each sequence in the main figures (>= 0).
  int skip_frames = 10;
  /// Worker threads (sequences in parallel); 0 = all cores.
  int num_threads = 0;

  bool Check(std::string* error = nullptr) const;
};

/// A mirror twin closer than this to the true view (degrees) is not told apart from it.
inline constexpr double kTwinMinSeparationDeg = 20.0;

/// One frame of one sequence under one tracker.
struct HandheldFrame {
  int frame = 0;
  // Truth.
  double distance_radii = 0.0;
  double off_axis_deg = 0.0;
  double speed_deg_per_frame = 0.0;
  bool cut = false;
  // Estimate.
  /// Estimated object (database index), -1 without an estimate.
  int object = -1;
  bool right_object = false;
  /// The right object with a 6-DOF pose (rotation and translation errors are set).
  bool has_pose = false;
  /// The estimate has a view direction (view_error is set).
  bool has_view = false;
  /// NaN where not defined (see the file comment).
  double rotation_error_deg = 0.0;
  double translation_error_percent = 0.0;
  double view_error = 0.0;
  double roll_error_deg = 0.0;
  /// rotation_error_deg and view_error modulo the model's symmetry (geometry/symmetry.h; equal
  /// to them for a model without rotations; the view error only for the right object).
  double rotation_error_symmetric_deg = 0.0;
  double view_error_symmetric = 0.0;
  /// On the wrong mirror twin: the right object with a mirror plane, an estimated view nearer
  /// (modulo the rotational symmetry) to a mirror twin of the true view (the view with the same
  /// outline up to perspective, geometry/symmetry.h) than to the true view, that twin more than
  /// kTwinMinSeparationDeg from the true view.
  bool wrong_twin = false;
  /// Tracker::Process time, ms (inflated when threads share the cores).
  double time_ms = 0.0;
};

/// One sequence (model, kind, seed, mask quality) as seen by one tracker.
struct HandheldRun {
  /// The filmed model: database index and name.
  int model = -1;
  std::string model_name;
  HandheldSequenceKind kind = HandheldSequenceKind::kHandheld;
  /// Orbit distance (object radii); 0 for hand-held.
  double orbit_distance_radii = 0.0;
  /// The sequence's number among the model's hand-held sequences (0-based), or among its orbits.
  int sequence = 0;
  uint64_t seed = 0;
  MaskQuality mask_quality = MaskQuality::kPerfect;
  HandheldTracker tracker = HandheldTracker::kFilter;
  std::vector<HandheldFrame> frames;

  /// "handheld", or "orbit-3" (the distance in radii, shortest form).
  std::string KindLabel() const;
};

/// Aggregates over a set of frames.
struct HandheldStats {
  int frames = 0;
  int right_object = 0;
  /// Frames without any estimate (counted as wrong object).
  int no_estimate = 0;
  /// Right-object frames without a 6-DOF pose.
  int no_pose = 0;
  /// Over right-object frames with a pose; NaN without any.
  double rotation_median_deg = 0.0;
  double rotation_mean_deg = 0.0;
  double rotation_p90_deg = 0.0;
  double translation_median_percent = 0.0;
  /// Over frames with a view; NaN without any.
  double view_error_mean = 0.0;
  /// Over right-object frames with a view; NaN without any.
  double roll_median_deg = 0.0;
  /// rotation_median_deg and view_error_mean modulo the model's symmetry.
  double rotation_median_symmetric_deg = 0.0;
  double view_error_symmetric_mean = 0.0;
  /// Frames on the wrong mirror twin (HandheldFrame::wrong_twin).
  int wrong_twin = 0;

  double RightObjectPercent() const { return frames > 0 ? 100.0 * right_object / frames : 0.0; }
};

/// Statistics of the given frames.
HandheldStats ComputeHandheldStats(const std::vector<const HandheldFrame*>& frames);

enum class HandheldBinAxis { kDistance, kOffAxis, kSpeed, kMaskQuality };
/// "distance", "off_axis", "speed", "mask_quality".
const char* HandheldBinAxisName(HandheldBinAxis axis);
const std::vector<HandheldBinAxis>& AllHandheldBinAxes();

/// The bins of an axis, in order: labels ("4-5", ..., "orbit 3", ...; the orbit bins for the
/// given distances). Every frame falls in exactly one of them (HandheldBinIndex).
std::vector<std::string> HandheldBinLabels(HandheldBinAxis axis,
                                           const std::vector<double>& orbit_distances_radii);
/// The bin of a frame of `run` on `axis`: an index into HandheldBinLabels(axis, distances).
/// Throws silpose::Error for an orbit distance not in the list.
int HandheldBinIndex(HandheldBinAxis axis, const HandheldRun& run, const HandheldFrame& frame,
                     const std::vector<double>& orbit_distances_radii);
/// A representative x value of each bin for plots (the middle of a range, 17.5 for speeds beyond
/// 15, the distance of an orbit; NaN for the mask quality and the "orbit" bins).
std::vector<double> HandheldBinCentres(HandheldBinAxis axis,
                                       const std::vector<double>& orbit_distances_radii);

/// One row of the summary: sequence kind x mask quality x tracker.
struct HandheldSummaryRow {
  std::string kind;
  MaskQuality mask_quality = MaskQuality::kPerfect;
  HandheldTracker tracker = HandheldTracker::kFilter;
  int sequences = 0;
  /// From skip_frames on, and over all frames.
  HandheldStats counted;
  HandheldStats all;
};

/// One row of the binned tables: axis x bin x mask quality (or all) x tracker; frames from
/// skip_frames on.
struct HandheldBinRow {
  HandheldBinAxis axis = HandheldBinAxis::kDistance;
  int bin = 0;
  std::string label;
  /// "all", "perfect" or "threshold".
  std::string mask_quality;
  HandheldTracker tracker = HandheldTracker::kFilter;
  HandheldStats stats;
};

struct HandheldExperimentResult {
  HandheldExperimentOptions options;
  /// The evaluated models (names) and the database's model count.
  std::vector<std::string> models;
  int database_models = 0;
  /// By model, sequence (hand-held, then orbits), mask quality, tracker.
  std::vector<HandheldRun> runs;
  /// Each run's statistics from skip_frames on, in the order of runs.
  std::vector<HandheldStats> run_stats;
  /// Kinds in order (handheld, orbit-3, ...) x options.mask_qualities x options.trackers.
  std::vector<HandheldSummaryRow> summary;
  /// Axes in order x bins x ("all", then each quality) x trackers.
  std::vector<HandheldBinRow> bins;
  double seconds = 0.0;

  /// The summary row, or null.
  const HandheldSummaryRow* Summary(const std::string& kind, MaskQuality quality,
                                    HandheldTracker tracker) const;
  /// The bin row, or null.
  const HandheldBinRow* Bin(HandheldBinAxis axis, int bin, const std::string& mask_quality,
                            HandheldTracker tracker) const;
  /// Every seed used (sorted).
  std::vector<uint64_t> Seeds() const;
};

/// One tracker against another, sequence by sequence: for one kind and mask quality, the
/// sequences both ran (same model, kind, sequence number and mask quality) and how many of them
/// `tracker` ended with a higher mean view error modulo symmetry than `reference` (a sequence
/// without any view from `tracker` but with one from `reference` counts as higher).
struct HandheldComparisonRow {
  std::string kind;
  MaskQuality mask_quality = MaskQuality::kPerfect;
  int sequences = 0;
  int above = 0;
};

/// The comparison of `tracker` with `reference` over result.run_stats, one row per kind and mask
/// quality in the summary's order (rows without a shared sequence are left out).
std::vector<HandheldComparisonRow> CompareHandheldTrackers(const HandheldExperimentResult& result,
                                                           HandheldTracker tracker,
                                                           HandheldTracker reference);

/// Number of tasks (sequences x mask qualities) for `num_models` models, for a progress bar.
int HandheldTaskCount(const HandheldExperimentOptions& options, int num_models);

/// Runs the experiment. `meshes` are the database's models, same order and names. on_progress(n)
/// is called (from worker threads) as n more tasks are done. Throws silpose::Error for invalid
/// options, mismatched meshes or an unknown model name.
HandheldExperimentResult RunHandheldExperiment(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const HandheldExperimentOptions& options,
                                               const std::function<void(int)>& on_progress = {});

/// Column names of the CSV files, in order.
const char* HandheldSummaryHeader();
const char* HandheldSequencesHeader();
const char* HandheldFramesHeader();
const char* HandheldBinsHeader();

/// summary.csv: one row per HandheldSummaryRow:
/// kind,mask_quality,tracker,sequences,frames,right_object_percent,no_estimate_frames,
/// no_pose_frames,rotation_median_deg,rotation_mean_deg,rotation_p90_deg,
/// translation_median_percent,view_error_mean,roll_median_deg,all_frames,
/// all_right_object_percent,all_rotation_median_deg,rotation_median_symmetric_deg,
/// view_error_symmetric_mean,wrong_twin_frames (empty cells for NaN).
void WriteHandheldSummary(const std::filesystem::path& path,
                          const HandheldExperimentResult& result);
/// sequences.csv: one row per run (result.run_stats), frames from skip_frames on:
/// model,kind,sequence,seed,mask_quality,tracker,frames,right_object_percent,
/// rotation_median_symmetric_deg,translation_median_percent,view_error_symmetric_mean,
/// wrong_twin_frames.
void WriteHandheldSequences(const std::filesystem::path& path,
                            const HandheldExperimentResult& result);
/// frames.csv: every frame of every run: model,kind,sequence,seed,mask_quality,tracker,frame,
/// distance_radii,off_axis_deg,speed_deg_per_frame,cut,estimated_object,right_object,has_pose,
/// rotation_error_deg,translation_error_percent,view_error,roll_error_deg,time_ms,wrong_twin.
void WriteHandheldFrames(const std::filesystem::path& path, const HandheldExperimentResult& result,
                         const ViewDatabase& database);
/// bins.csv: axis,bin,mask_quality,tracker,frames,right_object_percent,rotation_median_deg,
/// rotation_mean_deg,translation_median_percent,rotation_median_symmetric_deg.
void WriteHandheldBins(const std::filesystem::path& path, const HandheldExperimentResult& result);

/// Median rotation error modulo the models' symmetries (a turn a symmetric model's silhouette
/// cannot show is no error) per speed bin and per distance bin, a pair of panels per mask
/// quality, one series per tracker (the orbits as separate markers on the distance panels).
/// Empty bins are left out.
Figure HandheldFigure(const HandheldExperimentResult& result);

}  // namespace silpose
