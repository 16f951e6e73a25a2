#pragma once
// Building the view database from meshes (paper 4.1): every model is rendered from every view of
// the sphere (roll 0) and each silhouette is described by its polar signature.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

struct DatabaseBuildOptions {
  DatabaseParameters parameters;
  /// Worker threads; 0 = all cores.
  int num_threads = 0;
  /// Show a progress bar on stderr when it is a terminal.
  bool show_progress = false;
  /// Keep every view's signature in the database file beside its spectrum. Off by default: the
  /// file keeps the spectra only (a compact database, ViewDatabase::DropSignatures), about a
  /// quarter of the size, and the signatures the pose reads are derived from them. Applied by
  /// whoever writes the database after storing the spectra (build-db; EstimateDatabaseSize
  /// counts it); BuildViewDatabase itself always returns the signatures.
  bool keep_signatures = false;

  bool Check(std::string* error = nullptr) const;
};

/// What a database of `num_models` models built with `parameters` will cost, estimated before
/// building (docs/limits.md): the file; the memory build-db needs (the database and its serialised
/// copy, plus a rendering per thread); the memory match and track need to load it and search every
/// view (the file's bytes, the database and the views' spectra). Meshes are counted at
/// `mesh_bytes` in all (their stored copy).
struct DatabaseSizeEstimate {
  double file_bytes = 0.0;
  double build_memory_bytes = 0.0;
  double match_memory_bytes = 0.0;
};
DatabaseSizeEstimate EstimateDatabaseSize(const DatabaseParameters& parameters, int num_models,
                                          double mesh_bytes = 0.0, int num_threads = 1,
                                          bool keep_signatures = false);

/// Builds the database for the meshes at `mesh_paths` (model names: file stems, which must be
/// unique). Throws silpose::Error if a mesh cannot be loaded or the options are invalid.
ViewDatabase BuildViewDatabase(const std::vector<std::filesystem::path>& mesh_paths,
                               const DatabaseBuildOptions& options);

/// Renders and describes all views of one loaded mesh into `model` (name, geometry fields, views
/// and signatures; `mesh_hash` and `source_path` are left to the caller). `sphere` must have been
/// built from parameters.view_sphere.
void DescribeModelViews(const TriangleMesh& mesh, const ViewSphere& sphere,
                        const DatabaseParameters& parameters, int num_threads,
                        const std::function<void(int)>& on_views_done, ModelViews* model);

}  // namespace silpose
