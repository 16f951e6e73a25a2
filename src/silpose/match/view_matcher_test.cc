#include "silpose/match/view_matcher.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <thread>

#include "silpose/util/error.h"
#include "silpose/util/hash.h"

namespace silpose {
namespace {

// Random smooth signatures standing in for silhouettes; each model has `num_views` of them.
std::vector<float> RandomSignature(std::mt19937& rng, int length, double shift_bins = 0.0,
                                   const std::vector<double>* given_terms = nullptr,
                                   std::vector<double>* terms_out = nullptr) {
  std::vector<double> terms;
  if (given_terms != nullptr) {
    terms = *given_terms;
  } else {
    std::uniform_real_distribution<double> amplitude(-0.3, 0.3);
    for (int k = 1; k <= 8; ++k) {
      terms.push_back(amplitude(rng) / k);
      terms.push_back(amplitude(rng) / k);
    }
  }
  if (terms_out != nullptr) *terms_out = terms;
  std::vector<float> radii(static_cast<size_t>(length));
  for (int x = 0; x < length; ++x) {
    const double t = 2.0 * std::numbers::pi * (x + shift_bins) / length;
    double r = 1.0;
    for (size_t k = 0; k < terms.size() / 2; ++k) {
      const double f = static_cast<double>(k + 1);
      r += terms[2 * k] * std::cos(f * t) + terms[2 * k + 1] * std::sin(f * t);
    }
    radii[static_cast<size_t>(x)] = static_cast<float>(r);
  }
  return radii;
}

struct SyntheticDatabase {
  ViewDatabase database;
  std::vector<std::vector<std::vector<double>>> terms;  // [model][view]
};

SyntheticDatabase MakeDatabase(int num_models, int num_views, int length, uint32_t seed) {
  SyntheticDatabase result;
  ViewDatabase& database = result.database;
  database.parameters.signature.length = length;
  database.parameters.distances_in_radii = {3.0};  // one shell of hand-made signatures
  database.parameters.view_sphere.num_views = num_views;
  database.parameters.view_sphere.num_bins = std::min(10, num_views);
  database.sphere = BuildViewSphere(database.parameters.view_sphere);
  std::mt19937 rng(seed);
  result.terms.resize(static_cast<size_t>(num_models));
  for (int m = 0; m < num_models; ++m) {
    ModelViews model;
    model.name = "model" + std::to_string(m);
    model.views.resize(static_cast<size_t>(num_views));
    model.signatures.resize(static_cast<size_t>(num_views * length));
    for (int v = 0; v < num_views; ++v) {
      model.views[static_cast<size_t>(v)].status = SignatureStatus::kOk;
      std::vector<double> terms;
      std::vector<float> radii = RandomSignature(rng, length, 0.0, nullptr, &terms);
      double mean = 0.0;  // database signatures are divided by their mean
      for (float r : radii) mean += r;
      mean /= length;
      for (float& r : radii) r = static_cast<float>(r / mean);
      std::copy(radii.begin(), radii.end(), model.MutableSignature(v).begin());
      result.terms[static_cast<size_t>(m)].push_back(terms);
    }
    database.models.push_back(std::move(model));
  }
  return result;
}

TEST(ViewMatcher, FindsTheViewAndRollOfAShiftedDatabaseSignature) {
  const SyntheticDatabase synthetic = MakeDatabase(3, 200, 1000, 1);
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  std::mt19937 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    const int model = trial % 3;
    const int view = (trial * 37) % 200;
    const double shift = std::uniform_real_distribution<double>(0, 1000)(rng);
    const std::vector<float> query = RandomSignature(
        rng, 1000, shift, &synthetic.terms[static_cast<size_t>(model)][static_cast<size_t>(view)]);
    const std::vector<MatchCandidate> top = matcher.Match(query, {.top_k = 3});
    ASSERT_EQ(top.size(), 3u);
    EXPECT_EQ(top[0].model, model);
    EXPECT_EQ(top[0].view, view);
    EXPECT_NEAR(top[0].score, 1.0f, 1e-4f);
    double expected_roll = shift * 0.36;
    if (expected_roll > 180.0) expected_roll -= 360.0;
    EXPECT_NEAR(top[0].roll_deg, expected_roll, 0.05);
    EXPECT_GE(top[0].score, top[1].score);
    EXPECT_GE(top[1].score, top[2].score);
  }
}

TEST(ViewMatcher, PrunedSearchReturnsExactlyTheExhaustiveResult) {
  const SyntheticDatabase synthetic = MakeDatabase(4, 300, 256, 3);
  // The default smoothing, and none (every harmonic in the bounds).
  for (const double smoothing_deg : {CorrelationOptions{}.smoothing_deg, 0.0}) {
    SCOPED_TRACE(smoothing_deg);
    const ViewSpectra spectra(synthetic.database,
                              CorrelationOptions{.smoothing_deg = smoothing_deg});
    ViewMatcher matcher(spectra);
    std::mt19937 rng(4);
    int pruned_views = 0;
    for (int trial = 0; trial < 30; ++trial) {
      // Unrelated random queries: the hard case for pruning.
      const std::vector<float> query = RandomSignature(rng, 256);
      for (int k : {1, 5, 20}) {
        const auto exhaustive = matcher.Match(query, {.top_k = k, .exhaustive = true});
        EXPECT_EQ(matcher.last_stats().views_correlated, 1200);
        const auto pruned = matcher.Match(query, {.top_k = k});
        pruned_views += matcher.last_stats().views_correlated;
        ASSERT_EQ(pruned.size(), exhaustive.size());
        for (size_t i = 0; i < pruned.size(); ++i) {
          EXPECT_EQ(pruned[i].model, exhaustive[i].model) << "trial " << trial << " rank " << i;
          EXPECT_EQ(pruned[i].view, exhaustive[i].view) << "trial " << trial << " rank " << i;
          EXPECT_EQ(pruned[i].score, exhaustive[i].score);
        }
      }
    }
    EXPECT_LT(pruned_views, 30 * 3 * 1200) << "pruning never skipped a view";
  }
}

TEST(ViewMatcher, PrunedSearchIsExactOnTheDefaultBandLimitedPath) {
  // M = 1000 with the default 2-degree smoothing: peaks refined over continuous shifts.
  const SyntheticDatabase synthetic = MakeDatabase(3, 200, 1000, 8);
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  std::mt19937 rng(9);
  for (int trial = 0; trial < 20; ++trial) {
    // Noisy near-copies of database views (the realistic case) and unrelated signatures.
    std::vector<float> query =
        trial % 2 == 0
            ? RandomSignature(rng, 1000, 123.4, &synthetic.terms[1][static_cast<size_t>(trial)])
            : RandomSignature(rng, 1000);
    std::normal_distribution<float> noise(0.0f, 0.02f);
    for (float& r : query) r += noise(rng);
    const auto exhaustive = matcher.Match(query, {.top_k = 5, .exhaustive = true});
    const auto pruned = matcher.Match(query, {.top_k = 5});
    ASSERT_EQ(pruned.size(), exhaustive.size());
    for (size_t i = 0; i < pruned.size(); ++i) {
      EXPECT_EQ(pruned[i].model, exhaustive[i].model) << "trial " << trial << " rank " << i;
      EXPECT_EQ(pruned[i].view, exhaustive[i].view) << "trial " << trial << " rank " << i;
      EXPECT_EQ(pruned[i].score, exhaustive[i].score);
    }
  }
}

TEST(ViewMatcher, BoundHeadsGiveABoundNeverBelowTheExactOneAndCloseToIt) {
  // The search's cheap bound (first kBoundHead magnitudes plus the rest's norm bound) must never
  // be below the exact bound, or the pruned search could skip the best view.
  const SyntheticDatabase synthetic = MakeDatabase(3, 200, 1000, 12);
  constexpr size_t kHead = ViewSpectra::kBoundHead;
  // The default smoothing, and none (the paper's plain correlation: every harmonic kept).
  for (const double smoothing_deg : {CorrelationOptions{}.smoothing_deg, 0.0}) {
    SCOPED_TRACE(smoothing_deg);
    CorrelationOptions options;
    options.smoothing_deg = smoothing_deg;
    const ViewSpectra spectra(synthetic.database, options);
    CircularCorrelator correlator(1000, spectra.options());
    std::mt19937 rng(13);
    double total_gap = 0.0;
    int bounded = 0;
    for (int trial = 0; trial < 10; ++trial) {
      const SignatureSpectrum query = correlator.Transform(RandomSignature(rng, 1000), true);
      const std::span<const float> q = query.magnitudes.span();
      float q_tail = 0.0f;
      for (size_t k = kHead; k < q.size(); ++k) q_tail += q[k] * q[k];
      q_tail = std::sqrt(q_tail);
      for (int m = 0; m < 3; ++m) {
        const std::span<const float> heads = spectra.BoundHeads(m);
        ASSERT_EQ(heads.size(), 200 * ViewSpectra::kBoundHeadStride);
        for (int v = 0; v < 200; ++v) {
          const float* head = heads.data() + static_cast<size_t>(v) * ViewSpectra::kBoundHeadStride;
          if (!spectra.Usable(m, v)) {
            EXPECT_TRUE(std::all_of(head, head + ViewSpectra::kBoundHeadStride,
                                    [](float x) { return x == 0.0f; }));
            continue;
          }
          float cheap = q_tail * head[kHead] + ViewSpectra::kBoundHeadSlack;
          for (size_t k = 0; k < kHead; ++k) cheap += q[k] * head[k];
          const float exact = CorrelationUpperBound(q, spectra.Magnitudes(m, v));
          EXPECT_GE(cheap, exact) << "model " << m << " view " << v;
          total_gap += cheap - exact;
          ++bounded;
        }
      }
    }
    ASSERT_GT(bounded, 0);
    // Loose enough to be cheap, tight enough to prune: on average within 0.2 of the exact bound.
    EXPECT_LT(total_gap / bounded, 0.2);
  }
}

TEST(ViewMatcher, ADatabaseWithoutUsableViewsGivesNoCandidates) {
  SyntheticDatabase synthetic = MakeDatabase(2, 20, 64, 10);
  for (auto& model : synthetic.database.models) {
    for (auto& view : model.views) view.status = SignatureStatus::kTooSmall;
  }
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  std::mt19937 rng(11);
  for (bool exhaustive : {false, true}) {
    EXPECT_TRUE(
        matcher.Match(RandomSignature(rng, 64), {.top_k = 3, .exhaustive = exhaustive}).empty());
  }
}

TEST(ViewMatcher, ConstantSignaturesNeverBreakTheSearch) {
  SyntheticDatabase synthetic = MakeDatabase(2, 30, 1000, 12);
  // A database view that is a perfect circle (constant radii): no shape to correlate.
  for (float& r : synthetic.database.models[0].MutableSignature(4)) r = 1.0f;
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  std::mt19937 rng(13);
  for (bool exhaustive : {false, true}) {
    const auto top =
        matcher.Match(RandomSignature(rng, 1000), {.top_k = 60, .exhaustive = exhaustive});
    EXPECT_EQ(top.size(), 59u);  // the circle is not a candidate
    // A constant query matches nothing: every candidate scores 0 or the search returns none.
    for (const auto& c :
         matcher.Match(std::vector<float>(1000, 1.0f), {.top_k = 3, .exhaustive = exhaustive})) {
      EXPECT_EQ(c.score, 0.0f);
    }
  }
}

// Every single-byte change of a database file whose checksum is then recomputed (so the change
// reaches the parser) is either refused with an error or gives a database the matcher can search.
TEST(ViewMatcher, CorruptedButChecksummedDatabasesAreRefusedOrSearchable) {
  const SyntheticDatabase synthetic = MakeDatabase(2, 12, 32, 14);
  const std::string bytes = synthetic.database.Serialize();
  std::mt19937 rng(15);
  const std::vector<float> query = RandomSignature(rng, 32);
  int refused = 0;
  for (size_t i = 20; i + 8 < bytes.size(); ++i) {
    for (uint8_t change : {uint8_t{0x01}, uint8_t{0x80}, uint8_t{0xff}}) {
      std::string corrupt = bytes;
      corrupt[i] = static_cast<char>(corrupt[i] ^ change);
      const uint64_t checksum = HashBytes(corrupt.data(), corrupt.size() - 8);
      std::memcpy(corrupt.data() + corrupt.size() - 8, &checksum, 8);
      try {
        const ViewDatabase loaded = ViewDatabase::Deserialize(corrupt, "fuzz.db");
        const ViewSpectra spectra(loaded);
        ViewMatcher matcher(spectra);
        const auto top = matcher.Match(query, {.top_k = 3});
        for (const auto& c : top) {
          ASSERT_GE(c.model, 0);
          ASSERT_LT(c.view, loaded.num_views());
          ASSERT_TRUE(std::isfinite(c.score) && std::isfinite(c.roll_deg));
        }
      } catch (const Error&) {
        ++refused;
      }
    }
  }
  EXPECT_GT(refused, 0);
}

TEST(ViewMatcher, ModelSubsetAndUnusableViewsAreRespected) {
  SyntheticDatabase synthetic = MakeDatabase(3, 50, 128, 5);
  synthetic.database.models[1].views[7].status = SignatureStatus::kTooSmall;
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  std::mt19937 rng(6);
  const std::vector<float> query = RandomSignature(rng, 128, 0.0, &synthetic.terms[1][7]);
  for (bool exhaustive : {false, true}) {
    const auto top =
        matcher.Match(query, {.top_k = 200, .exhaustive = exhaustive, .models = {1, 2}});
    EXPECT_EQ(top.size(), 99u);  // 2 models x 50 views, one unusable
    for (const auto& candidate : top) {
      EXPECT_NE(candidate.model, 0);
      EXPECT_FALSE(candidate.model == 1 && candidate.view == 7);
    }
  }
}

// MakeDatabase with a second distance shell: shell 1 holds each view's signature reversed (another
// shape), and view 3 of model 0 is unusable in shell 1.
SyntheticDatabase MakeTwoShellDatabase(int num_models, int num_views, int length, uint32_t seed) {
  SyntheticDatabase synthetic = MakeDatabase(num_models, num_views, length, seed);
  ViewDatabase& database = synthetic.database;
  database.parameters.distances_in_radii = {3.0, 6.0};
  for (ModelViews& model : database.models) {
    const std::vector<float> shell0 = model.signatures.ToVector();
    model.views_per_shell = num_views;
    model.views.resize(2 * model.views.size(), model.views.front());
    model.signatures.resize(2 * shell0.size());
    for (int v = 0; v < num_views; ++v) {
      const std::span<const float> radii(shell0.data() + static_cast<size_t>(v * length),
                                         static_cast<size_t>(length));
      std::reverse_copy(radii.begin(), radii.end(), model.MutableSignature(v, 1).begin());
    }
  }
  database.models[0].views[static_cast<size_t>(num_views + 3)].status = SignatureStatus::kTooSmall;
  return synthetic;
}

void ExpectSameCandidates(const std::vector<MatchCandidate>& a,
                          const std::vector<MatchCandidate>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].model, b[i].model) << "candidate " << i;
    EXPECT_EQ(a[i].view, b[i].view) << "candidate " << i;
    EXPECT_EQ(a[i].shell, b[i].shell) << "candidate " << i;
    EXPECT_EQ(a[i].score, b[i].score) << "candidate " << i;
    EXPECT_EQ(a[i].roll_deg, b[i].roll_deg) << "candidate " << i;
  }
}

void ExpectSameSpectrum(const SignatureSpectrum& a, const SignatureSpectrum& b) {
  ASSERT_EQ(a.coefficients.size(), b.coefficients.size());
  ASSERT_EQ(a.magnitudes.size(), b.magnitudes.size());
  EXPECT_EQ(a.has_variance, b.has_variance);
  // Byte for byte (memcmp must not see the null data of an empty spectrum: an unusable view's).
  if (!a.coefficients.empty()) {
    EXPECT_EQ(std::memcmp(a.coefficients.data(), b.coefficients.data(),
                          a.coefficients.size() * sizeof(a.coefficients[0])),
              0);
  }
  if (!a.magnitudes.empty()) {
    EXPECT_EQ(std::memcmp(a.magnitudes.data(), b.magnitudes.data(),
                          a.magnitudes.size() * sizeof(a.magnitudes[0])),
              0);
  }
}

TEST(ViewSpectra, KeepOnlyTheSmoothedHarmonicsAndCorrelateExactlyAsTheFullSpectra) {
  const SyntheticDatabase synthetic = MakeDatabase(2, 40, 1000, 21);
  for (const double smoothing : {2.0, 0.5, 0.0}) {
    const CorrelationOptions options{.smoothing_deg = smoothing};
    const ViewSpectra spectra(synthetic.database, options);
    CircularCorrelator correlator(1000, options);
    if (smoothing == 2.0) {
      EXPECT_EQ(correlator.harmonics(), 151u);
    } else if (smoothing == 0.0) {
      EXPECT_EQ(correlator.harmonics(), 501u);
    }
    std::mt19937 rng(22);
    for (int trial = 0; trial < 10; ++trial) {
      const std::vector<float> query_radii = RandomSignature(rng, 1000);
      const SignatureSpectrum query = correlator.Transform(query_radii);
      for (int v = trial; v < 40; v += 10) {
        const SignatureSpectrum full =
            correlator.Transform(synthetic.database.models[1].Signature(v));
        const SignatureSpectrum& kept = spectra.Get(1, v);
        // The stored spectrum is the full one's first harmonics(); the rest are exactly 0.
        ASSERT_EQ(kept.coefficients.size(), correlator.harmonics());
        ASSERT_EQ(full.coefficients.size(), 501u);
        EXPECT_EQ(std::memcmp(kept.coefficients.data(), full.coefficients.data(),
                              kept.coefficients.size() * sizeof(kept.coefficients[0])),
                  0);
        for (size_t k = kept.coefficients.size(); k < full.coefficients.size(); ++k) {
          ASSERT_EQ(full.coefficients[k], std::complex<float>(0.0f, 0.0f)) << "harmonic " << k;
        }
        EXPECT_EQ(kept.magnitudes, full.magnitudes);
        // Every correlation gives the very same values with either.
        const CorrelationPeak a = correlator.Peak(query, kept);
        const CorrelationPeak b = correlator.Peak(query, full);
        EXPECT_EQ(a.score, b.score);
        EXPECT_EQ(a.shift_bins, b.shift_bins);
        const double shift = 1000.0 * trial / 10.0 + 0.3;
        EXPECT_EQ(correlator.ScoreAtShift(query, kept, shift),
                  correlator.ScoreAtShift(query, full, shift));
        std::vector<float> e_kept(1000), e_full(1000);
        correlator.Correlate(query, kept, e_kept);
        correlator.Correlate(query, full, e_full);
        EXPECT_EQ(e_kept, e_full);
        const std::vector<double> starts = {0.0, 250.5, 740.0};
        std::vector<CorrelationPeak> local_kept(3), local_full(3);
        correlator.LocalPeaks(query, kept, starts, 30.0, local_kept);
        correlator.LocalPeaks(query, full, starts, 30.0, local_full);
        for (size_t i = 0; i < starts.size(); ++i) {
          EXPECT_EQ(local_kept[i].score, local_full[i].score);
          EXPECT_EQ(local_kept[i].shift_bins, local_full[i].shift_bins);
        }
      }
    }
  }
}

TEST(ViewSpectra, ComputeAllMakesTheSpectraGetMakesLazily) {
  const SyntheticDatabase synthetic = MakeTwoShellDatabase(3, 60, 1000, 23);
  const ViewDatabase& database = synthetic.database;
  const ViewSpectra lazy(database);
  const ViewSpectra eager(database);
  EXPECT_EQ(eager.num_computed(), 0u);
  eager.ComputeAll(2);
  // Every view whose silhouette was described, in both shells; not the unusable one.
  EXPECT_EQ(eager.num_computed(), 3u * 60u * 2u - 1u);
  for (int m = 0; m < 3; ++m) {
    for (int s = 0; s < 2; ++s) {
      for (int v = 0; v < 60; ++v) ExpectSameSpectrum(lazy.Get(m, v, s), eager.Get(m, v, s));
    }
  }
  EXPECT_TRUE(eager.Get(0, 3, 1).coefficients.empty());
  EXPECT_FALSE(eager.Get(0, 3, 0).coefficients.empty());
  // Shell 1 is not shell 0 (the index is decoded right).
  EXPECT_NE(eager.Get(2, 5, 1).coefficients, eager.Get(2, 5, 0).coefficients);
  EXPECT_EQ(lazy.num_computed(), eager.num_computed());
  EXPECT_EQ(lazy.MemoryBytes(), eager.MemoryBytes());
  // Again: nothing more is made.
  eager.ComputeAll(1);
  EXPECT_EQ(eager.num_computed(), 3u * 60u * 2u - 1u);
  EXPECT_EQ(eager.MemoryBytes(), lazy.MemoryBytes());

  // The same search results, value for value, in each shell.
  ViewMatcher lazy_matcher(lazy);
  ViewMatcher eager_matcher(eager);
  std::mt19937 rng(24);
  for (int trial = 0; trial < 10; ++trial) {
    const std::vector<float> query = RandomSignature(rng, 1000);
    for (const double apparent : {0.0, 1.0}) {
      for (const bool exhaustive : {false, true}) {
        const MatchOptions options{
            .top_k = 8, .exhaustive = exhaustive, .apparent_radius = apparent};
        const auto a = lazy_matcher.Match(query, options);
        const auto b = eager_matcher.Match(query, options);
        ExpectSameCandidates(a, b);
      }
    }
  }
}

TEST(ViewSpectra, ComputeAllRunsBesideLazyUsers) {
  const SyntheticDatabase synthetic = MakeTwoShellDatabase(2, 200, 256, 25);
  const ViewSpectra shared(synthetic.database);
  const ViewSpectra reference(synthetic.database);
  std::thread reader([&] {
    for (int m = 1; m >= 0; --m) {
      for (int v = 199; v >= 0; --v) (void)shared.Get(m, v, 1);
    }
  });
  shared.ComputeAll(0);
  reader.join();
  EXPECT_EQ(shared.num_computed(), 2u * 200u * 2u - 1u);
  for (int m = 0; m < 2; ++m) {
    for (int s = 0; s < 2; ++s) {
      for (int v = 0; v < 200; v += 7)
        ExpectSameSpectrum(shared.Get(m, v, s), reference.Get(m, v, s));
    }
  }
}

TEST(ViewSpectra, MemoryAccountingCountsTheTablesAndEachSpectrumMade) {
  const SyntheticDatabase synthetic = MakeTwoShellDatabase(2, 50, 1000, 26);
  const ViewSpectra spectra(synthetic.database);
  const size_t records = 2 * 2 * 50;
  const size_t tables = spectra.MemoryBytes();
  // Per record: a usable flag, an apparent radius and a once flag; no spectrum slot yet.
  EXPECT_GE(tables, records * (sizeof(float) + 1 + sizeof(std::once_flag)));
  EXPECT_LT(tables, records * (sizeof(SignatureSpectrum) / 2 + 16));
  // One spectrum: 151 coefficients and 151 magnitudes at M = 1000 and 2 degrees of smoothing;
  // the first of a (model, shell) also makes that block's 50 slots.
  const size_t per_spectrum = 151 * (sizeof(std::complex<float>) + sizeof(float));
  const size_t per_block = 50 * sizeof(SignatureSpectrum);
  (void)spectra.Get(1, 10, 1);
  EXPECT_EQ(spectra.num_computed(), 1u);
  EXPECT_EQ(spectra.MemoryBytes(), tables + per_block + per_spectrum);
  (void)spectra.Get(1, 10, 1);  // made once
  EXPECT_EQ(spectra.MemoryBytes(), tables + per_block + per_spectrum);
  (void)spectra.Get(0, 3, 1);  // unusable: nothing made, but its block's slots exist
  EXPECT_EQ(spectra.num_computed(), 1u);
  EXPECT_EQ(spectra.MemoryBytes(), tables + 2 * per_block + per_spectrum);
  spectra.ComputeAll();
  EXPECT_EQ(spectra.num_computed(), records - 1);
  EXPECT_EQ(spectra.MemoryBytes(), tables + 4 * per_block + (records - 1) * per_spectrum);
  // Less than a third of the full spectra's 501 coefficients and magnitudes.
  EXPECT_LT(per_spectrum * 3, 501 * (sizeof(std::complex<float>) + sizeof(float)));
}

TEST(ViewMatcher, BadQueriesAndOptionsAreErrors) {
  const SyntheticDatabase synthetic = MakeDatabase(1, 10, 64, 7);
  const ViewSpectra spectra(synthetic.database);
  ViewMatcher matcher(spectra);
  EXPECT_THROW(matcher.Match(std::vector<float>(63, 1.0f)), Error);
  EXPECT_THROW(matcher.Match(std::vector<float>(64, 1.0f), {.top_k = 0}), Error);
  EXPECT_THROW(matcher.Match(std::vector<float>(64, 1.0f), {.models = {1}}), Error);
}

}  // namespace
}  // namespace silpose

namespace silpose {
namespace {

// Hand-made databases have no model extent; a file needs one.
void GiveModelsAnExtent(ViewDatabase* database) {
  for (ModelViews& model : database->models) model.radius = 1.0;
}

std::filesystem::path TemporaryDatabasePath(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("silpose_" + name + "_" + std::to_string(::getpid()) + ".db");
}

TEST(ViewSpectra, StoredSpectraAreLentFromTheFileAndEqualTheComputedOnes) {
  SyntheticDatabase synthetic = MakeTwoShellDatabase(3, 60, 1000, 31);
  GiveModelsAnExtent(&synthetic.database);
  const ViewDatabase plain = synthetic.database;  // without stored spectra
  StoreViewSpectra(&synthetic.database, CorrelationOptions{}, 2);
  const auto path = TemporaryDatabasePath("stored_spectra");
  synthetic.database.Write(path);
  const ViewDatabase read = ViewDatabase::Read(path);
  std::filesystem::remove(path);  // the mapping outlives the file's name
  const ViewSpectra stored(read);
  const ViewSpectra computed(plain);
  for (int m = 0; m < 3; ++m) {
    EXPECT_TRUE(stored.Stored(m));
    EXPECT_FALSE(computed.Stored(m));
    for (int s = 0; s < 2; ++s) {
      for (int v = 0; v < 60; ++v) {
        ASSERT_EQ(stored.Usable(m, v, s), computed.Usable(m, v, s)) << m << " " << v << " " << s;
        const SignatureSpectrum& lent = stored.Get(m, v, s);
        ExpectSameSpectrum(lent, computed.Get(m, v, s));
        EXPECT_EQ(lent.has_variance, computed.Get(m, v, s).has_variance);
        if (stored.Usable(m, v, s)) {
          EXPECT_TRUE(lent.coefficients.referring());
          const std::span<const float> magnitudes = stored.Magnitudes(m, v, s);
          EXPECT_TRUE(std::equal(magnitudes.begin(), magnitudes.end(), lent.magnitudes.begin()));
        }
      }
    }
  }
  EXPECT_EQ(stored.num_computed(), computed.num_computed());
  // The lent coefficients are not counted as this object's memory (the magnitudes it made from
  // them are: a third of a spectrum's bytes).
  EXPECT_LT(stored.MemoryBytes(), computed.MemoryBytes() / 2);
  // Matching through either gives the same candidates.
  ViewMatcher from_file(stored);
  ViewMatcher from_memory(computed);
  std::mt19937 rng(5);
  for (int query = 0; query < 5; ++query) {
    const std::vector<float> radii = RandomSignature(rng, 1000, 37.0 * query);
    MatchOptions options;
    options.apparent_radius = 0.1;
    const std::vector<MatchCandidate> a = from_file.Match(radii, options);
    const std::vector<MatchCandidate> b = from_memory.Match(radii, options);
    ExpectSameCandidates(a, b);
  }
  // A matcher with another smoothing computes its own spectra.
  CorrelationOptions other;
  other.smoothing_deg = 1.0;
  const ViewSpectra resmoothed(read, other);
  EXPECT_FALSE(resmoothed.Stored(0));
  ExpectSameSpectrum(resmoothed.Get(1, 4, 0), ViewSpectra(plain, other).Get(1, 4, 0));
}

TEST(ViewSpectra, ACorruptStoredSpectrumIsNamedWhenTheMatcherFirstUsesIt) {
  SyntheticDatabase synthetic = MakeDatabase(2, 40, 1000, 32);
  GiveModelsAnExtent(&synthetic.database);
  StoreViewSpectra(&synthetic.database);
  // A crafted file: an impossible value behind valid checksums.
  const uint32_t harmonics = synthetic.database.models[1].spectra.harmonics;
  synthetic.database.models[1].spectra.coefficients.mutable_data()[harmonics * 7 + 2] = {
      std::numeric_limits<float>::quiet_NaN(), 0.0f};
  const auto path = TemporaryDatabasePath("corrupt_spectra");
  synthetic.database.Write(path);
  const std::string expected = path.string() +
                               ": corrupt database: model 'model1' view 7 of shell 0 has an "
                               "invalid stored spectrum value";
  {
    const ViewDatabase read = ViewDatabase::Read(path);  // opens: values are checked when used
    const ViewSpectra spectra(read);
    ViewMatcher matcher(spectra);
    std::mt19937 rng(6);
    try {
      (void)matcher.Match(RandomSignature(rng, 1000));
      ADD_FAILURE() << "a corrupt spectrum was matched";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
  }
  try {
    (void)ViewDatabase::Read(path, ViewChecks::kAtOpen);
    ADD_FAILURE() << "a corrupt spectrum was read";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
  }
  std::filesystem::remove(path);
}

// `database` written to bytes with the lowest bit of model 1's radius of view 7 (shell 0) flipped
// (every value still valid, so CheckView passes; the block's checksum does not), read lazily as
// file `source`. The database keeps the bytes alive.
ViewDatabase WithOneSignatureBitFlipped(const ViewDatabase& database, const std::string& source) {
  const auto bytes = std::make_shared<std::string>(database.Serialize());
  size_t at = 0;
  {
    const ViewDatabase good =
        ViewDatabase::Deserialize(*bytes, source, ViewChecks::kOnFirstUse, bytes);
    at = static_cast<size_t>(reinterpret_cast<const char*>(good.models[1].Signature(7, 0).data()) -
                             bytes->data());
  }
  (*bytes)[at] = static_cast<char>((*bytes)[at] ^ 0x01);
  return ViewDatabase::Deserialize(*bytes, source, ViewChecks::kOnFirstUse, bytes);
}

TEST(ViewSpectra, WithStoredSpectraTheSignatureBlockIsCheckedByWhoReadsItNotByTheMatcher) {
  SyntheticDatabase synthetic = MakeDatabase(2, 40, 1000, 33);
  GiveModelsAnExtent(&synthetic.database);
  StoreViewSpectra(&synthetic.database);
  const ViewDatabase read = WithOneSignatureBitFlipped(synthetic.database, "test.db");
  const ViewSpectra spectra(read);
  ASSERT_TRUE(spectra.Stored(1));
  ViewMatcher matcher(spectra);
  std::mt19937 rng(8);
  MatchOptions every_view;
  every_view.exhaustive = true;
  every_view.top_k = 80;
  EXPECT_EQ(matcher.Match(RandomSignature(rng, 1000), every_view).size(), 80u);  // all matched
  spectra.CheckSignatures(0, 0);  // model 0's signatures are fine
  try {
    spectra.CheckSignatures(1, 0);
    ADD_FAILURE() << "a corrupt signature block passed its check";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what())
                  .find("test.db: corrupt database (checksum mismatch in the signatures of model "
                        "'model1', shell 0)"),
              std::string::npos)
        << error.what();
  }
  // Impossible signature values behind valid checksums (a crafted file): the matcher, which does
  // not read them, matches; the check before the pose names the view.
  ViewDatabase crafted = synthetic.database;
  crafted.models[1].signatures.mutable_data()[1000 * 9 + 17] =
      std::numeric_limits<float>::quiet_NaN();
  const auto crafted_path = TemporaryDatabasePath("crafted_signature");
  crafted.Write(crafted_path);
  {
    const ViewDatabase crafted_read = ViewDatabase::Read(crafted_path);
    const ViewSpectra crafted_spectra(crafted_read);
    ViewMatcher crafted_matcher(crafted_spectra);
    EXPECT_EQ(crafted_matcher.Match(RandomSignature(rng, 1000), every_view).size(), 80u);
    crafted_spectra.CheckSignatures(0, 0);
    try {
      crafted_spectra.CheckSignatures(1, 0);
      ADD_FAILURE() << "an impossible signature value passed the check before the pose";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what())
                    .find(crafted_path.string() +
                          ": corrupt database: model 'model1' view 9 of shell 0 has an invalid "
                          "signature value"),
                std::string::npos)
          << error.what();
    }
  }
  std::filesystem::remove(crafted_path);
  // Without stored spectra the matcher makes them from the signatures: it checks their block.
  ViewDatabase plain = synthetic.database;
  for (ModelViews& model : plain.models) model.spectra = StoredSpectra{};
  const ViewDatabase plain_read = WithOneSignatureBitFlipped(plain, "plain.db");
  const ViewSpectra made(plain_read);
  EXPECT_FALSE(made.Stored(1));
  (void)made.Get(0, 3);
  try {
    (void)made.Get(1, 3);
    ADD_FAILURE() << "spectra were made from a corrupt signature block";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("checksum mismatch in the signatures"),
              std::string::npos)
        << error.what();
  }
}

// A compact database keeps only the spectra; the signatures the pose reads are derived from them.
// They must be the stored signatures smoothed as the spectra were: for these synthetic ones (a few
// harmonics a_k cos + b_k sin) harmonic k is scaled by exp(-(k s)^2 / 2), s the smoothing in
// radians.
TEST(CompactDatabase, DerivedSignaturesAreTheStoredOnesSmoothedAsTheSpectra) {
  SyntheticDatabase synthetic = MakeTwoShellDatabase(3, 60, 1000, 41);
  GiveModelsAnExtent(&synthetic.database);
  StoreViewSpectra(&synthetic.database, CorrelationOptions{}, 2);
  const ViewDatabase full = synthetic.database;
  ViewDatabase compact = synthetic.database;
  compact.DropSignatures();
  const double sigma = 2.0 * std::numbers::pi / 180.0;
  double largest_error = 0.0;
  for (int m = 0; m < 3; ++m) {
    EXPECT_TRUE(full.models[static_cast<size_t>(m)].signatures_stored());
    EXPECT_FALSE(compact.models[static_cast<size_t>(m)].signatures_stored());
    EXPECT_TRUE(compact.models[static_cast<size_t>(m)].signatures.empty());
    EXPECT_EQ(compact.models[static_cast<size_t>(m)].signature_length(), 1000);
    for (int v = 0; v < 60; ++v) {
      const std::vector<double>& terms =
          synthetic.terms[static_cast<size_t>(m)][static_cast<size_t>(v)];
      const std::span<const float> raw = full.models[static_cast<size_t>(m)].Signature(v, 0);
      const std::span<const float> derived = compact.models[static_cast<size_t>(m)].Signature(v, 0);
      ASSERT_EQ(derived.size(), 1000u);
      double mean = 0.0;
      for (float r : raw) mean += r;
      mean /= 1000.0;
      for (int x = 0; x < 1000; ++x) {
        const double t = 2.0 * std::numbers::pi * x / 1000.0;
        double r = 1.0;
        for (size_t k = 0; k < terms.size() / 2; ++k) {
          const double f = static_cast<double>(k + 1);
          const double weight = std::exp(-0.5 * f * f * sigma * sigma);
          r += weight * (terms[2 * k] * std::cos(f * t) + terms[2 * k + 1] * std::sin(f * t));
        }
        // MakeDatabase divides the radii by their mean (1 up to rounding for these terms).
        largest_error =
            std::max(largest_error, std::abs(r / mean - derived[static_cast<size_t>(x)]));
      }
      // Shell 1 holds the signatures reversed: derived the same way.
      const std::span<const float> raw1 = full.models[static_cast<size_t>(m)].Signature(v, 1);
      const std::span<const float> derived1 =
          compact.models[static_cast<size_t>(m)].Signature(v, 1);
      if (full.models[static_cast<size_t>(m)].Record(v, 1).status == SignatureStatus::kOk) {
        EXPECT_NEAR(derived1[10], derived[989], 1e-4) << m << " " << v;
        EXPECT_NEAR(derived1[500], derived[499], 1e-4) << m << " " << v;
        EXPECT_GT(raw1[0], 0.0f);
      } else {
        EXPECT_TRUE(std::all_of(derived1.begin(), derived1.end(), [](float r) { return r == 0; }));
      }
    }
  }
  EXPECT_LT(largest_error, 2e-5);
  // The same view asked for twice (or from a copy of the model) is the same memory.
  const ModelViews copy = compact.models[1];
  EXPECT_EQ(copy.Signature(5, 0).data(), compact.models[1].Signature(5, 0).data());
  EXPECT_THROW(compact.models[1].MutableSignature(5, 0), Error);

  // Written and read back: about a quarter of the file, the same derived signatures, the same
  // matches as the full database, and a format-4 file (which needs signatures) is refused.
  const auto full_path = TemporaryDatabasePath("full");
  const auto compact_path = TemporaryDatabasePath("compact");
  full.Write(full_path);
  compact.Write(compact_path);
  const auto full_bytes = std::filesystem::file_size(full_path);
  const auto compact_bytes = std::filesystem::file_size(compact_path);
  EXPECT_LT(compact_bytes, full_bytes / 3) << compact_bytes << " vs " << full_bytes;
  const ViewDatabase full_read = ViewDatabase::Read(full_path);
  const ViewDatabase compact_read = ViewDatabase::Read(compact_path);
  std::filesystem::remove(full_path);
  std::filesystem::remove(compact_path);
  EXPECT_FALSE(compact_read.models[2].signatures_stored());
  for (int v : {0, 17, 59}) {
    const std::span<const float> a = compact.models[2].Signature(v, 0);
    const std::span<const float> b = compact_read.models[2].Signature(v, 0);
    EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin())) << v;
  }
  EXPECT_THROW((void)compact.Serialize(4), Error);
  const ViewSpectra from_full(full_read);
  const ViewSpectra from_compact(compact_read);
  // Checking a compact model's "signatures" checks the spectra they come from.
  from_compact.CheckSignatures(2, 1);
  ViewMatcher a(from_full);
  ViewMatcher b(from_compact);
  std::mt19937 rng(9);
  for (int query = 0; query < 5; ++query) {
    const std::vector<float> radii = RandomSignature(rng, 1000, 11.0 * query);
    MatchOptions options;
    options.apparent_radius = 0.1;
    ExpectSameCandidates(a.Match(radii, options), b.Match(radii, options));
  }
  // The spectra of a compact database serve only their own smoothing.
  CorrelationOptions other;
  other.smoothing_deg = 1.0;
  try {
    const ViewSpectra resmoothed(compact_read, other);
    ADD_FAILURE() << "a compact database was resmoothed";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("--full-signatures"), std::string::npos)
        << error.what();
  }
  // Without stored spectra there is nothing to derive the signatures from.
  ViewDatabase bare = MakeDatabase(1, 20, 1000, 3).database;
  EXPECT_THROW(bare.DropSignatures(), Error);
}

// Without smoothing the spectrum keeps every harmonic up to M/2 (the Nyquist term at the end of
// OpenCV's packed layout): the derived signatures are the stored ones.
TEST(CompactDatabase, WithoutSmoothingTheDerivedSignaturesAreTheStoredOnes) {
  SyntheticDatabase synthetic = MakeDatabase(2, 30, 64, 43);
  GiveModelsAnExtent(&synthetic.database);
  // A signature with a Nyquist component (alternating radii) besides the smooth ones.
  std::span<float> radii = synthetic.database.models[1].MutableSignature(7);
  for (size_t x = 0; x < radii.size(); ++x) radii[x] += (x % 2 == 0 ? 0.05f : -0.05f);
  CorrelationOptions plain;
  plain.smoothing_deg = 0.0;
  StoreViewSpectra(&synthetic.database, plain, 1);
  const ViewDatabase full = synthetic.database;
  ViewDatabase compact = synthetic.database;
  compact.DropSignatures();
  ASSERT_EQ(compact.models[0].spectra.harmonics, 33u);
  for (int m = 0; m < 2; ++m) {
    for (int v = 0; v < 30; ++v) {
      const std::span<const float> a = full.models[static_cast<size_t>(m)].Signature(v);
      const std::span<const float> b = compact.models[static_cast<size_t>(m)].Signature(v);
      for (size_t x = 0; x < a.size(); ++x) ASSERT_NEAR(a[x], b[x], 2e-5) << m << " " << v;
    }
  }
  // A matcher with the same (no) smoothing serves the compact database from its spectra.
  const ViewSpectra spectra(compact, plain);
  EXPECT_TRUE(spectra.Stored(1));
}

// Several threads asking for the same derived signatures (a ViewSpectra shared by trackers) get
// the same values, each derived once (ThreadSanitizer runs this test).
TEST(CompactDatabase, DerivedSignaturesSharedBetweenThreads) {
  SyntheticDatabase synthetic = MakeTwoShellDatabase(2, 40, 1000, 47);
  GiveModelsAnExtent(&synthetic.database);
  StoreViewSpectra(&synthetic.database, CorrelationOptions{}, 1);
  ViewDatabase compact = synthetic.database;
  compact.DropSignatures();
  const ViewDatabase reference = compact;  // shares the cache: derived below, once
  std::vector<std::vector<const float*>> seen(2);
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) {
    threads.emplace_back([&compact, &seen, t] {
      for (int m = 0; m < 2; ++m)
        for (int s = 0; s < 2; ++s)
          for (int v = 0; v < 40; ++v)
            seen[static_cast<size_t>(t)].push_back(
                compact.models[static_cast<size_t>(m)].Signature(v, s).data());
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(seen[0], seen[1]);
  EXPECT_EQ(reference.models[1].Signature(39, 1).data(), compact.models[1].Signature(39, 1).data());
  // A copy whose spectra are replaced keeps deriving from the spectra its cache was made for.
  ModelViews copy = compact.models[0];
  const std::vector<float> before(copy.Signature(3, 0).begin(), copy.Signature(3, 0).end());
  copy.spectra = StoredSpectra{};
  const std::span<const float> after = copy.Signature(4, 0);
  EXPECT_EQ(after.size(), 1000u);
  EXPECT_TRUE(std::equal(before.begin(), before.end(), copy.Signature(3, 0).begin()));
  const std::span<const float> expected = compact.models[0].Signature(4, 0);
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), after.begin()));
}

}  // namespace
}  // namespace silpose
