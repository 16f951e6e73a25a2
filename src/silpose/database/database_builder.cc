#include "silpose/database/database_builder.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "silpose/geometry/view_frame.h"
#include "silpose/mesh/mesh_symmetry.h"
#include "silpose/util/error.h"
#include "silpose/util/hash.h"
#include "silpose/util/parallel.h"
#include "silpose/util/progress.h"

namespace silpose {

bool DatabaseBuildOptions::Check(std::string* error) const {
  if (!parameters.Check(error)) return false;
  if (num_threads < 0) {
    if (error != nullptr) *error = "thread count must be >= 0 (0 = all cores)";
    return false;
  }
  return true;
}

DatabaseSizeEstimate EstimateDatabaseSize(const DatabaseParameters& parameters, int num_models,
                                          double mesh_bytes, int num_threads,
                                          bool keep_signatures) {
  const double views = parameters.view_sphere.num_views;
  const double length = parameters.signature.length;
  const double records = views * parameters.num_shells() * std::max(num_models, 0);
  // Per view and shell: a 25-byte record, M float radii if kept and the stored spectrum (a kind
  // byte, an amplitude, and a complex float per harmonic the default 2-degree smoothing keeps,
  // match/view_matcher.h: at most 151, M/2 + 1 for shorter signatures). Per view of the sphere:
  // its direction, bin and neighbour lists (about 64 bytes).
  const double harmonics = std::min(length / 2.0 + 1.0, 151.0);
  const double signature_bytes = keep_signatures ? 4.0 * length : 0.0;
  DatabaseSizeEstimate estimate;
  estimate.file_bytes =
      records * (30.0 + signature_bytes + 8.0 * harmonics) + views * 64.0 + mesh_bytes + 4096.0;
  const double resolution = parameters.render.resolution_px;
  // Building holds every signature, the spectra (with magnitudes) and the serialised file.
  estimate.build_memory_bytes = records * (4.0 * length + 12.0 * harmonics) + estimate.file_bytes +
                                std::max(num_threads, 1) * 2.0 * resolution * resolution;
  // Matching maps the file (at most all of it resident) and makes the magnitudes of every view it
  // bounds, plus its bookkeeping; with the signatures kept, a matcher with other options than the
  // stored spectra's may make a whole spectrum per view instead.
  estimate.match_memory_bytes =
      estimate.file_bytes + records * (harmonics * (keep_signatures ? 12.0 : 4.0) + 64.0);
  return estimate;
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
  // A mesh whose triangles enclose no area (collinear or coincident vertices) has no silhouette
  // from any view: refuse it rather than store views that can never match.
  double area = 0.0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  if (!(area > 1e-9 * model->radius * model->radius)) {
    ThrowError(mesh.name,
               ": the mesh is degenerate: its triangles have no area (collinear or coincident "
               "vertices), so it has no silhouette to match");
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
  // Every shell's camera is more than one radius from the centre, outside the bounding sphere:
  // a closed mesh's silhouette needs only the triangles facing the camera.
  const FaceCulling culling = IsClosedSurface(mesh) ? FaceCulling::kBackFaces : FaceCulling::kNone;
  auto describe = [&](int first, int last) {
    cv::Mat mask;  // reused by the chunk's views
    for (int index = first; index != last; ++index) {
      const int shell = index / num_views;
      const int v = index % num_views;
      const double distance =
          parameters.distances_in_radii[static_cast<size_t>(shell)] * model->radius;
      RenderSilhouette(
          mesh, cameras[static_cast<size_t>(shell)],
          CameraFromObjectAtView(sphere.directions[static_cast<size_t>(v)], 0.0, distance, centre),
          &mask, culling);
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
    if (on_views_done) on_views_done(last - first);
  };
  // The symmetries come from the surface (mesh/mesh_symmetry.h), found beside the renderings.
  const auto find_symmetry = [&] { model->symmetry = DetectSymmetry(mesh); };
  if (num_threads == 1) {
    find_symmetry();
    constexpr int kChunk = 16;  // report progress as views are done
    for (int begin = 0; begin < num_records; begin += kChunk) {
      describe(begin, std::min(begin + kChunk, num_records));
    }
  } else {
    ParallelFor(0, num_records, 8, num_threads, describe, find_symmetry);
  }
  if (std::none_of(model->views.begin(), model->views.end(),
                   [](const ViewRecord& view) { return view.status == SignatureStatus::kOk; })) {
    ThrowError(mesh.name,
               ": no view of the mesh has a usable silhouette (a degenerate or tiny mesh?), so "
               "it could never be matched");
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
