#include "silpose/match/view_matcher.h"

#include <algorithm>
#include <queue>
#include <sstream>

#include "silpose/util/error.h"

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

ViewSpectra::ViewSpectra(const ViewDatabase& database, const CorrelationOptions& options)
    : options_(options),
      num_models_(static_cast<int>(database.models.size())),
      num_views_(database.sphere.num_views()),
      signature_length_(database.parameters.signature.length) {
  CircularCorrelator correlator(signature_length_, options);
  spectra_.resize(static_cast<size_t>(num_models_) * static_cast<size_t>(num_views_));
  usable_.resize(spectra_.size());
  for (int m = 0; m < num_models_; ++m) {
    const ModelViews& model = database.models[static_cast<size_t>(m)];
    for (int v = 0; v < num_views_; ++v) {
      const size_t index =
          static_cast<size_t>(m) * static_cast<size_t>(num_views_) + static_cast<size_t>(v);
      // A view is searched if its silhouette was described and has a shape (not a perfect circle).
      if (model.views[static_cast<size_t>(v)].status == SignatureStatus::kOk) {
        correlator.Transform(model.Signature(v), &spectra_[index]);
        usable_[index] = spectra_[index].has_variance;
      }
    }
  }
}

ViewMatcher::ViewMatcher(const ViewSpectra& spectra)
    : spectra_(spectra), correlator_(spectra.signature_length(), spectra.options()) {}

CorrelationPeak ViewMatcher::Score(const SignatureSpectrum& query, int model, int view) {
  return correlator_.Peak(query, spectra_.Get(model, view));
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

  auto make_candidate = [&](int model, int view, const CorrelationPeak& peak) {
    return MatchCandidate{model, view, peak.RollDeg(length), peak.score};
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
        if (!spectra_.Usable(m, v)) continue;
        offer(make_candidate(m, v, correlator_.Peak(query_, spectra_.Get(m, v))));
        ++stats_.views_correlated;
      }
    }
  } else {
    std::vector<BoundedView>& bounds = bounds_;  // reused: no allocation per query
    bounds.clear();
    for (int m : models) {
      for (int v = 0; v < spectra_.num_views(); ++v) {
        if (!spectra_.Usable(m, v)) continue;
        bounds.push_back(
            {CorrelationUpperBound(query_.magnitudes, spectra_.Get(m, v).magnitudes), m, v});
      }
    }
    stats_.views_bounded = static_cast<int>(bounds.size());
    std::make_heap(bounds.begin(), bounds.end());
    // Rounding in the FFT can put an exact score a hair above its bound; the margin keeps the
    // pruning exact.
    constexpr float kMargin = 1e-5f;
    while (!bounds.empty()) {
      const BoundedView next = bounds.front();
      if (static_cast<int>(best.size()) == options.top_k &&
          best.top().score >= next.bound + kMargin) {
        break;
      }
      std::pop_heap(bounds.begin(), bounds.end());
      bounds.pop_back();
      offer(make_candidate(next.model, next.view,
                           correlator_.Peak(query_, spectra_.Get(next.model, next.view))));
      ++stats_.views_correlated;
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
