#include "silpose/database/database_builder.h"

#include <oneapi/tbb/enumerable_thread_specific.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"
#include "silpose/util/hash.h"
#include "silpose/util/progress.h"
#include "silpose/util/threads.h"

namespace silpose {

bool DatabaseBuildOptions::Check(std::string* error) const {
  if (!parameters.Check(error)) return false;
  if (num_threads < 0) {
    if (error != nullptr) *error = "thread count must be >= 0 (0 = all cores)";
    return false;
  }
  return true;
}

void DescribeModelViews(const TriangleMesh& mesh, const ViewSphere& sphere,
                        const DatabaseParameters& parameters, int num_threads,
                        const std::function<void(int)>& on_views_done, ModelViews* model) {
  const int num_views = sphere.num_views();
  const int length = parameters.signature.length;
  model->name = mesh.name;
  const Eigen::Vector3d centre = mesh.Centre();
  for (int i = 0; i < 3; ++i) model->centre[i] = centre[i];
  model->radius = mesh.Radius();
  if (!(model->radius > 0.0) || !std::isfinite(model->radius)) {
    ThrowError(mesh.name, ": the mesh has no extent (all vertices coincide), nothing to render");
  }
  model->num_vertices = static_cast<uint32_t>(mesh.vertices.size());
  model->num_triangles = static_cast<uint32_t>(mesh.triangles.size());
  model->mesh = mesh;
  const int num_shells = parameters.num_shells();
  const int num_records = num_views * num_shells;
  model->views_per_shell = num_views;
  model->views.assign(static_cast<size_t>(num_records), ViewRecord{});
  model->signatures.assign(static_cast<size_t>(num_records) * static_cast<size_t>(length), 0.0f);

  // Camera and distance are the same for every view of a shell; RenderView would recompute the
  // mesh's centre and radius each time.
  std::vector<PinholeCamera> cameras;
  for (int s = 0; s < num_shells; ++s) cameras.push_back(ViewCamera(parameters.ShellRender(s)));
  tbb::enumerable_thread_specific<cv::Mat> masks;
  auto describe = [&](const tbb::blocked_range<int>& range) {
    cv::Mat& mask = masks.local();
    for (int index = range.begin(); index != range.end(); ++index) {
      const int shell = index / num_views;
      const int v = index % num_views;
      const double distance =
          parameters.distances_in_radii[static_cast<size_t>(shell)] * model->radius;
      RenderSilhouette(
          mesh, cameras[static_cast<size_t>(shell)],
          CameraFromObjectAtView(sphere.directions[static_cast<size_t>(v)], 0.0, distance, centre),
          &mask);
      const SignatureResult result = ExtractSignature(mask, parameters.signature);
      ViewRecord& record = model->views[static_cast<size_t>(index)];
      record.status = result.status;
      record.flags = result.flags;
      record.area_px = static_cast<float>(result.signature.area_px);
      if (result.ok()) {
        const PolarSignature& signature = result.signature;
        record.mean_radius_px = static_cast<float>(signature.mean_radius_px);
        record.centroid_x_px = static_cast<float>(signature.centroid_px.x());
        record.centroid_y_px = static_cast<float>(signature.centroid_px.y());
        record.relative_std = static_cast<float>(signature.relative_std);
        std::copy(signature.radii.begin(), signature.radii.end(),
                  model->MutableSignature(v, shell).begin());
      }
    }
    if (on_views_done) on_views_done(static_cast<int>(range.size()));
  };
  if (num_threads == 1) {
    constexpr int kChunk = 16;  // report progress as views are done
    for (int begin = 0; begin < num_records; begin += kChunk) {
      describe(tbb::blocked_range<int>(begin, std::min(begin + kChunk, num_records)));
    }
  } else {
    tbb::task_arena arena(WorkerThreads(num_threads));
    arena.execute([&] { tbb::parallel_for(tbb::blocked_range<int>(0, num_records, 8), describe); });
  }
}

ViewDatabase BuildViewDatabase(const std::vector<std::filesystem::path>& mesh_paths,
                               const DatabaseBuildOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid database options: ", error);
  if (mesh_paths.empty()) ThrowError("no model given: the database needs at least one mesh");
  std::set<std::string> names;
  for (const auto& path : mesh_paths) {
    if (!names.insert(path.stem().string()).second) {
      ThrowError(path.string(), ": another model is also named '", path.stem().string(),
                 "' (model names are file stems and must be unique)");
    }
  }

  ViewDatabase database;
  database.parameters = options.parameters;
  database.sphere = BuildViewSphere(options.parameters.view_sphere);
  const int num_views = database.sphere.num_views();
  ProgressBar progress(
      "build-db",
      static_cast<int64_t>(mesh_paths.size()) * num_views * options.parameters.num_shells(),
      options.show_progress && ProgressBar::StderrIsTerminal());
  database.models.resize(mesh_paths.size());
  for (size_t i = 0; i < mesh_paths.size(); ++i) {
    const TriangleMesh mesh = LoadMesh(mesh_paths[i]);
    ModelViews& model = database.models[i];
    DescribeModelViews(
        mesh, database.sphere, options.parameters, options.num_threads,
        [&progress](int done) { progress.Advance(done); }, &model);
    model.source_path = mesh_paths[i].string();
    model.mesh_hash = HashFile(mesh_paths[i]);
  }
  progress.Finish();
  return database;
}

}  // namespace silpose
