#include "silpose/filter/particle_filter.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <climits>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"
#include "silpose/util/top_k.h"

namespace silpose {
namespace {

// ranking[v] = sum over k < harmonics of query[k] table[k * views + v]: the proposal's ranking of
// an object's views, row by row (each view's sum in the order of k, whatever the vector width).
// Blocks of kRankBlock views are summed in registers over every k, then stored: as many
// independent sums as the vector registers hold (8 AVX2 or 16 SSE2 registers of them). The block
// only changes how many sums run at once, not the order within one.
template <size_t kRankBlock>
SILPOSE_ALWAYS_INLINE void RankViewsBody(const float* table, size_t harmonics, size_t views,
                                         const float* query, float* ranking) {
  size_t first = 0;
  for (; first + kRankBlock <= views; first += kRankBlock) {
    float sums[kRankBlock] = {};
    for (size_t k = 0; k < harmonics; ++k) {
      const float q = query[k];
      const float* row = table + k * views + first;
      for (size_t j = 0; j < kRankBlock; ++j) sums[j] += q * row[j];
    }
    std::copy(sums, sums + kRankBlock, ranking + first);
  }
  std::fill(ranking + first, ranking + views, 0.0f);
  for (size_t k = 0; k < harmonics; ++k) {
    const float q = query[k];
    const float* row = table + k * views;
    for (size_t v = first; v < views; ++v) ranking[v] += q * row[v];
  }
}

void RankViewsBaseline(const float* table, size_t harmonics, size_t views, const float* query,
                       float* ranking) {
  RankViewsBody<32>(table, harmonics, views, query, ranking);
}

SILPOSE_TARGET_AVX2 void RankViewsAvx2(const float* table, size_t harmonics, size_t views,
                                       const float* query, float* ranking) {
  RankViewsBody<64>(table, harmonics, views, query, ranking);
}

void RankViews(const float* table, size_t harmonics, size_t views, const float* query,
               float* ranking) {
  if (Avx2Enabled()) {
    RankViewsAvx2(table, harmonics, views, query, ranking);
  } else {
    RankViewsBaseline(table, harmonics, views, query, ranking);
  }
}

// Requests from memory the coefficients of a spectrum that the correlator reads (its first
// `harmonics`): the database's spectra are scattered and seldom in the cache.
void PrefetchCoefficients(const SignatureSpectrum& spectrum, size_t harmonics) {
  const auto* bytes = reinterpret_cast<const char*>(spectrum.coefficients.data());
  const size_t size =
      std::min(spectrum.coefficients.size(), harmonics) * sizeof(std::complex<float>);
  for (size_t offset = 0; offset < size; offset += 64) __builtin_prefetch(bytes + offset);
}

constexpr double kRadPerDeg = std::numbers::pi / 180.0;
}  // namespace

bool ParticleFilterOptions::Check(std::string* error) const {
  std::ostringstream message;
  auto in = [](double value, double lo, double hi) {
    return std::isfinite(value) && value >= lo && value <= hi;
  };
  if (particles_per_object < 1) {
    message << "particles per object must be >= 1, got " << particles_per_object;
  } else if (!(std::isfinite(likelihood_sharpness) && likelihood_sharpness > 0.0)) {
    message << "likelihood sharpness must be > 0, got " << likelihood_sharpness;
  } else if (!in(likelihood_floor, 0.0, 1.0)) {
    message << "likelihood floor must be in [0, 1], got " << likelihood_floor;
  } else if (!in(resample_threshold, 0.0, 1.0)) {
    message << "resample threshold must be in [0, 1], got " << resample_threshold;
  } else if (!in(stay_probability, 0.0, 1.0)) {
    message << "stay probability must be in [0, 1], got " << stay_probability;
  } else if (!in(jump_probability, 0.0, 1.0)) {
    message << "jump probability must be in [0, 1], got " << jump_probability;
  } else if (!in(roll_noise_deg, 0.0, 180.0)) {
    message << "roll noise must be in [0, 180] degrees, got " << roll_noise_deg;
  } else if (!in(roll_search_deg, 0.0, 180.0)) {
    message << "roll search window must be in [0, 180] degrees, got " << roll_search_deg;
  } else if (!(in(object_switch_probability, 0.0, 1.0) && object_switch_probability < 1.0)) {
    message << "object switch probability must be in [0, 1), got " << object_switch_probability;
  } else if (min_particles_per_object < 0 || min_particles_per_object > particles_per_object) {
    message << "min particles per object must be in [0, particles per object = "
            << particles_per_object << "], got " << min_particles_per_object;
  } else if (dormant_particles_per_object < 0) {
    message << "dormant particles per object must be >= 0, got " << dormant_particles_per_object;
  } else if (!in(dormant_probability, 0.0, 1.0)) {
    message << "dormant probability must be in [0, 1], got " << dormant_probability;
  } else if (!in(reseed_fraction, 0.0, 1.0)) {
    message << "reseed fraction must be in [0, 1], got " << reseed_fraction;
  } else if (guided_candidates < 1) {
    message << "guided candidates must be >= 1, got " << guided_candidates;
  } else if (estimate_rule != EstimateRule::kMostProbableArea &&
             estimate_rule != EstimateRule::kHeaviestParticle) {
    message << "unknown estimate rule " << static_cast<int>(estimate_rule);
  } else if (!(std::isfinite(kld_epsilon) && kld_epsilon > 0.0)) {
    message << "KLD epsilon must be > 0, got " << kld_epsilon;
  } else if (!(std::isfinite(kld_delta) && kld_delta > 0.0 && kld_delta < 0.5)) {
    message << "KLD delta must be in (0, 0.5), got " << kld_delta;
  } else if (max_particles_per_object < particles_per_object) {
    message << "max particles per object must be >= particles per object = " << particles_per_object
            << ", got " << max_particles_per_object;
  } else if (motion_model != MotionModel::kAdaptive && motion_model != MotionModel::kNeighbour) {
    message << "unknown motion model " << static_cast<int>(motion_model);
  } else if (!in(rotation_noise_deg, 0.0, 180.0)) {
    message << "rotation noise must be in [0, 180] degrees, got " << rotation_noise_deg;
  } else if (!in(rotation_noise_speed_factor, 0.0, 10.0)) {
    message << "rotation noise speed factor must be in [0, 10], got "
            << rotation_noise_speed_factor;
  } else if (!in(velocity_share, 0.0, 1.0)) {
    message << "velocity share must be in [0, 1], got " << velocity_share;
  } else if (!(in(velocity_smoothing, 0.0, 1.0) && velocity_smoothing < 1.0)) {
    message << "velocity smoothing must be in [0, 1), got " << velocity_smoothing;
  } else if (!(in(max_speed_deg, 0.0, 180.0) && max_speed_deg > 0.0)) {
    message << "max speed must be in (0, 180] degrees per frame, got " << max_speed_deg;
  } else if (proposal_views < 1) {
    message << "proposal views must be >= 1, got " << proposal_views;
  } else if (!(in(proposal_prior_floor, 0.0, 1.0) && proposal_prior_floor > 0.0)) {
    message << "proposal prior floor must be in (0, 1], got " << proposal_prior_floor;
  } else if (proposal_objects_per_frame < 0) {
    message << "proposal objects per frame must be >= 0, got " << proposal_objects_per_frame;
  } else if (!in(proposal_confident_score, -1.0, 1.0)) {
    message << "proposal confident score must be in [-1, 1], got " << proposal_confident_score;
  } else if (!in(proposal_drop, 0.0, 2.0)) {
    message << "proposal drop must be in [0, 2], got " << proposal_drop;
  } else if (!in(cut_min_score, -1.0, 1.0)) {
    message << "cut minimum score must be in [-1, 1], got " << cut_min_score;
  } else if (!in(cut_score_gap, 0.0, 2.0)) {
    message << "cut score gap must be in [0, 2], got " << cut_score_gap;
  } else if (max_history_frames < 0) {
    message << "max history frames must be >= 0, got " << max_history_frames;
  } else if (!(mode_radius_deg > 0.0 && mode_radius_deg <= 90.0)) {
    message << "mode radius must be in (0, 90] degrees, got " << mode_radius_deg;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

HistoryNode::HistoryNode(const PoseState& state, std::shared_ptr<const HistoryNode> parent)
    : state_(state), parent_(std::move(parent)) {}

HistoryNode::~HistoryNode() {
  // Destroying the parent from here would recurse once per frame of history and overflow the
  // stack on long sequences. Instead walk up while this chain is the only owner: detach each
  // parent's own parent before the parent dies, so every destructor finds an empty link.
  std::shared_ptr<const HistoryNode> next = std::move(parent_);
  while (next && next.use_count() == 1) {
    std::shared_ptr<const HistoryNode> after = std::move(next->parent_);
    next = std::move(after);
  }
}

ParticleFilter::ParticleFilter(const ViewSphere& sphere, const ViewSpectra& spectra,
                               const ParticleFilterOptions& options)
    : sphere_(sphere),
      spectra_(spectra),
      options_(options),
      num_objects_(spectra.num_models()),
      num_views_(spectra.num_views()),
      correlator_(spectra.signature_length(), spectra.options()),
      rng_(options.seed) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid particle filter options: ", error);
  if (num_objects_ < 1) ThrowError("the particle filter needs at least one model");
  if (sphere.num_views() != num_views_ ||
      sphere.neighbour_offsets.size() != static_cast<size_t>(num_views_) + 1 ||
      sphere.bin_of_view.size() != static_cast<size_t>(num_views_)) {
    ThrowError("the view sphere (", sphere.num_views(), " views) does not match the spectra (",
               num_views_, " views)");
  }
  // TransportRoll(a, r, b) = r + TransportRoll(a, 0, b): the transport rotates the whole camera,
  // and a roll is a rotation about the optical axis applied after it (geometry/view_frame.h).
  transport_offset_deg_.resize(sphere.neighbour_indices.size());
  for (int a = 0; a < num_views_; ++a) {
    for (uint32_t e = sphere.neighbour_offsets[static_cast<size_t>(a)];
         e < sphere.neighbour_offsets[static_cast<size_t>(a) + 1]; ++e) {
      transport_offset_deg_[e] = TransportRoll(sphere.directions[static_cast<size_t>(a)], 0.0,
                                               sphere.directions[sphere.neighbour_indices[e]]);
    }
  }
  for (const ModelViews& model : spectra.database().models)
    equivalence_.emplace_back(model.symmetry);
  view_rotation_.resize(static_cast<size_t>(num_views_));
  for (int v = 0; v < num_views_; ++v) {
    view_rotation_[static_cast<size_t>(v)] =
        CameraFromObjectRotation(sphere.directions[static_cast<size_t>(v)], 0.0);
  }
  if (options.guided_reseeding || options.guided_start || options.data_driven_proposal) {
    // The first harmonics' magnitudes of every view, contiguous per object (BestViewOfObject);
    // shell 0 (the shells' magnitudes differ little: this only ranks candidates).
    for (int m = 0; m < num_objects_ && ranking_harmonics_ == 0; ++m) {
      for (int v = 0; v < num_views_; ++v) {
        if (!spectra.Usable(m, v)) continue;
        ranking_harmonics_ = std::min<Eigen::Index>(
            kRankingHarmonics, static_cast<Eigen::Index>(spectra.Magnitudes(m, v).size()));
        break;
      }
    }
    // One more row: the square root of the energy beyond the ranked harmonics (BestViewsOfObject).
    const auto views = static_cast<size_t>(num_views_);
    const auto harmonics = static_cast<size_t>(ranking_harmonics_);
    ranking_table_.assign(static_cast<size_t>(num_objects_),
                          std::vector<float>((harmonics + 1) * views));
    const size_t half = static_cast<size_t>(spectra.signature_length() / 2 + 1);
    ranked_views_.assign(static_cast<size_t>(num_objects_), {});
    for (int m = 0; m < num_objects_; ++m) {
      std::vector<float>& table = ranking_table_[static_cast<size_t>(m)];
      for (int v = 0; v < num_views_; ++v) {
        if (!spectra.Usable(m, v)) continue;
        ranked_views_[static_cast<size_t>(m)].push_back(v);
        std::span<const float> magnitudes = spectra.Magnitudes(m, v);
        const auto column = static_cast<size_t>(v);
        bool valid = true;
        for (size_t k = 0; k < harmonics; ++k) {
          const float value = magnitudes[k];
          valid = valid && value >= 0.0f && value <= 1.0f;  // false for NaN too
          table[k * views + column] = value;
        }
        table[harmonics * views + column] = TailEnergyRoot(magnitudes, harmonics, half);
        // Stored magnitudes are read in place unchecked: Get checks the view's values (and throws
        // for a corrupt file).
        if (!valid) (void)spectra.Get(m, v);
      }
    }
  }
  challenger_score_.assign(static_cast<size_t>(num_objects_), -1.0f);
  group_head_.assign(static_cast<size_t>(num_objects_) * static_cast<size_t>(num_views_), -1);
  const int total = options.particles_per_object * num_objects_;
  particles_.reserve(static_cast<size_t>(total));
  for (int object = 0; object < num_objects_; ++object) {
    for (int i = 0; i < options.particles_per_object; ++i) {
      Particle particle = FreshParticle(object);
      particle.weight = 1.0 / total;
      particles_.push_back(std::move(particle));
    }
  }
}

ParticleFilter::~ParticleFilter() = default;

Particle ParticleFilter::FreshParticle(int object) {
  Particle particle;
  particle.object = object;
  particle.view = std::uniform_int_distribution<int>(0, num_views_ - 1)(rng_);
  return particle;
}

FilterEstimate ParticleFilter::Step(const SignatureSpectrum& frame, double apparent_radius) {
  const size_t expected = static_cast<size_t>(spectra_.signature_length() / 2 + 1);
  if (frame.coefficients.size() != expected) {
    ThrowError("frame spectrum has ", frame.coefficients.size(),
               " coefficients, the database's signatures need ", expected);
  }
  apparent_radius_ =
      std::isfinite(apparent_radius) && apparent_radius > 0.0 ? apparent_radius : 0.0;
  return Advance(&frame);
}

FilterEstimate ParticleFilter::Step(std::span<const float> radii, double apparent_radius) {
  correlator_.Transform(radii, &frame_spectrum_);
  apparent_radius_ =
      std::isfinite(apparent_radius) && apparent_radius > 0.0 ? apparent_radius : 0.0;
  return Advance(&frame_spectrum_);
}

int ParticleFilter::ShellOf(int object, int view) const {
  return spectra_.ChooseShell(object, view, apparent_radius_);
}

void ParticleFilter::ObserveRotation(const Eigen::Matrix3d& camera_from_object_on_axis) {
  if (options_.motion_model != MotionModel::kAdaptive || !have_last_rotation_ ||
      !camera_from_object_on_axis.allFinite()) {
    return;
  }
  last_rotation_ = camera_from_object_on_axis;
  if (has_previous_rotation_) {
    velocity_ = velocity_before_update_;
    ApplyVelocityObservation(last_rotation_ * previous_rotation_.transpose());
  }
}

void ParticleFilter::ApplyVelocityObservation(const Eigen::Matrix3d& change_rotation) {
  const Eigen::AngleAxisd change(change_rotation);
  const double angle = change.angle() / last_gap_frames_;
  if (angle > options_.max_speed_deg * kRadPerDeg) {
    velocity_.setZero();  // a cut, not motion
    return;
  }
  velocity_ = options_.velocity_smoothing * velocity_ +
              (1.0 - options_.velocity_smoothing) * angle * change.axis();
}

void ParticleFilter::UpdateVelocity(const FilterEstimate& estimate) {
  if (options_.motion_model != MotionModel::kAdaptive) return;
  if (!estimate.measured || !estimate.roll_known || estimate.object < 0) return;
  const Eigen::Matrix3d rotation = CameraFromObjectRotation(
      sphere_.directions[static_cast<size_t>(estimate.view)], estimate.roll_deg);
  velocity_before_update_ = velocity_;
  has_previous_rotation_ = have_last_rotation_ && last_object_ == estimate.object;
  if (has_previous_rotation_) {
    // A gap of frames without silhouette: the change spreads over them.
    last_gap_frames_ =
        static_cast<double>(std::max<int64_t>(1, estimate.frame - last_measured_frame_));
    previous_rotation_ = last_rotation_;
    ApplyVelocityObservation(rotation * previous_rotation_.transpose());
  } else {
    velocity_.setZero();
  }
  last_rotation_ = rotation;
  last_object_ = estimate.object;
  last_measured_frame_ = estimate.frame;
  have_last_rotation_ = true;
}

void ParticleFilter::ReflectMode(int object, int view, const Eigen::Matrix3d& model_reflection) {
  if (object < 0 || object >= num_objects_ || view < 0 || view >= num_views_) {
    ThrowError("ReflectMode: object ", object, ", view ", view, " is not in the database");
  }
  const Eigen::Matrix3d f = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(object)];
  const Eigen::Vector3d centre = sphere_.directions[static_cast<size_t>(view)];
  for (Particle& p : particles_) {
    if (p.object != object || same.AngleDeg(sphere_.directions[static_cast<size_t>(p.view)],
                                            centre) > options_.mode_radius_deg) {
      continue;
    }
    const Eigen::Vector3d& d = sphere_.directions[static_cast<size_t>(p.view)];
    if (!p.roll_known) {
      p.view = sphere_.NearestView(-(model_reflection * d));
      continue;
    }
    const Eigen::Matrix3d twin = f * CameraFromObjectRotation(d, p.roll_deg) * model_reflection;
    Eigen::Vector3d twin_view;
    ViewAndRollFromRotation(twin, &twin_view, &p.roll_deg);
    p.view = sphere_.NearestView(twin_view);
  }
  // F Exp(w) F = Exp(-F w): the velocity of the twin motion.
  velocity_ = -(f * velocity_);
  velocity_before_update_ = -(f * velocity_before_update_);
  last_rotation_ = f * last_rotation_ * model_reflection;
  previous_rotation_ = f * previous_rotation_ * model_reflection;
}

FilterEstimate ParticleFilter::Predict() { return Advance(nullptr); }

FilterEstimate ParticleFilter::Advance(const SignatureSpectrum* frame) {
  if (frame_ > 0) PredictParticles();
  // Scores first: whether the particles lost the frame decides how much the proposal covers.
  if (frame != nullptr) ScoreParticles(*frame);
  int proposed = 0;
  if (frame != nullptr && frame->has_variance && RankingReady() &&
      (options_.data_driven_proposal || (!measured_once_ && options_.guided_start))) {
    proposed = Propose(*frame, !measured_once_ || ParticlesLostFrame());
  }
  if (frame != nullptr) {
    WeightParticles(*frame);
    measured_once_ = true;
  }

  FilterEstimate estimate;
  estimate.frame = frame_;
  estimate.measured = frame != nullptr;
  estimate.object_probability.assign(static_cast<size_t>(num_objects_), 0.0);
  estimate.particles_per_object.assign(static_cast<size_t>(num_objects_), 0);
  double sum_squares = 0.0;
  auto sum_weights = [&] {
    std::fill(estimate.object_probability.begin(), estimate.object_probability.end(), 0.0);
    sum_squares = 0.0;
    for (const Particle& p : particles_) {
      estimate.object_probability[static_cast<size_t>(p.object)] += p.weight;
      sum_squares += p.weight * p.weight;
    }
  };
  sum_weights();
  size_t best = 0;
  for (size_t i = 0; i < particles_.size(); ++i) {
    const Particle& p = particles_[i];
    ++estimate.particles_per_object[static_cast<size_t>(p.object)];
    const Particle& b = particles_[best];
    if (p.weight > b.weight || (p.weight == b.weight && p.score > b.score)) best = i;
  }
  if (options_.estimate_rule == EstimateRule::kMostProbableArea) {
    best = MostProbableAreaParticle(estimate);
  }
  if (frame != nullptr) {
    size_t top = 0;
    for (size_t i = 1; i < particles_.size(); ++i) {
      if (particles_[i].score > particles_[top].score) top = i;
    }
    const auto describe = [this](const Particle& p) {
      return FilterEstimate::Hypothesis{
          p.object,     p.view, ShellOf(p.object, p.view), p.roll_known ? p.roll_deg : 0.0,
          p.roll_known, p.score};
    };
    estimate.top = describe(particles_[top]);
    // The top particle is reported and takes half of the weight (the others share the rest).
    const auto promote = [&] {
      if (particles_[top].weight < 0.5) {
        const double scale = 0.5 / (1.0 - particles_[top].weight);
        for (size_t i = 0; i < particles_.size(); ++i) {
          if (i != top) particles_[i].weight *= scale;
        }
        particles_[top].weight = 0.5;
        sum_weights();
      }
      best = top;
    };
    const double top_score = particles_[top].score;
    if (options_.cut_score_gap > 0.0 && top_score >= options_.cut_min_score &&
        top_score - particles_[best].score >= options_.cut_score_gap) {
      // A cut: a particle (typically a proposal) matches the frame cleanly and far better than
      // the chosen hypothesis. The likelihood floor would make the posterior need a frame or two
      // to move there; the evidence is unequivocal, so the estimate and the weight move at once.
      promote();
      estimate.cut = true;
    } else if (arbiter_ && top != best && particles_[top].score > particles_[best].score &&
               particles_[top].roll_known && particles_[best].roll_known) {
      const Particle& c = particles_[best];
      const Particle& t = particles_[top];
      const bool same_mode =
          c.object == t.object &&
          equivalence_[static_cast<size_t>(c.object)].AngleDeg(
              sphere_.directions[static_cast<size_t>(c.view)],
              sphere_.directions[static_cast<size_t>(t.view)]) <= options_.mode_radius_deg;
      if (!same_mode) {
        estimate.arbitrated = true;
        if (arbiter_(describe(c), describe(t))) {
          promote();
          estimate.challenger_won = true;
        }
      }
    }
  }
  estimate.num_particles = static_cast<int>(particles_.size());
  estimate.effective_particles = sum_squares > 0.0 ? 1.0 / sum_squares : 0.0;

  // History: one node per particle for this frame.
  if (options_.keep_history) {
    for (Particle& p : particles_) {
      p.history = std::make_shared<const HistoryNode>(
          PoseState{frame_, p.object, p.view, p.roll_known ? p.roll_deg : 0.0, p.roll_known,
                    p.score, frame != nullptr && frame->has_variance},
          std::move(p.history));
    }
  }
  const Particle& chosen = particles_[best];
  estimate.object = chosen.object;
  estimate.view = chosen.view;
  estimate.shell = frame != nullptr ? ShellOf(chosen.object, chosen.view) : 0;
  estimate.proposed = proposed;
  estimate.roll_deg = chosen.roll_known ? chosen.roll_deg : 0.0;
  estimate.roll_known = chosen.roll_known;
  estimate.score = chosen.score;
  estimate.weight = chosen.weight;
  best_history_ = chosen.history;
  AnalyseModes(&estimate);
  if (frame != nullptr && frame->has_variance) last_estimate_score_ = chosen.score;
  UpdateVelocity(estimate);
  estimate.speed_deg = velocity_.norm() / kRadPerDeg;

  if (estimate.effective_particles <
      options_.resample_threshold * static_cast<double>(particles_.size())) {
    Resample(estimate.object_probability, frame);
    estimate.resampled = true;
  }
  estimate.num_particles_after = static_cast<int>(particles_.size());
  if (options_.keep_history && options_.max_history_frames > 0 &&
      (frame_ + 1) % options_.max_history_frames == 0) {
    CutHistory(frame_ - options_.max_history_frames + 1);
  }
  ++frame_;
  return estimate;
}

void ParticleFilter::AnalyseModes(FilterEstimate* estimate) const {
  if (estimate->object < 0 || estimate->view < 0 || particles_.empty()) return;
  const double radius = options_.mode_radius_deg;
  const auto direction = [&](int view) -> const Eigen::Vector3d& {
    return sphere_.directions[static_cast<size_t>(view)];
  };
  double total = 0.0;
  for (const Particle& p : particles_) total += p.weight;
  if (!(total > 0.0)) return;
  std::vector<uint8_t> in_mode(particles_.size(), 0);
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(estimate->object)];
  const Eigen::Vector3d& centre = direction(estimate->view);
  double mode = 0.0;
  size_t runner = particles_.size();
  for (size_t i = 0; i < particles_.size(); ++i) {
    const Particle& p = particles_[i];
    if (p.object == estimate->object && same.AngleDeg(direction(p.view), centre) <= radius) {
      in_mode[i] = 1;
      mode += p.weight;
    } else if (runner == particles_.size() || p.weight > particles_[runner].weight ||
               (p.weight == particles_[runner].weight && p.score > particles_[runner].score)) {
      runner = i;
    }
  }
  estimate->mode_mass = mode / total;
  estimate->runner_up = {};
  if (runner == particles_.size()) return;
  const Particle& r = particles_[runner];
  const ViewEquivalence& other = equivalence_[static_cast<size_t>(r.object)];
  double mass = 0.0;
  for (size_t i = 0; i < particles_.size(); ++i) {
    const Particle& p = particles_[i];
    if (!in_mode[i] && p.object == r.object &&
        other.AngleDeg(direction(p.view), direction(r.view)) <= radius)
      mass += p.weight;
  }
  estimate->runner_up = {{r.object, r.view, ShellOf(r.object, r.view),
                          r.roll_known ? r.roll_deg : 0.0, r.roll_known, r.score},
                         mass / total};
}

size_t ParticleFilter::MostProbableAreaParticle(const FilterEstimate& estimate) {
  const auto object = static_cast<int>(
      std::max_element(estimate.object_probability.begin(), estimate.object_probability.end()) -
      estimate.object_probability.begin());
  // Weight per view of that object (scratch kept at 0 between calls).
  view_mass_.resize(static_cast<size_t>(num_views_), 0.0);
  touched_groups_.clear();
  for (const Particle& p : particles_) {
    if (p.object != object) continue;
    double& mass = view_mass_[static_cast<size_t>(p.view)];
    if (mass == 0.0) touched_groups_.push_back(p.view);
    mass += p.weight + std::numeric_limits<double>::denorm_min();  // > 0 even for weight 0
  }
  auto area_mass = [&](int view) {
    double mass = view_mass_[static_cast<size_t>(view)];
    for (const uint32_t n : sphere_.Neighbours(view)) mass += view_mass_[n];
    return mass;
  };
  int centre = -1;
  double centre_mass = -1.0;
  for (const int32_t view : touched_groups_) {
    const double mass = area_mass(view);
    if (mass > centre_mass || (mass == centre_mass && view < centre)) {
      centre_mass = mass;
      centre = view;
    }
  }
  for (const int32_t view : touched_groups_) view_mass_[static_cast<size_t>(view)] = 0.0;
  const std::span<const uint32_t> neighbours = sphere_.Neighbours(centre);
  size_t best = particles_.size();
  for (size_t i = 0; i < particles_.size(); ++i) {
    const Particle& p = particles_[i];
    if (p.object != object) continue;
    if (p.view != centre && std::find(neighbours.begin(), neighbours.end(),
                                      static_cast<uint32_t>(p.view)) == neighbours.end()) {
      continue;
    }
    if (best == particles_.size() || p.weight > particles_[best].weight ||
        (p.weight == particles_[best].weight && p.score > particles_[best].score)) {
      best = i;
    }
  }
  SILPOSE_ASSERT(best < particles_.size());
  return best;
}

void ParticleFilter::PredictParticles() {
  // Object identity: mix the object masses towards uniform.
  const double switch_probability = options_.object_switch_probability;
  if (num_objects_ > 1 && switch_probability > 0.0) {
    std::vector<double> mass(static_cast<size_t>(num_objects_), 0.0);
    std::vector<int> count(static_cast<size_t>(num_objects_), 0);
    for (const Particle& p : particles_) {
      mass[static_cast<size_t>(p.object)] += p.weight;
      ++count[static_cast<size_t>(p.object)];
    }
    std::vector<double> scale(static_cast<size_t>(num_objects_), 0.0);
    std::vector<double> share(static_cast<size_t>(num_objects_), 0.0);
    for (size_t o = 0; o < mass.size(); ++o) {
      const double target =
          (1.0 - switch_probability) * mass[o] + switch_probability / num_objects_;
      if (mass[o] > 0.0) {
        scale[o] = target / mass[o];
      } else if (count[o] > 0) {
        share[o] = target / count[o];  // all its weights underflowed: spread the new mass evenly
      }
    }
    double total = 0.0;
    for (Particle& p : particles_) {
      const auto o = static_cast<size_t>(p.object);
      p.weight = mass[o] > 0.0 ? p.weight * scale[o] : share[o];
      total += p.weight;
    }
    // Objects without particles (floor 0) take no mass: renormalise.
    if (total > 0.0) {
      for (Particle& p : particles_) p.weight /= total;
    }
  }
  // Views and rolls.
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> roll_noise(0.0, options_.roll_noise_deg);
  std::normal_distribution<double> normal(0.0, 1.0);
  // kAdaptive: the rotation noise per axis, grown with the tracked speed.
  const double sigma_rad = (options_.rotation_noise_deg + options_.rotation_noise_speed_factor *
                                                              (velocity_.norm() / kRadPerDeg)) *
                           kRadPerDeg;
  // The same for every particle: made once per frame.
  Eigen::Matrix3d velocity_step;
  const bool moving = options_.velocity_share > 0.0 && velocity_.squaredNorm() > 0.0;
  if (moving) {
    velocity_step = Eigen::AngleAxisd(velocity_.norm(), velocity_.normalized()).toRotationMatrix();
  }
  for (Particle& p : particles_) {
    if (options_.jump_probability > 0.0 && uniform(rng_) < options_.jump_probability) {
      p.view = std::uniform_int_distribution<int>(0, num_views_ - 1)(rng_);
      p.roll_known = false;
      p.roll_deg = 0.0;
      continue;
    }
    if (options_.motion_model == MotionModel::kAdaptive) {
      PredictAdaptive(p, sigma_rad, moving ? &velocity_step : nullptr, uniform, normal);
      continue;
    }
    if (uniform(rng_) >= options_.stay_probability) {
      const uint32_t begin = sphere_.neighbour_offsets[static_cast<size_t>(p.view)];
      const uint32_t end = sphere_.neighbour_offsets[static_cast<size_t>(p.view) + 1];
      if (end > begin) {
        const uint32_t edge =
            begin + std::uniform_int_distribution<uint32_t>(0, end - begin - 1)(rng_);
        p.view = static_cast<int>(sphere_.neighbour_indices[edge]);
        p.roll_deg += transport_offset_deg_[edge];
      }
    }
    if (p.roll_known) {
      if (options_.roll_noise_deg > 0.0) p.roll_deg += roll_noise(rng_);
      p.roll_deg = WrapDegrees(p.roll_deg);
    }
  }
}

void ParticleFilter::PredictAdaptive(Particle& p, double sigma_rad,
                                     const Eigen::Matrix3d* velocity_step,
                                     std::uniform_real_distribution<double>& uniform,
                                     std::normal_distribution<double>& normal) {
  if (!p.roll_known) {
    // No orientation yet (never measured, or jumped): only the view diffuses.
    const Eigen::Vector3d& d = sphere_.directions[static_cast<size_t>(p.view)];
    const Eigen::Vector3d noise(normal(rng_) * sigma_rad, normal(rng_) * sigma_rad,
                                normal(rng_) * sigma_rad);
    const double angle = noise.norm();
    const Eigen::Vector3d moved = angle > 0.0 ? Eigen::AngleAxisd(angle, noise / angle) * d : d;
    p.view = NearestView(p.view, moved);
    return;
  }
  // The camera orientation: roll about the optical axis after the view's roll-0 rotation.
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(p.roll_deg * kRadPerDeg, Eigen::Vector3d::UnitZ())
          .toRotationMatrix()
          .transpose() *
      view_rotation_[static_cast<size_t>(p.view)];
  Eigen::Vector3d step(normal(rng_) * sigma_rad, normal(rng_) * sigma_rad,
                       normal(rng_) * sigma_rad);
  Eigen::Matrix3d moved = rotation;
  if (velocity_step != nullptr && uniform(rng_) < options_.velocity_share) {
    moved = *velocity_step * moved;
  }
  const double angle = step.norm();
  if (angle > 0.0) moved = Eigen::AngleAxisd(angle, step / angle).toRotationMatrix() * moved;
  // The camera looks along -view: its optical axis (row 2) is -view_dir in the object frame.
  const Eigen::Vector3d view_dir = -moved.row(2).transpose();
  const int view = NearestView(p.view, view_dir);
  // Roll of the moved orientation at the snapped view: the rotation about the optical axis that
  // best turns the view's roll-0 camera into it (exact when the view is the moved direction).
  const Eigen::Matrix3d relative = moved * view_rotation_[static_cast<size_t>(view)].transpose();
  p.view = view;
  p.roll_deg = WrapDegrees(std::atan2(relative(0, 1), relative(0, 0)) / kRadPerDeg);
}

int ParticleFilter::NearestView(int start, const Eigen::Vector3d& direction) const {
  int current = start;
  double current_dot = sphere_.directions[static_cast<size_t>(current)].dot(direction);
  for (int step = 0; step < 4 * num_views_; ++step) {
    int best = current;
    double best_dot = current_dot;
    for (const uint32_t n : sphere_.Neighbours(current)) {
      const double dot = sphere_.directions[n].dot(direction);
      if (dot > best_dot) {
        best_dot = dot;
        best = static_cast<int>(n);
      }
    }
    if (best == current) break;
    current = best;
    current_dot = best_dot;
  }
  return current;
}

std::vector<size_t> ParticleFilter::ObjectRanges() const {
  // Particles are sorted by object: object o holds [begin[o], begin[o + 1]).
  const auto num_objects = static_cast<size_t>(num_objects_);
  std::vector<size_t> begin(num_objects + 1, particles_.size());
  for (size_t i = particles_.size(); i-- > 0;) begin[static_cast<size_t>(particles_[i].object)] = i;
  for (size_t o = num_objects; o-- > 0;) begin[o] = std::min(begin[o], begin[o + 1]);
  return begin;
}

bool ParticleFilter::ParticlesLostFrame() const {
  float best = -1.0f;
  for (const Particle& p : particles_) best = std::max(best, p.score);
  return best < options_.proposal_confident_score ||
         best < last_estimate_score_ - options_.proposal_drop;
}

int ParticleFilter::Propose(const SignatureSpectrum& frame, bool all_objects) {
  // Object masses and mean particle weights before the proposal.
  const auto num_objects = static_cast<size_t>(num_objects_);
  std::vector<double> mass(num_objects, 0.0);
  for (const Particle& p : particles_) mass[static_cast<size_t>(p.object)] += p.weight;
  const auto top = static_cast<int>(std::max_element(mass.begin(), mass.end()) - mass.begin());
  // Which objects: all, or the most probable and the next ones in turn.
  std::vector<char> chosen(num_objects, all_objects ? 1 : 0);
  chosen[static_cast<size_t>(top)] = 1;
  if (!all_objects) {
    // Challengers: objects whose best view came close to the tracked object at their last
    // proposal stay in every frame's proposal.
    float tracked_best = -1.0f;
    for (const Particle& p : particles_) {
      if (p.object == top) tracked_best = std::max(tracked_best, p.score);
    }
    for (size_t o = 0; o < num_objects; ++o) {
      if (challenger_score_[o] >= tracked_best - options_.proposal_drop) chosen[o] = 1;
    }
    const int others = std::min(options_.proposal_objects_per_frame, num_objects_ - 1);
    for (int k = 0; k < others; ++k) {
      if (next_proposal_object_ == top)
        next_proposal_object_ = (next_proposal_object_ + 1) % num_objects_;
      chosen[static_cast<size_t>(next_proposal_object_)] = 1;
      next_proposal_object_ = (next_proposal_object_ + 1) % num_objects_;
    }
  }
  const std::vector<size_t> begin = ObjectRanges();
  int proposed = 0;
  std::vector<size_t> order;
  for (int o = 0; o < num_objects_; ++o) {
    const auto object = static_cast<size_t>(o);
    const size_t count = begin[object + 1] - begin[object];
    if (count == 0 || !chosen[object]) continue;
    const int wanted = o == top && measured_once_ ? options_.proposal_views : 1;
    const std::vector<CandidateView> candidates = BestViewsOfObject(frame, o, wanted);
    challenger_score_[object] = candidates.empty() ? -1.0f : candidates.front().score;
    if (candidates.empty()) continue;
    // The object's particles by increasing weight: the lightest are replaced.
    order.clear();
    for (size_t i = begin[object]; i < begin[object + 1]; ++i) order.push_back(i);
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return particles_[a].weight < particles_[b].weight; });
    const double mean_weight = mass[object] / static_cast<double>(count);
    // Prior of each candidate place, from the predicted particles (before any is replaced).
    // The proposed particle continues the history of the heaviest particle there (or of the
    // object's heaviest): where the sequence's evidence for that place comes from.
    std::vector<double> prior(candidates.size(), 0.0);
    std::vector<std::shared_ptr<const HistoryNode>> parent(candidates.size());
    size_t heaviest = begin[object];
    for (size_t i = begin[object]; i < begin[object + 1]; ++i) {
      if (particles_[i].weight > particles_[heaviest].weight) heaviest = i;
    }
    for (size_t c = 0; c < candidates.size(); ++c) {
      const int view = candidates[c].view;
      const std::span<const uint32_t> neighbours = sphere_.Neighbours(view);
      double local = 0.0;
      int local_count = 0;
      size_t local_heaviest = heaviest;
      for (size_t i = begin[object]; i < begin[object + 1]; ++i) {
        const Particle& p = particles_[i];
        if (p.view == view || std::find(neighbours.begin(), neighbours.end(),
                                        static_cast<uint32_t>(p.view)) != neighbours.end()) {
          if (local_count == 0 || p.weight > particles_[local_heaviest].weight) local_heaviest = i;
          local += p.weight;
          ++local_count;
        }
      }
      parent[c] = particles_[local_heaviest].history;
      const double local_mean = local_count > 0 ? local / local_count : 0.0;
      prior[c] = std::max(local_mean, options_.proposal_prior_floor * mean_weight);
      if (!measured_once_) prior[c] = mean_weight;  // the start: every place equally likely
    }
    const size_t replace = std::min(candidates.size(), order.size());
    for (size_t c = 0; c < replace; ++c) {
      Particle& p = particles_[order[c]];
      p.view = candidates[c].view;
      p.roll_deg = candidates[c].roll_deg;
      p.roll_known = true;
      p.score = candidates[c].score;
      p.weight = prior[c];
      p.history = parent[c];
      ++proposed;
    }
  }
  double total = 0.0;
  for (const Particle& p : particles_) total += p.weight;
  if (total > 0.0 && std::isfinite(total)) {
    for (Particle& p : particles_) p.weight /= total;
  }
  return proposed;
}

void ParticleFilter::ScoreParticles(const SignatureSpectrum& frame) {
  // A signature without variance (a nearly circular silhouette after smoothing) says nothing.
  if (!frame.has_variance) return;
  const int length = spectra_.signature_length();
  const double bins_per_degree = length / 360.0;
  const double window_deg =
      std::min(180.0, options_.roll_search_deg + (options_.motion_model == MotionModel::kAdaptive
                                                      ? velocity_.norm() / kRadPerDeg
                                                      : 0.0));
  const double window_bins = window_deg * bins_per_degree;
  // Group the particles by (object, view): linked lists through group_next_.
  group_next_.resize(particles_.size());
  touched_groups_.clear();
  for (size_t i = 0; i < particles_.size(); ++i) {
    const Particle& p = particles_[i];
    const auto key = static_cast<size_t>(p.object) * static_cast<size_t>(num_views_) +
                     static_cast<size_t>(p.view);
    if (group_head_[key] < 0) touched_groups_.push_back(static_cast<int32_t>(key));
    group_next_[i] = group_head_[key];
    group_head_[key] = static_cast<int32_t>(i);
  }
  // A group's reference spectrum (null if the view is unusable), its data requested now: the
  // spectra are scattered over the database and seldom in the cache, so the next group's is
  // fetched while this one's is correlated.
  auto fetch = [&](size_t g) -> const SignatureSpectrum* {
    if (g >= touched_groups_.size()) return nullptr;
    const int32_t key = touched_groups_[g];
    const int object = key / num_views_;
    const int view = key % num_views_;
    const int shell = ShellOf(object, view);
    if (!spectra_.Usable(object, view, shell)) return nullptr;
    const SignatureSpectrum& spectrum = spectra_.Get(object, view, shell);
    PrefetchCoefficients(spectrum, correlator_.harmonics());
    return &spectrum;
  };
  const SignatureSpectrum* next = fetch(0);
  for (size_t g = 0; g < touched_groups_.size(); ++g) {
    const SignatureSpectrum* const current = next;
    next = fetch(g + 1);
    const int32_t key = touched_groups_[g];
    const int32_t head = group_head_[static_cast<size_t>(key)];
    group_head_[static_cast<size_t>(key)] = -1;
    if (current == nullptr) {
      for (int32_t i = head; i >= 0; i = group_next_[static_cast<size_t>(i)]) {
        particles_[static_cast<size_t>(i)].score = -1.0f;
      }
      continue;
    }
    const SignatureSpectrum& reference = *current;
    group_starts_.clear();
    group_members_.clear();
    bool any_unknown = false;
    for (int32_t i = head; i >= 0; i = group_next_[static_cast<size_t>(i)]) {
      const Particle& p = particles_[static_cast<size_t>(i)];
      if (p.roll_known) {
        group_members_.push_back(i);
        group_starts_.push_back(p.roll_deg * bins_per_degree);
      } else {
        any_unknown = true;
      }
    }
    if (!group_members_.empty()) {
      group_peaks_.resize(group_members_.size());
      correlator_.LocalPeaks(frame, reference, group_starts_, window_bins, group_peaks_);
      for (size_t m = 0; m < group_members_.size(); ++m) {
        Particle& p = particles_[static_cast<size_t>(group_members_[m])];
        p.roll_deg = group_peaks_[m].RollDeg(length);
        p.score = group_peaks_[m].score;
      }
    }
    if (any_unknown) {
      const CorrelationPeak peak = correlator_.Peak(frame, reference);
      for (int32_t i = head; i >= 0; i = group_next_[static_cast<size_t>(i)]) {
        Particle& p = particles_[static_cast<size_t>(i)];
        if (p.roll_known) continue;
        p.roll_deg = peak.RollDeg(length);
        p.roll_known = true;
        p.score = peak.score;
      }
    }
  }
}

void ParticleFilter::WeightParticles(const SignatureSpectrum& frame) {
  if (!frame.has_variance) return;
  // w <- w (exp(lambda (s - s_best)) + floor): exp(lambda (s - 1)) up to normalisation, taken
  // relative to the best score so that the best particle's factor is 1 + floor, nothing underflows
  // needlessly, and the floor is relative to the best particle (the header explains why).
  double reference = -1.0;
  for (const Particle& p : particles_) {
    reference = std::max(reference, static_cast<double>(p.score));
  }
  const double lambda = options_.likelihood_sharpness;
  const double floor = options_.likelihood_floor;
  double total = 0.0;
  for (Particle& p : particles_) {
    p.weight *= std::exp(lambda * (static_cast<double>(p.score) - reference)) + floor;
    total += p.weight;
  }
  if (total > 0.0 && std::isfinite(total)) {
    for (Particle& p : particles_) p.weight /= total;
  } else {
    // Every weight underflowed (cannot happen while the best particle has weight): start afresh.
    for (Particle& p : particles_) p.weight = 1.0 / static_cast<double>(particles_.size());
  }
}

ParticleFilter::CandidateView ParticleFilter::BestViewOfObject(const SignatureSpectrum& frame,
                                                               int object) {
  const std::vector<CandidateView> best = BestViewsOfObject(frame, object, 1);
  return best.empty() ? CandidateView{} : best.front();
}

std::vector<ParticleFilter::CandidateView> ParticleFilter::BestViewsOfObject(
    const SignatureSpectrum& frame, int object, int count) {
  std::vector<CandidateView> best;
  if (!frame.has_variance || ranking_harmonics_ == 0) return best;
  // Rank the object's views by two bounds over the first harmonics, each a matrix-vector product
  // over a contiguous table: the low-harmonic part of the spectral bound (the frame's weighted
  // magnitudes, as CircularCorrelator::Transform(..., weighted = true) makes them, against every
  // view's), and the same plus the product of the energies beyond (TailEnergyRoot). The first
  // favours views with much energy in the first harmonics; the second is a bound over all
  // harmonics and finds the views of a nearly round outline. The guided_candidates best of each
  // ranking are correlated exactly.
  const size_t half = frame.coefficients.size();
  const auto harmonics = static_cast<size_t>(ranking_harmonics_);
  frame_magnitudes_.resize(2 * harmonics);
  float* const weighted = frame_magnitudes_.data() + harmonics;
  for (size_t k = 0; k < harmonics; ++k) {
    frame_magnitudes_[k] = std::abs(frame.coefficients[k]);
    const float weight = (k == 0 || k == half - 1) ? 1.0f : 2.0f;
    weighted[k] = weight * frame_magnitudes_[k];
  }
  const float frame_tail =
      TailEnergyRoot(std::span<const float>(frame_magnitudes_.data(), harmonics), harmonics, half);
  const std::vector<float>& table = ranking_table_[static_cast<size_t>(object)];
  const auto views = static_cast<size_t>(num_views_);
  ranking_.resize(views);
  RankViews(table.data(), harmonics, views, weighted, ranking_.data());
  const float* const tails = table.data() + harmonics * views;
  // Both rankings' leaders in one pass over the usable views: each list keeps its `ranked` best
  // (value, view) pairs in decreasing order (ties: the higher view first), as a partial sort of
  // all of them would, with one comparison for most views.
  const auto ranked = static_cast<size_t>(std::max(options_.guided_candidates, count));
  bounds_.clear();
  tail_bounds_.clear();
  for (const int v : ranked_views_[static_cast<size_t>(object)]) {
    KeepLargest(&bounds_, ranked, {ranking_[static_cast<size_t>(v)], v});
    KeepLargest(&tail_bounds_, ranked,
                {ranking_[static_cast<size_t>(v)] + frame_tail * tails[v], v});
  }
  candidate_views_.clear();
  for (const std::vector<std::pair<float, int>>* ranking : {&bounds_, &tail_bounds_}) {
    for (size_t c = 0; c < ranking->size(); ++c) {
      const int view = (*ranking)[c].second;
      if (std::find(candidate_views_.begin(), candidate_views_.end(), view) ==
          candidate_views_.end()) {
        candidate_views_.push_back(view);
      }
    }
  }
  // The candidates' spectra are scattered over the database: all of them are requested before
  // the first is correlated.
  candidate_spectra_.clear();
  for (const int view : candidate_views_) {
    const int shell = ShellOf(object, view);
    if (!spectra_.Usable(object, view, shell)) continue;
    const SignatureSpectrum& spectrum = spectra_.Get(object, view, shell);
    PrefetchCoefficients(spectrum, correlator_.harmonics());
    candidate_spectra_.emplace_back(view, &spectrum);
  }
  for (const auto& [view, spectrum] : candidate_spectra_) {
    const CorrelationPeak peak = correlator_.Peak(frame, *spectrum);
    best.push_back({view, peak.RollDeg(spectra_.signature_length()), peak.score});
  }
  std::sort(best.begin(), best.end(),
            [](const CandidateView& a, const CandidateView& b) { return a.score > b.score; });
  if (best.size() > static_cast<size_t>(count)) best.resize(static_cast<size_t>(count));
  return best;
}

void ParticleFilter::Resample(const std::vector<double>& object_mass,
                              const SignatureSpectrum* frame) {
  const auto num_objects = static_cast<size_t>(num_objects_);
  const int floor = options_.min_particles_per_object;
  const std::vector<size_t> begin = ObjectRanges();

  // A joint systematic draw decides how many particles each object deserves.
  std::vector<double> weights(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) weights[i] = particles_[i].weight;
  const int fixed_total = options_.particles_per_object * num_objects_;
  const int draws = options_.adaptive ? static_cast<int>(particles_.size()) : fixed_total;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const std::vector<int> joint = SystematicResampleCounts(weights, draws, uniform(rng_));
  std::vector<int> drawn(num_objects, 0);
  std::vector<int> count(num_objects, 0);
  std::vector<uint8_t> bin_hit(static_cast<size_t>(std::max(1, sphere_.num_bins())), 0);
  for (size_t o = 0; o < num_objects; ++o) {
    std::fill(bin_hit.begin(), bin_hit.end(), 0);
    int bins = 0;
    for (size_t i = begin[o]; i < begin[o + 1]; ++i) {
      if (joint[i] == 0) continue;
      drawn[o] += joint[i];
      const uint32_t bin = sphere_.bin_of_view[static_cast<size_t>(particles_[i].view)];
      if (bin < bin_hit.size() && bin_hit[bin] == 0) {
        bin_hit[bin] = 1;
        ++bins;
      }
    }
    if (options_.adaptive) {
      const int own_floor = object_mass[o] < options_.dormant_probability
                                ? std::min(options_.dormant_particles_per_object, floor)
                                : floor;
      count[o] = drawn[o] > 0
                     ? std::clamp(KldParticleCount(bins, options_.kld_epsilon, options_.kld_delta),
                                  own_floor, options_.max_particles_per_object)
                     : own_floor;
    } else {
      count[o] = std::max(drawn[o], floor);
    }
  }
  if (!options_.adaptive) {
    // The floor's extra particles come from the objects with the most.
    int excess = std::accumulate(count.begin(), count.end(), 0) - fixed_total;
    while (excess > 0) {
      const auto largest =
          static_cast<size_t>(std::max_element(count.begin(), count.end()) - count.begin());
      const int take = std::min(excess, count[largest] - floor);
      if (take <= 0) break;
      count[largest] -= take;
      excess -= take;
    }
  }

  std::vector<Particle> resampled;
  resampled.reserve(static_cast<size_t>(std::accumulate(count.begin(), count.end(), 0)));
  for (size_t o = 0; o < num_objects; ++o) {
    if (count[o] == 0) continue;
    const std::span<const double> own(weights.data() + begin[o], begin[o + 1] - begin[o]);
    const double own_mass = std::accumulate(own.begin(), own.end(), 0.0);
    int fresh = 0;
    if (drawn[o] < floor) {
      fresh = static_cast<int>(std::lround(options_.reseed_fraction * count[o]));
    }
    // With the data-driven proposal every frame gets the best views anyway.
    const bool guided = options_.guided_reseeding && !options_.data_driven_proposal &&
                        frame != nullptr && frame->has_variance && RankingReady();
    if (guided) fresh = std::clamp(fresh, 1, count[o]);
    const double weight = object_mass[o] / count[o];
    if (own.empty()) {
      // No particle to descend from (a floor of 0 before): start new histories.
      for (int f = 0; f < count[o]; ++f) {
        Particle particle = FreshParticle(static_cast<int>(o));
        particle.weight = weight;
        resampled.push_back(std::move(particle));
      }
      continue;
    }
    // Draw all count[o] by weight (evenly if every weight underflowed); `fresh` of them, chosen at
    // random, then move (the first to the guided view, the others to uniform views), keeping
    // their history up to this frame.
    const std::vector<double> even(own.size(), 1.0);
    const std::vector<int> copies = SystematicResampleCounts(
        own_mass > 0.0 ? own : std::span<const double>(even), count[o], uniform(rng_));
    const size_t first_new = resampled.size();
    for (size_t i = 0; i < copies.size(); ++i) {
      for (int c = 0; c < copies[i]; ++c) {
        resampled.push_back(particles_[begin[o] + i]);
        resampled.back().weight = weight;
      }
    }
    // Which draws are reseeded: a random subset, so the best hypotheses are not always the ones.
    for (int f = 0; f < fresh; ++f) {
      const size_t remaining = resampled.size() - first_new - static_cast<size_t>(f);
      const size_t pick = first_new + static_cast<size_t>(f) +
                          std::uniform_int_distribution<size_t>(0, remaining - 1)(rng_);
      std::swap(resampled[first_new + static_cast<size_t>(f)], resampled[pick]);
      Particle& particle = resampled[first_new + static_cast<size_t>(f)];
      particle.roll_known = false;
      particle.roll_deg = 0.0;
      particle.score = 0.0f;
      if (f == 0 && guided) {
        // The object's best view for this frame (exact, pruned by the spectral bound).
        const CandidateView candidate = BestViewOfObject(*frame, static_cast<int>(o));
        if (candidate.view >= 0) {
          particle.view = candidate.view;
          particle.roll_deg = candidate.roll_deg;
          particle.roll_known = true;
          particle.score = candidate.score;
          continue;
        }
      }
      particle.view = std::uniform_int_distribution<int>(0, num_views_ - 1)(rng_);
    }
  }
  // Objects left without particles (a floor of 0) take their mass with them: renormalise.
  double total = 0.0;
  for (const Particle& p : resampled) total += p.weight;
  if (total > 0.0) {
    for (Particle& p : resampled) p.weight /= total;
  } else {
    for (Particle& p : resampled) p.weight = 1.0 / static_cast<double>(resampled.size());
  }
  particles_ = std::move(resampled);
}

void ParticleFilter::CutHistory(int64_t oldest_kept_frame) {
  std::unordered_set<const HistoryNode*> visited;
  auto cut = [&](const HistoryNode* node) {
    while (node != nullptr && visited.insert(node).second) {
      if (node->state_.frame <= oldest_kept_frame) {
        node->parent_.reset();
        break;
      }
      node = node->parent_.get();
    }
  };
  for (const Particle& p : particles_) cut(p.history.get());
  cut(best_history_.get());
}

std::vector<PoseState> ParticleFilter::History(const Particle& particle) {
  std::vector<PoseState> states;
  for (const HistoryNode* node = particle.history.get(); node != nullptr; node = node->parent()) {
    states.push_back(node->state());
  }
  std::reverse(states.begin(), states.end());
  return states;
}

std::vector<PoseState> ParticleFilter::BestHistory() const {
  Particle holder;
  holder.history = best_history_;
  return History(holder);
}

std::optional<PoseState> ParticleFilter::SmoothedState(int64_t frame, int object) const {
  // Each particle's ancestor in `frame`, and the weight per (object, view) of them.
  struct Group {
    int object = -1;
    int view = -1;
    double mass = 0.0;
    const HistoryNode* heaviest = nullptr;
    double heaviest_mass = 0.0;
  };
  std::unordered_map<const HistoryNode*, double> ancestors;
  for (const Particle& p : particles_) {
    if (object >= 0 && p.object != object) continue;
    const HistoryNode* node = p.history.get();
    while (node != nullptr && node->state().frame > frame) node = node->parent();
    if (node == nullptr || node->state().frame != frame || node->state().object < 0 ||
        node->state().view < 0)
      continue;
    ancestors[node] += p.weight;
  }
  if (ancestors.empty()) return std::nullopt;
  std::vector<Group> groups;
  std::unordered_map<int64_t, size_t> group_of;
  for (const auto& [node, mass] : ancestors) {
    const PoseState& state = node->state();
    const int64_t key = static_cast<int64_t>(state.object) * num_views_ + state.view;
    auto [it, added] = group_of.emplace(key, groups.size());
    if (added) groups.push_back({state.object, state.view});
    Group& group = groups[it->second];
    group.mass += mass;
    if (group.heaviest == nullptr || mass > group.heaviest_mass ||
        (mass == group.heaviest_mass && state.score > group.heaviest->state().score)) {
      group.heaviest = node;
      group.heaviest_mass = mass;
    }
  }
  // The object with the most ancestor weight (as the filter's estimate picks the most probable
  // object first), then the mode around each of its groups; the heaviest mode's centre wins (then
  // its own mass).
  if (object < 0) {
    std::vector<double> object_mass(static_cast<size_t>(num_objects_), 0.0);
    for (const Group& group : groups) object_mass[static_cast<size_t>(group.object)] += group.mass;
    object = static_cast<int>(std::max_element(object_mass.begin(), object_mass.end()) -
                              object_mass.begin());
  }
  const ViewEquivalence& same = equivalence_[static_cast<size_t>(object)];
  const double radius = options_.mode_radius_deg;
  size_t best = groups.size();
  double best_mode = -1.0;
  for (size_t i = 0; i < groups.size(); ++i) {
    if (groups[i].object != object) continue;
    const Eigen::Vector3d& centre = sphere_.directions[static_cast<size_t>(groups[i].view)];
    double mode = 0.0;
    for (const Group& other : groups) {
      if (other.object == object &&
          same.AngleDeg(sphere_.directions[static_cast<size_t>(other.view)], centre) <= radius)
        mode += other.mass;
    }
    if (mode > best_mode || (mode == best_mode && groups[i].mass > groups[best].mass)) {
      best = i;
      best_mode = mode;
    }
  }
  return groups[best].heaviest->state();
}

std::vector<PoseState> ParticleFilter::MostLikelyHistory(int64_t from_frame, int object) const {
  // Every node from `from_frame` on, reachable from the particles, and each frame's best score.
  std::unordered_map<const HistoryNode*, double> path_log_likelihood;
  std::vector<const HistoryNode*> nodes;
  std::unordered_map<int64_t, float> best_score;
  auto visit = [&](const HistoryNode* node) {
    for (; node != nullptr && node->state().frame >= from_frame; node = node->parent()) {
      if (!path_log_likelihood.emplace(node, 0.0).second) break;
      nodes.push_back(node);
      if (node->state().measured) {
        auto [it, added] = best_score.emplace(node->state().frame, node->state().score);
        if (!added) it->second = std::max(it->second, node->state().score);
      }
    }
  };
  const bool best_counts =
      best_history_ != nullptr && (object < 0 || best_history_->state().object == object);
  if (best_counts) visit(best_history_.get());
  for (const Particle& p : particles_) {
    if (object < 0 || p.object == object) visit(p.history.get());
  }
  // Path sums, parents (earlier frames) first.
  std::sort(nodes.begin(), nodes.end(), [](const HistoryNode* a, const HistoryNode* b) {
    return a->state().frame < b->state().frame;
  });
  const double lambda = options_.likelihood_sharpness;
  const double floor = options_.likelihood_floor;
  for (const HistoryNode* node : nodes) {
    double sum = 0.0;
    if (node->parent() != nullptr) {
      const auto parent = path_log_likelihood.find(node->parent());
      if (parent != path_log_likelihood.end()) sum = parent->second;
    }
    const PoseState& state = node->state();
    if (state.measured) {
      const double gap =
          static_cast<double>(state.score) - static_cast<double>(best_score.at(state.frame));
      sum += std::log(std::exp(lambda * gap) + floor);
    }
    path_log_likelihood[node] = sum;
  }
  const HistoryNode* chosen = best_counts ? best_history_.get() : nullptr;
  double chosen_sum = chosen != nullptr && path_log_likelihood.count(chosen) != 0
                          ? path_log_likelihood.at(chosen)
                          : -std::numeric_limits<double>::infinity();
  for (const Particle& p : particles_) {
    if (object >= 0 && p.object != object) continue;
    const auto it = path_log_likelihood.find(p.history.get());
    if (it != path_log_likelihood.end() && it->second > chosen_sum) {
      chosen = it->first;
      chosen_sum = it->second;
    }
  }
  Particle holder;
  for (const Particle& p : particles_) {
    if (p.history.get() == chosen) holder.history = p.history;
  }
  if (holder.history == nullptr && best_counts) holder.history = best_history_;
  return History(holder);
}

int64_t ParticleFilter::CountLiveHistoryNodes() const {
  std::unordered_set<const HistoryNode*> visited;
  auto walk = [&](const HistoryNode* node) {
    while (node != nullptr && visited.insert(node).second) node = node->parent();
  };
  for (const Particle& p : particles_) walk(p.history.get());
  walk(best_history_.get());
  return static_cast<int64_t>(visited.size());
}

double EffectiveSampleSize(std::span<const double> normalised_weights) {
  double sum_squares = 0.0;
  for (double w : normalised_weights) sum_squares += w * w;
  return sum_squares > 0.0 ? 1.0 / sum_squares : 0.0;
}

std::vector<int> SystematicResampleCounts(std::span<const double> weights, int count, double u) {
  if (count < 0) ThrowError("resampling count must be >= 0, got ", count);
  if (!(u >= 0.0 && u < 1.0)) ThrowError("resampling offset must be in [0, 1), got ", u);
  std::vector<int> counts(weights.size(), 0);
  double total = 0.0;
  for (double w : weights) {
    if (!(w >= 0.0) || !std::isfinite(w)) ThrowError("resampling weight ", w, " is not >= 0");
    total += w;
  }
  if (count == 0) return counts;
  if (!(total > 0.0)) ThrowError("resampling weights sum to ", total);
  // Comb positions (u + j) / count of the cumulative normalised weights.
  int drawn = 0;
  double cumulative = 0.0;
  size_t last_positive = 0;
  for (size_t i = 0; i < weights.size() && drawn < count; ++i) {
    if (weights[i] > 0.0) last_positive = i;
    cumulative += weights[i] / total;
    while (drawn < count && (u + drawn) / count < cumulative) {
      ++counts[i];
      ++drawn;
    }
  }
  // Rounding can leave the last tooth past a cumulative sum of 1 - tiny.
  for (size_t i = last_positive; i < weights.size(); ++i) {
    if (weights[i] > 0.0) last_positive = i;
  }
  counts[last_positive] += count - drawn;
  return counts;
}

double StandardNormalQuantile(double p) {
  if (!(p > 0.0 && p < 1.0)) ThrowError("normal quantile needs p in (0, 1), got ", p);
  // Bisection on the CDF 0.5 erfc(-z / sqrt 2): exact to double precision, and called rarely.
  double lo = -40.0;
  double hi = 40.0;
  for (int iteration = 0; iteration < 200 && hi - lo > 1e-14; ++iteration) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(-mid / std::numbers::sqrt2) < p) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

int KldParticleCount(int bins, double epsilon, double delta) {
  if (!(epsilon > 0.0)) ThrowError("KLD epsilon must be > 0, got ", epsilon);
  if (bins <= 1) return 0;
  const double z = StandardNormalQuantile(1.0 - delta);
  const double k = bins - 1;
  const double a = 2.0 / (9.0 * k);
  const double cube = std::pow(1.0 - a + std::sqrt(a) * z, 3.0);
  const double count = std::ceil(k / (2.0 * epsilon) * cube);
  return count >= static_cast<double>(INT_MAX) ? INT_MAX : static_cast<int>(count);
}

}  // namespace silpose
