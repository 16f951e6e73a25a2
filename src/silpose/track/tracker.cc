#include "silpose/track/tracker.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <numbers>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"
#include "silpose/util/top_k.h"

namespace silpose {

PinholeCamera DefaultCamera(int width_px, int height_px) {
  return PinholeCamera::Centered(width_px, height_px, 525.0 / 640.0 * width_px);
}

ParticleFilterOptions TrackerOptions::DefaultFilterOptions() {
  ParticleFilterOptions options;
  options.max_history_frames = 100;
  return options;
}

TrackerOptions::TrackerOptions() = default;

bool TrackerOptions::Check(std::string* error) const {
  std::string problem;
  if (!segmentation.Check(&problem)) {
    if (error != nullptr) *error = "segmentation: " + problem;
    return false;
  }
  if (!brute_force && !filter.Check(&problem)) {
    if (error != nullptr) *error = "particle filter: " + problem;
    return false;
  }
  if (estimate_pose && !pose.Check(&problem)) {
    if (error != nullptr) *error = "pose: " + problem;
    return false;
  }
  if (estimate_pose && refine && !refinement.Check(&problem)) {
    if (error != nullptr) *error = "refinement: " + problem;
    return false;
  }
  if (!(fit_arbitration_ratio >= 0.0 && fit_arbitration_ratio <= 1.0)) {
    if (error != nullptr) *error = "fit_arbitration_ratio must be in [0, 1] (0 = off)";
    return false;
  }
  if (!(fit_arbitration_margin_px >= 0.0 && std::isfinite(fit_arbitration_margin_px))) {
    if (error != nullptr) *error = "fit_arbitration_margin_px must be finite and >= 0";
    return false;
  }
  if (!(fit_arbitration_iou_gain >= 0.0 && fit_arbitration_iou_gain <= 1.0)) {
    if (error != nullptr) *error = "fit_arbitration_iou_gain must be in [0, 1] (0 = off)";
    return false;
  }
  if (!(other_pose_score_gap >= 0.0 && other_pose_score_gap <= 2.0)) {
    if (error != nullptr) *error = "other_pose_score_gap must be in [0, 2]";
    return false;
  }
  if (!(other_pose_fit_ratio > 0.0 && other_pose_fit_ratio <= 1.0)) {
    if (error != nullptr) *error = "other_pose_fit_ratio must be in (0, 1]";
    return false;
  }
  if (!(fit_arbitration_score_gap >= 0.0 && fit_arbitration_score_gap <= 2.0)) {
    if (error != nullptr) *error = "fit_arbitration_score_gap must be in [0, 2] (0 = off)";
    return false;
  }
  if (!(polish_steps >= 0 && polish_steps <= 10)) {
    if (error != nullptr) *error = "polish_steps must be in [0, 10] (0 = off)";
    return false;
  }
  if (!state.Check(&problem)) {
    if (error != nullptr) *error = "state: " + problem;
    return false;
  }
  return true;
}

void ToCanonicalForm(const ObjectSymmetry& symmetry, FrameResult* result) {
  if (!result->view_dir_in_object || !symmetry.HasRotations()) return;
  const Eigen::Vector3d view_dir = *result->view_dir_in_object;
  const Rigid3 s = CanonicalSymmetry(view_dir, symmetry);
  // The pose P becomes P * S; seen from the camera, the view direction d becomes R_S^T d and the
  // roll follows from the rotated on-axis camera.
  if (std::isfinite(result->roll_deg)) {
    const Eigen::Matrix3d on_axis =
        CameraFromObjectRotation(view_dir, result->roll_deg) * s.rotation;
    Eigen::Vector3d canonical_view;
    double roll_deg = 0.0;
    ViewAndRollFromRotation(on_axis, &canonical_view, &roll_deg);
    result->view_dir_in_object = canonical_view;
    result->roll_deg = roll_deg;
  } else {
    result->view_dir_in_object = (s.rotation.transpose() * view_dir).normalized();
  }
  if (result->camera_from_object) result->camera_from_object = *result->camera_from_object * s;
}

Tracker::Tracker(const ViewDatabase& database, const PinholeCamera& camera,
                 const TrackerOptions& options)
    : Tracker(database, nullptr, camera, options) {}

Tracker::Tracker(const ViewSpectra& spectra, const PinholeCamera& camera,
                 const TrackerOptions& options)
    : Tracker(spectra.database(), &spectra, camera, options) {}

Tracker::Tracker(const ViewDatabase& database, const ViewSpectra* shared_spectra,
                 const PinholeCamera& camera, const TrackerOptions& options)
    : database_(database), camera_(camera), options_(options) {
  std::string problem;
  if (!options_.Check(&problem)) ThrowError("tracker options: ", problem);
  if (!camera_.Check(&problem)) ThrowError("camera: ", problem);
  if (database_.models.empty()) ThrowError("tracker: the database has no models");
  if (shared_spectra == nullptr) own_spectra_ = std::make_unique<ViewSpectra>(database_);
  spectra_ = shared_spectra != nullptr ? shared_spectra : own_spectra_.get();
  segmenter_ = CreateSegmenter(options_.segmentation);
  state_ = std::make_unique<TrackStateEstimator>(options_.state);
  // The matcher searches in brute-force mode and scores mirror twins (Assess) in both modes.
  matcher_ = std::make_unique<ViewMatcher>(*spectra_);
  if (!options_.brute_force) {
    filter_ = std::make_unique<ParticleFilter>(database_.sphere, *spectra_, options_.filter);
    if (options_.estimate_pose && options_.refine && options_.fit_arbitration_ratio > 0.0) {
      filter_->SetArbiter([this](const FilterEstimate::Hypothesis& chosen,
                                 const FilterEstimate::Hypothesis& challenger) {
        return ArbitrateByFit(chosen, challenger);
      });
    }
  }
  for (const ModelViews& model : database_.models) {
    equivalence_.emplace_back(model.symmetry);
    centres_.push_back(model.mesh.Centre());
  }
  contours_.resize(database_.models.size());
}

Tracker::Tracker(const ViewDatabase& database, const PinholeCamera& camera)
    : Tracker(database, camera, TrackerOptions()) {}

Tracker::~Tracker() = default;

namespace {

// Whether a refinement is kept: it explains the outline better than the grid pose.
bool Improves(const ContourRefinementResult& refined) {
  return refined.final_rms_px <= refined.initial_rms_px && refined.points_used >= 6 &&
         refined.camera_from_object.rotation.allFinite() &&
         refined.camera_from_object.translation.allFinite();
}

// The outline distance of the pose a refinement leaves: the refined pose's if it improved, the
// start's otherwise (infinite without enough outline points).
double FinalFit(const ContourRefinementResult& refined) {
  if (Improves(refined)) return refined.final_rms_px;
  return refined.points_used >= 6 && std::isfinite(refined.initial_rms_px)
             ? refined.initial_rms_px
             : std::numeric_limits<double>::infinity();
}

// The outline distance of the better of a refinement's start and end (the fit a hypothesis is
// compared by, whichever pose it reports).
double BetterRms(const ContourRefinementResult& refined) {
  return std::min(refined.final_rms_px, refined.initial_rms_px);
}

}  // namespace

void Tracker::Refine(const TriangleMesh& mesh, TrackedFrame* tracked, bool feed_filter) {
  SilhouettePose& pose = *tracked->pose;
  const FrameOutline& outline = Outline(*tracked);
  // Not for the fit arbitration's hypotheses (feed_filter false): they compete from their grid
  // poses alike, or the motion start would favour the filter's mode.
  const std::optional<Rigid3> carried =
      feed_filter ? MotionStart(*tracked) : std::optional<Rigid3>();
  ContourRefinementOptions options = options_.refinement;
  // With two refinements, the IoU only of the pose kept.
  if (carried) options.compute_iou = false;
  const ContourModel& contour = Contour(tracked->result.object);
  ContourRefinementResult refined =
      RefinePoseToContour(contour, camera_, outline, pose.camera_from_object, options);
  if (carried) {
    // Both starts are refined and the pose that ends closer to the outline is kept: from either
    // start the refinement can stop in a shallow minimum the other avoids, and the fit it ends
    // with, not the one it starts from, is what the frame shows.
    ContourRefinementResult from_motion =
        RefinePoseToContour(contour, camera_, outline, *carried, options);
    if (Improves(from_motion) && from_motion.final_rms_px < FinalFit(refined)) {
      refined = std::move(from_motion);
    }
    const Rigid3& kept = Improves(refined) ? refined.camera_from_object : pose.camera_from_object;
    const Eigen::Vector3d& centre = centres_[static_cast<size_t>(tracked->result.object)];
    if (options_.refinement.compute_iou && (kept * centre).z() > 0.0) {
      refined.iou = ContourIou(contour, camera_, outline, kept);
    }
  }
  // Reported if it improves and Adopt takes it (its centre in front of the camera); otherwise the
  // grid pose stays, with the refinement's fit on record.
  if (Improves(refined) && Adopt(mesh, refined, tracked, feed_filter)) return;
  tracked->refinement = std::move(refined);
  tracked->refinement->camera_from_object = pose.camera_from_object;
}

std::optional<Rigid3> Tracker::MotionStart(const TrackedFrame& tracked) const {
  const FrameResult& result = tracked.result;
  // Only in filter mode, for the frame being processed (not a revised one), right after a
  // refined frame of the same object.
  if (!filter_ || !options_.refine_from_motion || !motion_prior_ || !tracked.pose ||
      result.frame != frame_ || motion_prior_->frame != frame_ - 1 ||
      motion_prior_->object != result.object || !result.view_dir_in_object) {
    return std::nullopt;
  }
  const SilhouettePose& pose = *tracked.pose;
  const Eigen::Matrix3d on_axis = motion_prior_->change * motion_prior_->on_axis;
  // Its view direction (of the on-axis camera, as the database's) near the grid view's.
  Eigen::Vector3d view_dir;
  double roll_deg = 0.0;
  ViewAndRollFromRotation(on_axis, &view_dir, &roll_deg);
  const double apart_deg = equivalence_[static_cast<size_t>(result.object)].AngleDeg(
      view_dir, *result.view_dir_in_object);
  if (!(apart_deg <= options_.filter.mode_radius_deg)) return std::nullopt;
  // Turned about the model's centre, which stays where the grid pose puts it.
  const Eigen::Vector3d& centre = centres_[static_cast<size_t>(result.object)];
  Rigid3 start = pose.camera_from_object;
  start.rotation = RotationFromOpticalAxisTo(pose.centre_ray) * on_axis;
  start.translation += (pose.camera_from_object.rotation - start.rotation) * centre;
  return start;
}

void Tracker::RememberMotion(const TrackedFrame& tracked) {
  const FrameResult& result = tracked.result;
  if (!filter_ || !tracked.pose || !tracked.refinement || !Improves(*tracked.refinement) ||
      result.object < 0) {
    motion_prior_.reset();
    return;
  }
  const SilhouettePose& pose = *tracked.pose;
  MotionPrior next;
  next.object = result.object;
  next.frame = result.frame;
  next.on_axis =
      RotationFromOpticalAxisTo(pose.centre_ray).transpose() * pose.camera_from_object.rotation;
  if (motion_prior_ && motion_prior_->object == next.object &&
      motion_prior_->frame == next.frame - 1) {
    // Of a symmetric object's equivalent poses, the one the motion reached (the refinement may
    // settle on any of them).
    next.on_axis =
        NearestEquivalentRotation(next.on_axis, motion_prior_->on_axis,
                                  database_.models[static_cast<size_t>(next.object)].symmetry);
    const Eigen::Matrix3d change = next.on_axis * motion_prior_->on_axis.transpose();
    // Faster than the filter's fastest motion: a jump (a cut, another pose), not motion.
    if (Eigen::AngleAxisd(change).angle() <=
        options_.filter.max_speed_deg * std::numbers::pi / 180.0) {
      next.change = change;
    }
  }
  motion_prior_ = next;
}

bool Tracker::Adopt(const TriangleMesh& mesh, ContourRefinementResult refined,
                    TrackedFrame* tracked, bool feed_filter) {
  FrameResult& result = tracked->result;
  SilhouettePose& pose = *tracked->pose;
  const Eigen::Vector3d centre(mesh.Centre());
  const Eigen::Vector3d centre_in_camera =
      refined.camera_from_object.rotation * centre + refined.camera_from_object.translation;
  if (!(centre_in_camera.z() > 0.0)) return false;
  pose.camera_from_object = refined.camera_from_object;
  pose.distance = centre_in_camera.norm();
  pose.centre_ray = centre_in_camera / pose.distance;
  pose.off_axis_deg = std::acos(std::min(1.0, pose.centre_ray.z())) * 180.0 / std::numbers::pi;
  result.camera_from_object = pose.camera_from_object;
  // The view and roll the refined pose means (of the on-axis camera, as the database's).
  const Eigen::Matrix3d on_axis =
      RotationFromOpticalAxisTo(pose.centre_ray).transpose() * pose.camera_from_object.rotation;
  double roll_deg = 0.0;
  Eigen::Vector3d view_dir;
  ViewAndRollFromRotation(on_axis, &view_dir, &roll_deg);
  result.view_dir_in_object = view_dir;
  result.roll_deg = roll_deg;
  tracked->refinement = std::move(refined);
  // The refined orientation feeds the filter's velocity.
  if (filter_ && feed_filter) filter_->ObserveRotation(on_axis);
  return true;
}

const ContourModel& Tracker::Contour(int object) {
  SILPOSE_ASSERT(object >= 0 && static_cast<size_t>(object) < database_.models.size());
  std::unique_ptr<ContourModel>& contour = contours_[static_cast<size_t>(object)];
  if (!contour)
    contour = std::make_unique<ContourModel>(database_.models[static_cast<size_t>(object)].mesh);
  return *contour;
}

const FrameOutline& Tracker::Outline(const TrackedFrame& tracked) {
  const cv::Mat& mask = tracked.segmentation.mask;
  if (!outline_ || outline_frame_ != tracked.result.frame || outline_data_ != mask.data) {
    outline_.reset();
    outline_.emplace(mask);
    outline_frame_ = tracked.result.frame;
    outline_data_ = mask.data;
  }
  return *outline_;
}

bool Tracker::ArbitrateByFit(const FilterEstimate::Hypothesis& chosen,
                             const FilterEstimate::Hypothesis& challenger) {
  if (current_ == nullptr) return false;
  const auto start = std::chrono::steady_clock::now();
  // The fit of a hypothesis: robust RMS outline distance (pixels) and IoU of the pose the
  // tracker would report for it, grid pose or refined.
  const auto pose = [&](const FilterEstimate::Hypothesis& h, double* rms, double* iou) {
    Posed& posed = posed_.emplace_back();
    posed.object = h.object;
    posed.view = h.view;
    posed.frame = *current_;
    TrackedFrame& frame = posed.frame;
    FrameResult& r = frame.result;
    r.object = h.object;
    r.object_name = database_.models[static_cast<size_t>(h.object)].name;
    r.view_dir_in_object = database_.sphere.directions[static_cast<size_t>(h.view)];
    r.roll_deg = h.roll_deg;
    EstimatePose(h.view, h.shell, /*feed_filter=*/false, &frame, [] { return 0.0; });
    const std::optional<ContourRefinementResult>& fit = frame.refinement;
    if (!fit || fit->points_used < 6) return false;
    *rms = BetterRms(*fit);
    *iou = fit->iou;
    return std::isfinite(*rms);
  };
  HypothesisFit chosen_fit{chosen.object, static_cast<double>(chosen.score)};
  HypothesisFit challenger_fit{challenger.object, static_cast<double>(challenger.score)};
  const bool challenger_fits = pose(challenger, &challenger_fit.rms_px, &challenger_fit.iou);
  const bool chosen_fits = challenger_fits && pose(chosen, &chosen_fit.rms_px, &chosen_fit.iou);
  arbitration_ms_ +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return chosen_fits && FitArbitrationPrefersChallenger(chosen_fit, challenger_fit, options_);
}

bool FitArbitrationPrefersChallenger(const HypothesisFit& chosen, const HypothesisFit& challenger,
                                     const TrackerOptions& options) {
  if (!(options.fit_arbitration_ratio > 0.0)) return false;
  if (!std::isfinite(chosen.rms_px) || !std::isfinite(challenger.rms_px) ||
      !std::isfinite(chosen.iou) || !std::isfinite(challenger.iou)) {
    return false;
  }
  if (challenger.iou < chosen.iou) return false;
  // Clearly the better fit: closer by the ratio, and by the margin or in the IoU.
  if (challenger.rms_px < options.fit_arbitration_ratio * chosen.rms_px &&
      (chosen.rms_px - challenger.rms_px > options.fit_arbitration_margin_px ||
       (options.fit_arbitration_iou_gain > 0.0 &&
        challenger.iou - chosen.iou >= options.fit_arbitration_iou_gain))) {
    return true;
  }
  // As good a fit of the same object, and far the better score.
  return options.fit_arbitration_score_gap > 0.0 && challenger.object == chosen.object &&
         challenger.score - chosen.score >= options.fit_arbitration_score_gap &&
         challenger.rms_px <= chosen.rms_px;
}

namespace {

// The mirror-twin check's screen: a twin is refined only if its fit before refinement (robust RMS)
// is below kTwinScreenRatio times the reported pose's plus kTwinScreenSlackPx. Chosen on the tuning
// models: it skips nearly two thirds of the twins and none that won (the largest such start was
// 2.09 times the reported pose's RMS); 1.5 lost some.
constexpr double kTwinScreenRatio = 2.0;
constexpr double kTwinScreenSlackPx = 0.5;

}  // namespace

bool Tracker::WorthRefining(int object, const FrameOutline& outline, const Rigid3& start,
                            double own_rms) {
  ContourRefinementOptions screen = options_.refinement;
  screen.max_iterations = 1;
  screen.compute_iou = false;
  const ContourRefinementResult first =
      RefinePoseToContour(Contour(object), camera_, outline, start, screen);
  return first.points_used >= 6 &&
         first.initial_rms_px < kTwinScreenRatio * own_rms + kTwinScreenSlackPx;
}

bool Tracker::FitMirrorTwins(TrackedFrame* tracked, bool feed_filter, int* view) {
  FrameResult& result = tracked->result;
  const ModelViews& model = database_.models[static_cast<size_t>(result.object)];
  if (model.symmetry.mirrors.empty() || model.mesh.triangles.empty() || !tracked->pose ||
      !tracked->refinement || tracked->refinement->points_used < 6) {
    return false;
  }
  const ContourRefinementResult& own = *tracked->refinement;
  const double own_rms = BetterRms(own);
  if (!std::isfinite(own_rms)) return false;
  const Rigid3 reported = tracked->pose->camera_from_object;
  const Eigen::Vector3d centre(model.mesh.Centre());
  const std::vector<Rigid3>& transforms = SymmetryTransformsOf(result.object);
  // The fit arbitration's rule; a twin's view scores the same as the reported one (the score gap
  // does not apply).
  const auto twin_better = [&](double a_rms, double a_iou, double b_rms, double b_iou) {
    return FitArbitrationPrefersChallenger({result.object, 0.0, a_rms, a_iou},
                                           {result.object, 0.0, b_rms, b_iou}, options_);
  };
  std::optional<ContourRefinementResult> best;
  double best_rms = 0.0;
  size_t best_mirror = 0;
  for (size_t m = 0; m < model.symmetry.mirrors.size(); ++m) {
    Rigid3 start;
    try {
      start = MirrorTwinPose(reported, model.symmetry.mirrors[m], centre);
    } catch (const Error&) {
      return false;
    }
    // A twin that is the same pose modulo the object's rotations (a bearing's) is no other pose.
    if (RotationErrorModuloSymmetryDeg(start.rotation, reported.rotation, transforms) <=
        options_.filter.mode_radius_deg) {
      continue;
    }
    // A screen first: the fit at the twin pose itself. Near the camera perspective makes the
    // twin fit far worse than the reported pose; such a twin is not refined.
    if (!WorthRefining(result.object, Outline(*tracked), start, own_rms)) continue;
    ContourRefinementResult twin = RefinePoseToContour(
        Contour(result.object), camera_, Outline(*tracked), start, options_.refinement);
    if (twin.points_used < 6) continue;
    if (!Improves(twin)) twin.camera_from_object = start;
    const double rms = BetterRms(twin);
    if (std::isfinite(rms) && twin_better(own_rms, own.iou, rms, twin.iou) &&
        (!best || rms < best_rms)) {
      best = std::move(twin);
      best_rms = rms;
      best_mirror = m;
    }
  }
  if (!best) return false;
  // A reported pose whose refinement stopped far from the outline (a first frame's coarse
  // guess) can fit worse than its twin although the twin is wrong: the twin's own twin, refined,
  // is then the reported hypothesis at its best, and the twin must beat that too.
  const MirrorSymmetry& mirror = model.symmetry.mirrors[best_mirror];
  if (!((best->camera_from_object * centre).z() > 0.0)) return false;
  const Rigid3 back_start = MirrorTwinPose(best->camera_from_object, mirror, centre);
  ContourRefinementResult back = RefinePoseToContour(
      Contour(result.object), camera_, Outline(*tracked), back_start, options_.refinement);
  if (!Improves(back)) back.camera_from_object = back_start;
  const double back_rms = BetterRms(back);
  if (back.points_used >= 6 && std::isfinite(back_rms) &&
      !twin_better(back_rms, back.iou, best_rms, best->iou)) {
    // Not the twin (the reported pose is kept: a refinement from elsewhere may find another
    // local minimum that fits a little better and is wrong).
    return false;
  }
  // The frame is the twin of the reported hypothesis: the filter's mode moves there too.
  // The filter's mode is centred on its estimate, which the view polish may have left.
  const int old_view = tracked->estimate && tracked->estimate->object == result.object &&
                               tracked->estimate->view >= 0
                           ? tracked->estimate->view
                           : *view;
  const Eigen::Vector3d n = mirror.normal.normalized();
  if (filter_ && feed_filter && old_view >= 0) {
    filter_->ReflectMode(result.object, old_view,
                         Eigen::Matrix3d::Identity() - 2.0 * n * n.transpose());
  }
  // Its centre is in front of the camera (checked above, before the filter's mode moved): Adopt
  // takes it.
  const bool adopted = Adopt(model.mesh, std::move(*best), tracked, feed_filter);
  SILPOSE_ASSERT(adopted);
  if (result.view_dir_in_object) *view = database_.sphere.NearestView(*result.view_dir_in_object);
  tracked->mirror_twin_fitted = true;
  return true;
}

bool Tracker::FitOtherPose(TrackedFrame* tracked, int* view, int shell) {
  FrameResult& result = tracked->result;
  if (result.object < 0 || *view < 0 || !tracked->pose || !tracked->refinement ||
      tracked->refinement->points_used < 6) {
    return false;
  }
  const ModelViews& model = database_.models[static_cast<size_t>(result.object)];
  if (model.mesh.triangles.empty()) return false;
  const ContourRefinementResult& own = *tracked->refinement;
  const double own_rms = BetterRms(own);
  if (!std::isfinite(own_rms)) return false;
  OtherPose other;
  const double gap = ScorePoseGap(result.object, *view, shell, &other);
  if (other.view < 0 || !(gap <= options_.other_pose_score_gap)) return false;
  SilhouettePose start;
  try {
    PoseFromSilhouetteOptions pose_options = options_.pose;
    pose_options.shell = shell;
    start = EstimatePoseFromSilhouette(database_, result.object, other.view, other.roll_deg,
                                       tracked->silhouette.signature, camera_, pose_options);
  } catch (const Error&) {
    return false;
  }
  const FrameOutline& outline = Outline(*tracked);
  const ContourModel& contour = Contour(result.object);
  // The mirror-twin check's screen: a start that fits far worse than the reported pose is not
  // refined.
  if (!WorthRefining(result.object, outline, start.camera_from_object, own_rms)) return false;
  ContourRefinementResult refined =
      RefinePoseToContour(contour, camera_, outline, start.camera_from_object, options_.refinement);
  if (refined.points_used < 6 || !Improves(refined)) return false;
  // Far the closer fit (a ragged mask lets another pose fit its noise a little better), and
  // clearly better by the fit arbitration's rule.
  if (!(refined.final_rms_px < options_.other_pose_fit_ratio * own_rms) ||
      !FitArbitrationPrefersChallenger({result.object, 0.0, own_rms, own.iou},
                                       {result.object, 0.0, refined.final_rms_px, refined.iou},
                                       options_)) {
    return false;
  }
  // Reported only: the filter keeps its particles and velocity (moving its mode there on
  // evidence this noisy cost the far threshold-like orbits the right object).
  if (!Adopt(model.mesh, std::move(refined), tracked, /*feed_filter=*/false)) return false;
  if (result.view_dir_in_object) *view = database_.sphere.NearestView(*result.view_dir_in_object);
  tracked->other_pose_fitted = true;
  return true;
}

const std::vector<Rigid3>& Tracker::SymmetryTransformsOf(int object) {
  pose_gap_transforms_.resize(database_.models.size());
  std::vector<Rigid3>& transforms = pose_gap_transforms_[static_cast<size_t>(object)];
  if (transforms.empty()) {
    // Sampled every 5 % of the diameter (a few degrees): fine enough for a 15 degree test.
    transforms = SymmetryTransforms(database_.models[static_cast<size_t>(object)].symmetry, 0.05);
  }
  return transforms;
}

bool Tracker::ScoreMirrorTwin(int view, int shell, TrackedFrame* tracked, MirrorTwin* twin) {
  const FrameResult& result = tracked->result;
  const ModelViews& model = database_.models[static_cast<size_t>(result.object)];
  if (model.symmetry.mirrors.empty() || !result.view_dir_in_object || view < 0) return false;
  const Eigen::Vector3d d = result.view_dir_in_object->normalized();
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(result.object)];
  bool found = false;
  for (const MirrorSymmetry& mirror : model.symmetry.mirrors) {
    const Eigen::Vector3d other = mirror.TwinView(d);
    if (same.AngleDeg(other, d) <= options_.filter.mode_radius_deg) continue;
    const int twin_view = database_.sphere.NearestView(other);
    if (twin_view < 0 || !spectra_->Usable(result.object, twin_view, shell)) continue;
    if (!found) {
      if (!frame_spectrum_.has_variance || !spectra_->Usable(result.object, view, shell))
        return false;
      // The reported view scored the same way (best over all rolls) as its twins.
      twin->reported_score = matcher_->Score(frame_spectrum_, result.object, view, shell).score;
    }
    const CorrelationPeak peak = matcher_->Score(frame_spectrum_, result.object, twin_view, shell);
    if (!found || peak.score > twin->score) {
      twin->view = twin_view;
      twin->score = peak.score;
      twin->roll_deg = peak.RollDeg(spectra_->signature_length());
    }
    found = true;
  }
  return found;
}

void Tracker::PolishView(const SignatureSpectrum& query, int object, double apparent_radius,
                         int* view, int* shell, double* roll_deg, double* score) {
  if (!query.has_variance || !spectra_->Usable(object, *view, *shell)) return;
  constexpr double kMaxRollChangeDeg = 15.0;
  constexpr float kMinGain = 0.3f;
  const int length = spectra_->signature_length();
  const double start_roll_deg = *roll_deg;
  const auto roll_apart_deg = [](double a, double b) {
    return std::abs(std::remainder(a - b, 360.0));
  };
  // The estimate's own view, correlated like its neighbours (its particle's score is a peak near
  // the predicted roll, from the same correlation).
  const CorrelationPeak own = matcher_->Score(query, object, *view, *shell);
  float best_score = static_cast<float>(*score);
  if (roll_apart_deg(own.RollDeg(length), start_roll_deg) <= kMaxRollChangeDeg)
    best_score = std::max(best_score, own.score);
  // Within the filter's mode (modulo the object's symmetry), as the estimate's area.
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(object)];
  const Eigen::Vector3d estimate_dir = database_.sphere.directions[static_cast<size_t>(*view)];
  int best_view = *view;
  int best_shell = *shell;
  double best_roll_deg = *roll_deg;
  if (best_score > static_cast<float>(*score)) best_roll_deg = own.RollDeg(length);
  // Views already looked at: one that did not beat the best then cannot beat it now.
  polish_seen_.assign(1, *view);
  for (int step = 0; step < options_.polish_steps; ++step) {
    const int centre = best_view;
    for (const uint32_t n : database_.sphere.Neighbours(centre)) {
      const auto v = static_cast<int>(n);
      if (std::find(polish_seen_.begin(), polish_seen_.end(), v) != polish_seen_.end()) continue;
      polish_seen_.push_back(v);
      // Each view in the distance shell the silhouette's size picks for it, as the filter's.
      const int v_shell =
          apparent_radius > 0.0 ? database_.ChooseShell(object, v, apparent_radius) : *shell;
      if (!spectra_->Usable(object, v, v_shell) ||
          same.AngleDeg(database_.sphere.directions[n], estimate_dir) >
              options_.filter.mode_radius_deg)
        continue;
      const CorrelationPeak peak = matcher_->Score(query, object, v, v_shell);
      const double roll = peak.RollDeg(length);
      // Better by a share of the remaining mismatch 1 - score, whose noise grows with it (a ragged
      // or small silhouette): not a neighbour that scores higher by the mask's noise alone.
      if (1.0f - peak.score < (1.0f - best_score) * (1.0f - kMinGain) &&
          roll_apart_deg(roll, start_roll_deg) <= kMaxRollChangeDeg) {
        best_score = peak.score;
        best_view = v;
        best_shell = v_shell;
        best_roll_deg = roll;
      }
    }
    if (best_view == centre) break;
  }
  *view = best_view;
  *shell = best_shell;
  *roll_deg = best_roll_deg;
  *score = static_cast<double>(best_score);
}

double Tracker::ScorePoseGap(int object, int view, int shell, OtherPose* other) {
  PoseGapCache& cache = pose_gap_cache_;
  if (cache.frame == frame_ && cache.object == object && cache.view == view &&
      cache.shell == shell) {
    *other = cache.other;
    return cache.gap;
  }
  const double gap = ComputePoseGap(object, view, shell, other);
  cache = {frame_, object, view, shell, gap, *other};
  return gap;
}

double Tracker::ComputePoseGap(int object, int view, int shell, OtherPose* other) {
  *other = {};
  // Another pose: farther than a posterior mode's radius (as the filter's runner-up).
  const double radius_deg = options_.filter.mode_radius_deg;
  // Far views correlated exactly, the best ranked, and harmonics the ranking uses (as the
  // filter's proposal ranks views: the low-harmonic part of the spectral bound).
  constexpr size_t kFarCandidates = 8;
  constexpr size_t kRankingHarmonics = 32;
  if (!frame_spectrum_.has_variance || !spectra_->Usable(object, view, shell)) return std::nan("");
  const int length = spectra_->signature_length();
  const std::vector<Eigen::Vector3d>& directions = database_.sphere.directions;
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(object)];
  const Eigen::Vector3d& centre = directions[static_cast<size_t>(view)];
  const auto score = [&](int v) {
    return spectra_->Usable(object, v, shell) ? matcher_->Score(frame_spectrum_, object, v, shell)
                                              : CorrelationPeak{-1.0f, 0.0f};
  };
  // The best score near the reported pose: its view and the neighbours the grid may place better.
  const CorrelationPeak own = score(view);
  float near = own.score;
  for (const uint32_t n : database_.sphere.Neighbours(view)) {
    if (same.AngleDeg(directions[n], centre) <= radius_deg)
      near = std::max(near, score(static_cast<int>(n)).score);
  }
  // The best far view: every view farther than the radius (modulo symmetry) ranked by the bound
  // over the first harmonics, the best ranked correlated exactly.
  const size_t half = frame_spectrum_.coefficients.size();
  const size_t harmonics = std::min(kRankingHarmonics, half);
  std::array<float, kRankingHarmonics> query{};
  for (size_t k = 0; k < harmonics; ++k) {
    const float weight = (k == 0 || k == half - 1) ? 1.0f : 2.0f;
    query[k] = weight * std::abs(frame_spectrum_.coefficients[k]);
  }
  ranked_.clear();
  for (int v = 0; v < database_.sphere.num_views(); ++v) {
    if (!spectra_->Usable(object, v, shell) ||
        same.AngleDeg(directions[static_cast<size_t>(v)], centre) <= radius_deg)
      continue;
    const std::span<const float> magnitudes = spectra_->Magnitudes(object, v, shell);
    float bound = 0.0f;
    for (size_t k = 0; k < std::min(harmonics, magnitudes.size()); ++k)
      bound += query[k] * magnitudes[k];
    KeepLargest(&ranked_, kFarCandidates, {bound, v});
  }
  float alternative = -1.0f;
  for (const auto& [bound, v] : ranked_) {
    const CorrelationPeak peak = score(v);
    if (peak.score > alternative) {
      alternative = peak.score;
      *other = {v, peak.RollDeg(length)};
    }
  }
  // The reported view at other rolls: the local maxima of its correlation, best first, beyond the
  // radius of rotation modulo the object's symmetry.
  const std::vector<Rigid3>& transforms = SymmetryTransformsOf(object);
  const Eigen::Matrix3d own_rotation = CameraFromObjectRotation(centre, own.RollDeg(length));
  correlation_.resize(static_cast<size_t>(length));
  matcher_->correlator().Correlate(frame_spectrum_, spectra_->Get(object, view, shell),
                                   correlation_);
  maxima_.clear();
  for (int i = 0; i < length; ++i) {
    const float e = correlation_[static_cast<size_t>(i)];
    const float before = correlation_[static_cast<size_t>((i + length - 1) % length)];
    const float after = correlation_[static_cast<size_t>((i + 1) % length)];
    if (e > alternative && e >= before && e > after) maxima_.emplace_back(e, i);
  }
  std::sort(maxima_.begin(), maxima_.end(), std::greater<>());
  for (const auto& [e, shift] : maxima_) {
    CorrelationPeak peak;
    peak.score = e;
    peak.shift_bins = static_cast<float>(shift);
    const double roll_deg = peak.RollDeg(length);
    if (RotationErrorModuloSymmetryDeg(CameraFromObjectRotation(centre, roll_deg), own_rotation,
                                       transforms) > radius_deg) {
      alternative = e;
      *other = {view, roll_deg};
      break;
    }
  }
  return static_cast<double>(near) - static_cast<double>(alternative);
}

void Tracker::MeasureFit(TrackedFrame* tracked, double* iou, double* rms_px) {
  if (tracked->refinement && options_.refinement.compute_iou) {
    *iou = tracked->refinement->iou;
    *rms_px = tracked->refinement->final_rms_px;
    return;
  }
  if (!tracked->pose || tracked->result.object < 0) return;
  const TriangleMesh& mesh = database_.models[static_cast<size_t>(tracked->result.object)].mesh;
  if (mesh.triangles.empty()) return;
  // Without refinement the fit is measured after one Levenberg-Marquardt step from the reported
  // pose (the reported pose stays as it is).
  ContourRefinementOptions check = options_.refinement;
  check.max_iterations = 1;
  check.compute_iou = true;
  try {
    const FrameOutline& outline = Outline(*tracked);
    const ContourRefinementResult fit =
        RefinePoseToContour(Contour(tracked->result.object), camera_, outline,
                            tracked->pose->camera_from_object, check);
    *iou = fit.iou;
    *rms_px = fit.final_rms_px;
  } catch (const Error&) {
    // No fit for this frame (e.g. the object centre behind the camera): the features say so.
  }
}

void Tracker::Assess(TrackedFrame* tracked, bool usable, std::span<const float> radii, int view,
                     int shell) {
  FrameResult& result = tracked->result;
  double fit_iou = std::nan(""), fit_rms_px = std::nan("");
  if (usable) MeasureFit(tracked, &fit_iou, &fit_rms_px);
  if (std::isfinite(fit_iou)) result.iou = fit_iou;
  const FilterEstimate* estimate = tracked->estimate ? &*tracked->estimate : nullptr;
  if (estimate != nullptr && measured_frames_ > 0 && estimate->runner_up.object >= 0) {
    const FilterEstimate::RunnerUp& r = estimate->runner_up;
    result.runner_up_object = r.object;
    result.runner_up_name = database_.models[static_cast<size_t>(r.object)].name;
    result.runner_up_mass = r.mass;
    result.runner_up_view_dir = database_.sphere.directions[static_cast<size_t>(r.view)];
    if (r.roll_known) result.runner_up_roll_deg = r.roll_deg;
  }
  if (!usable || result.object < 0) {
    const TrackStateEstimator::Output out = state_->NoSilhouette();
    result.state = out.state;
    result.confidence = result.object >= 0 ? out.confidence : std::nan("");
    if (result.object < 0 && usable) {
      // A silhouette without any estimate (e.g. every view unusable): nothing fits it.
      result.state = TrackState::kUnknownObject;
    }
    return;
  }
  ConfidenceFeatures features;
  if (estimate != nullptr) {
    features.object_probability = result.probability;
    features.mode_mass = estimate->mode_mass;
    features.runner_up_mass = estimate->runner_up.mass;
  }
  features.score = result.score;
  const PolarSignature& signature = tracked->silhouette.signature;
  if (std::isfinite(fit_iou) && std::isfinite(fit_rms_px) && signature.mean_radius_px > 0.0) {
    features.has_fit = true;
    features.iou = fit_iou;
    features.outline_rms = fit_rms_px / signature.mean_radius_px;
  }
  MirrorTwin twin;
  const bool has_twin = usable && !radii.empty() && ScoreMirrorTwin(view, shell, tracked, &twin);
  OtherPose other;
  if (usable && !radii.empty() && view >= 0) {
    features.pose_score_gap = ScorePoseGap(result.object, view, shell, &other);
  }
  if (has_twin) {
    features.twin_score_gap =
        static_cast<double>(twin.reported_score) - static_cast<double>(twin.score);
    tracked->mirror_twin = twin;
  }
  if (previous_area_px_ > 0.0 && signature.area_px > 0.0)
    features.area_change = std::abs(std::log(signature.area_px / previous_area_px_));
  previous_area_px_ = signature.area_px;
  // The competing-mode rule compares particle scores: the runner-up's with the estimate's, which
  // the view polish may have raised in result.score (an exact peak of a better view), so the
  // runner-up's is shifted by that rise.
  const double runner_up_score = estimate != nullptr
                                     ? static_cast<double>(estimate->runner_up.score) +
                                           (result.score - static_cast<double>(estimate->score))
                                     : -1.0;
  const TrackStateEstimator::Output out = state_->Measured(&features, runner_up_score);
  tracked->confidence_features = features;
  result.confidence = out.confidence;
  result.state = out.state;
  // A mirror twin that explains the silhouette as well as the reported view (within the state's
  // twin gap) is the runner-up, unless the filter's own runner-up made the frame ambiguous.
  if (out.twin_alike && !out.competing_mode) {
    result.runner_up_object = result.object;
    result.runner_up_name = result.object_name;
    result.runner_up_mass = std::nan("");
    result.runner_up_view_dir = database_.sphere.directions[static_cast<size_t>(twin.view)];
    result.runner_up_roll_deg = twin.roll_deg;
  } else if (out.pose_alike && !out.competing_mode && other.view >= 0) {
    // Another pose of the object explains the silhouette as well: it is the runner-up.
    result.runner_up_object = result.object;
    result.runner_up_name = result.object_name;
    result.runner_up_mass = std::nan("");
    result.runner_up_view_dir = database_.sphere.directions[static_cast<size_t>(other.view)];
    result.runner_up_roll_deg = other.roll_deg;
  }
}

void Tracker::EstimatePose(int view, int shell, bool feed_filter, TrackedFrame* tracked,
                           const std::function<double()>& lap) {
  FrameResult& result = tracked->result;
  if ((tracked->silhouette.flags & kSilhouetteTouchesBorder) != 0) {
    // The silhouette runs out of the image: its centre and size are not the object's.
    result.status += "-cut-by-border-no-pose";
    return;
  }
  lap();
  // The pose reads the view's signature: its block is checked first (a corrupt database is an
  // error, not a frame without pose).
  spectra_->CheckSignatures(result.object, shell);
  try {
    PoseFromSilhouetteOptions pose_options = options_.pose;
    pose_options.shell = shell;
    tracked->pose =
        EstimatePoseFromSilhouette(database_, result.object, view, result.roll_deg,
                                   tracked->silhouette.signature, camera_, pose_options);
    result.camera_from_object = tracked->pose->camera_from_object;
    result.time_pose_ms = lap();
    const TriangleMesh& mesh = database_.models[static_cast<size_t>(result.object)].mesh;
    if (options_.refine && !mesh.triangles.empty()) {
      Refine(mesh, tracked, feed_filter);
      result.time_refine_ms = lap();
    }
  } catch (const Error&) {
    // A problem of this frame only (e.g. a centroid outside the lens model's valid range): the
    // frame keeps its object and view (and the grid pose if only the refinement failed).
    result.status += "-no-pose";
  }
}

void Tracker::Canonicalise(FrameResult* result, bool runner_up) const {
  if (!options_.canonical_poses) return;
  if (result->object >= 0 && result->view_dir_in_object) {
    const ObjectSymmetry& symmetry = database_.models[static_cast<size_t>(result->object)].symmetry;
    if (symmetry.HasRotations()) ToCanonicalForm(symmetry, result);
  }
  if (runner_up && result->runner_up_object >= 0 && result->runner_up_view_dir) {
    const ObjectSymmetry& symmetry =
        database_.models[static_cast<size_t>(result->runner_up_object)].symmetry;
    if (symmetry.HasRotations()) {
      FrameResult other;
      other.view_dir_in_object = result->runner_up_view_dir;
      other.roll_deg = result->runner_up_roll_deg;
      ToCanonicalForm(symmetry, &other);
      result->runner_up_view_dir = other.view_dir_in_object;
      result->runner_up_roll_deg = other.roll_deg;
    }
  }
}

TrackedFrame Tracker::Revise(const TrackedFrame& frame, const PoseState& state) {
  const int num_models = static_cast<int>(database_.models.size());
  if (state.object < 0 || state.object >= num_models || state.view < 0 ||
      state.view >= database_.sphere.num_views()) {
    ThrowError("Revise: state (object ", state.object, ", view ", state.view,
               ") is not in the database");
  }
  if (!filter_ || !frame.estimate || !frame.estimate->measured || !frame.silhouette.ok() ||
      !state.roll_known || frame.estimate->object < 0 || frame.estimate->view < 0) {
    return frame;
  }
  const FilterEstimate& estimate = *frame.estimate;
  const auto& directions = database_.sphere.directions;
  // Whether the state is the hypothesis (object, view direction) within the filter's mode radius.
  const auto is_state = [&](int object, const Eigen::Vector3d& view_dir) {
    return state.object == object && equivalence_[static_cast<size_t>(state.object)].AngleDeg(
                                         directions[static_cast<size_t>(state.view)], view_dir) <=
                                         options_.filter.mode_radius_deg;
  };
  // The filter's estimate, or the pose the frame reported (the mirror-twin check may have
  // reported another view than the estimate's): nothing to re-pose.
  if (is_state(estimate.object, directions[static_cast<size_t>(estimate.view)]) ||
      (frame.result.view_dir_in_object &&
       is_state(frame.result.object, *frame.result.view_dir_in_object))) {
    return frame;
  }
  if (frame.segmentation.mask.empty())
    ThrowError("Revise: frame ", frame.result.frame, " has no segmentation mask");

  TrackedFrame revised = frame;
  const FrameResult& before = frame.result;
  FrameResult& result = revised.result;
  result.object = state.object;
  result.object_name = database_.models[static_cast<size_t>(state.object)].name;
  result.view_dir_in_object = directions[static_cast<size_t>(state.view)];
  result.roll_deg = state.roll_deg;
  result.score = static_cast<double>(state.score);
  result.probability = static_cast<size_t>(state.object) < estimate.object_probability.size()
                           ? estimate.object_probability[static_cast<size_t>(state.object)]
                           : std::nan("");
  revised.pose.reset();
  revised.refinement.reset();
  revised.mirror_twin.reset();
  revised.mirror_twin_fitted = false;
  result.camera_from_object.reset();
  result.iou = std::nan("");
  for (const char* suffix : {"-cut-by-border-no-pose", "-no-pose"}) {
    if (result.status.ends_with(suffix)) {
      result.status.resize(result.status.size() - std::strlen(suffix));
      break;
    }
  }
  if (options_.estimate_pose) {
    const double apparent_radius = revised.on_axis
                                       ? revised.on_axis->apparent_radius
                                       : revised.silhouette.signature.mean_radius_px /
                                             std::sqrt(camera_.focal_x_px * camera_.focal_y_px);
    const int shell = database_.ChooseShell(state.object, state.view, apparent_radius);
    EstimatePose(state.view, shell, /*feed_filter=*/false, &revised, [] { return 0.0; });
    // The mirror-twin check, as the frame had when it was processed: a history that holds the
    // twin the check corrected live must not bring it back.
    if (options_.mirror_twin_check && options_.refine && revised.refinement) {
      int view = state.view;
      FitMirrorTwins(&revised, /*feed_filter=*/false, &view);
    }
    // The times stay those of the frame's processing.
    result.time_pose_ms = before.time_pose_ms;
    result.time_refine_ms = before.time_refine_ms;
  }

  // The fit and the confidence at the new pose; the posterior features stay the frame's.
  double fit_iou = std::nan(""), fit_rms_px = std::nan("");
  MeasureFit(&revised, &fit_iou, &fit_rms_px);
  if (std::isfinite(fit_iou)) result.iou = fit_iou;
  ConfidenceFeatures features =
      frame.confidence_features ? *frame.confidence_features : ConfidenceFeatures{};
  features.score = result.score;
  features.object_probability = std::isfinite(result.probability) ? result.probability : 0.0;
  const double mean_radius = revised.silhouette.signature.mean_radius_px;
  features.has_fit = std::isfinite(fit_iou) && std::isfinite(fit_rms_px) && mean_radius > 0.0;
  features.iou = features.has_fit ? fit_iou : 0.0;
  features.outline_rms = features.has_fit ? fit_rms_px / mean_radius : 0.0;
  // The twin gap: re-posed as the frame's own mirror twin, the gap turns round (the former view
  // is now the twin); re-posed elsewhere, the frame's outline favoured the former view by the gap
  // (if it had one), so the new one is taken as at best as good.
  if (std::isfinite(features.twin_score_gap)) {
    const bool as_twin = frame.mirror_twin && frame.mirror_twin->view == state.view;
    features.twin_score_gap =
        as_twin ? -features.twin_score_gap : -std::abs(features.twin_score_gap);
  }
  // The pose gap: the frame's outline scored the former pose at before.score, which the new one
  // cannot beat by more than their difference; both as particle scores (the view polish may
  // have raised the reported score above the estimate's).
  if (std::isfinite(features.pose_score_gap)) {
    features.pose_score_gap = std::min(
        features.pose_score_gap, static_cast<double>(state.score) -
                                     std::min(before.score, static_cast<double>(estimate.score)));
  }
  revised.confidence_features = features;
  result.confidence = state_->options().model.Evaluate(features);
  if (before.state == TrackState::kTracking || before.state == TrackState::kAmbiguous) {
    // The state rules' tracking test, without their memory: confident, and no twin or other pose
    // alike.
    const bool twin_alike = std::isfinite(features.twin_score_gap) &&
                            features.twin_score_gap <= state_->options().twin_score_gap;
    const bool pose_alike = std::isfinite(features.pose_score_gap) &&
                            features.pose_score_gap <= state_->options().pose_score_gap;
    result.state =
        result.confidence >= state_->options().min_confidence && !twin_alike && !pose_alike
            ? TrackState::kTracking
            : TrackState::kAmbiguous;
  }
  // The former hypothesis is the runner-up (already in canonical form).
  result.runner_up_object = before.object;
  result.runner_up_name = before.object_name;
  result.runner_up_mass = std::nan("");
  result.runner_up_view_dir = before.view_dir_in_object;
  result.runner_up_roll_deg = before.roll_deg;
  Canonicalise(&result, /*runner_up=*/false);
  return revised;
}

TrackedFrame Tracker::Process(const cv::Mat& frame) { return ProcessFrame(frame, nullptr, 0.0); }

TrackedFrame Tracker::Process(const cv::Mat& frame, SegmentationResult segmentation,
                              double segment_ms) {
  return ProcessFrame(frame, &segmentation, segment_ms);
}

TrackedFrame Tracker::ProcessFrame(const cv::Mat& frame, SegmentationResult* segmented,
                                   double segment_ms) {
  if (frame.empty()) ThrowError("frame ", frame_, " is empty");
  if (frame.cols != camera_.width_px || frame.rows != camera_.height_px) {
    ThrowError("frame ", frame_, " is ", frame.cols, "x", frame.rows, " pixels but the camera is ",
               camera_.width_px, "x", camera_.height_px,
               " (give the camera file of this video, or none for a default)");
  }
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  Clock::time_point stage_start = start;
  // Milliseconds since the previous call (or the start), for the per-stage times.
  const auto lap = [&stage_start] {
    const Clock::time_point now = Clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - stage_start).count();
    stage_start = now;
    return ms;
  };
  TrackedFrame tracked;
  FrameResult& result = tracked.result;
  result.frame = frame_;
  if (segmented != nullptr) {
    // Segmented outside: its time is the segmenter's, not this thread's.
    if (segmented->mask.size() != frame.size() || segmented->mask.type() != CV_8UC1) {
      ThrowError("frame ", frame_, ": the segmentation given is not a ", frame.cols, "x",
                 frame.rows, " CV_8UC1 mask");
    }
    if (!(std::isfinite(segment_ms) && segment_ms >= 0.0)) {
      ThrowError("frame ", frame_, ": the segmentation time given must be >= 0 ms, got ",
                 segment_ms);
    }
    tracked.segmentation = std::move(*segmented);
    lap();
    result.time_segment_ms = segment_ms;
  } else {
    tracked.segmentation = segmenter_->Segment(frame);
    result.time_segment_ms = lap();
  }
  bool usable = false;
  if (tracked.segmentation.ok()) {
    tracked.silhouette =
        ExtractSignature(tracked.segmentation.mask, database_.parameters.signature);
    usable = tracked.silhouette.ok();
    result.status =
        usable ? "measured" : std::string("no-silhouette-") + ToString(tracked.silhouette.status);
  } else {
    result.status = std::string("no-silhouette-") + ToString(tracked.segmentation.status);
  }

  // What is matched: the silhouette seen straight on (no off-axis stretch, no distortion) and its
  // apparent size, which picks each view's distance shell.
  std::span<const float> radii;
  double apparent_radius = 0.0;
  if (usable) {
    radii = tracked.silhouette.signature.radii;
    apparent_radius = tracked.silhouette.signature.mean_radius_px /
                      std::sqrt(camera_.focal_x_px * camera_.focal_y_px);
    if (options_.on_axis_matching) {
      OnAxisSilhouette on_axis;
      if (DescribeOnAxis(tracked.silhouette.outline_px, camera_, database_.parameters.signature,
                         &on_axis)) {
        tracked.on_axis = std::move(on_axis);
        radii = tracked.on_axis->signature.radii;
        apparent_radius = tracked.on_axis->apparent_radius;
      }
    }
  }
  // The frame's spectrum, once: the filter's step, the view polish and Assess's checks correlate
  // it with views (the filter's correlator is made from the same spectra, so it is the same).
  if (usable && !radii.empty()) matcher_->correlator().Transform(radii, &frame_spectrum_);
  // Scores of the previous spectrum are no longer the frame's.
  pose_gap_cache_ = {};
  if (tracked.segmentation.ok()) result.time_describe_ms = lap();

  int view = -1;
  int shell = 0;
  bool roll_known = false;
  posed_.clear();
  arbitration_ms_ = 0.0;
  if (filter_) {
    // The arbiter (called from Step) poses hypotheses on this frame, and on no other.
    struct CurrentFrame {
      TrackedFrame*& current;
      ~CurrentFrame() { current = nullptr; }
    } scope{current_ = &tracked};
    tracked.estimate =
        usable ? filter_->Step(frame_spectrum_, apparent_radius) : filter_->Predict();
    // The arbitration's pose estimates count as refinement.
    result.time_match_ms = lap() - arbitration_ms_;
    const FilterEstimate& estimate = *tracked.estimate;
    result.particles = estimate.num_particles;
    result.effective_particles = estimate.effective_particles;
    if (!estimate.measured) result.status = "predicted-" + result.status;
    measured_frames_ += estimate.measured;
  }
  if (filter_ && measured_frames_ > 0) {
    // Before the first measurement the filter's particles are its uniform prior: no estimate.
    const FilterEstimate& estimate = *tracked.estimate;
    result.object = estimate.object;
    view = estimate.view;
    shell = estimate.shell;
    roll_known = estimate.roll_known;
    if (roll_known) result.roll_deg = estimate.roll_deg;
    result.score = static_cast<double>(estimate.score);
    if (estimate.object >= 0)
      result.probability = estimate.object_probability[static_cast<size_t>(estimate.object)];
    // Not when the fit arbitration has posed the estimate already: it chose between refined
    // hypotheses, and its pose is reported as it is.
    const bool posed_by_arbitration =
        std::any_of(posed_.begin(), posed_.end(),
                    [&](const Posed& p) { return p.object == estimate.object && p.view == view; });
    if (options_.polish_steps > 0 && usable && roll_known && estimate.object >= 0 && view >= 0 &&
        !posed_by_arbitration) {
      PolishView(frame_spectrum_, estimate.object, apparent_radius, &view, &shell, &result.roll_deg,
                 &result.score);
      // Part of choosing the view: the match stage.
      result.time_match_ms += lap();
    }
  } else if (!filter_ && usable) {  // brute force
    const std::vector<MatchCandidate> top =
        matcher_->Match(radii, {.top_k = 1, .apparent_radius = apparent_radius});
    result.time_match_ms = lap();
    if (!top.empty()) {
      result.object = top.front().model;
      view = top.front().view;
      shell = top.front().shell;
      roll_known = true;
      result.roll_deg = top.front().roll_deg;
      result.score = static_cast<double>(top.front().score);
    }
  }
  if (result.object >= 0 && view >= 0) {
    result.object_name = database_.models[static_cast<size_t>(result.object)].name;
    result.view_dir_in_object = database_.sphere.directions[static_cast<size_t>(view)];
    const auto posed = std::find_if(posed_.begin(), posed_.end(), [&](const Posed& p) {
      return p.object == result.object && p.view == view;
    });
    if (options_.estimate_pose && usable && roll_known && posed != posed_.end()) {
      // Posed by the arbitration already.
      const TrackedFrame& done = posed->frame;
      tracked.pose = done.pose;
      tracked.refinement = done.refinement;
      result.camera_from_object = done.result.camera_from_object;
      result.view_dir_in_object = done.result.view_dir_in_object;
      result.roll_deg = done.result.roll_deg;
      result.status = done.result.status;
      result.time_refine_ms = arbitration_ms_;
      if (done.pose && done.refinement && Improves(*done.refinement)) {
        const Eigen::Matrix3d on_axis =
            RotationFromOpticalAxisTo(done.pose->centre_ray).transpose() *
            done.pose->camera_from_object.rotation;
        filter_->ObserveRotation(on_axis);
      }
    } else if (options_.estimate_pose && usable && roll_known) {
      EstimatePose(view, shell, /*feed_filter=*/true, &tracked, lap);
      result.time_refine_ms += arbitration_ms_;
    }
  }
  if (options_.mirror_twin_check && options_.estimate_pose && options_.refine && usable &&
      result.object >= 0 && tracked.refinement) {
    // The twin's fit counts as refinement.
    lap();
    const int matched_view = view;
    FitMirrorTwins(&tracked, /*feed_filter=*/true, &view);
    if (view != matched_view) shell = database_.ChooseShell(result.object, view, apparent_radius);
    result.time_refine_ms += lap();
  }
  if (options_.other_pose_check && options_.estimate_pose && options_.refine && usable &&
      result.object >= 0 && tracked.refinement && view >= 0 && !radii.empty()) {
    // The other pose's search and fit count as refinement.
    lap();
    const int matched_view = view;
    FitOtherPose(&tracked, &view, shell);
    if (view != matched_view) shell = database_.ChooseShell(result.object, view, apparent_radius);
    result.time_refine_ms += lap();
  }
  RememberMotion(tracked);
  Assess(&tracked, usable, radii, view, shell);
  Canonicalise(&result, /*runner_up=*/true);
  result.time_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  if (segmented != nullptr) result.time_ms += segment_ms;
  ++frame_;
  return tracked;
}

}  // namespace silpose
