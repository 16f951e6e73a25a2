#include "silpose/eval/confidence_experiment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "silpose/util/error.h"

namespace silpose {
namespace {

TEST(RocAuc, CountsOrderedPairsAndHalvesTies) {
  EXPECT_DOUBLE_EQ(RocAuc({0.9, 0.8}, {0.1, 0.2}), 1.0);
  EXPECT_DOUBLE_EQ(RocAuc({0.1, 0.2}, {0.9, 0.8}), 0.0);
  EXPECT_DOUBLE_EQ(RocAuc({0.5}, {0.5}), 0.5);
  // Pairs: (0.9 > 0.3, 0.9 > 0.7, 0.6 > 0.3, 0.6 < 0.7) -> 3 of 4.
  EXPECT_DOUBLE_EQ(RocAuc({0.9, 0.6}, {0.3, 0.7}), 0.75);
  EXPECT_TRUE(std::isnan(RocAuc({}, {0.3})));
}

TEST(FitConfidenceModel, RecoversTheSignOfAnInformativeFeatureAndIgnoresConstantOnes) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<std::array<double, ConfidenceFeatures::kSize>> rows;
  std::vector<bool> labels;
  for (int i = 0; i < 2000; ++i) {
    std::array<double, ConfidenceFeatures::kSize> x{};
    x[5] = uniform(rng);      // "iou": the label's cause
    x[6] = 0.1 * noise(rng);  // noise
    x[4] = 1.0;               // constant
    const double p = 1.0 / (1.0 + std::exp(-(12.0 * (x[5] - 0.5))));
    rows.push_back(x);
    labels.push_back(uniform(rng) < p);
  }
  const ConfidenceModel model = FitConfidenceModel(rows, labels, 1e-3);
  EXPECT_NEAR(model.weights[5], 12.0, 2.5);
  EXPECT_NEAR(model.bias, -6.0, 1.5);
  EXPECT_EQ(model.weights[4], 0.0);
  EXPECT_LT(std::abs(model.weights[6]), 3.0);
  EXPECT_THROW(FitConfidenceModel(rows, {true}, 1e-3), Error);
}

TEST(LookalikeMesh, StretchesAboutTheCentreAndRenames) {
  TriangleMesh mesh;
  mesh.name = "box";
  mesh.vertices = {{-1, -1, -1}, {3, 1, 1}, {1, -1, 1}};
  mesh.triangles = {{0, 1, 2}};
  const TriangleMesh copy = LookalikeMesh(mesh);
  EXPECT_EQ(copy.name, "box-lookalike");
  EXPECT_TRUE(copy.Centre().isApprox(mesh.Centre()));
  EXPECT_NEAR(copy.vertices[1].x() - copy.vertices[0].x(), 1.35 * 4.0, 1e-5);
  EXPECT_NEAR(copy.vertices[1].z() - copy.vertices[0].z(), 0.8 * 2.0, 1e-5);
}

TEST(ConfidenceExperimentOptions, RefusesAFitWithoutModels) {
  ConfidenceExperimentOptions options;
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("fit model"), std::string::npos);
  options.fit_models = {"bunny"};
  EXPECT_TRUE(options.Check());
  options.frames = 1;
  EXPECT_FALSE(options.Check(&error));
}

}  // namespace
}  // namespace silpose
