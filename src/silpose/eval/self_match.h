#pragma once
// The database self-consistency experiment: every view of every model is rendered again with a
// random roll and at other image sizes, described and matched against the whole database; it
// should come back as its own view (or a neighbour) with the roll right.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

struct SelfMatchOptions {
  /// Image sizes relative to the database resolution (the silhouette scales with them).
  std::vector<double> scales = {0.5, 2.0};
  /// Roll tolerance, in signature bins.
  double roll_tolerance_bins = 2.0;
  /// Seed of the random rolls.
  uint64_t seed = 1;
  /// Test every `view_stride`-th view only (1 = all).
  int view_stride = 1;
  /// Worker threads; 0 = all cores.
  int num_threads = 0;

  bool Check(std::string* error = nullptr) const;
};

/// One query that did not come back right.
struct SelfMatchFailure {
  int view = -1;
  double scale = 1.0;
  double true_roll_deg = 0.0;
  int found_model = -1;
  int found_view = -1;
  double found_roll_deg = 0.0;
  float found_score = 0.0f;
  /// Correlation of the database silhouettes of the true and the found view at the found relative
  /// roll: near 1 means the two are indistinguishable by silhouette (symmetry), not a matching
  /// error.
  float silhouette_agreement = 0.0f;
};

struct SelfMatchModelResult {
  std::string name;
  int queries = 0;
  /// Found model is right.
  int right_model = 0;
  /// Found view is the queried one.
  int own_view = 0;
  /// Found view is the queried one or a neighbour.
  int own_or_neighbour = 0;
  /// ... and the roll is within the tolerance (the criterion).
  int passed = 0;
  /// Failures whose silhouettes agree to >= 0.99 (ambiguous by symmetry).
  int failed_but_indistinguishable = 0;
  /// Queries whose silhouette was nearly circular (roll unobservable) or not describable.
  int nearly_circular = 0;
  int not_describable = 0;
  std::vector<SelfMatchFailure> failures;

  /// Adds the counts and failures of `other` (the name stays).
  void Add(const SelfMatchModelResult& other);
};

/// Runs the experiment for `meshes` (same order and names as database.models).
/// `on_progress(n)` is called as views are done. Throws silpose::Error on mismatched inputs.
std::vector<SelfMatchModelResult> RunSelfMatch(const ViewDatabase& database,
                                               const std::vector<TriangleMesh>& meshes,
                                               const SelfMatchOptions& options,
                                               const std::function<void(int)>& on_progress = {});

}  // namespace silpose
