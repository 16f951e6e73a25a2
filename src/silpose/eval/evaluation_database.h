#pragma once
// The view database an evaluation runs on: read from a file built from the given meshes, or built
// from them.

#include <filesystem>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"

namespace silpose {

struct EvaluationDatabaseOptions {
  /// A database file to use; empty: build one from the meshes.
  std::filesystem::path database_path;
  /// Viewpoints per model when building.
  int num_views = 1000;
  /// Worker threads when building; 0 = all cores.
  int num_threads = 0;
  /// Show a progress bar while building (on a terminal).
  bool show_progress = false;
};

/// Reads options.database_path and checks that its models are `mesh_paths`, in order (same count,
/// each mesh file's hash equal to the one recorded), or builds a database from `mesh_paths` with
/// default parameters and options.num_views views. Throws silpose::Error naming the file and the
/// mismatch.
ViewDatabase EvaluationDatabase(const std::vector<std::filesystem::path>& mesh_paths,
                                const EvaluationDatabaseOptions& options);

}  // namespace silpose
