#include "silpose/match/view_matcher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <queue>
#include <sstream>
#include <system_error>
#include <thread>

#include "silpose/util/error.h"
#include "silpose/util/threads.h"

namespace silpose {

bool MatchOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (top_k < 1) {
    message << "top K must be >= 1, got " << top_k;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

namespace {

// A view is searched if its silhouette was described and has a shape (not a perfect circle):
// radii with no spread are constant after normalisation.
bool UsableSignature(const ModelViews& model, int view, int shell) {
  if (model.Record(view, shell).status != SignatureStatus::kOk) return false;
  float low = 1.0f, high = 1.0f;
  for (float r : model.Signature(view, shell)) {
    low = std::min(low, r);
    high = std::max(high, r);
  }
  return high - low > 1e-6f;
}

}  // namespace

ViewSpectra::ViewSpectra(const ViewDatabase& database, const CorrelationOptions& options)
    : database_(database),
      options_(options),
      num_models_(static_cast<int>(database.models.size())),
      num_views_(database.sphere.num_views()),
      num_shells_(database.num_shells()),
      signature_length_(database.parameters.signature.length) {
  const size_t blocks = static_cast<size_t>(num_models_) * static_cast<size_t>(num_shells_);
  const size_t total = blocks * static_cast<size_t>(num_views_);
  blocks_.resize(blocks);
  block_once_ = std::make_unique<std::once_flag[]>(blocks);
  magnitudes_once_ = std::make_unique<std::once_flag[]>(blocks);
  coefficients_once_ = std::make_unique<std::once_flag[]>(blocks);
  signatures_once_ = std::make_unique<std::once_flag[]>(blocks);
  heads_.resize(blocks);
  magnitudes_.resize(blocks);
  heads_once_ = std::make_unique<std::once_flag[]>(blocks);
  once_ = std::make_unique<std::once_flag[]>(total);
  usable_.assign(total, 0);
  apparent_.assign(total, 0.0f);
  // ViewDatabase::ApparentRadius with each shell's focal length computed once.
  std::vector<double> focal(static_cast<size_t>(num_shells_));
  for (int s = 0; s < num_shells_; ++s) {
    focal[static_cast<size_t>(s)] = ViewCamera(database.parameters.ShellRender(s)).focal_x_px;
  }
  stored_.assign(static_cast<size_t>(num_models_), 0);
  const size_t harmonics = CircularCorrelator(signature_length_, options_).harmonics();
  for (int m = 0; m < num_models_; ++m) {
    const ModelViews& model = database.models[static_cast<size_t>(m)];
    if (model.views.size() != static_cast<size_t>(num_views_) * static_cast<size_t>(num_shells_)) {
      ThrowError("model '", model.name, "' has ", model.views.size(), " view records, expected ",
                 num_views_, " views x ", num_shells_, " shells");
    }
    // Stored spectra serve only a matcher with the smoothing they were made with.
    const StoredSpectra& stored = model.spectra;
    stored_[static_cast<size_t>(m)] = !stored.empty() && stored.harmonics == harmonics &&
                                      stored.smoothing_deg == options_.smoothing_deg;
    if (stored_[static_cast<size_t>(m)] == 0 && !model.signatures_stored()) {
      // Its signatures are derived from the stored spectra, already smoothed: no other spectra
      // can be made from them.
      ThrowError(database.source.empty() ? std::string("database") : database.source, ": model '",
                 model.name, "' keeps only its views' spectra (", stored.harmonics,
                 " harmonics of signatures of ", signature_length_, " smoothed by ",
                 stored.smoothing_deg,
                 " degrees: a compact database), not the signatures a matcher with smoothing ",
                 options_.smoothing_deg, " degrees and signatures of ", signature_length_,
                 " needs: rebuild it with 'silpose build-db --full-signatures'");
    }
    for (int s = 0; s < num_shells_; ++s) {
      for (int v = 0; v < num_views_; ++v) {
        const size_t index = Index(m, s) * static_cast<size_t>(num_views_) + static_cast<size_t>(v);
        const size_t record =
            static_cast<size_t>(s) * static_cast<size_t>(num_views_) + static_cast<size_t>(v);
        if (stored_[static_cast<size_t>(m)] != 0) {
          usable_[index] = (stored.kinds[record] & StoredSpectra::kUsable) != 0;
        } else {
          usable_[index] = UsableSignature(model, v, s);
        }
        const ViewRecord& view_record = model.views[record];
        apparent_[index] =
            view_record.status == SignatureStatus::kOk
                ? static_cast<float>(view_record.mean_radius_px / focal[static_cast<size_t>(s)])
                : 0.0f;
      }
    }
  }
  table_bytes_ = blocks_.capacity() * sizeof(blocks_[0]) + heads_.capacity() * sizeof(heads_[0]) +
                 4 * blocks * sizeof(std::once_flag) + total * sizeof(std::once_flag) +
                 usable_.capacity() * sizeof(uint8_t) + stored_.capacity() +
                 apparent_.capacity() * sizeof(float);
}

void ViewSpectra::OpenBlock(int model, int shell) const {
  if (database_.views_unchecked) {
    if (stored_[static_cast<size_t>(model)] != 0) {
      // Matching reads the stored spectra only; the signatures' block and values are checked by
      // whoever reads them (CheckSignatures): hashing 4 MB of signatures per model and shell was
      // most of a first frame's time.
      CheckCoefficients(model, shell);
      (void)Magnitudes(model, 0, shell);  // checks (or makes) the magnitudes once
    } else {
      CheckSignatures(model, shell);  // the spectra are made from them
    }
  }
  blocks_[Index(model, shell)] =
      std::make_unique<SignatureSpectrum[]>(static_cast<size_t>(num_views_));
  spectrum_bytes_.fetch_add(static_cast<size_t>(num_views_) * sizeof(SignatureSpectrum),
                            std::memory_order_relaxed);
}

void ViewSpectra::OpenMagnitudes(int model, int shell) const {
  const StoredSpectra& stored = database_.models[static_cast<size_t>(model)].spectra;
  if (!stored.magnitudes.empty()) {
    if (database_.views_unchecked) database_.CheckBlock(model, shell, ViewBlock::kMagnitudes);
    return;
  }
  // Their coefficients' block is checked first: a corrupt one is reported, not bounded.
  CheckCoefficients(model, shell);
  const size_t count = static_cast<size_t>(num_views_) * stored.harmonics;
  const std::complex<float>* coefficients =
      stored.coefficients.data() + static_cast<size_t>(shell) * count;
  auto magnitudes = std::make_unique_for_overwrite<float[]>(count);
  for (size_t i = 0; i < count; ++i) magnitudes[i] = std::abs(coefficients[i]);
  magnitudes_[Index(model, shell)] = std::move(magnitudes);
  spectrum_bytes_.fetch_add(count * sizeof(float), std::memory_order_relaxed);
}

void ViewSpectra::MakeBoundHeads(int model, int shell) const {
  const size_t views = static_cast<size_t>(num_views_);
  auto heads = std::make_unique<float[]>(views * kBoundHeadStride);
  for (size_t v = 0; v < views; ++v) {
    float* head = heads.get() + v * kBoundHeadStride;
    std::fill(head, head + kBoundHeadStride, 0.0f);
    if (!Usable(model, static_cast<int>(v), shell)) continue;
    const std::span<const float> magnitudes = Magnitudes(model, static_cast<int>(v), shell);
    const size_t n = std::min(kBoundHead, magnitudes.size());
    std::copy_n(magnitudes.begin(), n, head);
    // The norm of the other magnitudes (non-finite for a corrupt view, which sends the search to
    // its checked spectrum).
    double tail = 0.0;
    for (size_t k = n; k < magnitudes.size(); ++k) {
      tail += static_cast<double>(magnitudes[k]) * static_cast<double>(magnitudes[k]);
    }
    head[kBoundHead] = static_cast<float>(std::sqrt(tail));
  }
  spectrum_bytes_.fetch_add(views * kBoundHeadStride * sizeof(float), std::memory_order_relaxed);
  heads_[Index(model, shell)] = std::move(heads);
}

void ViewSpectra::Compute(int model, int view, int shell) const {
  const ModelViews& views = database_.models[static_cast<size_t>(model)];
  const size_t record =
      static_cast<size_t>(shell) * static_cast<size_t>(num_views_) + static_cast<size_t>(view);
  // A database read with ViewChecks::kOnFirstUse: this view's values are checked now (throws
  // silpose::Error naming the file; call_once lets the next Get try, and fail, again). With stored
  // spectra only the spectrum: the matcher reads nothing else, and reading every used view's
  // signature was most of the first frames' time; its signature is checked where it is read
  // (CheckSignatures).
  const bool from_file = stored_[static_cast<size_t>(model)] != 0;
  if (database_.views_unchecked) {
    if (from_file) {
      database_.CheckViewSpectrum(model, record);
    } else {
      database_.CheckView(model, record);
    }
  }
  if (views.Record(view, shell).status != SignatureStatus::kOk) return;
  if (from_file) {
    // The database's own spectrum, where the file is mapped: nothing made, nothing copied.
    const StoredSpectra& stored = views.spectra;
    SignatureSpectrum& spectrum = blocks_[Index(model, shell)][static_cast<size_t>(view)];
    spectrum.coefficients = SharedArray<std::complex<float>>::Refer(
        stored.coefficients.data() + record * stored.harmonics, stored.harmonics);
    spectrum.magnitudes =
        SharedArray<float>::Refer(Magnitudes(model, view, shell).data(), stored.harmonics);
    spectrum.has_variance = (stored.kinds[record] & StoredSpectra::kHasVariance) != 0;
    spectrum.amplitude = stored.amplitudes.empty() ? 0.0f : stored.amplitudes[record];
    num_computed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  // One correlator per thread: the FFT plan and scratch are reused across views.
  thread_local std::unique_ptr<CircularCorrelator> correlator;
  thread_local SignatureSpectrum full;
  if (!correlator || correlator->length() != signature_length_ ||
      correlator->options().smoothing_deg != options_.smoothing_deg ||
      correlator->options().backend != options_.backend) {
    correlator = std::make_unique<CircularCorrelator>(signature_length_, options_);
  }
  correlator->Transform(views.Signature(view, shell), &full);
  // Only the harmonics the smoothing keeps: the others are exactly 0 and the correlator treats
  // left-out coefficients as 0. assign() into the empty vectors allocates their exact size.
  SignatureSpectrum& stored = blocks_[Index(model, shell)][static_cast<size_t>(view)];
  const auto kept = static_cast<std::ptrdiff_t>(correlator->harmonics());
  stored.coefficients.assign(full.coefficients.begin(), full.coefficients.begin() + kept);
  stored.magnitudes.assign(full.magnitudes.begin(), full.magnitudes.end());
  stored.has_variance = full.has_variance;
  stored.amplitude = full.amplitude;
  num_computed_.fetch_add(1, std::memory_order_relaxed);
  spectrum_bytes_.fetch_add(stored.coefficients.owned_bytes() + stored.magnitudes.owned_bytes(),
                            std::memory_order_relaxed);
}

void ViewSpectra::ComputeAll(int num_threads) const {
  const size_t total = usable_.size();
  const size_t per_model = static_cast<size_t>(num_shells_) * static_cast<size_t>(num_views_);
  // Views are handed out in chunks from a shared counter; a failure stops every worker and is
  // rethrown here.
  constexpr size_t kChunk = 64;
  std::atomic<size_t> next{0};
  std::mutex failure_mutex;
  std::exception_ptr failure;
  auto work = [&] {
    try {
      for (size_t begin = next.fetch_add(kChunk); begin < total; begin = next.fetch_add(kChunk)) {
        for (size_t index = begin; index < std::min(total, begin + kChunk); ++index) {
          const size_t in_model = index % per_model;
          Get(static_cast<int>(index / per_model),
              static_cast<int>(in_model % static_cast<size_t>(num_views_)),
              static_cast<int>(in_model / static_cast<size_t>(num_views_)));
        }
      }
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next.store(total);
    }
  };
  const size_t chunks = (total + kChunk - 1) / kChunk;
  const auto threads = static_cast<size_t>(
      std::min<size_t>(static_cast<size_t>(WorkerThreads(num_threads)), chunks));
  std::vector<std::thread> workers;
  for (size_t t = 1; t < threads; ++t) {
    try {
      workers.emplace_back(work);
    } catch (const std::system_error&) {
      break;  // no more threads: the ones running (and this one) do the rest
    }
  }
  work();
  for (std::thread& worker : workers) worker.join();
  if (failure) std::rethrow_exception(failure);
}

void StoreViewSpectra(ViewDatabase* database, const CorrelationOptions& options, int num_threads) {
  const size_t harmonics = CircularCorrelator(database->signature_length(), options).harmonics();
  // Drop what was stored, so that the spectra below are computed, not lent; a compact model's
  // spectra are its only data: they are kept if they are these (else ViewSpectra refuses them).
  for (ModelViews& model : database->models) {
    if (model.signatures_stored()) model.spectra = StoredSpectra{};
  }
  const ViewSpectra spectra(*database, options);
  spectra.ComputeAll(num_threads);
  const int views = database->num_views();
  for (int m = 0; m < spectra.num_models(); ++m) {
    ModelViews& model = database->models[static_cast<size_t>(m)];
    if (!model.signatures_stored()) continue;
    const size_t records = model.views.size();
    std::vector<uint8_t> kinds(records, 0);
    std::vector<std::complex<float>> coefficients(records * harmonics);
    std::vector<float> magnitudes(records * harmonics);
    std::vector<float> amplitudes(records, 0.0f);
    for (size_t r = 0; r < records; ++r) {
      const int view = static_cast<int>(r % static_cast<size_t>(views));
      const int shell = static_cast<int>(r / static_cast<size_t>(views));
      const SignatureSpectrum& spectrum = spectra.Get(m, view, shell);
      if (model.views[r].status != SignatureStatus::kOk) continue;
      SILPOSE_ASSERT(spectrum.coefficients.size() == harmonics &&
                     spectrum.magnitudes.size() == harmonics);
      kinds[r] = StoredSpectra::kPresent |
                 (spectrum.has_variance ? StoredSpectra::kHasVariance : uint8_t{0}) |
                 (spectra.Usable(m, view, shell) ? StoredSpectra::kUsable : uint8_t{0});
      std::copy(spectrum.coefficients.begin(), spectrum.coefficients.end(),
                coefficients.begin() + static_cast<std::ptrdiff_t>(r * harmonics));
      std::copy(spectrum.magnitudes.begin(), spectrum.magnitudes.end(),
                magnitudes.begin() + static_cast<std::ptrdiff_t>(r * harmonics));
      amplitudes[r] = spectrum.amplitude;
    }
    // `spectra` made every view's spectrum from the signatures above: replacing this model's stored
    // spectra changes none of them.
    StoredSpectra stored;
    stored.smoothing_deg = options.smoothing_deg;
    stored.harmonics = static_cast<uint32_t>(harmonics);
    stored.kinds = std::move(kinds);
    stored.coefficients = std::move(coefficients);
    stored.magnitudes = std::move(magnitudes);
    stored.amplitudes = std::move(amplitudes);
    model.spectra = std::move(stored);
  }
}

int ViewSpectra::ChooseShell(int model, int view, double apparent_radius) const {
  return NearestShell(apparent_radius, database_.parameters.distances_in_radii, [&](int shell) {
    return static_cast<double>(apparent_[Index(model, shell) * static_cast<size_t>(num_views_) +
                                         static_cast<size_t>(view)]);
  });
}

ViewMatcher::ViewMatcher(const ViewSpectra& spectra)
    : spectra_(spectra), correlator_(spectra.signature_length(), spectra.options()) {}

CorrelationPeak ViewMatcher::Score(const SignatureSpectrum& query, int model, int view, int shell) {
  return correlator_.Peak(query, spectra_.Get(model, view, shell));
}

std::vector<MatchCandidate> ViewMatcher::Match(std::span<const float> radii,
                                               const MatchOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid match options: ", error);
  const int length = spectra_.signature_length();
  if (static_cast<int>(radii.size()) != length) {
    ThrowError("signature has ", radii.size(), " values but the database uses ", length);
  }
  std::vector<int> models = options.models;
  if (models.empty()) {
    for (int m = 0; m < spectra_.num_models(); ++m) models.push_back(m);
  }
  for (int m : models) {
    if (m < 0 || m >= spectra_.num_models()) ThrowError("model index ", m, " out of range");
  }
  correlator_.Transform(radii, &query_, /*weighted=*/true);
  stats_ = {};

  auto make_candidate = [&](int model, int view, int shell, const CorrelationPeak& peak) {
    return MatchCandidate{model, view, shell, peak.RollDeg(length), peak.score};
  };
  auto better = [](const MatchCandidate& a, const MatchCandidate& b) {
    if (a.score != b.score) return a.score > b.score;
    if (a.model != b.model) return a.model < b.model;
    return a.view < b.view;
  };
  // Min-heap (worst on top) of the best candidates so far.
  std::priority_queue<MatchCandidate, std::vector<MatchCandidate>, decltype(better)> best(better);
  auto offer = [&](const MatchCandidate& candidate) {
    if (static_cast<int>(best.size()) < options.top_k) {
      best.push(candidate);
    } else if (better(candidate, best.top())) {
      best.pop();
      best.push(candidate);
    }
  };

  if (options.exhaustive) {
    for (int m : models) {
      for (int v = 0; v < spectra_.num_views(); ++v) {
        const int shell = spectra_.ChooseShell(m, v, options.apparent_radius);
        if (!spectra_.Usable(m, v, shell)) continue;
        offer(make_candidate(m, v, shell, correlator_.Peak(query_, spectra_.Get(m, v, shell))));
        ++stats_.views_correlated;
      }
    }
  } else {
    // Best-first search on upper bounds of each view's score, in two stages. The exact bound
    // (CorrelationUpperBound: the dot product of the magnitudes, over every kept harmonic) reads
    // each view's 151 magnitudes; with hundreds of objects, reading them all made the search
    // memory-bound. By Cauchy-Schwarz the harmonics from kBoundHead on contribute at most
    // |q_tail| |d_tail|, and ViewSpectra::BoundHeads keeps each view's first magnitudes and
    // |d_tail| in one small contiguous table: a cheap bound, never below the exact one.
    // Every view gets this one; a view is given its exact bound when it comes to the top of the
    // queue, and correlated when it comes there again. The top-k views by the cheap bound are
    // correlated first, and no view whose bound is below their k-th score enters the queue.
    constexpr size_t kHead = ViewSpectra::kBoundHead;
    constexpr size_t kStride = ViewSpectra::kBoundHeadStride;
    // Rounding in the FFT can put an exact score a hair above its bound; the margin keeps the
    // pruning exact.
    constexpr float kMargin = 1e-5f;
    const std::span<const float> q = query_.magnitudes.span();
    std::array<float, kHead> q_head{};
    std::copy_n(q.begin(), std::min(kHead, q.size()), q_head.begin());
    float q_tail = 0.0f;
    for (size_t k = kHead; k < q.size(); ++k) q_tail += q[k] * q[k];
    q_tail = std::sqrt(q_tail);
    // The exact bound, or the Get that names a corrupt view.
    auto exact_bound = [&](int m, int v, int shell) {
      const float bound = CorrelationUpperBound(q, spectra_.Magnitudes(m, v, shell));
      // Impossible for a valid spectrum (bounds are at most 1 plus rounding): Get checks the
      // view's values and names the corrupt file; if they pass, the bound is the true one's.
      return bound <= 1.5f ? bound : CorrelationUpperBound(q, spectra_.Get(m, v, shell).magnitudes);
    };
    std::vector<BoundedView>& bounds = bounds_;  // reused: no allocation per query
    bounds.clear();
    const bool one_shell = spectra_.num_shells() == 1;
    for (int m : models) {
      const float* shell_0 = one_shell ? spectra_.BoundHeads(m, 0).data() : nullptr;
      for (int v = 0; v < spectra_.num_views(); ++v) {
        const int shell = one_shell ? 0 : spectra_.ChooseShell(m, v, options.apparent_radius);
        if (!spectra_.Usable(m, v, shell)) continue;
        const float* head = (one_shell ? shell_0 : spectra_.BoundHeads(m, shell).data()) +
                            static_cast<size_t>(v) * kStride;
        float dot = 0.0f;
        for (size_t k = 0; k < kHead; ++k) dot += q_head[k] * head[k];
        const float bound = dot + q_tail * head[kHead] + ViewSpectra::kBoundHeadSlack;
        if (bound <= 1.5f) {
          bounds.push_back({bound, m, v, shell, false});
        } else {
          bounds.push_back({exact_bound(m, v, shell), m, v, shell, true});
        }
      }
    }
    stats_.views_bounded = static_cast<int>(bounds.size());
    auto correlate = [&](const BoundedView& view) {
      offer(make_candidate(
          view.model, view.view, view.shell,
          correlator_.Peak(query_, spectra_.Get(view.model, view.view, view.shell))));
      ++stats_.views_correlated;
    };
    const auto full_list = [&] { return static_cast<int>(best.size()) == options.top_k; };
    const auto seeds =
        static_cast<std::ptrdiff_t>(std::min(bounds.size(), static_cast<size_t>(options.top_k)));
    if (seeds > 0) {
      std::nth_element(bounds.begin(), bounds.begin() + (seeds - 1), bounds.end(),
                       [](const BoundedView& a, const BoundedView& b) { return b < a; });
      for (std::ptrdiff_t i = 0; i < seeds; ++i) correlate(bounds[static_cast<size_t>(i)]);
      bounds.erase(bounds.begin(), bounds.begin() + seeds);
      if (full_list()) {
        const float floor = best.top().score;
        std::erase_if(bounds, [&](const BoundedView& b) { return floor >= b.bound + kMargin; });
      }
    }
    std::make_heap(bounds.begin(), bounds.end());
    while (!bounds.empty()) {
      const BoundedView next = bounds.front();
      if (full_list() && best.top().score >= next.bound + kMargin) break;
      std::pop_heap(bounds.begin(), bounds.end());
      bounds.pop_back();
      if (next.full) {
        correlate(next);
        continue;
      }
      const float bound = exact_bound(next.model, next.view, next.shell);
      if (full_list() && best.top().score >= bound + kMargin) continue;
      bounds.push_back({bound, next.model, next.view, next.shell, true});
      std::push_heap(bounds.begin(), bounds.end());
    }
  }

  std::vector<MatchCandidate> result;
  result.reserve(best.size());
  while (!best.empty()) {
    result.push_back(best.top());
    best.pop();
  }
  std::reverse(result.begin(), result.end());
  return result;
}

}  // namespace silpose
