#include "silpose/track/confidence.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {

std::array<double, ConfidenceFeatures::kSize> ConfidenceFeatures::Vector() const {
  const double ratio = std::min(runner_up_mass / std::max(mode_mass, 0.01), 3.0);
  const double sharpness = -std::log10(std::max(1.0 - score, 1e-4));
  return {object_probability,
          mode_mass,
          std::isfinite(ratio) ? ratio : 3.0,
          std::isfinite(sharpness) ? sharpness : 0.0,
          has_fit ? 1.0 : 0.0,
          has_fit && std::isfinite(iou) ? iou : 0.0,
          has_fit && std::isfinite(outline_rms) ? std::min(outline_rms, 1.0) : 0.0,
          std::isfinite(area_change) ? std::min(area_change, 2.0) : 2.0,
          std::isfinite(recent_iou) ? recent_iou : 0.0,
          std::isfinite(recent_outline_rms) ? std::min(recent_outline_rms, 1.0) : 1.0,
          std::isfinite(twin_score_gap) ? std::clamp(twin_score_gap, 0.0, 0.05) / 0.05 : 1.0,
          std::isfinite(pose_score_gap) ? std::clamp(pose_score_gap, 0.0, 0.05) / 0.05 : 1.0};
}

const std::array<const char*, ConfidenceFeatures::kSize>& ConfidenceFeatures::Names() {
  static const std::array<const char*, kSize> names = {
      "object_probability", "mode_mass",   "runner_up_ratio",
      "score_sharpness",    "has_fit",     "iou",
      "outline_rms",        "area_change", "recent_iou",
      "recent_outline_rms", "twin_gap",    "pose_gap"};
  return names;
}

ConfidenceModel ConfidenceModel::Default() {
  // Fitted by `silpose eval confidence --sequences 3 --frames 100` on the sample models (fit on
  // bunny and cow and their look-alikes; docs/confidence.md), printed to model.txt.
  ConfidenceModel model;
  model.bias = -10.1256198;
  model.weights = {0.749606111, -0.280082073, -0.637298065, 0.641516732, 0.285431921, 6.6394591,
                   -33.1224438, 0.150282079,  4.94739851,   -4.45297334, 0.149039892, 0.183033688};
  return model;
}

double ConfidenceModel::Evaluate(const ConfidenceFeatures& features) const {
  return Evaluate(features.Vector());
}

double ConfidenceModel::Evaluate(const std::array<double, ConfidenceFeatures::kSize>& x) const {
  double z = bias;
  for (int i = 0; i < ConfidenceFeatures::kSize; ++i) z += weights[i] * x[i];
  if (!std::isfinite(z)) return z > 0.0 ? 1.0 : 0.0;
  return 1.0 / (1.0 + std::exp(-z));
}

bool ConfidenceModel::Check(std::string* error) const {
  bool ok = std::isfinite(bias);
  for (double w : weights) ok = ok && std::isfinite(w);
  if (!ok && error != nullptr) *error = "confidence model coefficients must be finite";
  return ok;
}

bool TrackStateOptions::Check(std::string* error) const {
  std::ostringstream message;
  std::string problem;
  if (!model.Check(&problem)) {
    message << problem;
  } else if (!(min_confidence >= 0.0 && min_confidence <= 1.0)) {
    message << "minimum confidence must be in [0, 1], got " << min_confidence;
  } else if (!(ambiguous_mass_ratio > 0.0) || !std::isfinite(ambiguous_mass_ratio)) {
    message << "ambiguous mass ratio must be > 0, got " << ambiguous_mass_ratio;
  } else if (!(ambiguous_score_gap >= 0.0) || !std::isfinite(ambiguous_score_gap)) {
    message << "ambiguous score gap must be >= 0, got " << ambiguous_score_gap;
  } else if (!(twin_score_gap >= 0.0) || !std::isfinite(twin_score_gap)) {
    message << "twin score gap must be >= 0, got " << twin_score_gap;
  } else if (!(pose_score_gap >= 0.0) || !std::isfinite(pose_score_gap)) {
    message << "pose score gap must be >= 0, got " << pose_score_gap;
  } else if (!(unknown_fit_iou >= 0.0 && unknown_fit_iou <= 1.0)) {
    message << "unknown-object IoU must be in [0, 1], got " << unknown_fit_iou;
  } else if (fit_frames < 3 || fit_frames > 100000) {
    message << "fit frames must be in [3, 100000], got " << fit_frames;
  } else if (!(abrupt_area_change > 0.0) || !std::isfinite(abrupt_area_change)) {
    message << "abrupt area change must be > 0, got " << abrupt_area_change;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

TrackStateEstimator::TrackStateEstimator(const TrackStateOptions& options) : options_(options) {
  std::string problem;
  if (!options_.Check(&problem)) ThrowError("track state options: ", problem);
}

TrackStateEstimator::Output TrackStateEstimator::Measured(ConfidenceFeatures* features,
                                                          double runner_up_score) {
  Output out;
  // The fit window holds the frames with a fit only (a frame without a pose says nothing about
  // how well the model explains the silhouette).
  if (features->has_fit && std::isfinite(features->iou)) {
    recent_fit_.push_back(features->iou);
    recent_rms_.push_back(std::isfinite(features->outline_rms) ? features->outline_rms : 1.0);
    while (static_cast<int>(recent_fit_.size()) > options_.fit_frames) {
      recent_fit_.pop_front();
      recent_rms_.pop_front();
    }
  }
  const bool fit_known = !recent_fit_.empty();
  double mean_fit = 0.0, mean_rms = 1.0;
  if (fit_known) {
    mean_fit = mean_rms = 0.0;
    for (double f : recent_fit_) mean_fit += f;
    for (double r : recent_rms_) mean_rms += r;
    mean_fit /= static_cast<double>(recent_fit_.size());
    mean_rms /= static_cast<double>(recent_rms_.size());
  }
  features->recent_iou = mean_fit;
  features->recent_outline_rms = mean_rms;
  out.confidence = options_.model.Evaluate(*features);

  // Followed recently: at least kEstablished of the last fit_frames frames were kTracking, or
  // confidently kAmbiguous between poses of the object (Remember below).
  constexpr int kEstablished = 3;
  int tracked_frames = 0;
  for (bool t : recent_tracking_) tracked_frames += t;
  const bool recently_tracked = tracked_frames >= kEstablished;
  out.competing_mode =
      features->runner_up_mass > 0.0 &&
      features->runner_up_mass >= options_.ambiguous_mass_ratio * features->mode_mass &&
      runner_up_score >= features->score - options_.ambiguous_score_gap;
  out.twin_alike = std::isfinite(features->twin_score_gap) &&
                   features->twin_score_gap <= options_.twin_score_gap;
  out.pose_alike = std::isfinite(features->pose_score_gap) &&
                   features->pose_score_gap <= options_.pose_score_gap;
  const bool ambiguous = out.competing_mode || out.twin_alike || out.pose_alike;
  // Confident, and ambiguous only between poses of the object (not a competing mode, which may be
  // another object): the object is followed as well as in a tracking frame.
  const bool followed_alike =
      ambiguous && !out.competing_mode && out.confidence >= options_.min_confidence;
  if (!ambiguous && out.confidence >= options_.min_confidence) {
    out.state = TrackState::kTracking;
  } else if (followed_alike || (ambiguous && fit_known && mean_fit >= options_.unknown_fit_iou)) {
    out.state = TrackState::kAmbiguous;
  } else if (recently_tracked) {
    out.state = TrackState::kBadSegmentation;
  } else if (fit_known && mean_fit < options_.unknown_fit_iou) {
    out.state = TrackState::kUnknownObject;
  } else if (features->area_change > options_.abrupt_area_change) {
    out.state = TrackState::kBadSegmentation;
  } else {
    out.state = TrackState::kLost;
  }
  Remember(out.state == TrackState::kTracking || followed_alike);
  return out;
}

TrackStateEstimator::Output TrackStateEstimator::NoSilhouette() {
  Remember(false);
  return {0.0, TrackState::kNoSilhouette};
}

void TrackStateEstimator::Remember(bool tracking) {
  recent_tracking_.push_back(tracking);
  while (static_cast<int>(recent_tracking_.size()) > options_.fit_frames)
    recent_tracking_.pop_front();
}

}  // namespace silpose
