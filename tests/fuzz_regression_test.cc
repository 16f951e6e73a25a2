// Inputs the fuzzers (fuzz/, docs/fuzzing.md) found mishandled, each reduced to what went wrong.
// Most of them fail only under the sanitizers (the 'asan' preset), which CI runs them with.

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "silpose/database/view_database.h"
#include "silpose/geometry/view_sphere.h"

namespace silpose {
namespace {

// A database whose views have no neighbours (an empty neighbour list) read back: reading an empty
// array passed memcpy a null pointer (undefined behaviour, reported by UBSan).
TEST(FuzzRegression, DatabaseWithAnEmptyNeighbourListReadsBack) {
  ViewDatabase database;
  database.parameters.view_sphere.num_views = 8;
  database.parameters.view_sphere.num_bins = 2;
  database.parameters.signature.length = 16;
  database.parameters.render.resolution_px = 64;
  database.parameters.distances_in_radii = {3.0};
  database.sphere = BuildViewSphere(database.parameters.view_sphere);
  database.sphere.neighbour_indices.clear();
  std::fill(database.sphere.neighbour_offsets.begin(), database.sphere.neighbour_offsets.end(), 0u);
  const std::string bytes = database.Serialize();
  const ViewDatabase read = ViewDatabase::Deserialize(bytes, "empty-neighbours.db");
  EXPECT_TRUE(read.sphere.neighbour_indices.empty());
  EXPECT_EQ(read.Serialize(), bytes);
}

}  // namespace
}  // namespace silpose
