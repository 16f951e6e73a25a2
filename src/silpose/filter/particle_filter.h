#pragma once
// The particle filter over (object, view, roll) of the paper (sections 3, 4.1, 4.3, 5.1): it
// identifies the object and follows its pose through a sequence of silhouettes from no initial
// pose, and rides out frames whose silhouette is missing or wrong.
//
// State. A particle is one hypothesis: an object (model index in the database), a view of that
// object's view sphere (database view index), a camera roll in degrees (geometry/view_frame.h),
// a weight, and a handle to its pose history. Weights are normalised over all particles; an
// object's mass W_o is the sum of its particles' weights (its posterior probability).
//
// Start. particles_per_object particles per object, views uniform at random over the sphere, equal
// weights. The roll starts unknown: a particle's first measurement takes the global correlation
// peak (the best roll for its view), which costs one full peak search but guesses nothing; after
// that the roll is tracked (below). With guided_start (default; not in the paper) the first frame
// with a silhouette also moves one particle of every object to that object's best view.
//
// One frame (Step; Predict when the caller has no usable silhouette):
//  1. Prediction (every frame but the first), the motion model.
//     - Object identity: W_o <- (1 - g) W_o + g / O (g = object_switch_probability, O objects),
//       each particle's weight scaled with its object's mass: the object in view may change.
//       Not in the paper: without it an object absent for a while keeps a mass so small that it
//       needs as many frames to come back.
//     - View and roll (MotionModel::kAdaptive, the default). Objects turned by hand move at 0 to
//       30 degrees per frame, pause, turn back and jump (cuts); the paper's one-neighbour step
//       (about 6 degrees) cannot follow them. The camera orientation R (camera_from_object, the
//       on-axis camera of view and roll) is moved in SO(3) and then snapped to the nearest view:
//         R' = Exp(n) Exp(w) R   for a share velocity_share of the particles (constant velocity),
//         R' = Exp(n) R          for the others (the object may have stopped or be turning back),
//       with w the filter's angular velocity (below) and n ~ N(0, sigma^2 I) a rotation vector
//       of sigma = rotation_noise_deg + rotation_noise_speed_factor |w|: a random walk whose
//       step adapts to the speed. The nearest database view to R's view direction is found by
//       greedy descent over the neighbour graph from the particle's view, and the roll is the
//       one of R' at that view (TransportRoll), so the roll is carried along exactly.
//       The velocity w is a state of the filter: after each measured frame the rotation between
//       the last two estimates, R_t R_{t-1}^T (as a rotation vector, in the camera frame), is
//       averaged into w with weight 1 - velocity_smoothing; a change larger than max_speed_deg
//       is taken as a cut and resets w to 0. The tracker may pass the refined (continuous) pose
//       instead of the grid estimate (ObserveRotation). With probability jump_probability a
//       particle instead jumps to a uniformly random view (roll unknown again).
//       MotionModel::kNeighbour is the paper's model: with stay_probability the same view, else
//       one of the view's neighbours (ViewSphere::Neighbours) with the roll transported along
//       the edge (TransportRoll, one constant per directed edge) plus Gaussian noise of
//       roll_noise_deg; jumps as above.
//     - Data-driven proposal (mixture proposal, data_driven_proposal, default on): a share of the
//       particles is drawn from the frame's best database views instead of the motion model.
//       Every object gets one particle at its best view for the frame, and the most probable
//       object proposal_views of them (its best views, ranked as in guided reseeding below and
//       correlated exactly); each replaces the object's lightest particle. Its weight is the
//       prior the motion model gives that place, so the proposal cannot overrule the sequence's
//       evidence: the mean weight of the object's predicted particles on that view and its
//       neighbours, but at least proposal_prior_floor times the object's mean particle weight
//       (what lets a cut or a lost track be picked up within a frame or two). With a proposal,
//       the view of a fast-moving object is in the particle set in the frame it is seen, while
//       an ambiguous frame (a mirror-twin view, a degraded silhouette) cannot pull the estimate
//       away: the twin's proposal starts with little weight and has to keep winning.
//       The guided start below is the same proposal at the first silhouette.
//       Cost: ranking an object's views and correlating its best ranked ones touches all of its
//       views, so the proposal is amortised over frames: the most probable object is proposed
//       every frame, the others proposal_objects_per_frame at a time in turn, and all of them at
//       once only when the particles lost the frame (the best particle's score is below
//       proposal_confident_score, or fell by more than proposal_drop since the previous
//       frame's estimate: a cut, another object, a degraded frame) and at the first silhouette.
//       An object whose best view scored within proposal_drop of the tracked object's best
//       particle at its last proposal (a look-alike, a challenger) is proposed every frame.
//  2. Measurement (Step only). Each particle's similarity s is the circular correlation of the
//     frame with its (object, view) reference at the nearest local peak within roll_search_deg
//     of its predicted roll (CircularCorrelator::LocalPeaks), and the particle's roll moves to
//     that peak: the roll stays coherent from frame to frame, and a symmetric shape's other peak
//     cannot make it jump. A particle without a roll takes the global peak. All particles on one
//     (object, view) share one correlation (one short inverse FFT) and each distinct peak's
//     refinement. The roll window grows with the filter's speed (roll_search_deg + |w|). Each
//     (object, view) is correlated in the distance shell the frame's apparent size implies for it
//     (ViewDatabase::ChooseShell; shell 0 when no size is given). Views whose database silhouette
//     was unusable score -1. A frame signature
//     without variance (after smoothing) carries no information and changes nothing.
//     Likelihood, per particle: L = exp(lambda (s - s_best)) + f, then w <- w L, normalised;
//     s_best = the frame's best particle score, lambda = likelihood_sharpness = 100,
//     f = likelihood_floor = 0.03. Up to normalisation this is exp(lambda (s - 1)) floored at f
//     times the best particle's value: a correlation gap of d between two hypotheses weighs
//     exp(lambda d), but no single frame can change the ratio of two weights by more than
//     1 / f = 33. Why, with numbers from synthetic sequences (below):
//       - the scale: on clean frames the right view (or a neighbour) beats the best view
//         3 spacings away by a median of 0.025 (5th percentile 0.009) and the best view of
//         another object by 0.077 (5th percentile 0.043); 1 - s at the nearest view has median
//         0.006, 95th percentile 0.025. lambda = 100 turns the median wrong-view gap into a
//         factor e^2.5 per frame and the wrong-object gap into e^7.7, and s - 1 ~ -0.01 of a
//         right view costs little;
//       - the floor: on a badly degraded frame (erosion by a 25 px disc, or a box over a quarter
//         of the silhouette) the right object's best view scores a median 0.08 below another
//         object's, so without a floor a few such frames wipe out the right hypothesis
//         (ablation below). An absolute floor (all scores below 0.9 alike) was tried and
//         rejected: when no particle is near the truth yet, every score is below it, the
//         weights stay flat and the filter never climbs out (a sequence stuck for 80 frames).
//     Tuning (5 sample models, 1000 views, 512 px database; 10 orbits per model at 1 degree per
//     frame with a roll drift of 0.3 degree per frame, 640 x 480 frames at another distance and
//     focal length; 3 seeds; 80 frames; figures from frame 20 on; pose error = distance between
//     unit view directions, rotation error = angle between camera rotations; brute force =
//     ViewMatcher top 1 per frame):
//         lambda                       25      50      100     200     400
//       clean:  pose error            0.0614  0.0600  0.0597  0.0596  0.0600
//               rotation error (deg)  3.75    3.67    3.66    3.65    3.70
//               first right frame     5.7     2.6     3.7     2.2     1.8
//       20% degraded, good frames:    0.0641  0.0609  0.0604  0.0601  0.0605
//               degraded frames       0.150   0.144   0.142   0.134   0.129
//       brute force: 0.0638 (4.03 deg) on clean frames; on degraded frames right object 55 %,
//       pose error 0.57. The filter: right object 100 % on clean frames, 99.9 % on degraded ones.
//       lambda is flat from 50 to 200; 100 sits in the middle. Ablations at lambda = 100, 20 %
//       degraded: floor 0 -> right object 95.0 %, pose error 0.110, 27 of 150 runs wrong at the
//       end; floor 0.01 / 0.1 -> 0.0605 / 0.0603; no guided reseeding -> 0.0692 and 48 frames
//       off by more than 0.3 (vs 1); estimate by heaviest particle -> degraded frames 71 % right
//       object, pose error 0.54.
//  3. Estimate (EstimateRule). Cut rule first (cut_score_gap): a particle that matches the frame
//     cleanly (score >= cut_min_score) and far better than the rule's choice (by cut_score_gap) is
//     reported and gets half of the total weight: after a cut the posterior would otherwise need
//     a frame or two, against the likelihood floor, to move to the proposal. Then, by default the
//     object of largest mass, in it the view whose neighbourhood (the view and its neighbours)
//     holds the most weight, and in that neighbourhood the particle of largest weight, which gives
//     view, roll and score. The single heaviest particle (kHeaviestParticle, the paper's rule)
//     follows a degraded frame: one badly segmented frame makes a lone look-alike particle the
//     heaviest while most of the mass stays near the truth. Also reported: every object's mass, the
//     particle counts, ESS = 1 / sum(w_i^2) over the normalised weights (before resampling).
//  4. History: every particle gets a history node for this frame (below).
//  5. Resampling (sampling importance resampling, systematic / low-variance) when
//     ESS < resample_threshold * N, N = current number of particles (paper: 2N/3, after
//     Doucet). Stratified by object, it keeps every object's mass: object o gets n_o particles
//     drawn by systematic resampling from its own particles, each with weight W_o / n_o, so
//     resampling never changes the posterior over objects, only how finely each object's pose
//     posterior is sampled. n_o:
//       - fixed count (default, as in the paper's experiments): a systematic draw of
//         particles_per_object * O over all particles gives c_o (proportional to W_o);
//         n_o = max(c_o, min_particles_per_object), the floor's extra particles taken from the
//         object with the most, so the total stays particles_per_object * O;
//       - adaptive (KLD-sampling, Fox 2003; paper eq. 4): a systematic draw of N (the current
//         total) gives c_o and k_o = number of K-means bins (ViewSphere::bin_of_view) hit by
//         object o's draws; n_o = clamp(KldParticleCount(k_o, kld_epsilon, kld_delta),
//         min_particles_per_object, max_particles_per_object) if c_o > 0, else the floor.
//     Reseeding, after the draw (the reseeded particles keep their history): an object with
//     c_o < min_particles_per_object is dormant (its mass alone would not keep the floor), and
//     reseed_fraction of its particles move to uniformly random views (roll unknown), so an
//     object that was dropped, or appears later, is searched for over its whole sphere. With
//     guided_reseeding (default; not in the paper), one particle of every object moves to the
//     object's best view for this frame: its views ranked by the low-harmonic part (32
//     harmonics) of the spectral bound of match/circular_correlator.h, and again by that part
//     plus the product of the energies beyond it (TailEnergyRoot: a bound over all harmonics,
//     which finds the views of a nearly round outline, whose first harmonics carry little), the
//     guided_candidates best of each ranking correlated exactly. This is a data-driven proposal: it
//     costs about 0.45 ms per frame for 20 objects x 1000 views, and it is what makes
//     re-identification after an object switch and escape from a look-alike mode quick (object
//     switch on the sample models, view within 0.25: mean 4.1 frames, at most 16, against 11.8 and
//     39 without). The filter still decides: the guided particle must keep winning over the
//     following frames to take over.
//
// Pose history, bounded memory. Each particle's history is a chain of immutable
// HistoryNode {frame, object, view, roll, score} -> parent, held by shared pointers. Resampling
// copies the pointer, not the chain, so copies share their common ancestry and the tree of live
// nodes coalesces. Resampling is stratified by object, so lineages merge within an object only:
// the live nodes grow with the frame count T along one common trunk per object (one node per
// frame and object, about 80 bytes with its control block and allocation: 20 objects cost
// 1.6 kB per frame, 160 MB per 100 000 frames), plus roughly N times the few frames back to the
// common ancestors (Jacob, Murray, Rubenthaler 2015: T + O(N log N) expected, per object), not
// N * T. Between two resamplings every particle extends its own chain. max_history_frames > 0
// cuts the trunks: every that many frames the links older than the last max_history_frames
// frames are dropped, so memory is bounded and histories hold between max_history_frames and
// 2 * max_history_frames - 1 frames; use it for live video. Chains are destroyed iteratively
// (HistoryNode's destructor), so a history of any length is freed without deep recursion.
// keep_history = false keeps none (BestHistory, MostLikelyHistory and SmoothedState then find
// nothing): one node made and one chain released per particle and frame is about a tenth of the
// step (docs/PERFORMANCE.md), and nothing else in the filter reads the histories, so the
// estimates are the same with and without them.
//
// Determinism and threads: the filter draws from its own std::mt19937_64 seeded with
// ParticleFilterOptions::seed; the same database, options and frames give the same estimates (on
// one standard library: the distributions are libstdc++'s). No global state. A filter is not
// thread-safe (one per thread); filters may share the database and the ViewSpectra. History
// nodes must not be shared between threads.
//
// Cost per frame (bench/filter_bench.cc): one short inverse FFT per distinct (object, view) among
// the particles, one Newton refinement per distinct local peak, one global peak search per
// particle without a roll, one history node per particle, and with guided reseeding one ranking
// of every object's views. 20 objects x 60 particles, 1000 views, steady tracking, signature
// extraction from a 640 x 480 mask (0.21 ms) included, one core: 1.77 ms (1.36 ms without guided
// reseeding); the first frames, when no particle has a roll yet, about 2.4 ms each.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "silpose/geometry/symmetry.h"
#include "silpose/geometry/view_sphere.h"
#include "silpose/match/circular_correlator.h"
#include "silpose/match/view_matcher.h"

namespace silpose {

/// How particles move between frames (step 1 above).
enum class MotionModel : uint8_t {
  /// Rotation random walk with an adaptive step and a velocity state, snapped to the view grid.
  kAdaptive = 0,
  /// The paper's: stay or move to one neighbouring view.
  kNeighbour = 1,
};

/// Which particle a frame's estimate reports (step 3 above).
enum class EstimateRule : uint8_t {
  /// Object of largest mass, then the view neighbourhood of largest weight, then its heaviest
  /// particle.
  kMostProbableArea = 0,
  /// The heaviest particle (the paper's rule).
  kHeaviestParticle = 1,
};

struct ParticleFilterOptions {
  /// Particles per object at the start, and with a fixed count the total per object ever after
  /// (particles_per_object * number of objects in all). Paper: 60 ("starting from 60 particles,
  /// the results do not improve drastically", 5.1). >= 1.
  int particles_per_object = 60;

  /// lambda of the likelihood exp(lambda (s - 1)), s the correlation in [-1, 1]; tuned, see
  /// step 2 above. > 0.
  double likelihood_sharpness = 100.0;
  /// f: a particle's likelihood is at least f times the frame's best particle's, so one frame
  /// changes a ratio of weights by at most 1 / f. In [0, 1]; 0 = the plain exponential.
  double likelihood_floor = 0.03;

  /// Resample when ESS < resample_threshold * N (paper: 2/3). In [0, 1]; 0 never resamples,
  /// 1 resamples unless all weights are equal.
  double resample_threshold = 2.0 / 3.0;

  /// Motion model (step 1 above).
  MotionModel motion_model = MotionModel::kAdaptive;
  /// kAdaptive: rotation noise per axis when the object is still, degrees (>= 0), and its growth
  /// with the speed |w| (>= 0): sigma = rotation_noise_deg + rotation_noise_speed_factor |w|.
  double rotation_noise_deg = 3.0;
  double rotation_noise_speed_factor = 0.5;
  /// kAdaptive: share of the particles moved with the velocity w, in [0, 1]; the others assume
  /// the object stopped.
  double velocity_share = 0.5;
  /// kAdaptive: weight of the old velocity in its update, in [0, 1).
  double velocity_smoothing = 0.5;
  /// kAdaptive: a change of camera orientation between two frames larger than this (degrees) is
  /// a cut, not motion: the velocity is reset. > 0.
  double max_speed_deg = 45.0;
  /// Mixture proposal from the frame's best views (step 1 above).
  bool data_driven_proposal = true;
  /// Particles of the most probable object placed at its best views each frame (>= 1; other
  /// objects get one).
  int proposal_views = 3;
  /// Least weight of a proposed particle, relative to its object's mean particle weight, in
  /// (0, 1].
  double proposal_prior_floor = 0.2;
  /// Objects besides the most probable one proposed per frame, in turn (>= 0); every object is
  /// proposed in a frame the particles lost (below). At least the number of objects minus one:
  /// every object every frame.
  int proposal_objects_per_frame = 4;
  /// The particles lost the frame when its best particle scores below proposal_confident_score
  /// or more than proposal_drop below the previous frame's estimate (scores in [-1, 1]); then
  /// every object is proposed. An object whose best view came within proposal_drop of the
  /// tracked object's best particle is proposed every frame. Clean silhouettes score 0.975 or
  /// better at their nearest view (see the cut rule below).
  double proposal_confident_score = 0.97;
  double proposal_drop = 0.02;
  /// Cut rule (step 3): when a particle scores at least cut_min_score and at least
  /// cut_score_gap above the particle the estimate rule chose, the frame is taken as a cut: that
  /// particle is reported and given half of the total weight. Clean silhouettes match their
  /// nearest view at 0.975 or better (95th percentile of 1 - s: 0.025), and a view five spacings
  /// away scores about 0.05 lower; a mirror twin scores the same, and a degraded frame scores
  /// below cut_min_score, so neither triggers it. cut_score_gap 0 disables the rule.
  double cut_min_score = 0.97;
  double cut_score_gap = 0.05;
  /// Motion model kNeighbour: probability that a particle keeps its view in one frame; otherwise
  /// it moves to a uniformly chosen neighbour. In [0, 1]. At 1 degree per frame the true nearest
  /// view changes every ~6 frames (1000 views, 6.4 degree spacing). Insensitive with guided
  /// reseeding (tuning set, 20 % degraded: pose error 0.0605 / 0.0604 / 0.0603 for 0.3 / 0.5 /
  /// 0.7); without it 0.3 and 0.7 were worse than 0.5 (0.070 and 0.067 against 0.061).
  double stay_probability = 0.5;
  /// Motion model: probability that a particle jumps to a uniformly random view of its object
  /// (roll unknown again) instead of the above. In [0, 1]. Without guided reseeding this is what
  /// gets particles out of a look-alike mode (pose error 0.092 at 0 against 0.069 at 0.03, 20 %
  /// degraded); with it, it changes nothing measurable (0.0604 either way) and costs about
  /// 0.08 ms per frame for 1200 particles (global peak searches): cheap insurance.
  double jump_probability = 0.03;
  /// kNeighbour: standard deviation of the Gaussian roll noise added in each prediction, degrees.
  /// >= 0.
  /// The measurement moves the roll to the local peak anyway: 0.5 and 2 gave 0.0602 and 0.0601.
  double roll_noise_deg = 1.0;
  /// Half-width of the window around the predicted roll in which the measurement looks for the
  /// nearest correlation peak, degrees. In [0, 180]. Wide enough for the roll change of a frame
  /// plus the noise; 5 and 20 gave 0.0600 and 0.0602 (20 was slower: more climbing).
  double roll_search_deg = 10.0;
  /// g: probability per frame that the object in view changes (mixing of object masses, step 1).
  /// In [0, 1).
  double object_switch_probability = 0.01;

  /// Floor of particles per object after resampling (both modes), so that no object is dropped
  /// for good. In [0, particles_per_object].
  int min_particles_per_object = 10;
  /// Fraction of a dormant object's particles moved to uniformly random views at each
  /// resampling. In [0, 1].
  double reseed_fraction = 0.5;
  /// At each resampling one particle of every object moves to the object's best view for the
  /// frame (step 5). Not needed with data_driven_proposal, which does the same every frame (it is
  /// skipped then). Off (and no proposal): the paper's filter, with uniform reseeding only.
  bool guided_reseeding = true;
  /// At the first frame with a silhouette, one particle of every object starts at the object's
  /// best view for it (found as in guided reseeding) instead of a random one, so that every
  /// object competes with its best hypothesis from the start. Without it an object whose random
  /// start views all miss loses the first frames to a look-alike (eval tracking, 5 asymmetric
  /// models: 25 of 9000 frames, all in the first 12 frames of a run, went to a wrong object).
  bool guided_start = true;
  /// Views correlated exactly per object for guided reseeding and the proposal, the best ranked
  /// by each of the two rankings (the same view once). >= 1.
  int guided_candidates = 4;

  /// KLD-sampling (paper 4.3): adapt the particle count of each object at every resampling.
  /// Off by default, as in the paper's experiments.
  bool adaptive = false;
  /// KLD bound epsilon (paper: 0.01). > 0.
  double kld_epsilon = 0.01;
  /// KLD confidence: the bound holds with probability 1 - kld_delta; z_{1-delta} is its standard
  /// normal quantile (delta 0.01 -> z = 2.326, the usual choice in Fox 2003). In (0, 0.5).
  double kld_delta = 0.01;
  /// Cap of particles per object in adaptive mode. >= particles_per_object. With K = 10 bins and
  /// epsilon = 0.01 the KLD count is 0 for one bin (the floor applies), 330 for two and 1085 for
  /// ten, so an object gets either the floor or (nearly) this cap: a converged object whose
  /// particles straddle a bin border costs the cap. (On the sample models the mean total was
  /// 259 against 300 with a fixed count.)
  int max_particles_per_object = 300;
  /// Adaptive mode: the floor of a dormant object, one whose probability (after the frame's
  /// weighting) is below dormant_probability, >= 0 (at most min_particles_per_object is used);
  /// the others keep min_particles_per_object. With many objects the floors are most of the
  /// particles (at 200 objects 199 dormant ones x 10 of about 2300), while a dormant object needs
  /// particles only to be found again, which the data-driven proposal and guided reseeding do with
  /// one (they place the object's best views for the frame). Equal to min_particles_per_object: one
  /// floor for all.
  int dormant_particles_per_object = 1;
  /// Below this probability an object is dormant (adaptive mode), in [0, 1].
  double dormant_probability = 0.01;

  EstimateRule estimate_rule = EstimateRule::kMostProbableArea;
  /// Radius of a posterior mode (FilterEstimate::mode_mass, runner_up), degrees of view
  /// direction, in (0, 90].
  double mode_radius_deg = 15.0;

  /// Keep each particle's pose history (see the file comment), which smoothing reads
  /// (BestHistory, MostLikelyHistory, SmoothedState; track/smoother.h). Off: no history, the
  /// same estimates, a cheaper step.
  bool keep_history = true;
  /// Keep about this many frames of history (see the file comment); 0 = all.
  int64_t max_history_frames = 0;

  /// Seed of the filter's random generator.
  uint64_t seed = 1;

  bool Check(std::string* error = nullptr) const;
};

/// One particle's state in one frame: an entry of a pose history.
struct PoseState {
  /// Frame number, 0 for the first Step or Predict.
  int64_t frame = 0;
  int object = -1;
  int view = -1;
  /// Camera roll, degrees in (-180, 180]; 0 while !roll_known.
  double roll_deg = 0.0;
  /// False until the particle's first measurement.
  bool roll_known = false;
  /// Correlation at the particle's roll in its last measurement (this frame's if measured), in
  /// [-1, 1]; 0 before any.
  float score = 0.0f;
  /// The frame was measured and weighed (Step with a signature that is not flat), so `score` is
  /// this frame's.
  bool measured = false;
};

/// An immutable node of the history tree: a state and the node of the frame before (null at the
/// first frame, or where max_history_frames cut the chain).
class HistoryNode {
 public:
  HistoryNode(const PoseState& state, std::shared_ptr<const HistoryNode> parent);
  /// Frees the chain of parents this node alone holds, iteratively (no recursion).
  ~HistoryNode();
  HistoryNode(const HistoryNode&) = delete;
  HistoryNode& operator=(const HistoryNode&) = delete;

  const PoseState& state() const { return state_; }
  const HistoryNode* parent() const { return parent_.get(); }

 private:
  friend class ParticleFilter;
  PoseState state_;
  /// Reset only by ParticleFilter when max_history_frames cuts old history.
  mutable std::shared_ptr<const HistoryNode> parent_;
};

struct Particle {
  int object = -1;
  int view = -1;
  /// Degrees in (-180, 180]; meaningless while !roll_known.
  double roll_deg = 0.0;
  bool roll_known = false;
  /// Correlation in the last measurement.
  float score = 0.0f;
  /// Normalised over all particles.
  double weight = 0.0;
  /// This particle's history up to the last frame (null before the first).
  std::shared_ptr<const HistoryNode> history;
};

/// One hypothesis of the filter: a particle's object, view, the distance shell the view was
/// measured in (ViewDatabase::ChooseShell for the frame's size), roll (0 while unknown) and last
/// correlation score.
struct FilterHypothesis {
  int object = -1;
  int view = -1;
  int shell = 0;
  double roll_deg = 0.0;
  bool roll_known = false;
  float score = 0.0f;
};

/// What one frame gave. Its FilterHypothesis fields are the particle the estimate rule chose
/// (ParticleFilterOptions::estimate_rule); `weight` is that particle's weight.
struct FilterEstimate : FilterHypothesis {
  using Hypothesis = FilterHypothesis;

  int64_t frame = 0;
  /// False for a prediction-only frame (no usable silhouette: Predict).
  bool measured = false;
  double weight = 0.0;
  /// The filter's angular speed |w| after this frame, degrees per frame (kAdaptive).
  double speed_deg = 0.0;
  /// Particles placed by the data-driven proposal in this frame.
  int proposed = 0;
  /// The cut rule fired (ParticleFilterOptions::cut_score_gap).
  bool cut = false;
  /// The arbiter was asked (ParticleFilter::SetArbiter), and whether it took the challenger.
  bool arbitrated = false;
  bool challenger_won = false;
  /// Each object's share of the total weight (sums to 1), after the measurement.
  std::vector<double> object_probability;
  /// Particles per object during this frame's measurement (before resampling).
  std::vector<int> particles_per_object;
  /// Total particles during the measurement, and after this frame's resampling.
  int num_particles = 0;
  int num_particles_after = 0;
  /// 1 / sum(w^2) over the normalised weights, before resampling.
  double effective_particles = 0.0;
  bool resampled = false;
  /// The posterior's modes after the measurement (before resampling), for the tracker's
  /// confidence and ambiguity (docs/confidence.md). mode_mass: the share of the total weight on
  /// particles of the estimate's object whose view lies within mode_radius_deg of the estimate's
  /// (modulo the object's rotational symmetries, geometry/symmetry.h ViewEquivalence).
  double mode_mass = 0.0;
  /// The strongest other hypothesis: the heaviest particle outside that mode (another object, or
  /// a view of the same object farther than mode_radius_deg: e.g. a mirror twin) and the share of
  /// the weight within mode_radius_deg of it (same object, outside the first mode). object = -1
  /// and mass = 0 when every particle is in the first mode.
  struct RunnerUp : Hypothesis {
    double mass = 0.0;
  } runner_up;
  /// The particle that scored highest on this frame (measured frames; a proposal, typically):
  /// what a search of the frame alone would report among the particles. object = -1 when not
  /// measured.
  Hypothesis top;
};

class ParticleFilter {
 public:
  /// `sphere` is the database's view sphere and `spectra` its views' spectra; both must outlive the
  /// filter. Throws silpose::Error for invalid options or a sphere that does not match the spectra.
  ParticleFilter(const ViewSphere& sphere, const ViewSpectra& spectra,
                 const ParticleFilterOptions& options = {});
  /// The filter keeps references to the sphere and the spectra: temporaries are refused.
  ParticleFilter(ViewSphere&&, const ViewSpectra&, const ParticleFilterOptions& = {}) = delete;
  ParticleFilter(const ViewSphere&, ViewSpectra&&, const ParticleFilterOptions& = {}) = delete;
  ParticleFilter(ViewSphere&&, ViewSpectra&&, const ParticleFilterOptions& = {}) = delete;
  ~ParticleFilter();
  ParticleFilter(const ParticleFilter&) = delete;
  ParticleFilter& operator=(const ParticleFilter&) = delete;

  /// One frame with a measurement: `frame` must come from a CircularCorrelator of the spectra's
  /// length and CorrelationOptions (ViewSpectra::options()), e.g. correlator().Transform(radii).
  /// Throws silpose::Error for a spectrum of another length.
  /// `apparent_radius`: the frame silhouette's mean radius / focal length in the on-axis virtual
  /// camera (pose/on_axis.h), which chooses each view's distance shell; 0 = unknown (shell 0).
  FilterEstimate Step(const SignatureSpectrum& frame, double apparent_radius = 0.0);
  /// Same, from a signature's radii (PolarSignature::radii).
  FilterEstimate Step(std::span<const float> radii, double apparent_radius = 0.0);
  /// Replaces the last estimate's camera orientation (camera_from_object of the on-axis camera,
  /// as CameraFromObjectRotation(view, roll) gives it) by a better one, e.g. a refined pose, for
  /// the velocity update of the next frame. Call after Step, before the next frame.
  void ObserveRotation(const Eigen::Matrix3d& camera_from_object_on_axis);
  /// One frame without a measurement (no usable silhouette): prediction, estimate, history.
  FilterEstimate Predict();
  /// Moves a mode to its mirror twin, for when evidence the filter does not have (the tracker's
  /// fit of both poses to the frame's outline) shows that the frame is the twin of the filter's
  /// choice. `model_reflection` is the linear part of the object's mirror (I - 2 n n^T, model
  /// frame). Every particle of `object` within mode_radius_deg of `view` (modulo symmetry) is
  /// moved: its on-axis camera rotation R becomes F R A (F = diag(1, 1, -1), A the reflection),
  /// which puts it at the database view nearest the twin direction -A d, with the roll that
  /// rotation has (a particle without roll keeps none). The weights stay. The velocity and the
  /// last estimate's rotation are reflected the same way, so that the next ObserveRotation (the
  /// twin's refined pose) continues the motion. Call after Step, before the next frame.
  void ReflectMode(int object, int view, const Eigen::Matrix3d& model_reflection);

  /// Decides between two hypotheses of a measured frame by evidence the filter does not have
  /// (the tracker fits both models to the frame's outline): true if `challenger` explains the
  /// frame better than `chosen`. See SetArbiter.
  using Arbiter = std::function<bool(const FilterEstimate::Hypothesis& chosen,
                                     const FilterEstimate::Hypothesis& challenger)>;
  /// With an arbiter, in every measured frame in which the particle that scored highest lies
  /// outside the mode of the estimate rule's choice (another object, or a view farther than
  /// mode_radius_deg modulo symmetry) and scored higher than the choice, the arbiter is asked;
  /// if it prefers the challenger, the frame is treated as a cut (step 3): the challenger is
  /// reported and given half of the total weight. Without one (the default), only the scores
  /// decide. The arbiter is called from Step, on its thread.
  void SetArbiter(Arbiter arbiter) { arbiter_ = std::move(arbiter); }

  const std::vector<Particle>& particles() const { return particles_; }
  int num_objects() const { return num_objects_; }
  /// Frames processed so far.
  int64_t num_frames() const { return frame_; }
  /// The correlator the filter measures with (spectra's options); use it to transform frames.
  CircularCorrelator& correlator() { return correlator_; }

  /// The history of the particle the last estimate reported, one state per frame, oldest first
  /// (from frame 0, or as far as max_history_frames keeps). Empty before the first frame.
  std::vector<PoseState> BestHistory() const;
  /// Of the current particles' histories (those of `object`'s particles if object >= 0), the one
  /// that explains the measured frames from `from_frame` on best: the highest sum over those
  /// frames of the log-likelihood the filter weighs with, log(exp(lambda (s - s_best)) + f)
  /// (likelihood_sharpness, likelihood_floor), s_best the best score among these histories in
  /// that frame. The history the last estimate reported wins ties. Oldest first, as BestHistory;
  /// empty if there is none. This is the most likely of the sampled trajectories (the motion
  /// prior is the same for all: they were drawn from it): unlike the last estimate's, it does not
  /// hang on the last frame alone. A particle's history never leaves its object (resampling and
  /// proposals are per object), so no history follows a change of object: give `object` to
  /// smooth the views of one object. Costs one visit of every history node from `from_frame` on.
  std::vector<PoseState> MostLikelyHistory(int64_t from_frame = 0, int object = -1) const;
  /// The fixed-lag smoothing estimate of an earlier frame: the particles' ancestors in `frame`
  /// (the states their histories hold for it), weighted by the particles' current weights, form
  /// the smoothed posterior of that frame given every frame since; of them, in `object` (if >= 0:
  /// only that object's particles count; else the object with the most weight), the state at the
  /// centre of the heaviest mode: the view whose neighbourhood (views within mode_radius_deg modulo
  /// rotational symmetry) holds the most weight, its own weight breaking ties. As histories never
  /// leave their object, give the object the frame was reported as when the object may have changed
  /// since. nullopt if no history reaches `frame` (not yet processed, or cut by
  /// max_history_frames). Costs one walk of each particle's history back to `frame`.
  std::optional<PoseState> SmoothedState(int64_t frame, int object = -1) const;
  /// The history of one particle, oldest first.
  static std::vector<PoseState> History(const Particle& particle);
  /// Number of distinct history nodes reachable from the particles and the best history
  /// (O(that number); for tests and diagnostics).
  int64_t CountLiveHistoryNodes() const;

 private:
  FilterEstimate Advance(const SignatureSpectrum* frame);
  void PredictParticles();
  /// `velocity_step`: the rotation of the velocity w over one frame (null if w is zero).
  void PredictAdaptive(Particle& particle, double sigma_rad, const Eigen::Matrix3d* velocity_step,
                       std::uniform_real_distribution<double>& uniform,
                       std::normal_distribution<double>& normal);
  /// Where each object's particles start in particles_ (sorted by object), and the end.
  std::vector<size_t> ObjectRanges() const;
  int NearestView(int start, const Eigen::Vector3d& direction) const;
  /// The mixture proposal; `all_objects`: every object, else the most probable one and the
  /// next proposal_objects_per_frame in turn.
  int Propose(const SignatureSpectrum& frame, bool all_objects);
  /// Whether the scored particles lost the frame (see proposal_confident_score).
  bool ParticlesLostFrame() const;
  void UpdateVelocity(const FilterEstimate& estimate);
  void ApplyVelocityObservation(const Eigen::Matrix3d& change_rotation);
  /// Measurement: ScoreParticles correlates (score and roll), WeightParticles applies the
  /// likelihood to the scores.
  void ScoreParticles(const SignatureSpectrum& frame);
  void WeightParticles(const SignatureSpectrum& frame);
  void Resample(const std::vector<double>& object_mass, const SignatureSpectrum* frame);
  struct CandidateView {
    int view = -1;
    double roll_deg = 0.0;
    float score = 0.0f;
  };
  CandidateView BestViewOfObject(const SignatureSpectrum& frame, int object);
  /// The `count` best views of `object` for the frame, best first (exact scores of the
  /// guided_candidates best ranked; at most that many).
  std::vector<CandidateView> BestViewsOfObject(const SignatureSpectrum& frame, int object,
                                               int count);
  int ShellOf(int object, int view) const;
  void AnalyseModes(FilterEstimate* estimate) const;
  bool RankingReady() const { return ranking_harmonics_ > 0; }
  void CutHistory(int64_t oldest_kept_frame);
  Particle FreshParticle(int object);
  size_t MostProbableAreaParticle(const FilterEstimate& estimate);

  const ViewSphere& sphere_;
  const ViewSpectra& spectra_;
  /// Per object: views alike by its symmetries (AnalyseModes).
  std::vector<ViewEquivalence> equivalence_;
  ParticleFilterOptions options_;
  int num_objects_ = 0;
  int num_views_ = 0;
  CircularCorrelator correlator_;
  std::mt19937_64 rng_;
  Arbiter arbiter_;
  int64_t frame_ = 0;
  bool measured_once_ = false;
  /// Score of the last measured frame's estimate (proposal schedule), and the next object whose
  /// turn it is for a proposal.
  double last_estimate_score_ = -1.0;
  int next_proposal_object_ = 0;
  /// Per object, the best view's score at its last proposal (-1 before any).
  std::vector<float> challenger_score_;
  /// Frame silhouette's apparent size of the current measurement (0 = unknown).
  double apparent_radius_ = 0.0;
  /// Velocity state (kAdaptive): rotation vector per frame, camera frame, radians.
  Eigen::Vector3d velocity_ = Eigen::Vector3d::Zero();
  /// The last measured estimate's orientation, object and frame, for the velocity update.
  Eigen::Matrix3d last_rotation_ = Eigen::Matrix3d::Identity();
  int last_object_ = -1;
  int64_t last_measured_frame_ = -1;
  bool have_last_rotation_ = false;
  /// The orientation before the last one, the velocity before the last update and the frames
  /// between the two (so ObserveRotation can redo the update).
  Eigen::Matrix3d previous_rotation_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d velocity_before_update_ = Eigen::Vector3d::Zero();
  double last_gap_frames_ = 1.0;
  bool has_previous_rotation_ = false;
  /// Per view: camera_from_object at roll 0 (kAdaptive prediction).
  std::vector<Eigen::Matrix3d> view_rotation_;
  /// Sorted by object (resampling keeps them so).
  std::vector<Particle> particles_;
  std::shared_ptr<const HistoryNode> best_history_;
  /// Roll transport offset per directed edge of the neighbour graph (same order as
  /// ViewSphere::neighbour_indices): TransportRoll(a, r, b) = r + offset.
  std::vector<double> transport_offset_deg_;
  // Scratch for the measurement, reused across frames.
  SignatureSpectrum frame_spectrum_;
  std::vector<double> view_mass_;
  std::vector<int32_t> group_head_;
  std::vector<int32_t> group_next_;
  std::vector<int32_t> touched_groups_;
  std::vector<double> group_starts_;
  std::vector<int32_t> group_members_;
  std::vector<CorrelationPeak> group_peaks_;
  /// Harmonics used to rank views for guided reseeding, and per object their magnitudes and, in
  /// one more row, the root of each view's energy beyond them: (harmonics + 1) rows of one value
  /// per view, row k at [k * views, (k + 1) * views).
  static constexpr Eigen::Index kRankingHarmonics = 32;
  Eigen::Index ranking_harmonics_ = 0;
  std::vector<std::vector<float>> ranking_table_;
  /// Per object, the views the ranking considers (those Usable in shell 0), in increasing order.
  std::vector<std::vector<int>> ranked_views_;
  std::vector<float> ranking_;
  std::vector<std::pair<float, int>> bounds_;
  std::vector<std::pair<float, int>> tail_bounds_;
  std::vector<float> frame_magnitudes_;
  std::vector<int> candidate_views_;
  /// The usable candidates of BestViewsOfObject and their spectra.
  std::vector<std::pair<int, const SignatureSpectrum*>> candidate_spectra_;
};

/// 1 / sum(w_i^2) of weights that sum to 1 (0 for no weights).
double EffectiveSampleSize(std::span<const double> normalised_weights);

/// Systematic (low-variance) resampling: how many copies of each particle a draw of `count` from
/// `weights` (need not be normalised, sum > 0) makes, with the single uniform number `u` in [0, 1)
/// offsetting the comb. Each count is floor or ceil of count * w_i / sum(w).
std::vector<int> SystematicResampleCounts(std::span<const double> weights, int count, double u);

/// Fox's KLD-sampling bound (paper eq. 4): the number of samples so that, with probability
/// 1 - delta, the KL divergence between the sample-based and the true posterior over k non-empty
/// bins is below epsilon:
///   (k - 1) / (2 epsilon) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_{1-delta})^3,
/// rounded up; 0 for k <= 1.
int KldParticleCount(int bins, double epsilon, double delta);

/// Quantile of the standard normal distribution: z with P(Z <= z) = p, p in (0, 1).
double StandardNormalQuantile(double p);

}  // namespace silpose
