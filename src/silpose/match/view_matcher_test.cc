#include "silpose/match/view_matcher.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "silpose/util/error.h"

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
  database.parameters.view_sphere.num_views = num_views;
  database.sphere.directions.assign(static_cast<size_t>(num_views), Eigen::Vector3d::UnitX());
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
      const std::vector<float> radii = RandomSignature(rng, length, 0.0, nullptr, &terms);
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
  const ViewSpectra spectra(synthetic.database);
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
