#include "silpose/eval/handheld_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <span>
#include <sstream>
#include <tuple>

#include "silpose/geometry/view_frame.h"
#include "silpose/pose/pose_error.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/smoother.h"
#include "silpose/util/error.h"
#include "silpose/util/parallel.h"
#include "silpose/util/threads.h"

namespace silpose {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Orbit seeds start here (above any hand-held seed of a realistic run).
constexpr uint64_t kOrbitSeedOffset = 500000;

// Hand-held bin edges (upper ends, exclusive; the last bin is open).
const std::vector<double> kDistanceEdges = {5.0, 6.5, 8.0};
const std::vector<std::string> kDistanceLabels = {"4-5", "5-6.5", "6.5-8", "8-10"};
const std::vector<double> kDistanceCentres = {4.5, 5.75, 7.25, 9.0};
const std::vector<double> kOffAxisEdges = {5.0, 10.0, 15.0};
const std::vector<std::string> kOffAxisLabels = {"0-5", "5-10", "10-15", "15-25"};
const std::vector<double> kOffAxisCentres = {2.5, 7.5, 12.5, 20.0};
const std::vector<double> kSpeedEdges = {2.0, 5.0, 10.0, 15.0};
const std::vector<std::string> kSpeedLabels = {"0-2", "2-5", "5-10", "10-15", ">15"};
const std::vector<double> kSpeedCentres = {1.0, 3.5, 7.5, 12.5, 17.5};

int RangeBin(double value, const std::vector<double>& edges) {
  int bin = 0;
  while (bin < static_cast<int>(edges.size()) && !(value < edges[static_cast<size_t>(bin)])) ++bin;
  return bin;
}

std::string ShortNumber(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

int OrbitIndex(double distance, const std::vector<double>& distances) {
  for (size_t j = 0; j < distances.size(); ++j) {
    if (std::abs(distances[j] - distance) < 1e-9) return static_cast<int>(j);
  }
  ThrowError("orbit distance ", distance, " is not among the experiment's orbit distances");
}

// One sequence to render and track: a model, a trajectory, a mask quality.
struct Task {
  int model = -1;
  int model_order = 0;
  HandheldSequenceKind kind = HandheldSequenceKind::kHandheld;
  double orbit_distance = 0.0;
  int sequence = 0;
  uint64_t seed = 0;
  MaskQuality quality = MaskQuality::kPerfect;
};

double Median(std::vector<double> values) {
  if (values.empty()) return kNaN;
  return Percentile(values, 50.0);
}

double Mean(const std::vector<double>& values) {
  if (values.empty()) return kNaN;
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / static_cast<double>(values.size());
}

void RunTask(const ViewDatabase& database, const TriangleMesh& mesh, const Task& task,
             const HandheldExperimentOptions& options, std::vector<HandheldRun>* runs) {
  SequenceOptions sequence_options;
  sequence_options.degradation.seed = task.seed;
  sequence_options.degradation = WithMaskQuality(sequence_options.degradation, task.quality);
  if (task.kind == HandheldSequenceKind::kHandheld) {
    sequence_options.trajectory.kind = TrajectoryKind::kHandheld;
    sequence_options.trajectory.num_frames = options.frames;
    sequence_options.trajectory.handheld = options.handheld;
    sequence_options.trajectory.handheld.seed = task.seed;
  } else {
    sequence_options.trajectory.kind = TrajectoryKind::kOrbit;
    sequence_options.trajectory.num_frames = options.orbit_frames;
    sequence_options.trajectory.orbit.distance_in_radii = task.orbit_distance;
  }
  const SyntheticSequence sequence({mesh}, sequence_options);
  const Eigen::Vector3d centre = mesh.Centre();
  const std::vector<Rigid3> symmetries =
      SymmetryTransforms(database.models[static_cast<size_t>(task.model)].symmetry);

  const size_t num_trackers = options.trackers.size();
  std::vector<std::unique_ptr<Tracker>> trackers;
  std::vector<std::unique_ptr<TrackSmoother>> smoothers;
  runs->resize(num_trackers);
  for (size_t i = 0; i < num_trackers; ++i) {
    trackers.push_back(std::make_unique<Tracker>(
        database, sequence.camera(), HandheldTrackerOptions(options.trackers[i], task.seed)));
    const std::optional<int> lag = HandheldTrackerLag(options.trackers[i]);
    smoothers.push_back(lag ? std::make_unique<TrackSmoother>(*trackers.back(), *lag) : nullptr);
    HandheldRun& run = (*runs)[i];
    run.model = task.model;
    run.model_name = database.models[static_cast<size_t>(task.model)].name;
    run.kind = task.kind;
    run.orbit_distance_radii = task.orbit_distance;
    run.sequence = task.sequence;
    run.seed = task.seed;
    run.mask_quality = task.quality;
    run.tracker = options.trackers[i];
    run.frames.resize(static_cast<size_t>(sequence.num_frames()));
  }

  const ModelViews& model = database.models[static_cast<size_t>(task.model)];
  const ViewEquivalence equivalence(model.symmetry);
  // The truth of every frame, for results that come back later (smoothing).
  struct Truth {
    Rigid3 camera_from_object;
    Eigen::Vector3d view_dir = Eigen::Vector3d::UnitZ();
    double roll_deg = 0.0;
  };
  std::vector<Truth> truths(static_cast<size_t>(sequence.num_frames()));
  const auto record = [&](size_t i, const TrackedFrame& tracked) {
    const FrameResult& result = tracked.result;
    const size_t k = static_cast<size_t>(result.frame);
    const Truth& truth = truths[k];
    HandheldFrame& f = (*runs)[i].frames[k];
    f.time_ms = result.time_ms;
    f.object = result.object;
    f.right_object = result.object == task.model;
    f.rotation_error_deg = f.translation_error_percent = f.view_error = f.roll_error_deg = kNaN;
    f.rotation_error_symmetric_deg = f.view_error_symmetric = kNaN;
    f.wrong_twin = false;
    const std::span<const Rigid3> symmetric =
        f.right_object ? std::span<const Rigid3>(symmetries) : std::span<const Rigid3>();
    if (result.view_dir_in_object) {
      const Eigen::Vector3d estimated = result.view_dir_in_object->normalized();
      f.has_view = true;
      f.view_error = ViewDirectionError(estimated, truth.view_dir);
      f.view_error_symmetric = ViewErrorModuloSymmetry(estimated, truth.view_dir, symmetric);
      if (f.right_object && std::isfinite(result.roll_deg)) {
        const double carried = TransportRoll(estimated, result.roll_deg, truth.view_dir);
        f.roll_error_deg = std::abs(WrapDegrees(carried - truth.roll_deg));
      }
      if (f.right_object) {
        const double to_truth = equivalence.AngleDeg(estimated, truth.view_dir);
        for (const MirrorSymmetry& mirror : model.symmetry.mirrors) {
          const Eigen::Vector3d twin = mirror.TwinView(truth.view_dir);
          if (equivalence.AngleDeg(twin, truth.view_dir) > kTwinMinSeparationDeg &&
              equivalence.AngleDeg(estimated, twin) < to_truth) {
            f.wrong_twin = true;
          }
        }
      }
    }
    if (f.right_object && result.camera_from_object) {
      const Rigid3& pose = truth.camera_from_object;
      const double true_distance = (pose.rotation * centre + pose.translation).norm();
      f.has_pose = true;
      f.rotation_error_deg = RotationErrorDeg(result.camera_from_object->rotation, pose.rotation);
      f.rotation_error_symmetric_deg = RotationErrorModuloSymmetryDeg(
          result.camera_from_object->rotation, pose.rotation, symmetric);
      f.translation_error_percent =
          100.0 * (result.camera_from_object->translation - pose.translation).norm() /
          true_distance;
    }
  };

  SyntheticFrame frame;
  Eigen::Matrix3d previous_rotation = Eigen::Matrix3d::Identity();
  for (int k = 0; k < sequence.num_frames(); ++k) {
    sequence.Generate(k, &frame);
    const TrajectoryFrame& path = sequence.trajectory()[static_cast<size_t>(k)];
    Truth& truth = truths[static_cast<size_t>(k)];
    truth.camera_from_object = frame.truth.camera_from_object;
    truth.view_dir = path.view_dir_in_object.normalized();
    truth.roll_deg = path.roll_deg;
    const Eigen::Matrix3d& rotation = truth.camera_from_object.rotation;
    const double speed = k == 0 ? 0.0 : RotationErrorDeg(previous_rotation, rotation);
    previous_rotation = rotation;
    const double off_axis =
        std::acos(std::clamp(path.centre_ray_in_camera.normalized().z(), -1.0, 1.0)) * 180.0 /
        std::numbers::pi;
    for (size_t i = 0; i < num_trackers; ++i) {
      HandheldFrame& f = (*runs)[i].frames[static_cast<size_t>(k)];
      f.frame = k;
      f.distance_radii = path.distance_in_radii;
      f.off_axis_deg = off_axis;
      f.speed_deg_per_frame = speed;
      f.cut = path.cut;
      if (smoothers[i]) {
        for (const TrackedFrame& done : smoothers[i]->Process(frame.mask)) record(i, done);
      } else {
        record(i, trackers[i]->Process(frame.mask));
      }
    }
  }
  for (size_t i = 0; i < num_trackers; ++i) {
    if (!smoothers[i]) continue;
    for (const TrackedFrame& done : smoothers[i]->Finish()) record(i, done);
  }
}

template <typename Predicate>
std::vector<const HandheldFrame*> SelectFrames(std::span<const HandheldRun> runs, int skip_frames,
                                               Predicate keep) {
  std::vector<const HandheldFrame*> frames;
  for (const HandheldRun& run : runs) {
    for (const HandheldFrame& f : run.frames) {
      if (f.frame >= skip_frames && keep(run, f)) frames.push_back(&f);
    }
  }
  return frames;
}

std::ofstream OpenCsv(const std::filesystem::path& path) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(7);
  return file;
}

void CloseCsv(std::ofstream& file, const std::filesystem::path& path) {
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

// A number, or an empty cell for NaN.
std::string Cell(double value) {
  if (!std::isfinite(value)) return "";
  std::ostringstream text;
  text.precision(7);
  text << value;
  return text.str();
}

}  // namespace

const char* HandheldTrackerName(HandheldTracker tracker) {
  switch (tracker) {
    case HandheldTracker::kFilter:
      return "filter";
    case HandheldTracker::kBruteForce:
      return "brute-force";
    case HandheldTracker::kFilterNoRefine:
      return "filter-no-refine";
    case HandheldTracker::kFilterPaperMotion:
      return "filter-paper-motion";
    case HandheldTracker::kFilterLag10:
      return "filter-lag-10";
    case HandheldTracker::kFilterSmooth:
      return "filter-smooth";
    case HandheldTracker::kFilterAdaptive:
      return "filter-adaptive";
  }
  return "?";
}

bool ParseHandheldTracker(const std::string& name, HandheldTracker* tracker) {
  for (HandheldTracker t :
       {HandheldTracker::kFilter, HandheldTracker::kBruteForce, HandheldTracker::kFilterNoRefine,
        HandheldTracker::kFilterPaperMotion, HandheldTracker::kFilterLag10,
        HandheldTracker::kFilterSmooth, HandheldTracker::kFilterAdaptive}) {
    if (name == HandheldTrackerName(t)) {
      *tracker = t;
      return true;
    }
  }
  return false;
}

std::optional<int> HandheldTrackerLag(HandheldTracker tracker) {
  if (tracker == HandheldTracker::kFilterLag10) return 10;
  if (tracker == HandheldTracker::kFilterSmooth) return TrackSmoother::kOffline;
  return std::nullopt;
}

TrackerOptions HandheldTrackerOptions(HandheldTracker tracker, uint64_t seed) {
  TrackerOptions options;
  options.filter.seed = seed;
  // As `track` runs: particle histories only for the trackers that smooth (the times compare).
  options.filter.keep_history = HandheldTrackerLag(tracker).has_value();
  switch (tracker) {
    case HandheldTracker::kFilter:
      break;
    case HandheldTracker::kBruteForce:
      options.brute_force = true;
      break;
    case HandheldTracker::kFilterNoRefine:
      options.refine = false;
      break;
    case HandheldTracker::kFilterPaperMotion:
      options.filter.motion_model = MotionModel::kNeighbour;
      options.filter.data_driven_proposal = false;
      break;
    case HandheldTracker::kFilterLag10:
      break;
    case HandheldTracker::kFilterSmooth:
      options.filter.max_history_frames = 0;
      break;
    case HandheldTracker::kFilterAdaptive:
      options.filter.adaptive = true;
      break;
  }
  return options;
}

bool HandheldExperimentOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (sequences_per_model < 0) return fail("hand-held sequences per model must be >= 0");
  if (frames < 1 || frames > 1000000) return fail("frames must be in [1, 1000000]");
  if (orbit_frames < 1 || orbit_frames > 1000000)
    return fail("orbit frames must be in [1, 1000000]");
  if (sequences_per_model == 0 && orbit_distances_radii.empty())
    return fail("nothing to run: no hand-held sequences and no orbit distances");
  for (double d : orbit_distances_radii) {
    if (!(d > 1.0 && d <= 1000.0)) return fail("orbit distances must be in (1, 1000] radii");
  }
  if (std::set<double>(orbit_distances_radii.begin(), orbit_distances_radii.end()).size() !=
      orbit_distances_radii.size())
    return fail("orbit distances must not repeat");
  if (mask_qualities.empty()) return fail("at least one mask quality is needed");
  if (std::set<MaskQuality>(mask_qualities.begin(), mask_qualities.end()).size() !=
      mask_qualities.size())
    return fail("mask qualities must not repeat");
  if (trackers.empty()) return fail("at least one tracker is needed");
  if (std::set<HandheldTracker>(trackers.begin(), trackers.end()).size() != trackers.size())
    return fail("trackers must not repeat");
  if (skip_frames < 0) return fail("skip_frames must be >= 0");
  if (num_threads < 0) return fail("thread count must be >= 0");
  std::string problem;
  HandheldOptions probe = handheld;
  if (!probe.Check(&problem)) return fail("hand-held motion: " + problem);
  return true;
}

std::string HandheldRun::KindLabel() const {
  if (kind == HandheldSequenceKind::kHandheld) return "handheld";
  return "orbit-" + ShortNumber(orbit_distance_radii);
}

HandheldStats ComputeHandheldStats(const std::vector<const HandheldFrame*>& frames) {
  HandheldStats stats;
  std::vector<double> rotation, translation, view, roll, rotation_symmetric, view_symmetric;
  for (const HandheldFrame* f : frames) {
    ++stats.frames;
    stats.right_object += f->right_object;
    stats.no_estimate += f->object < 0;
    stats.no_pose += f->right_object && !f->has_pose;
    stats.wrong_twin += f->wrong_twin;
    if (f->has_pose) {
      rotation.push_back(f->rotation_error_deg);
      translation.push_back(f->translation_error_percent);
      rotation_symmetric.push_back(f->rotation_error_symmetric_deg);
    }
    if (f->has_view) {
      view.push_back(f->view_error);
      view_symmetric.push_back(f->view_error_symmetric);
    }
    if (std::isfinite(f->roll_error_deg)) roll.push_back(f->roll_error_deg);
  }
  stats.rotation_median_deg = Median(rotation);
  stats.rotation_mean_deg = Mean(rotation);
  stats.rotation_p90_deg = rotation.empty() ? kNaN : Percentile(rotation, 90.0);
  stats.translation_median_percent = Median(translation);
  stats.view_error_mean = Mean(view);
  stats.roll_median_deg = Median(roll);
  stats.rotation_median_symmetric_deg = Median(rotation_symmetric);
  stats.view_error_symmetric_mean = Mean(view_symmetric);
  return stats;
}

const char* HandheldBinAxisName(HandheldBinAxis axis) {
  switch (axis) {
    case HandheldBinAxis::kDistance:
      return "distance";
    case HandheldBinAxis::kOffAxis:
      return "off_axis";
    case HandheldBinAxis::kSpeed:
      return "speed";
    case HandheldBinAxis::kMaskQuality:
      return "mask_quality";
  }
  return "?";
}

const std::vector<HandheldBinAxis>& AllHandheldBinAxes() {
  static const std::vector<HandheldBinAxis> axes = {
      HandheldBinAxis::kDistance, HandheldBinAxis::kOffAxis, HandheldBinAxis::kSpeed,
      HandheldBinAxis::kMaskQuality};
  return axes;
}

std::vector<std::string> HandheldBinLabels(HandheldBinAxis axis,
                                           const std::vector<double>& orbit_distances_radii) {
  std::vector<std::string> labels;
  switch (axis) {
    case HandheldBinAxis::kDistance:
      labels = kDistanceLabels;
      for (double d : orbit_distances_radii) labels.push_back("orbit " + ShortNumber(d));
      break;
    case HandheldBinAxis::kOffAxis:
      labels = kOffAxisLabels;
      labels.push_back("orbit");
      break;
    case HandheldBinAxis::kSpeed:
      labels = kSpeedLabels;
      labels.push_back("orbit");
      break;
    case HandheldBinAxis::kMaskQuality:
      labels = {MaskQualityName(MaskQuality::kPerfect), MaskQualityName(MaskQuality::kThreshold)};
      break;
  }
  return labels;
}

std::vector<double> HandheldBinCentres(HandheldBinAxis axis,
                                       const std::vector<double>& orbit_distances_radii) {
  std::vector<double> centres;
  switch (axis) {
    case HandheldBinAxis::kDistance:
      centres = kDistanceCentres;
      for (double d : orbit_distances_radii) centres.push_back(d);
      break;
    case HandheldBinAxis::kOffAxis:
      centres = kOffAxisCentres;
      centres.push_back(kNaN);
      break;
    case HandheldBinAxis::kSpeed:
      centres = kSpeedCentres;
      centres.push_back(kNaN);
      break;
    case HandheldBinAxis::kMaskQuality:
      centres = {kNaN, kNaN};
      break;
  }
  return centres;
}

int HandheldBinIndex(HandheldBinAxis axis, const HandheldRun& run, const HandheldFrame& frame,
                     const std::vector<double>& orbit_distances_radii) {
  const bool orbit = run.kind == HandheldSequenceKind::kOrbit;
  switch (axis) {
    case HandheldBinAxis::kDistance:
      if (orbit) {
        return static_cast<int>(kDistanceLabels.size()) +
               OrbitIndex(run.orbit_distance_radii, orbit_distances_radii);
      }
      return RangeBin(frame.distance_radii, kDistanceEdges);
    case HandheldBinAxis::kOffAxis:
      return orbit ? static_cast<int>(kOffAxisLabels.size())
                   : RangeBin(frame.off_axis_deg, kOffAxisEdges);
    case HandheldBinAxis::kSpeed:
      return orbit ? static_cast<int>(kSpeedLabels.size())
                   : RangeBin(frame.speed_deg_per_frame, kSpeedEdges);
    case HandheldBinAxis::kMaskQuality:
      return run.mask_quality == MaskQuality::kPerfect ? 0 : 1;
  }
  return 0;
}

const HandheldSummaryRow* HandheldExperimentResult::Summary(const std::string& kind,
                                                            MaskQuality quality,
                                                            HandheldTracker tracker) const {
  for (const HandheldSummaryRow& row : summary) {
    if (row.kind == kind && row.mask_quality == quality && row.tracker == tracker) return &row;
  }
  return nullptr;
}

const HandheldBinRow* HandheldExperimentResult::Bin(HandheldBinAxis axis, int bin,
                                                    const std::string& mask_quality,
                                                    HandheldTracker tracker) const {
  for (const HandheldBinRow& row : bins) {
    if (row.axis == axis && row.bin == bin && row.mask_quality == mask_quality &&
        row.tracker == tracker)
      return &row;
  }
  return nullptr;
}

std::vector<uint64_t> HandheldExperimentResult::Seeds() const {
  std::set<uint64_t> seeds;
  for (const HandheldRun& run : runs) seeds.insert(run.seed);
  return {seeds.begin(), seeds.end()};
}

int HandheldTaskCount(const HandheldExperimentOptions& options, int num_models) {
  return num_models *
         (options.sequences_per_model + static_cast<int>(options.orbit_distances_radii.size())) *
         static_cast<int>(options.mask_qualities.size());
}

HandheldExperimentResult RunHandheldExperiment(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const HandheldExperimentOptions& options,
                                               const std::function<void(int)>& on_progress) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid hand-held experiment options: ", error);
  if (meshes.size() != database.models.size()) {
    ThrowError("the hand-held experiment needs one mesh per database model (",
               database.models.size(), "), got ", meshes.size());
  }
  for (size_t m = 0; m < meshes.size(); ++m) {
    if (meshes[m].name != database.models[m].name) {
      ThrowError("mesh '", meshes[m].name, "' does not match database model '",
                 database.models[m].name, "'");
    }
  }
  std::vector<int> models;
  if (options.models.empty()) {
    for (int m = 0; m < static_cast<int>(database.models.size()); ++m) models.push_back(m);
  } else {
    for (const std::string& name : options.models) {
      const int index = database.FindModel(name);
      if (index < 0) ThrowError("model to evaluate '", name, "' is not in the database");
      if (std::find(models.begin(), models.end(), index) != models.end())
        ThrowError("model to evaluate '", name, "' is named twice");
      models.push_back(index);
    }
  }
  const auto start = std::chrono::steady_clock::now();

  std::vector<Task> tasks;
  const int num_orbits = static_cast<int>(options.orbit_distances_radii.size());
  for (size_t i = 0; i < models.size(); ++i) {
    const uint64_t order = i;
    for (int k = 0; k < options.sequences_per_model; ++k) {
      for (MaskQuality quality : options.mask_qualities) {
        tasks.push_back({.model = models[i],
                         .model_order = static_cast<int>(i),
                         .kind = HandheldSequenceKind::kHandheld,
                         .sequence = k,
                         .seed = options.first_seed +
                                 order * static_cast<uint64_t>(options.sequences_per_model) +
                                 static_cast<uint64_t>(k),
                         .quality = quality});
      }
    }
    for (int j = 0; j < num_orbits; ++j) {
      for (MaskQuality quality : options.mask_qualities) {
        tasks.push_back({.model = models[i],
                         .model_order = static_cast<int>(i),
                         .kind = HandheldSequenceKind::kOrbit,
                         .orbit_distance = options.orbit_distances_radii[static_cast<size_t>(j)],
                         .sequence = j,
                         .seed = options.first_seed + kOrbitSeedOffset +
                                 order * static_cast<uint64_t>(num_orbits) +
                                 static_cast<uint64_t>(j),
                         .quality = quality});
      }
    }
  }

  std::vector<std::vector<HandheldRun>> task_runs(tasks.size());
  const int num_threads = WorkerThreads(options.num_threads);
  auto run_task = [&](size_t t) {
    RunTask(database, meshes[static_cast<size_t>(tasks[t].model)], tasks[t], options,
            &task_runs[t]);
    if (on_progress) on_progress(1);
  };
  if (num_threads == 1) {
    for (size_t t = 0; t < tasks.size(); ++t) run_task(t);
  } else {
    ParallelFor(0, static_cast<int>(tasks.size()), 1, num_threads, [&](int first, int last) {
      for (int t = first; t < last; ++t) run_task(static_cast<size_t>(t));
    });
  }

  HandheldExperimentResult result;
  result.options = options;
  result.database_models = static_cast<int>(database.models.size());
  for (int m : models) result.models.push_back(database.models[static_cast<size_t>(m)].name);
  for (std::vector<HandheldRun>& runs : task_runs) {
    for (HandheldRun& run : runs) result.runs.push_back(std::move(run));
  }

  // Summary: kinds x qualities x trackers.
  std::vector<std::string> kinds;
  if (options.sequences_per_model > 0) kinds.push_back("handheld");
  for (double d : options.orbit_distances_radii) kinds.push_back("orbit-" + ShortNumber(d));
  for (const HandheldRun& run : result.runs) {
    result.run_stats.push_back(ComputeHandheldStats(
        SelectFrames(std::span<const HandheldRun>(&run, 1), options.skip_frames,
                     [](const HandheldRun&, const HandheldFrame&) { return true; })));
  }
  for (const std::string& kind : kinds) {
    for (MaskQuality quality : options.mask_qualities) {
      for (HandheldTracker tracker : options.trackers) {
        HandheldSummaryRow row;
        row.kind = kind;
        row.mask_quality = quality;
        row.tracker = tracker;
        auto keep = [&](const HandheldRun& run, const HandheldFrame&) {
          return run.KindLabel() == kind && run.mask_quality == quality && run.tracker == tracker;
        };
        for (const HandheldRun& run : result.runs) row.sequences += keep(run, run.frames.front());
        row.counted = ComputeHandheldStats(SelectFrames(result.runs, options.skip_frames, keep));
        row.all = ComputeHandheldStats(SelectFrames(result.runs, 0, keep));
        result.summary.push_back(row);
      }
    }
  }

  // Bins: axes x bins x (all, qualities) x trackers.
  std::vector<std::string> quality_names = {"all"};
  for (MaskQuality quality : options.mask_qualities)
    quality_names.push_back(MaskQualityName(quality));
  for (HandheldBinAxis axis : AllHandheldBinAxes()) {
    const std::vector<std::string> labels = HandheldBinLabels(axis, options.orbit_distances_radii);
    // Each frame's bin, computed once per axis.
    std::vector<std::vector<const HandheldFrame*>> by_bin(labels.size() * quality_names.size() *
                                                          options.trackers.size());
    auto slot = [&](int bin, size_t quality, size_t tracker) {
      return (static_cast<size_t>(bin) * quality_names.size() + quality) * options.trackers.size() +
             tracker;
    };
    for (const HandheldRun& run : result.runs) {
      const size_t tracker = static_cast<size_t>(
          std::find(options.trackers.begin(), options.trackers.end(), run.tracker) -
          options.trackers.begin());
      const size_t quality = static_cast<size_t>(
          std::find(quality_names.begin(), quality_names.end(), MaskQualityName(run.mask_quality)) -
          quality_names.begin());
      for (const HandheldFrame& f : run.frames) {
        if (f.frame < options.skip_frames) continue;
        const int bin = HandheldBinIndex(axis, run, f, options.orbit_distances_radii);
        by_bin[slot(bin, 0, tracker)].push_back(&f);
        by_bin[slot(bin, quality, tracker)].push_back(&f);
      }
    }
    for (size_t bin = 0; bin < labels.size(); ++bin) {
      for (size_t q = 0; q < quality_names.size(); ++q) {
        for (size_t t = 0; t < options.trackers.size(); ++t) {
          HandheldBinRow row;
          row.axis = axis;
          row.bin = static_cast<int>(bin);
          row.label = labels[bin];
          row.mask_quality = quality_names[q];
          row.tracker = options.trackers[t];
          row.stats = ComputeHandheldStats(by_bin[slot(static_cast<int>(bin), q, t)]);
          result.bins.push_back(row);
        }
      }
    }
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

const char* HandheldSummaryHeader() {
  return "kind,mask_quality,tracker,sequences,frames,right_object_percent,no_estimate_frames,"
         "no_pose_frames,rotation_median_deg,rotation_mean_deg,rotation_p90_deg,"
         "translation_median_percent,view_error_mean,roll_median_deg,all_frames,"
         "all_right_object_percent,all_rotation_median_deg,rotation_median_symmetric_deg,"
         "view_error_symmetric_mean,wrong_twin_frames";
}

const char* HandheldSequencesHeader() {
  return "model,kind,sequence,seed,mask_quality,tracker,frames,right_object_percent,"
         "rotation_median_symmetric_deg,translation_median_percent,view_error_symmetric_mean,"
         "wrong_twin_frames";
}

std::vector<HandheldComparisonRow> CompareHandheldTrackers(const HandheldExperimentResult& result,
                                                           HandheldTracker tracker,
                                                           HandheldTracker reference) {
  if (result.run_stats.size() != result.runs.size()) {
    ThrowError("the hand-held result has ", result.run_stats.size(), " run statistics for ",
               result.runs.size(), " runs");
  }
  // The reference's mean view error of each sequence, by (model, kind, sequence, mask quality).
  std::map<std::tuple<int, std::string, int, MaskQuality>, double> reference_error;
  for (size_t r = 0; r < result.runs.size(); ++r) {
    const HandheldRun& run = result.runs[r];
    if (run.tracker != reference) continue;
    reference_error[{run.model, run.KindLabel(), run.sequence, run.mask_quality}] =
        result.run_stats[r].view_error_symmetric_mean;
  }
  std::vector<HandheldComparisonRow> rows;
  for (const HandheldSummaryRow& summary : result.summary) {
    if (summary.tracker != tracker) continue;
    HandheldComparisonRow row;
    row.kind = summary.kind;
    row.mask_quality = summary.mask_quality;
    for (size_t r = 0; r < result.runs.size(); ++r) {
      const HandheldRun& run = result.runs[r];
      if (run.tracker != tracker || run.KindLabel() != row.kind ||
          run.mask_quality != row.mask_quality) {
        continue;
      }
      const auto found =
          reference_error.find({run.model, run.KindLabel(), run.sequence, run.mask_quality});
      if (found == reference_error.end()) continue;
      ++row.sequences;
      const double own = result.run_stats[r].view_error_symmetric_mean;
      const double theirs = found->second;
      if (std::isfinite(theirs) && !(own <= theirs)) ++row.above;
    }
    if (row.sequences > 0) rows.push_back(row);
  }
  return rows;
}

const char* HandheldFramesHeader() {
  return "model,kind,sequence,seed,mask_quality,tracker,frame,distance_radii,off_axis_deg,"
         "speed_deg_per_frame,cut,estimated_object,right_object,has_pose,rotation_error_deg,"
         "translation_error_percent,view_error,roll_error_deg,time_ms,wrong_twin,"
         "rotation_error_symmetric_deg,view_error_symmetric";
}

const char* HandheldBinsHeader() {
  return "axis,bin,mask_quality,tracker,frames,right_object_percent,rotation_median_deg,"
         "rotation_mean_deg,translation_median_percent,rotation_median_symmetric_deg";
}

void WriteHandheldSummary(const std::filesystem::path& path,
                          const HandheldExperimentResult& result) {
  std::ofstream csv = OpenCsv(path);
  csv << HandheldSummaryHeader() << '\n';
  for (const HandheldSummaryRow& row : result.summary) {
    const HandheldStats& s = row.counted;
    csv << row.kind << ',' << MaskQualityName(row.mask_quality) << ','
        << HandheldTrackerName(row.tracker) << ',' << row.sequences << ',' << s.frames << ','
        << Cell(s.RightObjectPercent()) << ',' << s.no_estimate << ',' << s.no_pose << ','
        << Cell(s.rotation_median_deg) << ',' << Cell(s.rotation_mean_deg) << ','
        << Cell(s.rotation_p90_deg) << ',' << Cell(s.translation_median_percent) << ','
        << Cell(s.view_error_mean) << ',' << Cell(s.roll_median_deg) << ',' << row.all.frames << ','
        << Cell(row.all.RightObjectPercent()) << ',' << Cell(row.all.rotation_median_deg) << ','
        << Cell(s.rotation_median_symmetric_deg) << ',' << Cell(s.view_error_symmetric_mean) << ','
        << s.wrong_twin << '\n';
  }
  CloseCsv(csv, path);
}

void WriteHandheldSequences(const std::filesystem::path& path,
                            const HandheldExperimentResult& result) {
  if (result.run_stats.size() != result.runs.size()) {
    ThrowError("the hand-held result has ", result.run_stats.size(), " run statistics for ",
               result.runs.size(), " runs");
  }
  std::ofstream csv = OpenCsv(path);
  csv << HandheldSequencesHeader() << '\n';
  for (size_t r = 0; r < result.runs.size(); ++r) {
    const HandheldRun& run = result.runs[r];
    const HandheldStats& s = result.run_stats[r];
    csv << run.model_name << ',' << run.KindLabel() << ',' << run.sequence << ',' << run.seed << ','
        << MaskQualityName(run.mask_quality) << ',' << HandheldTrackerName(run.tracker) << ','
        << s.frames << ',' << (s.frames > 0 ? Cell(s.RightObjectPercent()) : "") << ','
        << Cell(s.rotation_median_symmetric_deg) << ',' << Cell(s.translation_median_percent) << ','
        << Cell(s.view_error_symmetric_mean) << ',' << s.wrong_twin << '\n';
  }
  CloseCsv(csv, path);
}

void WriteHandheldFrames(const std::filesystem::path& path, const HandheldExperimentResult& result,
                         const ViewDatabase& database) {
  std::ofstream csv = OpenCsv(path);
  csv << HandheldFramesHeader() << '\n';
  for (const HandheldRun& run : result.runs) {
    const std::string prefix = run.model_name + ',' + run.KindLabel() + ',' +
                               std::to_string(run.sequence) + ',' + std::to_string(run.seed) + ',' +
                               MaskQualityName(run.mask_quality) + ',' +
                               HandheldTrackerName(run.tracker) + ',';
    for (const HandheldFrame& f : run.frames) {
      csv << prefix << f.frame << ',' << Cell(f.distance_radii) << ',' << Cell(f.off_axis_deg)
          << ',' << Cell(f.speed_deg_per_frame) << ',' << (f.cut ? 1 : 0) << ','
          << (f.object >= 0 ? database.models[static_cast<size_t>(f.object)].name : "") << ','
          << (f.right_object ? 1 : 0) << ',' << (f.has_pose ? 1 : 0) << ','
          << Cell(f.rotation_error_deg) << ',' << Cell(f.translation_error_percent) << ','
          << Cell(f.view_error) << ',' << Cell(f.roll_error_deg) << ',' << Cell(f.time_ms) << ','
          << (f.wrong_twin ? 1 : 0) << ',' << Cell(f.rotation_error_symmetric_deg) << ','
          << Cell(f.view_error_symmetric) << '\n';
    }
  }
  CloseCsv(csv, path);
}

void WriteHandheldBins(const std::filesystem::path& path, const HandheldExperimentResult& result) {
  std::ofstream csv = OpenCsv(path);
  csv << HandheldBinsHeader() << '\n';
  for (const HandheldBinRow& row : result.bins) {
    const HandheldStats& s = row.stats;
    csv << HandheldBinAxisName(row.axis) << ',' << row.label << ',' << row.mask_quality << ','
        << HandheldTrackerName(row.tracker) << ',' << s.frames << ','
        << (s.frames > 0 ? Cell(s.RightObjectPercent()) : "") << ',' << Cell(s.rotation_median_deg)
        << ',' << Cell(s.rotation_mean_deg) << ',' << Cell(s.translation_median_percent) << ','
        << Cell(s.rotation_median_symmetric_deg) << '\n';
  }
  CloseCsv(csv, path);
}

Figure HandheldFigure(const HandheldExperimentResult& result) {
  const HandheldExperimentOptions& options = result.options;
  // One panel per mask quality and axis: the errors with perfect masks are a tenth of those with
  // threshold-like ones, and would lie flat on a shared scale.
  auto panel_for = [&](HandheldBinAxis axis, MaskQuality quality, const std::string& title,
                       const std::string& x_label) {
    PlotPanel panel;
    panel.title = title;
    panel.x_axis.label = x_label;
    panel.y_axis.label = "median rotation error mod. symmetry (deg)";
    panel.y_axis.min = 0.0;
    const std::vector<double> centres = HandheldBinCentres(axis, options.orbit_distances_radii);
    const size_t num_range_bins =
        axis == HandheldBinAxis::kDistance ? kDistanceLabels.size() : centres.size();
    int colour = 0;
    for (HandheldTracker tracker : options.trackers) {
      PlotSeries range, orbits;
      range.label = HandheldTrackerName(tracker);
      range.colour = orbits.colour = PaletteColour(colour++);
      range.marker = quality == MaskQuality::kThreshold ? Marker::kCross : Marker::kCircle;
      orbits.line = false;
      orbits.marker = Marker::kSquare;
      orbits.marker_radius_px = 4.0;
      for (size_t bin = 0; bin < centres.size(); ++bin) {
        if (!std::isfinite(centres[bin])) continue;
        const HandheldBinRow* row =
            result.Bin(axis, static_cast<int>(bin), MaskQualityName(quality), tracker);
        if (row == nullptr || !std::isfinite(row->stats.rotation_median_symmetric_deg)) continue;
        PlotSeries& series = bin < num_range_bins ? range : orbits;
        series.x.push_back(centres[bin]);
        series.y.push_back(row->stats.rotation_median_symmetric_deg);
      }
      if (!range.x.empty()) panel.series.push_back(range);
      if (!orbits.x.empty()) panel.series.push_back(orbits);
    }
    return panel;
  };
  Figure figure;
  figure.height_px = 460;
  for (MaskQuality quality : options.mask_qualities) {
    const std::string masks = quality == MaskQuality::kThreshold ? "threshold-like" : "perfect";
    figure.panels.push_back(panel_for(HandheldBinAxis::kSpeed, quality,
                                      "By speed, hand-held, " + masks + " masks",
                                      "true rotation speed (deg/frame, bin centre)"));
    figure.panels.push_back(panel_for(HandheldBinAxis::kDistance, quality,
                                      "By distance, " + masks + " masks (squares: orbits)",
                                      "distance (object radii, bin centre)"));
  }
  figure.width_px = 600 * static_cast<int>(figure.panels.size());
  return figure;
}

}  // namespace silpose
