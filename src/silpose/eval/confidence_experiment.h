#pragma once
// Calibration and test of the tracker's confidence and states (track/confidence.h,
// docs/confidence.md). `silpose eval confidence` runs it.
//
// Sequences (synth/synthetic_sequence.h, hand-held motion as in eval/handheld_experiment.h, the
// default 640 x 480 camera), `sequences` per model and condition, `frames` frames each:
//  - clean: the rendered masks;
//  - degraded: the flaws of a colour threshold's mask on every frame (MaskQuality::kThreshold)
//    and a strong degradation (a large occluder, a heavy erosion or a blob merged in) on 20 % of
//    the frames;
//  - occluded: the rendered masks with two occluders of up to half the silhouette's size in 30 %
//    of the frames (frames 14-19 of every 20: they enter and leave);
//  - unknown object (only for `unknown` meshes, which are not in the database): clean and
//    degraded masks; every frame is wrong, whatever is reported. The fit phase has its own
//    (fit_lookalikes): stretched copies of the fit models, never the evaluation's unknown objects.
// Sequence k of the i-th model of a condition c has the seed first_seed + 1000 c + 10 i + k; it
// seeds the trajectory, the degradation and the filter.
//
// A frame is correct when the tracker names the shown model, has a 6-DOF pose and its rotation is
// within correct_rotation_deg of the truth modulo the model's symmetry (geometry/symmetry.h).
// Frames without a usable silhouette (state no-silhouette, confidence 0) are counted apart and
// left out of the separation figures.
//
// Two phases: the fit models' sequences (clean, degraded, occluded) are tracked and a logistic
// regression of "correct" on ConfidenceFeatures::Vector (ridge-regularised, Newton's method) gives
// a ConfidenceModel; then the evaluation models' sequences and the unknown meshes' are tracked
// with that model (or the given one when fit = false) and measured: ROC AUC of the confidence,
// share of "tracking" frames that are wrong, share of correct frames reported "tracking", share
// of unknown-object frames reported "unknown-object", and a reliability diagram (10 bins).

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/plot/figure.h"
#include "silpose/synth/trajectory.h"
#include "silpose/track/confidence.h"

namespace silpose {

enum class ConfidenceCondition : uint8_t { kClean, kDegraded, kOccluded };
/// "clean", "degraded", "occluded".
const char* ConfidenceConditionName(ConfidenceCondition condition);

struct ConfidenceExperimentOptions {
  /// The tuning models: their sequences fit the confidence model (non-empty when fit is set);
  /// never evaluated, also when fit is not set (they are what the given model was fitted on).
  std::vector<std::string> fit_models;
  /// Database models evaluated (held out); empty: every database model not in fit_models.
  std::vector<std::string> eval_models;
  /// Sequences per model and condition (1..10) and their frames (>= 2).
  int sequences = 2;
  int frames = 100;
  HandheldOptions handheld;
  uint64_t first_seed = 3000;
  /// Fit the model in the first phase; false: evaluate options.state.model as given.
  bool fit = true;
  /// The fit phase also shows look-alike objects that are not in the database: each fit model
  /// stretched by 1.35 along its x axis and squeezed to 0.8 along z (about its centre), clean and
  /// degraded, every frame wrong. They teach the fit what a near miss looks like.
  bool fit_lookalikes = true;
  /// Ridge penalty of the fit on the standardised features, >= 0.
  double ridge = 1e-2;
  /// The thresholds of the states (and the model when fit = false).
  TrackStateOptions state;
  /// Rotation error below which a frame with the right object is correct, degrees, > 0.
  double correct_rotation_deg = 10.0;
  /// Worker threads (sequences in parallel); 0 = all cores.
  int num_threads = 0;

  bool Check(std::string* error = nullptr) const;
};

struct ConfidenceFrame {
  int frame = 0;
  /// The frame had a usable silhouette.
  bool silhouette = false;
  /// The tracker computed confidence features (a silhouette and an estimate); `features` are
  /// ConfidenceFeatures{}.Vector() otherwise, and the frame is left out of the fit.
  bool has_features = false;
  bool correct = false;
  double confidence = 0.0;
  TrackState state = TrackState::kNoSilhouette;
  std::array<double, ConfidenceFeatures::kSize> features{};
};

struct ConfidenceRun {
  std::string model;
  /// The model is not in the database.
  bool unknown = false;
  /// Part of the fit set.
  bool fit = false;
  ConfidenceCondition condition = ConfidenceCondition::kClean;
  uint64_t seed = 0;
  std::vector<ConfidenceFrame> frames;
};

/// Separation figures over a set of frames with a silhouette.
struct ConfidenceMetrics {
  int frames = 0;
  int correct = 0;
  /// Area under the ROC curve of confidence for correct vs wrong (NaN without both kinds).
  double auc = 0.0;
  int tracking = 0;
  int tracking_wrong = 0;
  int correct_tracking = 0;
  /// Frames of unknown objects, and those reported kUnknownObject.
  int unknown_frames = 0;
  int unknown_reported = 0;
  /// Frames per TrackState (index = the enum's value).
  std::array<int, 6> states{};

  double WrongTrackingPercent() const;
  double CorrectTrackingPercent() const;
  double UnknownReportedPercent() const;
};

/// ROC AUC: the probability that a random correct frame has a higher confidence than a random
/// wrong one (ties count one half). NaN if either set is empty.
double RocAuc(const std::vector<double>& positive, const std::vector<double>& negative);

/// Logistic regression of labels on rows (ridge on the standardised columns, Newton steps).
/// Throws silpose::Error for mismatched sizes or fewer than two rows.
ConfidenceModel FitConfidenceModel(
    const std::vector<std::array<double, ConfidenceFeatures::kSize>>& rows,
    const std::vector<bool>& labels, double ridge);

struct ReliabilityBin {
  double lower = 0.0, upper = 0.0;
  int frames = 0;
  double mean_confidence = 0.0;
  /// Share of correct frames (NaN if empty).
  double accuracy = 0.0;
};

struct ConfidenceExperimentResult {
  ConfidenceExperimentOptions options;
  /// The model the evaluation used (fitted, or the given one).
  ConfidenceModel model;
  /// With a fit: the lowest threshold at which at most 1 % of the fit set's frames at or above it
  /// are wrong, with the fitted model's confidences (NaN without a fit).
  double fit_threshold = 0.0;
  std::vector<std::string> fit_models, eval_models, unknown_models;
  std::vector<ConfidenceRun> runs;
  /// Fit set (confidence recomputed with `model`; its states are those tracked with
  /// options.state.model, before the fit), evaluation set (all held-out
  /// runs), and the evaluation set per condition (clean, degraded, occluded; unknown objects
  /// included in their condition).
  ConfidenceMetrics fit_set, eval_set;
  std::array<ConfidenceMetrics, 3> eval_by_condition;
  /// Evaluation set, 10 bins of confidence.
  std::vector<ReliabilityBin> reliability;
  double seconds = 0.0;
};

/// A look-alike of `mesh` (fit_lookalikes): stretched 1.35 along x, 0.8 along z about its centre,
/// named "<name>-lookalike".
TriangleMesh LookalikeMesh(const TriangleMesh& mesh);

/// Number of sequences (tasks) for a progress bar.
int ConfidenceTaskCount(const ConfidenceExperimentOptions& options, int num_fit, int num_eval,
                        int num_unknown);

/// Runs both phases. `meshes` are the database's models (same order and names); `unknown` are
/// meshes of objects not in the database (names must differ from the database's). Throws
/// silpose::Error for invalid options, unknown or clashing names.
ConfidenceExperimentResult RunConfidenceExperiment(
    const ViewDatabase& database, const std::vector<TriangleMesh>& meshes,
    const std::vector<TriangleMesh>& unknown, const ConfidenceExperimentOptions& options,
    const std::function<void(int)>& on_progress = {});

/// frames.csv: model,unknown,fit,condition,seed,frame,silhouette,correct,confidence,state, then
/// the features (ConfidenceFeatures::Names).
void WriteConfidenceFrames(const std::filesystem::path& path,
                           const ConfidenceExperimentResult& result);
/// Reliability diagram (accuracy against mean confidence per bin, and the diagonal) and the ROC
/// curve of the evaluation set.
Figure ConfidenceFigure(const ConfidenceExperimentResult& result);

}  // namespace silpose
