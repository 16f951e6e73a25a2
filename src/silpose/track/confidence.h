#pragma once
// Knowing when the tracker is wrong (docs/confidence.md): a per-frame confidence and a state users
// can act on (pose/pose_output.h TrackState).
//
// Confidence. The probability that the reported object is right and its rotation within 10
// degrees of the truth (modulo the object's symmetry), as a logistic function of what the tracker
// knows about the frame without ground truth (ConfidenceFeatures):
//  - the particle filter's posterior: the reported object's probability, the share of the weight
//    in the reported mode, and that of the strongest competing mode (filter/particle_filter.h
//    FilterEstimate::mode_mass, runner_up);
//  - the correlation score of the match;
//  - how well the model at the reported (refined) pose explains the frame's silhouette: the IoU of
//    its rendered silhouette with the mask and the outline's RMS distance, relative to the
//    silhouette's size (pose/contour_refinement.h);
//  - how much the silhouette's area changed since the last frame with a silhouette.
// The coefficients (ConfidenceModel::Default) are fitted by logistic regression on synthetic
// sequences of the tuning models by `silpose eval confidence` (eval/confidence_experiment.h),
// which also measures how well the confidence separates right from wrong frames on held-out
// models and draws the reliability diagram.
//
// State (TrackStateEstimator), per frame in this order:
//  - no usable silhouette: kNoSilhouette (confidence 0);
//  - confidence >= min_confidence and no competing mode (one with at least ambiguous_mass_ratio
//    of the reported mode's weight and a score within ambiguous_score_gap of the reported one):
//    kTracking;
//  - a competing mode, a mirror twin whose score is within twin_score_gap of the reported one
//    (ConfidenceFeatures::twin_score_gap), or another pose scoring at least as well
//    (ConfidenceFeatures::pose_score_gap, pose_score_gap), and the model fits (the mean IoU over
//    the last fit_frames frames with a fit, i.e. a pose, at least unknown_fit_iou) or, without a
//    competing mode, the confidence is at least min_confidence (the frame would be kTracking
//    but for the mirror twin or other pose, e.g. with a degraded mask): kAmbiguous;
//  - the object was followed in at least 3 of the last fit_frames frames (kTracking, or kAmbiguous
//    without a competing mode and with confidence >= min_confidence): kBadSegmentation (an
//    occluder, a hand, a failed mask: the outline no longer fits);
//  - that mean IoU below unknown_fit_iou: kUnknownObject (no database object has fitted for a
//    while; never before the first frame with a fit);
//  - the area changed by more than abrupt_area_change (|ln| of the ratio) since the last frame
//    with a silhouette: kBadSegmentation;
//  - otherwise kLost.

#include <array>
#include <deque>
#include <limits>
#include <string>

#include "silpose/pose/pose_output.h"

namespace silpose {

/// What the confidence is computed from (see the file comment). Defaults: a brute-force match
/// (no posterior: probability 1, all weight in one mode).
struct ConfidenceFeatures {
  double object_probability = 1.0;
  double mode_mass = 1.0;
  double runner_up_mass = 0.0;
  /// Correlation score of the reported view, [-1, 1].
  double score = 0.0;
  /// Whether the model was refined against the frame (iou and outline_rms are known).
  bool has_fit = false;
  double iou = 0.0;
  /// The refinement's final robust RMS outline distance, pixels, divided by the silhouette's mean
  /// radius, pixels.
  double outline_rms = 0.0;
  /// |ln(area / area of the previous frame with a silhouette)|; 0 for the first.
  double area_change = 0.0;
  /// Means of iou and outline_rms over the last TrackStateOptions::fit_frames frames with a fit,
  /// this one included if it has one (0 and 1 before any fit); set by
  /// TrackStateEstimator::Measured. Persistent misfit is the mark of an object not in the
  /// database; a single bad frame is not.
  double recent_iou = 0.0;
  double recent_outline_rms = 1.0;
  /// For an object with a mirror plane: score minus the best score of the reported view's mirror
  /// twins (the views whose outline is the same up to perspective, farther than the mode radius);
  /// NaN when there is no such twin. Near 0: the outline cannot tell the two poses apart.
  double twin_score_gap = std::numeric_limits<double>::quiet_NaN();
  /// The reported database view's best score (any roll) minus the best score of another pose of
  /// the same object: one farther than the filter's mode radius (15 degrees of rotation, modulo
  /// the object's symmetry) from the reported pose, i.e. another view, a mirror twin, or the
  /// reported view at another roll. NaN when not measured. At or below 0: another pose explains
  /// the outline as well, so the outline cannot vouch for this one (a nearly round object turned
  /// by half a step, a mug whose handle is hidden).
  double pose_score_gap = std::numeric_limits<double>::quiet_NaN();

  static constexpr int kSize = 12;
  /// The regression's inputs: object_probability, mode_mass, min(runner_up_mass / max(mode_mass,
  /// 0.01), 3), -log10(max(1 - score, 1e-4)), has_fit, iou (0 without fit), min(outline_rms, 1)
  /// (0 without fit), min(area_change, 2), recent_iou, min(recent_outline_rms, 1),
  /// clamp(twin_score_gap, 0, 0.05) / 0.05 (1 without a twin), clamp(pose_score_gap, 0, 0.05) /
  /// 0.05 (1 when not measured).
  std::array<double, kSize> Vector() const;
  /// Their names, in that order (for CSV headers).
  static const std::array<const char*, kSize>& Names();
};

/// A logistic model: confidence = 1 / (1 + exp(-(bias + weights . features.Vector()))).
struct ConfidenceModel {
  double bias = 0.0;
  std::array<double, ConfidenceFeatures::kSize> weights{};

  /// The model fitted by `silpose eval confidence` on the tuning models (docs/confidence.md).
  static ConfidenceModel Default();
  double Evaluate(const ConfidenceFeatures& features) const;
  /// The same from the regression's inputs (ConfidenceFeatures::Vector).
  double Evaluate(const std::array<double, ConfidenceFeatures::kSize>& x) const;
  /// False (with the reason) for a non-finite coefficient.
  bool Check(std::string* error = nullptr) const;
};

struct TrackStateOptions {
  ConfidenceModel model = ConfidenceModel::Default();
  /// Confidence from which a frame is kTracking, in [0, 1]: the lowest threshold at which at most
  /// 1 % of the fit set's frames above it were wrong (0.748, printed by `silpose eval
  /// confidence`; docs/confidence.md), rounded.
  double min_confidence = 0.75;
  /// kAmbiguous: runner-up mass >= this times the reported mode's, > 0 ...
  double ambiguous_mass_ratio = 0.5;
  /// ... and its score >= the reported score minus this, >= 0.
  double ambiguous_score_gap = 0.01;
  /// kAmbiguous also when a mirror twin's score is >= the reported score minus this, >= 0. Twins
  /// differ only by perspective, so their scores are close even when the reported one is right:
  /// on the fit set of `silpose eval confidence` (the cow's hand-held sequences), of the frames
  /// whose twin came within 0.002, 83 % were wrong; within 0.01, 55 %.
  double twin_score_gap = 0.002;
  /// kAmbiguous also when another pose of the object (ConfidenceFeatures::pose_score_gap: farther
  /// than the filter's mode radius, modulo symmetry) scores at least the reported score minus
  /// this, >= 0. At 0 (the default) the rule is the state's definition, not a fitted threshold:
  /// the other pose explains the outline at least as well. (On the tuning models the filter's
  /// choice was right in such frames nearly always; on the reference models, where outlines such
  /// as a mug's with its handle hidden fit whole ranges of poses, a quarter of them were wrong.)
  double pose_score_gap = 0.0;
  /// kUnknownObject below this mean IoU over the last fit_frames frames, in [0, 1].
  double unknown_fit_iou = 0.9;
  /// Frames of memory for the unknown-object and bad-segmentation rules, >= 3.
  int fit_frames = 10;
  /// kBadSegmentation when the area changes by more than this (|ln| of the ratio), > 0.
  double abrupt_area_change = 0.25;

  bool Check(std::string* error = nullptr) const;
};

/// The state of one stream, frame after frame (see the file comment).
class TrackStateEstimator {
 public:
  /// Throws silpose::Error for invalid options.
  explicit TrackStateEstimator(const TrackStateOptions& options = {});

  struct Output {
    double confidence = 0.0;
    TrackState state = TrackState::kNoSilhouette;
    /// Which ambiguity rule held (whatever the state): a competing posterior mode, a mirror twin
    /// within twin_score_gap, another pose within pose_score_gap.
    bool competing_mode = false;
    bool twin_alike = false;
    bool pose_alike = false;
  };
  /// A frame with a silhouette: sets features->recent_iou and recent_outline_rms, then the
  /// confidence and state. `runner_up_score` is the competing mode's score (ignored when
  /// features->runner_up_mass is 0).
  Output Measured(ConfidenceFeatures* features, double runner_up_score);
  /// A frame without a usable silhouette.
  Output NoSilhouette();

  const TrackStateOptions& options() const { return options_; }

 private:
  TrackStateOptions options_;
  std::deque<double> recent_fit_;
  std::deque<double> recent_rms_;
  /// Whether the object was followed in each of the last fit_frames frames (kTracking, or
  /// kAmbiguous without a competing mode and with confidence >= min_confidence).
  std::deque<bool> recent_tracking_;
  void Remember(bool tracking);
};

}  // namespace silpose
