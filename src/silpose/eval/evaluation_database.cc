#include "silpose/eval/evaluation_database.h"

#include "silpose/database/database_builder.h"
#include "silpose/util/error.h"
#include "silpose/util/hash.h"

namespace silpose {

ViewDatabase EvaluationDatabase(const std::vector<std::filesystem::path>& mesh_paths,
                                const EvaluationDatabaseOptions& options) {
  if (mesh_paths.empty()) ThrowError("an evaluation needs at least one mesh");
  if (options.database_path.empty()) {
    DatabaseBuildOptions build;
    build.parameters.view_sphere.num_views = options.num_views;
    build.num_threads = options.num_threads;
    build.show_progress = options.show_progress;
    return BuildViewDatabase(mesh_paths, build);
  }
  const std::string file = options.database_path.string();
  ViewDatabase database = ViewDatabase::Read(options.database_path);
  if (database.models.size() != mesh_paths.size()) {
    ThrowError(file, ": has ", database.models.size(), " models, ", mesh_paths.size(),
               " meshes given");
  }
  for (size_t m = 0; m < mesh_paths.size(); ++m) {
    if (HashFile(mesh_paths[m]) != database.models[m].mesh_hash) {
      ThrowError(mesh_paths[m].string(), ": differs from the mesh the database '", file,
                 "' was built from (model ", database.models[m].name, ")");
    }
  }
  return database;
}

}  // namespace silpose
