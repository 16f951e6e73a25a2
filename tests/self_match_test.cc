// The database self-consistency experiment on the project's own sample models: every view
// of a 1000-view database, rendered again with a random roll at half and at double size, must come
// back as its own view or a neighbour with the roll right to within 2 signature bins.

#include "silpose/eval/self_match.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "silpose/database/database_builder.h"

namespace silpose {
namespace {

TEST(SelfMatch, EveryViewOfTheSampleModelsMatchesItselfAtHalfAndDoubleSize) {
  std::vector<std::filesystem::path> paths;
  for (const auto& entry : std::filesystem::directory_iterator(SILPOSE_SAMPLE_MODELS_DIR)) {
    if (entry.path().extension() == ".obj") paths.push_back(entry.path());
  }
  std::sort(paths.begin(), paths.end());
  ASSERT_GE(paths.size(), 5u);
  DatabaseBuildOptions build;  // defaults: 1000 views, 512 px, M = 1000
  const ViewDatabase database = BuildViewDatabase(paths, build);
  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));

  SelfMatchOptions options;  // scales 0.5 and 2, random rolls, 2 bins
  const std::vector<SelfMatchModelResult> results = RunSelfMatch(database, meshes, options);
  for (const SelfMatchModelResult& r : results) {
    std::cout << r.name << ": " << r.queries << " queries, right object " << r.right_model
              << ", own view or neighbour " << r.own_or_neighbour << ", passed " << r.passed
              << ", failures indistinguishable by silhouette " << r.failed_but_indistinguishable
              << "\n";
    EXPECT_EQ(r.queries, 2000) << r.name;
    EXPECT_EQ(r.not_describable, 0) << r.name;
    // Identification and view: every query.
    EXPECT_EQ(r.right_model, r.queries) << r.name;
    EXPECT_GE(r.own_or_neighbour, r.queries - 2) << r.name;
    // View and roll within 2 bins: measured 99.3 to 99.8 % per model (docs/PERFORMANCE.md); the
    // rest are mostly right views at half size whose roll is off by 2 to 3 bins.
    EXPECT_GE(r.passed, 0.99 * r.queries) << r.name;
  }
}

}  // namespace
}  // namespace silpose
