#pragma once
// The online pipeline of one video stream (docs/tracking.md): frame -> segmentation ->
// polar signature -> particle filter over (object, view, roll) (or the brute-force matcher) ->
// 6-DOF pose. This is what `silpose track` runs per frame; call it from your own code the same way:
//
//   const ViewDatabase database = ViewDatabase::Read("objects.db");
//   Tracker tracker(database, ReadCameraFile("camera.yml"), TrackerOptions{});
//   for (cv::Mat frame; source->Read(&frame);) {
//     const TrackedFrame tracked = tracker.Process(frame);
//     // tracked.result: object, score, probability, view, roll, pose (pose/pose_output.h)
//   }
//
// A frame whose segmentation fails (still learning the background, nothing found, the whole frame
// changed) or whose silhouette cannot be described (too small, ...) is not an error: the filter
// only predicts, the result's status says why, and there is no pose for it. Until the first frame
// with a silhouette the result names no object. A measured frame gets no 6-DOF pose when its
// silhouette touches the image border (status "measured-cut-by-border-no-pose": its centre and
// size are not the object's) or the pose cannot be computed for it ("measured-no-pose", e.g. a
// centroid outside the valid range of the lens distortion model).

#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/filter/particle_filter.h"
#include "silpose/geometry/pinhole_camera.h"
#include "silpose/match/view_matcher.h"
#include "silpose/pose/contour_refinement.h"
#include "silpose/pose/on_axis.h"
#include "silpose/pose/pose_from_silhouette.h"
#include "silpose/pose/pose_output.h"
#include "silpose/segment/segmenter.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/track/confidence.h"

namespace silpose {

/// The camera assumed when the user gives none (`silpose track` warns): principal point at the
/// image centre ((w - 1) / 2, (h - 1) / 2), square pixels, focal length 0.8203 * width (525 px at
/// 640 pixels: the VGA camera of the usual RGB-D datasets and of `silpose synth`; horizontal field
/// of view 62.7 degrees), no distortion. Object identity and view do not depend on it; the 6-DOF
/// pose's distance scales with the focal length.
PinholeCamera DefaultCamera(int width_px, int height_px);

struct TrackerOptions {
  /// The defaults below (out of line: GCC 12 warns spuriously about inlined copies of them).
  TrackerOptions();

  /// How frames become masks (segment/segmenter.h). Default: the frames are masks.
  SegmenterOptions segmentation;
  /// Match every frame against the whole database independently (the paper's baseline) instead
  /// of filtering.
  bool brute_force = false;
  /// The particle filter (filter/particle_filter.h). Tracker keeps at most
  /// filter.max_history_frames of history; the default here, 100, bounds memory on long videos.
  ParticleFilterOptions filter = DefaultFilterOptions();
  /// Describe the silhouette in the on-axis virtual camera before matching (pose/on_axis.h):
  /// removes the off-axis stretch and the lens distortion from the match. Off: the paper's
  /// description of the raw mask.
  bool on_axis_matching = true;
  /// Estimate the 6-DOF pose of every frame with a silhouette.
  bool estimate_pose = true;
  PoseFromSilhouetteOptions pose;
  /// Refine the 6-DOF pose continuously against the frame's outline (pose/contour_refinement.h),
  /// below the database's view grid; needs the models' geometry in the database. The refined
  /// rotation also gives the reported view direction and roll, and the filter's velocity.
  bool refine = true;
  ContourRefinementOptions refinement;
  /// Fit arbitration (filter mode with refinement; docs/tracking.md): when the particle that
  /// scored highest on a frame lies outside the mode the filter would report and scored higher
  /// (the other side of a flat object, a mirror twin, a look-alike object), both hypotheses are
  /// posed and refined against the frame's outline. The challenger is reported, and given half
  /// of the filter's weight, if its robust RMS outline distance is below fit_arbitration_ratio
  /// times the other's and lower by more than fit_arbitration_margin_px, and its IoU is no
  /// lower. Ratio 0 = off: the scores alone decide (and no frame is posed twice).
  double fit_arbitration_ratio = 0.8;
  /// About the RMS outline distance of the right pose on a perfectly segmented frame (0.15-0.35
  /// px): a smaller difference is pixel noise, not evidence.
  double fit_arbitration_margin_px = 0.25;
  /// ... or, below the ratio, whose IoU is higher by at least this much. The margin is in pixels,
  /// and a small silhouette (a far object) has small outline distances: at 15 radii, 35 px
  /// across, the back of a flat object fitted its outline in 0.45 px against its front's 0.21 px,
  /// within the margin, but covered it with an IoU of 0.971 against 0.999. In [0, 1]; 0 = off.
  double fit_arbitration_iou_gain = 0.01;
  /// A challenger of the same object whose signature scored at least this much higher than the
  /// filter's choice is also reported when it fits the outline at least as well (RMS no higher,
  /// IoU no lower). Both poses then explain the outline, and the frame's own evidence, the
  /// signature, clearly prefers the challenger: the filter's mode has lost the object (a nearly
  /// circular outline seen end-on, whose two ends the refinement can both fit). In [0, 2]; 0 =
  /// off. Another object needs the fit rule above: on poor masks a look-alike may score far
  /// higher.
  double fit_arbitration_score_gap = 0.3;
  /// Motion start (filter mode with refinement; docs/tracking.md): the previous frame's refined
  /// pose of the same object, turned on by the last frame-to-frame rotation, is a second
  /// starting pose for the refinement, beside the database view's grid pose (up to half a grid
  /// spacing off, about 3 degrees). When its view direction lies within the filter's
  /// mode_radius_deg of the grid view's (modulo symmetry), both starts are refined and the pose
  /// that ends closer to the frame's outline (robust RMS distance) is kept: from either start the
  /// refinement can stop in a shallow minimum that the other avoids. Costs a second refinement
  /// in such frames. Only for the reported hypothesis: the fit arbitration's hypotheses compete
  /// from their grid poses alike. A symmetric object's previous pose is taken as the equivalent
  /// one nearest the motion (NearestEquivalentRotation). Off: every frame is refined from its
  /// grid pose alone, as in brute-force mode.
  bool refine_from_motion = true;
  /// View polish (filter mode; docs/tracking.md): the pose starts from the best-scoring view near
  /// the filter's estimate instead of the estimate's own. The filter decides the object and the
  /// area of the view sphere; within it, its particles cover only some views, and its estimate is
  /// the heaviest particle there, which need not be the view that fits this frame best. The
  /// estimate's view and its neighbours are correlated exactly with the frame (7 to 10
  /// correlations of a few microseconds), and the search moves to the best of them while that one
  /// scores clearly higher, at most polish_steps times, never farther than the filter's
  /// mode_radius_deg from the estimate (modulo the object's symmetry). A neighbour counts only
  /// when it removes at least 30 % of the remaining mismatch 1 - score (whose noise grows with it
  /// on ragged or small silhouettes) and its best roll lies within 15 degrees of the estimate's.
  /// 0: the estimate's view, as the filter reports it.
  int polish_steps = 2;
  /// Mirror-twin check (refinement on; docs/tracking.md): for an object with a mirror plane,
  /// the pose that shows the same outline to a far-away camera (the mirror twin, which the
  /// database's views cannot tell apart from far away) is refined against the frame's outline
  /// too, and reported instead when it fits clearly better by the fit arbitration's rule
  /// (fit_arbitration_ratio and _margin_px; not with ratio 0). In filter mode, the filter's
  /// mode moves to the twin. Off: the matched pose's refinement is reported.
  bool mirror_twin_check = true;
  /// Other-pose check (refinement on; docs/tracking.md, "Other-pose check"): when the best pose
  /// of the reported object farther than the filter's mode radius (modulo symmetry; the one the
  /// confidence's other-pose search finds) scores within other_pose_score_gap of the reported
  /// view, it is posed and refined against the frame's outline too, and reported instead when
  /// it fits far closer (RMS below other_pose_fit_ratio times the reported pose's) and clearly
  /// better by the fit arbitration's rule. Only the report changes: the filter's particles and
  /// velocity stay. Off: as before.
  bool other_pose_check = true;
  /// The score gap below which the other pose is refined (the best score of the reported view
  /// and its neighbours minus the other pose's), in [0, 2].
  double other_pose_score_gap = 0.002;
  /// The other pose's refined RMS must be below this times the reported pose's, in (0, 1].
  double other_pose_fit_ratio = 0.5;
  /// Report the poses of symmetric objects in canonical form (geometry/symmetry.h,
  /// docs/symmetry.md): of the poses that look alike by the object's symmetries, the one whose
  /// camera direction lies in a fixed sector of the object. Off: the pose as matched.
  bool canonical_poses = true;
  /// Confidence and state of each frame (track/confidence.h, docs/confidence.md).
  TrackStateOptions state;

  /// ParticleFilterOptions{} with max_history_frames = 100.
  static ParticleFilterOptions DefaultFilterOptions();
  /// False with a message naming the option if any part is invalid.
  bool Check(std::string* error = nullptr) const;
};

/// Everything the tracker found in one frame.
struct TrackedFrame {
  /// The row of POSES.csv / JSON Lines / BOP (pose/pose_output.h). result.time_ms is the
  /// processing time of Process() (segmentation to pose; decoding not included), and
  /// result.time_segment_ms ... time_refine_ms split it by stage.
  FrameResult result;
  /// The segmentation (its mask is all zero unless ok()).
  SegmentationResult segmentation;
  /// The silhouette description (valid when segmentation.ok()).
  SignatureResult silhouette;
  /// The description that was matched, in the on-axis virtual camera (when on_axis_matching and
  /// the silhouette was usable).
  std::optional<OnAxisSilhouette> on_axis;
  /// The contour refinement, when it ran.
  std::optional<ContourRefinementResult> refinement;
  /// The pose and how it was found, when estimated.
  std::optional<SilhouettePose> pose;
  /// The particle filter's estimate (not set in brute-force mode).
  std::optional<FilterEstimate> estimate;
  /// What result.confidence was computed from (frames with a silhouette and an estimate).
  std::optional<ConfidenceFeatures> confidence_features;
  /// For an object with a mirror plane: the best-scoring mirror twin of the reported database
  /// view (the view whose outline is the same up to perspective, farther than the filter's mode
  /// radius), scored on this frame.
  struct MirrorTwin {
    /// Database view and the roll at its best score.
    int view = -1;
    double roll_deg = 0.0;
    /// Its best score over all rolls, and the reported view's, computed the same way.
    float score = 0.0f;
    float reported_score = 0.0f;
  };
  std::optional<MirrorTwin> mirror_twin;
  /// The mirror-twin check (TrackerOptions::mirror_twin_check) found that the mirror twin of the
  /// matched pose explains the outline clearly better, and the twin's refined pose is reported.
  bool mirror_twin_fitted = false;
  /// The other-pose check (TrackerOptions::other_pose_check) found a pose of the object more than
  /// the mode radius away that fits the outline far closer, and that pose is reported.
  bool other_pose_fitted = false;
};

/// Puts `result`'s pose, view direction and roll in canonical form for an object with
/// `symmetry` (geometry/symmetry.h): nothing changes for an object without rotations or a result
/// without view direction.
void ToCanonicalForm(const ObjectSymmetry& symmetry, FrameResult* result);

/// How well a posed hypothesis explains a frame, for the fit arbitration.
struct HypothesisFit {
  int object = -1;
  /// Signature score of the hypothesis's database view (FilterEstimate::Hypothesis::score).
  double score = -1.0;
  /// Robust RMS outline distance, pixels, and IoU with the frame mask, of its refined pose.
  double rms_px = 0.0;
  double iou = 0.0;
};

/// The fit arbitration's rule (TrackerOptions::fit_arbitration_ratio, _margin_px, _iou_gain,
/// _score_gap;
/// docs/tracking.md): true if `challenger` is to be reported instead of `chosen`. False when the
/// arbitration is off (ratio 0) or either fit is not finite.
bool FitArbitrationPrefersChallenger(const HypothesisFit& chosen, const HypothesisFit& challenger,
                                     const TrackerOptions& options);

class Tracker {
 public:
  /// `database` must outlive the tracker. `camera` is the camera of the frames (its size must be
  /// the frames' size). Throws silpose::Error for invalid options or camera, or a database
  /// without any usable view.
  Tracker(const ViewDatabase& database, const PinholeCamera& camera, const TrackerOptions& options);
  /// With default options.
  Tracker(const ViewDatabase& database, const PinholeCamera& camera);
  /// Matches with `spectra` (and its database) instead of spectra of its own: several trackers,
  /// one per stream and thread, can share one ViewSpectra, so that each view's spectrum is made
  /// (or checked) once and held once. `spectra` must outlive the tracker.
  Tracker(const ViewSpectra& spectra, const PinholeCamera& camera, const TrackerOptions& options);
  Tracker(ViewSpectra&&, const PinholeCamera&, const TrackerOptions&) = delete;
  ~Tracker();
  Tracker(const Tracker&) = delete;
  Tracker& operator=(const Tracker&) = delete;

  Tracker(ViewDatabase&&, const PinholeCamera&, const TrackerOptions&) = delete;
  Tracker(ViewDatabase&&, const PinholeCamera&) = delete;

  /// Processes the next frame of the stream (CV_8UC1 mask or grey image, or CV_8UC3 BGR; see
  /// segment/segmenter.h). Throws silpose::Error if the frame is empty, of an unsupported type, or
  /// not of the camera's size.
  TrackedFrame Process(const cv::Mat& frame);
  /// Processes the next frame of the stream, segmented already: `segmentation` is what a
  /// Segmenter made with options().segmentation, fed every frame of the stream in order, gives
  /// for `frame` (e.g. on another thread, while this one tracks the frame before, as `silpose
  /// track` does with --read-ahead), and `segment_ms` the time it took. The result is that of
  /// Process(frame); time_segment_ms is `segment_ms`, and time_ms includes it. Feed a stream
  /// through one of the two overloads only: the tracker's own segmenter does not see the frames
  /// given here. Throws as Process(frame), and if the mask is not a CV_8UC1 image of the frame's
  /// size or `segment_ms` is not a time (negative, NaN).
  TrackedFrame Process(const cv::Mat& frame, SegmentationResult segmentation, double segment_ms);

  /// Frames processed so far.
  int num_frames() const { return frame_; }
  const ViewDatabase& database() const { return database_; }
  const PinholeCamera& camera() const { return camera_; }
  const TrackerOptions& options() const { return options_; }
  /// The views' spectra the tracker matches with (made on first use, kept; shareable with a
  /// ViewMatcher of your own).
  const ViewSpectra& spectra() const { return *spectra_; }
  /// The particle filter (null in brute-force mode): its histories are what TrackSmoother
  /// (track/smoother.h) corrects earlier frames with.
  const ParticleFilter* filter() const { return filter_.get(); }

  /// An earlier frame of this stream (as Process returned it, with its segmentation mask)
  /// re-posed as the hypothesis `state` (object, database view, roll), as a smoother decides with
  /// hindsight. Returned unchanged when `state` is the frame's own hypothesis or the pose it
  /// reported (the same object, and a view within the filter's mode radius, modulo the object's
  /// rotational symmetry, of the filter's estimate or of the reported view), has no roll yet, or
  /// the frame had no measured silhouette or no filter estimate. Otherwise the result takes the
  /// state's object, view, roll and score, and the object's probability in that frame; the 6-DOF
  /// pose, its refinement and the mirror-twin check (TrackerOptions::mirror_twin_check, which
  /// may report the twin instead, as in Process), the fit (iou) and the confidence are computed
  /// again; the state stays what it was, except that tracking and ambiguous are decided again by
  /// the confidence threshold and the mirror-twin rule (track/confidence.h); and the runner-up
  /// becomes the frame's former hypothesis (its mass NaN). The filter, the state rules' memory and
  /// the stream position are not touched. Throws silpose::Error for a state outside the database,
  /// or a frame without its mask.
  TrackedFrame Revise(const TrackedFrame& frame, const PoseState& state);

 private:
  /// `feed_filter`: the refined rotation updates the filter's velocity (Process, not Revise).
  void Refine(const TriangleMesh& mesh, TrackedFrame* tracked, bool feed_filter);
  /// The motion start (TrackerOptions::refine_from_motion) for the frame being processed, posed
  /// at `tracked.pose` and its result's object and view; none if it does not apply.
  std::optional<Rigid3> MotionStart(const TrackedFrame& tracked) const;
  /// Keeps the reported refined pose of the frame just processed for the next frame's motion
  /// start (or forgets the last one: no refined pose).
  void RememberMotion(const TrackedFrame& tracked);
  /// Reports the refined pose `refined` (with the view and roll it means); `feed_filter`: it
  /// updates the filter's velocity. False, and nothing changes, if the pose puts the model's
  /// centre behind the camera.
  bool Adopt(const TriangleMesh& mesh, ContourRefinementResult refined, TrackedFrame* tracked,
             bool feed_filter);
  /// The screen of the mirror-twin and other-pose checks: whether `start`, another pose of
  /// `object`, fits the frame's outline before refinement (one step's robust RMS) well enough
  /// beside the reported pose's RMS `own_rms` to be refined.
  bool WorthRefining(int object, const FrameOutline& outline, const Rigid3& start, double own_rms);
  /// The mirror-twin check (TrackerOptions::mirror_twin_check) of a refined frame: each mirror
  /// twin pose of the reported pose (geometry/symmetry.h, MirrorTwinPose) that is another pose
  /// modulo the object's rotations is refined against the outline; the best one that fits
  /// clearly better (the fit arbitration's rule) than the reported pose, and than the reported
  /// hypothesis refined again from the twin's twin, is reported instead, `view` becomes its
  /// database view, and (feed_filter) the filter's mode moves to the twin: true. Otherwise
  /// nothing changes: false.
  bool FitMirrorTwins(TrackedFrame* tracked, bool feed_filter, int* view);
  /// The other-pose check (TrackerOptions::other_pose_check) of a refined frame at database
  /// view `view` in shell `shell`: the best far pose of the object (ScorePoseGap), if it scores
  /// within other_pose_score_gap, is posed and refined; if it fits far closer and clearly better,
  /// it is reported instead (the filter untouched) and `view` becomes its database view: true.
  /// Otherwise nothing changes: false.
  bool FitOtherPose(TrackedFrame* tracked, int* view, int shell);
  /// The object's symmetry transforms, coarsely sampled (made when first needed).
  const std::vector<Rigid3>& SymmetryTransformsOf(int object);
  Tracker(const ViewDatabase& database, const ViewSpectra* shared_spectra,
          const PinholeCamera& camera, const TrackerOptions& options);
  /// The pose (and refinement) of tracked->result's object as database view `view` in distance
  /// shell `shell` at the result's roll; status suffixes as Process documents.
  void EstimatePose(int view, int shell, bool feed_filter, TrackedFrame* tracked,
                    const std::function<double()>& lap);
  /// The filter's arbiter (ParticleFilter::SetArbiter): poses both hypotheses on the frame being
  /// processed, keeps them in posed_, and compares their fits.
  bool ArbitrateByFit(const FilterEstimate::Hypothesis& chosen,
                      const FilterEstimate::Hypothesis& challenger);
  /// The outline of `tracked`'s mask, built once per frame.
  const FrameOutline& Outline(const TrackedFrame& tracked);
  // The refinement's model of an object's mesh, made on first use and kept (it sorts the mesh's
  // edges: the fit arbitration may refine two objects in turn every frame).
  const ContourModel& Contour(int object);
  /// Canonical forms of the result's pose and runner-up (TrackerOptions::canonical_poses).
  void Canonicalise(FrameResult* result, bool runner_up) const;

  const ViewDatabase& database_;
  PinholeCamera camera_;
  TrackerOptions options_;
  /// The spectra made for this tracker alone (null when it shares someone else's), and the ones
  /// it matches with.
  std::unique_ptr<ViewSpectra> own_spectra_;
  const ViewSpectra* spectra_ = nullptr;
  std::unique_ptr<Segmenter> segmenter_;
  /// Process of a frame segmented outside (`segmented` not null) or by segmenter_.
  TrackedFrame ProcessFrame(const cv::Mat& frame, SegmentationResult* segmented, double segment_ms);
  std::unique_ptr<ParticleFilter> filter_;
  std::unique_ptr<ViewMatcher> matcher_;
  using MirrorTwin = TrackedFrame::MirrorTwin;
  /// The best-scoring mirror twin of the reported database view `view` farther than the filter's
  /// mode radius (modulo rotational symmetry); false if the object has no mirror plane, no such
  /// twin, or the frame's signature is flat.
  /// frame_spectrum_ must hold the frame's spectrum.
  bool ScoreMirrorTwin(int view, int shell, TrackedFrame* tracked, MirrorTwin* twin);
  /// ConfidenceFeatures::pose_score_gap of the reported database view `view` (shell `shell`) of
  /// `object`, from the frame's spectrum in frame_spectrum_: the best score (any roll) of the view
  /// and its neighbours within the filter's mode radius, minus the best of the other poses looked
  /// at: the 8 views farther than that radius (modulo symmetry) ranked best by the low-harmonic
  /// bound, and the local maxima of the view's own correlation over the roll whose rotation is
  /// farther. The best of those poses goes to `other` (view -1 when there is none).
  struct OtherPose {
    int view = -1;
    double roll_deg = 0.0;
  };
  /// Only for the frame being processed (Process: the other-pose check and Assess), whose
  /// spectrum frame_spectrum_ holds; its result is kept for the frame (pose_gap_cache_).
  double ScorePoseGap(int object, int view, int shell, OtherPose* other);
  /// ScorePoseGap's search itself.
  double ComputePoseGap(int object, int view, int shell, OtherPose* other);
  /// ScorePoseGap's last result, for the frame being processed (the other-pose check and the
  /// confidence ask for the same view when the check reports nothing). Process clears it when it
  /// makes a frame's spectrum; the frame index in the key guards the frames without one.
  struct PoseGapCache {
    int frame = -1;
    int object = -1;
    int view = -1;
    int shell = -1;
    double gap = 0.0;
    OtherPose other;
  };
  PoseGapCache pose_gap_cache_;
  /// The IoU and outline RMS (pixels) of the model at the frame's pose: the refinement's, or
  /// (refinement off) after one refinement step; unchanged (NaN) without a pose.
  void MeasureFit(TrackedFrame* tracked, double* iou, double* rms_px);
  void Assess(TrackedFrame* tracked, bool usable, std::span<const float> radii, int view,
              int shell);

  std::unique_ptr<TrackStateEstimator> state_;
  /// Per model: views alike by its rotational symmetries.
  std::vector<ViewEquivalence> equivalence_;
  /// Per object: its mesh's Centre() (a pass over the vertices), computed once.
  std::vector<Eigen::Vector3d> centres_;
  /// The spectrum of the frame being processed (its on-axis signature when it has one), made once
  /// per frame with a usable silhouette, for the filter's step, the view polish and the checks of
  /// Assess.
  SignatureSpectrum frame_spectrum_;
  /// The best-scoring view near the filter's estimate (TrackerOptions::polish_steps): moves
  /// `view`, `shell`, `roll_deg` and `score` there, each view in the shell the silhouette's
  /// apparent radius picks for it (0: the estimate's shell). `query` is the frame's spectrum.
  void PolishView(const SignatureSpectrum& query, int object, double apparent_radius, int* view,
                  int* shell, double* roll_deg, double* score);
  std::vector<int> polish_seen_;
  /// Per model: its symmetry transforms, coarsely sampled (SymmetryTransformsOf).
  std::vector<std::vector<Rigid3>> pose_gap_transforms_;
  std::vector<float> correlation_;
  std::vector<std::pair<float, int>> ranked_;
  std::vector<std::pair<float, int>> maxima_;
  int frame_ = 0;
  int measured_frames_ = 0;
  /// Area of the last usable silhouette, pixels (0 before the first).
  double previous_area_px_ = 0.0;
  // Fit arbitration: the frame being processed, the hypotheses posed on it, and the time spent.
  TrackedFrame* current_ = nullptr;
  struct Posed {
    int object = -1;
    int view = -1;
    TrackedFrame frame;
  };
  std::vector<Posed> posed_;
  double arbitration_ms_ = 0.0;
  // The outline of frame outline_frame_'s mask (Outline).
  std::optional<FrameOutline> outline_;
  // Per object, made by Contour on first use.
  std::vector<std::unique_ptr<ContourModel>> contours_;
  /// The last reported refined pose, for the motion start (refine_from_motion).
  struct MotionPrior {
    int object = -1;
    int64_t frame = -1;
    /// Refined camera_from_object rotation of the on-axis camera.
    Eigen::Matrix3d on_axis = Eigen::Matrix3d::Identity();
    /// Its rotation since the frame before (identity if unknown or a jump).
    Eigen::Matrix3d change = Eigen::Matrix3d::Identity();
  };
  std::optional<MotionPrior> motion_prior_;
  int64_t outline_frame_ = -1;
  const uint8_t* outline_data_ = nullptr;
};

}  // namespace silpose
