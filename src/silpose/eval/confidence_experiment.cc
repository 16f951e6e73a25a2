#include "silpose/eval/confidence_experiment.h"

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "silpose/geometry/symmetry.h"
#include "silpose/pose/pose_error.h"
#include "silpose/synth/degradation.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"
#include "silpose/util/parallel.h"
#include "silpose/util/threads.h"

namespace silpose {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kNumFeatures = ConfidenceFeatures::kSize;
using FeatureRow = std::array<double, kNumFeatures>;

// Occluded condition: frames 14..19 of every 20.
bool OccludedFrame(int frame) { return frame % 20 >= 14; }

struct Task {
  const TriangleMesh* mesh = nullptr;
  int model = -1;  // database index, -1 for an unknown object
  std::string name;
  bool fit = false;
  ConfidenceCondition condition = ConfidenceCondition::kClean;
  uint64_t seed = 0;
};

ConfidenceRun RunTask(const ViewDatabase& database, const Task& task,
                      const ConfidenceExperimentOptions& options, const TrackStateOptions& state) {
  SequenceOptions sequence_options;
  sequence_options.trajectory.kind = TrajectoryKind::kHandheld;
  sequence_options.trajectory.num_frames = options.frames;
  sequence_options.trajectory.handheld = options.handheld;
  sequence_options.trajectory.handheld.seed = task.seed;
  const SyntheticSequence sequence({*task.mesh}, sequence_options);

  DegradationOptions degradation;
  degradation.seed = task.seed;
  if (task.condition == ConfidenceCondition::kDegraded) {
    degradation = WithMaskQuality(degradation, MaskQuality::kThreshold);
    degradation.bad_probability = 0.2;
  } else if (task.condition == ConfidenceCondition::kOccluded) {
    degradation.occluders = 2;
    degradation.occluder_size = 0.5;
  }
  std::vector<Rigid3> symmetries;
  if (task.model >= 0)
    symmetries = SymmetryTransforms(database.models[static_cast<size_t>(task.model)].symmetry);

  TrackerOptions tracker_options;
  tracker_options.filter.seed = task.seed;
  tracker_options.filter.keep_history = false;  // as `track` without smoothing
  tracker_options.state = state;
  Tracker tracker(database, sequence.camera(), tracker_options);

  ConfidenceRun run;
  run.model = task.name;
  run.unknown = task.model < 0;
  run.fit = task.fit;
  run.condition = task.condition;
  run.seed = task.seed;
  SyntheticFrame frame;
  for (int k = 0; k < sequence.num_frames(); ++k) {
    sequence.Generate(k, &frame);
    if (task.condition != ConfidenceCondition::kOccluded || OccludedFrame(k))
      DegradeMask(degradation, k, &frame.mask);
    const TrackedFrame tracked = tracker.Process(frame.mask);
    const FrameResult& result = tracked.result;
    ConfidenceFrame f;
    f.frame = k;
    f.silhouette = result.state != TrackState::kNoSilhouette;
    f.confidence = std::isfinite(result.confidence) ? result.confidence : 0.0;
    f.state = result.state;
    if (task.model >= 0 && result.object == task.model && result.camera_from_object) {
      f.correct = RotationErrorModuloSymmetryDeg(result.camera_from_object->rotation,
                                                 frame.truth.camera_from_object.rotation,
                                                 symmetries) <= options.correct_rotation_deg;
    }
    f.has_features = tracked.confidence_features.has_value();
    f.features = tracked.confidence_features ? tracked.confidence_features->Vector()
                                             : ConfidenceFeatures().Vector();
    run.frames.push_back(f);
  }
  return run;
}

}  // namespace

const char* ConfidenceConditionName(ConfidenceCondition condition) {
  switch (condition) {
    case ConfidenceCondition::kClean:
      return "clean";
    case ConfidenceCondition::kDegraded:
      return "degraded";
    case ConfidenceCondition::kOccluded:
      return "occluded";
  }
  return "unknown";
}

bool ConfidenceExperimentOptions::Check(std::string* error) const {
  std::ostringstream message;
  std::string problem;
  if (fit && fit_models.empty()) {
    message << "fitting needs at least one fit model";
  } else if (sequences < 1 || sequences > 10) {
    message << "sequences must be in [1, 10], got " << sequences;
  } else if (frames < 2 || frames > 100000) {
    message << "frames must be in [2, 100000], got " << frames;
  } else if (!(ridge >= 0.0) || !std::isfinite(ridge)) {
    message << "ridge must be >= 0, got " << ridge;
  } else if (!state.Check(&problem)) {
    message << problem;
  } else if (!(correct_rotation_deg > 0.0 && correct_rotation_deg <= 180.0)) {
    message << "correct rotation must be in (0, 180] degrees, got " << correct_rotation_deg;
  } else if (num_threads < 0) {
    message << "threads must be >= 0, got " << num_threads;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

double ConfidenceMetrics::WrongTrackingPercent() const {
  return tracking > 0 ? 100.0 * tracking_wrong / tracking : kNaN;
}
double ConfidenceMetrics::CorrectTrackingPercent() const {
  return correct > 0 ? 100.0 * correct_tracking / correct : kNaN;
}
double ConfidenceMetrics::UnknownReportedPercent() const {
  return unknown_frames > 0 ? 100.0 * unknown_reported / unknown_frames : kNaN;
}

double RocAuc(const std::vector<double>& positive, const std::vector<double>& negative) {
  if (positive.empty() || negative.empty()) return kNaN;
  // Mann-Whitney U from the ranks of the pooled values (ties get their mean rank).
  std::vector<std::pair<double, bool>> all;
  all.reserve(positive.size() + negative.size());
  for (double v : positive) all.emplace_back(v, true);
  for (double v : negative) all.emplace_back(v, false);
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double rank_sum = 0.0;
  for (size_t i = 0; i < all.size();) {
    size_t j = i;
    while (j < all.size() && all[j].first == all[i].first) ++j;
    const double mean_rank = 0.5 * static_cast<double>(i + 1 + j);  // ranks i+1 .. j
    for (size_t k = i; k < j; ++k)
      if (all[k].second) rank_sum += mean_rank;
    i = j;
  }
  const double p = static_cast<double>(positive.size());
  const double n = static_cast<double>(negative.size());
  return (rank_sum - p * (p + 1.0) / 2.0) / (p * n);
}

ConfidenceModel FitConfidenceModel(const std::vector<FeatureRow>& rows,
                                   const std::vector<bool>& labels, double ridge) {
  if (rows.size() != labels.size()) ThrowError("confidence fit: rows and labels differ in count");
  if (rows.size() < 2) ThrowError("confidence fit: needs at least two frames");
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  // Standardise the columns (constant columns are left as they are and get no weight).
  Eigen::Matrix<double, kNumFeatures, 1> mean = Eigen::Matrix<double, kNumFeatures, 1>::Zero();
  Eigen::Matrix<double, kNumFeatures, 1> scale = Eigen::Matrix<double, kNumFeatures, 1>::Ones();
  for (const FeatureRow& r : rows)
    for (int j = 0; j < kNumFeatures; ++j) mean[j] += r[static_cast<size_t>(j)];
  mean /= static_cast<double>(n);
  Eigen::Matrix<double, kNumFeatures, 1> variance = Eigen::Matrix<double, kNumFeatures, 1>::Zero();
  for (const FeatureRow& r : rows)
    for (int j = 0; j < kNumFeatures; ++j)
      variance[j] += (r[static_cast<size_t>(j)] - mean[j]) * (r[static_cast<size_t>(j)] - mean[j]);
  std::array<bool, kNumFeatures> used{};
  for (int j = 0; j < kNumFeatures; ++j) {
    const double sd = std::sqrt(variance[j] / static_cast<double>(n));
    used[static_cast<size_t>(j)] = sd > 1e-9;
    scale[j] = used[static_cast<size_t>(j)] ? sd : 1.0;
  }
  constexpr int kDim = kNumFeatures + 1;
  Eigen::MatrixXd x(n, kDim);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    x(i, 0) = 1.0;
    for (int j = 0; j < kNumFeatures; ++j) {
      x(i, j + 1) =
          used[static_cast<size_t>(j)]
              ? (rows[static_cast<size_t>(i)][static_cast<size_t>(j)] - mean[j]) / scale[j]
              : 0.0;
    }
    y[i] = labels[static_cast<size_t>(i)] ? 1.0 : 0.0;
  }
  Eigen::VectorXd beta = Eigen::VectorXd::Zero(kDim);
  Eigen::VectorXd penalty = Eigen::VectorXd::Constant(kDim, ridge * static_cast<double>(n));
  penalty[0] = 0.0;
  for (int j = 0; j < kNumFeatures; ++j)
    if (!used[static_cast<size_t>(j)]) penalty[j + 1] = 1.0;  // pins unused weights at 0
  for (int iteration = 0; iteration < 100; ++iteration) {
    const Eigen::VectorXd z = x * beta;
    Eigen::VectorXd p(n), w(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      p[i] = 1.0 / (1.0 + std::exp(-z[i]));
      w[i] = std::max(p[i] * (1.0 - p[i]), 1e-10);
    }
    const Eigen::VectorXd gradient = x.transpose() * (y - p) - penalty.cwiseProduct(beta);
    Eigen::MatrixXd hessian = x.transpose() * w.asDiagonal() * x;
    hessian.diagonal() += penalty;
    const Eigen::VectorXd step = hessian.ldlt().solve(gradient);
    if (!step.allFinite()) break;
    beta += step;
    if (step.norm() < 1e-10) break;
  }
  ConfidenceModel model;
  model.bias = beta[0];
  for (int j = 0; j < kNumFeatures; ++j) {
    const double weight = used[static_cast<size_t>(j)] ? beta[j + 1] / scale[j] : 0.0;
    model.weights[static_cast<size_t>(j)] = weight;
    model.bias -= weight * (used[static_cast<size_t>(j)] ? mean[j] : 0.0);
  }
  return model;
}

namespace {

ConfidenceMetrics Measure(const std::vector<const ConfidenceRun*>& runs) {
  ConfidenceMetrics m;
  std::vector<double> positive, negative;
  for (const ConfidenceRun* run : runs) {
    for (const ConfidenceFrame& f : run->frames) {
      ++m.states[static_cast<size_t>(f.state)];
      if (!f.silhouette) continue;
      ++m.frames;
      (f.correct ? positive : negative).push_back(f.confidence);
      m.correct += f.correct;
      if (f.state == TrackState::kTracking) {
        ++m.tracking;
        m.tracking_wrong += !f.correct;
        m.correct_tracking += f.correct;
      }
      if (run->unknown) {
        ++m.unknown_frames;
        m.unknown_reported += f.state == TrackState::kUnknownObject;
      }
    }
  }
  m.auc = RocAuc(positive, negative);
  return m;
}

std::vector<size_t> ModelIndices(const ViewDatabase& database,
                                 const std::vector<std::string>& names) {
  std::vector<size_t> indices;
  for (const std::string& name : names) {
    size_t i = 0;
    while (i < database.models.size() && database.models[i].name != name) ++i;
    if (i == database.models.size())
      ThrowError("eval confidence: model '", name, "' is not in the database");
    indices.push_back(i);
  }
  return indices;
}

std::vector<ConfidenceRun> RunTasks(const ViewDatabase& database, const std::vector<Task>& tasks,
                                    const ConfidenceExperimentOptions& options,
                                    const TrackStateOptions& state,
                                    const std::function<void(int)>& on_progress) {
  std::vector<ConfidenceRun> runs(tasks.size());
  auto run_task = [&](size_t t) {
    runs[t] = RunTask(database, tasks[t], options, state);
    if (on_progress) on_progress(1);
  };
  const int num_threads = WorkerThreads(options.num_threads);
  if (num_threads == 1) {
    for (size_t t = 0; t < tasks.size(); ++t) run_task(t);
  } else {
    ParallelFor(0, static_cast<int>(tasks.size()), 1, num_threads, [&](int first, int last) {
      for (int t = first; t < last; ++t) run_task(static_cast<size_t>(t));
    });
  }
  return runs;
}

}  // namespace

TriangleMesh LookalikeMesh(const TriangleMesh& mesh) {
  TriangleMesh copy = mesh;
  copy.name = mesh.name + "-lookalike";
  const Eigen::Vector3f centre = mesh.Centre().cast<float>();
  const Eigen::Vector3f scale(1.35f, 1.0f, 0.8f);
  for (Eigen::Vector3f& v : copy.vertices) v = centre + (v - centre).cwiseProduct(scale);
  return copy;
}

int ConfidenceTaskCount(const ConfidenceExperimentOptions& options, int num_fit, int num_eval,
                        int num_unknown) {
  const int fit = options.fit ? (options.fit_lookalikes ? 5 : 3) * num_fit : 0;
  return options.sequences * (fit + 3 * num_eval + 2 * num_unknown);
}

ConfidenceExperimentResult RunConfidenceExperiment(const ViewDatabase& database,
                                                   const std::vector<TriangleMesh>& meshes,
                                                   const std::vector<TriangleMesh>& unknown,
                                                   const ConfidenceExperimentOptions& options,
                                                   const std::function<void(int)>& on_progress) {
  const auto start = std::chrono::steady_clock::now();
  std::string problem;
  if (!options.Check(&problem)) ThrowError("eval confidence: ", problem);
  if (meshes.size() != database.models.size())
    ThrowError("eval confidence: ", meshes.size(), " meshes for a database of ",
               database.models.size(), " models");
  ConfidenceExperimentResult result;
  result.options = options;
  const std::vector<size_t> fit = ModelIndices(database, options.fit_models);
  std::vector<size_t> eval = ModelIndices(database, options.eval_models);
  if (options.eval_models.empty()) {
    for (size_t i = 0; i < database.models.size(); ++i)
      if (std::find(fit.begin(), fit.end(), i) == fit.end()) eval.push_back(i);
  }
  for (size_t i : eval) {
    if (std::find(fit.begin(), fit.end(), i) != fit.end())
      ThrowError("eval confidence: model '", database.models[i].name,
                 "' is both a fit and an evaluation model");
  }
  std::set<std::string> names;
  for (const ModelViews& m : database.models) names.insert(m.name);
  for (const TriangleMesh& mesh : unknown) {
    if (names.count(mesh.name) != 0)
      ThrowError("eval confidence: the unknown object '", mesh.name, "' is in the database");
  }
  for (size_t i : fit) result.fit_models.push_back(database.models[i].name);
  for (size_t i : eval) result.eval_models.push_back(database.models[i].name);
  for (const TriangleMesh& mesh : unknown) result.unknown_models.push_back(mesh.name);

  const std::array<ConfidenceCondition, 3> conditions = {
      ConfidenceCondition::kClean, ConfidenceCondition::kDegraded, ConfidenceCondition::kOccluded};
  const auto seed_of = [&](int condition, int model_order, int k) {
    return options.first_seed + 1000u * static_cast<uint64_t>(condition) +
           10u * static_cast<uint64_t>(model_order) + static_cast<uint64_t>(k);
  };
  // Phase 1: fit.
  result.model = options.state.model;
  std::vector<ConfidenceRun> fit_runs;
  if (options.fit) {
    std::vector<Task> tasks;
    for (size_t c = 0; c < conditions.size(); ++c)
      for (size_t i = 0; i < fit.size(); ++i)
        for (int k = 0; k < options.sequences; ++k)
          tasks.push_back({&meshes[fit[i]], static_cast<int>(fit[i]), database.models[fit[i]].name,
                           true, conditions[c],
                           seed_of(static_cast<int>(c), static_cast<int>(i), k)});
    std::vector<TriangleMesh> lookalikes;
    if (options.fit_lookalikes)
      for (size_t i : fit) lookalikes.push_back(LookalikeMesh(meshes[i]));
    for (size_t c = 0; c < 2 && options.fit_lookalikes; ++c)
      for (size_t i = 0; i < lookalikes.size(); ++i)
        for (int k = 0; k < options.sequences; ++k)
          tasks.push_back(
              {&lookalikes[i], -1, lookalikes[i].name, true, conditions[c],
               seed_of(static_cast<int>(c), static_cast<int>(fit.size() + i), k) + 500u});
    fit_runs = RunTasks(database, tasks, options, options.state, on_progress);
    std::vector<FeatureRow> rows;
    std::vector<bool> labels;
    for (const ConfidenceRun& run : fit_runs) {
      for (const ConfidenceFrame& f : run.frames) {
        if (!f.silhouette || !f.has_features) continue;
        rows.push_back(f.features);
        labels.push_back(f.correct);
      }
    }
    result.model = FitConfidenceModel(rows, labels, options.ridge);
  }
  // Phase 2: evaluate with that model.
  TrackStateOptions state = options.state;
  state.model = result.model;
  std::vector<Task> tasks;
  const int fit_count = static_cast<int>(fit.size());
  for (size_t c = 0; c < conditions.size(); ++c) {
    for (size_t i = 0; i < eval.size(); ++i)
      for (int k = 0; k < options.sequences; ++k)
        tasks.push_back({&meshes[eval[i]], static_cast<int>(eval[i]), database.models[eval[i]].name,
                         false, conditions[c],
                         seed_of(static_cast<int>(c), fit_count + static_cast<int>(i), k)});
    if (conditions[c] == ConfidenceCondition::kOccluded) continue;
    for (size_t i = 0; i < unknown.size(); ++i)
      for (int k = 0; k < options.sequences; ++k)
        tasks.push_back(
            {&unknown[i], -1, unknown[i].name, false, conditions[c],
             seed_of(static_cast<int>(c), fit_count + static_cast<int>(eval.size() + i), k)});
  }
  std::vector<ConfidenceRun> eval_runs = RunTasks(database, tasks, options, state, on_progress);

  // Fit set: confidence with the fitted model, and the lowest threshold with at most 1 % of the
  // frames above it wrong.
  std::vector<std::pair<double, bool>> fit_frames;
  for (ConfidenceRun& run : fit_runs) {
    for (ConfidenceFrame& f : run.frames) {
      if (!f.silhouette || !f.has_features) continue;
      f.confidence = result.model.Evaluate(f.features);
      fit_frames.emplace_back(f.confidence, f.correct);
    }
  }
  result.fit_threshold = kNaN;
  if (!fit_frames.empty()) {
    std::sort(fit_frames.begin(), fit_frames.end(),
              [](const auto& a, const auto& b) { return a.first > b.first; });
    int above = 0, wrong = 0;
    for (size_t i = 0; i < fit_frames.size(); ++i) {
      ++above;
      wrong += !fit_frames[i].second;
      const bool last_of_tie =
          i + 1 == fit_frames.size() || fit_frames[i + 1].first < fit_frames[i].first;
      if (last_of_tie && wrong <= 0.01 * above) result.fit_threshold = fit_frames[i].first;
    }
  }
  result.runs = std::move(fit_runs);
  result.runs.insert(result.runs.end(), std::make_move_iterator(eval_runs.begin()),
                     std::make_move_iterator(eval_runs.end()));
  std::vector<const ConfidenceRun*> fit_set, eval_set;
  std::array<std::vector<const ConfidenceRun*>, 3> by_condition;
  for (const ConfidenceRun& run : result.runs) {
    (run.fit ? fit_set : eval_set).push_back(&run);
    if (!run.fit) by_condition[static_cast<size_t>(run.condition)].push_back(&run);
  }
  result.fit_set = Measure(fit_set);
  result.eval_set = Measure(eval_set);
  for (size_t c = 0; c < 3; ++c) result.eval_by_condition[c] = Measure(by_condition[c]);
  for (int b = 0; b < 10; ++b) {
    ReliabilityBin bin;
    bin.lower = b / 10.0;
    bin.upper = (b + 1) / 10.0;
    double confidence_sum = 0.0;
    int correct = 0;
    for (const ConfidenceRun* run : eval_set) {
      for (const ConfidenceFrame& f : run->frames) {
        if (!f.silhouette) continue;
        const int index = std::min(9, static_cast<int>(f.confidence * 10.0));
        if (index != b) continue;
        ++bin.frames;
        confidence_sum += f.confidence;
        correct += f.correct;
      }
    }
    bin.mean_confidence = bin.frames > 0 ? confidence_sum / bin.frames : kNaN;
    bin.accuracy = bin.frames > 0 ? static_cast<double>(correct) / bin.frames : kNaN;
    result.reliability.push_back(bin);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void WriteConfidenceFrames(const std::filesystem::path& path,
                           const ConfidenceExperimentResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(7);
  file << "model,unknown,fit,condition,seed,frame,silhouette,correct,confidence,state";
  for (const char* name : ConfidenceFeatures::Names()) file << ',' << name;
  file << '\n';
  for (const ConfidenceRun& run : result.runs) {
    for (const ConfidenceFrame& f : run.frames) {
      file << run.model << ',' << run.unknown << ',' << run.fit << ','
           << ConfidenceConditionName(run.condition) << ',' << run.seed << ',' << f.frame << ','
           << f.silhouette << ',' << f.correct << ',' << f.confidence << ','
           << TrackStateName(f.state);
      for (double x : f.features) file << ',' << x;
      file << '\n';
    }
  }
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

Figure ConfidenceFigure(const ConfidenceExperimentResult& result) {
  PlotPanel reliability;
  reliability.title = "Reliability (held-out sequences)";
  reliability.x_axis.label = "confidence (bin mean)";
  reliability.y_axis.label = "share of correct frames";
  reliability.x_axis.min = 0.0;
  reliability.x_axis.max = 1.0;
  reliability.y_axis.min = 0.0;
  reliability.y_axis.max = 1.0;
  PlotSeries diagonal;
  diagonal.label = "perfectly calibrated";
  diagonal.x = {0.0, 1.0};
  diagonal.y = {0.0, 1.0};
  diagonal.line = true;
  diagonal.marker = Marker::kNone;
  PlotSeries measured;
  measured.label = "measured";
  measured.line = true;
  measured.marker = Marker::kCircle;
  for (const ReliabilityBin& bin : result.reliability) {
    if (bin.frames == 0) continue;
    measured.x.push_back(bin.mean_confidence);
    measured.y.push_back(bin.accuracy);
  }
  reliability.series = {diagonal, measured};
  reliability.legend = LegendPosition::kTopLeft;

  PlotPanel roc;
  roc.title = "ROC of the confidence (held-out sequences)";
  roc.x_axis.label = "wrong frames above the threshold (false positive rate)";
  roc.y_axis.label = "correct frames above it (true positive rate)";
  roc.x_axis.min = roc.y_axis.min = 0.0;
  roc.x_axis.max = roc.y_axis.max = 1.0;
  std::vector<std::pair<double, bool>> frames;
  for (const ConfidenceRun& run : result.runs) {
    if (run.fit) continue;
    for (const ConfidenceFrame& f : run.frames)
      if (f.silhouette) frames.emplace_back(f.confidence, f.correct);
  }
  std::sort(frames.begin(), frames.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  const double positives = static_cast<double>(
      std::count_if(frames.begin(), frames.end(), [](const auto& f) { return f.second; }));
  const double negatives = static_cast<double>(frames.size()) - positives;
  PlotSeries curve;
  curve.label = "confidence";
  curve.line = true;
  curve.marker = Marker::kNone;
  curve.x.push_back(0.0);
  curve.y.push_back(0.0);
  double tp = 0.0, fp = 0.0;
  for (size_t i = 0; i < frames.size(); ++i) {
    (frames[i].second ? tp : fp) += 1.0;
    if (i + 1 < frames.size() && frames[i + 1].first == frames[i].first) continue;
    curve.x.push_back(negatives > 0.0 ? fp / negatives : 0.0);
    curve.y.push_back(positives > 0.0 ? tp / positives : 0.0);
  }
  roc.series = {curve};
  roc.legend = LegendPosition::kBottomRight;

  Figure figure;
  figure.width_px = 1100;
  figure.height_px = 480;
  figure.panels = {reliability, roc};
  return figure;
}

}  // namespace silpose
