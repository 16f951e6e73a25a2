#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numbers>
#include <random>

#include "silpose/cli/commands.h"
#include "silpose/database/database_builder.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/io/mask_file.h"
#include "silpose/match/view_matcher.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct DemoArguments {
  std::string models_dir;
  std::string output_dir;
  int queries = 15;
  int views = 1000;
  uint64_t seed = 1;
  int threads = 0;
};

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

void RunDemo(const DemoArguments& arguments) {
  if (arguments.queries < 1) ThrowError("--queries must be >= 1");
  const std::vector<std::filesystem::path> models = SampleModels(arguments.models_dir);
  std::printf("silpose demo: %zu sample models from %s\n", models.size(),
              models.front().parent_path().c_str());
  std::filesystem::path output;
  if (!arguments.output_dir.empty()) {
    output = arguments.output_dir;
    std::error_code error;
    std::filesystem::create_directories(output, error);
    if (error) ThrowError(output.string(), ": cannot create folder: ", error.message());
  }

  // 1. The view database (paper 4.1), as 'silpose build-db' makes it.
  DatabaseBuildOptions options;
  options.parameters.view_sphere.num_views = arguments.views;
  options.num_threads = arguments.threads;
  options.show_progress = true;
  const auto build_start = std::chrono::steady_clock::now();
  const ViewDatabase database = BuildViewDatabase(models, options);
  const double build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - build_start).count();
  std::printf("built the database: %zu models x %d views in %.1f s (view spacing %.1f deg)\n",
              database.models.size(), database.num_views(), build_s,
              database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi);
  if (!output.empty()) database.Write(output / "demo.db");

  std::vector<TriangleMesh> meshes;
  for (const auto& path : models) meshes.push_back(LoadMesh(path));
  const ViewSpectra spectra(database);
  ViewMatcher matcher(spectra);

  // 2. Silhouettes at random poses, sizes and rolls (views off the database lattice), matched
  //    against the whole database (paper 4.2).
  const PinholeCamera database_camera = ViewCamera(database.parameters.render);
  std::mt19937_64 rng(arguments.seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::printf("\n%-3s | %-10s %-24s %7s | %-10s %5s %7s %6s | %8s %8s\n", "#", "true object",
              "true view direction", "roll", "found", "view", "roll", "score", "view err",
              "roll err");
  int right = 0;
  std::vector<double> view_errors;
  std::vector<double> roll_errors;
  double match_ms_total = 0.0;
  std::ofstream csv;
  if (!output.empty()) {
    csv.open(output / "demo.csv");
    csv << "query,true_object,true_view_x,true_view_y,true_view_z,true_roll_deg,found_object,"
           "found_view,found_roll_deg,score,view_error_deg,roll_error_deg\n";
  }
  for (int q = 0; q < arguments.queries; ++q) {
    const size_t model = static_cast<size_t>(q) % meshes.size();
    const Eigen::Vector3d direction =
        Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const double roll = -180.0 + 360.0 * uniform(rng);
    const double size = 0.4 + 0.5 * uniform(rng);  // silhouette size relative to the database's
    const PinholeCamera camera =
        PinholeCamera::Centered(320, 240, database_camera.focal_x_px * size);
    const TriangleMesh& mesh = meshes[model];
    cv::Mat mask;
    RenderSilhouette(
        mesh, camera,
        CameraFromObjectAtView(direction, roll,
                               database.parameters.render.distance_in_radii * mesh.Radius(),
                               mesh.Centre()),
        &mask);
    if (!output.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "query_%03d.png", q);
      WriteMask(output / name, mask);
    }
    const SignatureResult silhouette = ExtractSignature(mask, database.parameters.signature);
    if (!silhouette.ok()) {
      std::printf("%-3d | %-10s silhouette not usable: %s\n", q, mesh.name.c_str(),
                  silhouette.Describe().c_str());
      continue;
    }
    const auto match_start = std::chrono::steady_clock::now();
    const std::vector<MatchCandidate> top = matcher.Match(silhouette.signature.radii, {.top_k = 1});
    if (top.empty()) ThrowError("no database view has a usable silhouette");
    const MatchCandidate& best = top.front();
    match_ms_total +=
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - match_start)
            .count();
    const std::string& found = database.models[static_cast<size_t>(best.model)].name;
    const Eigen::Vector3d& found_dir = database.sphere.directions[static_cast<size_t>(best.view)];
    const bool right_object = best.model == static_cast<int>(model);
    right += right_object;
    const double view_error = AngleDeg(direction, found_dir);
    const double roll_error =
        std::abs(WrapDegrees(best.roll_deg - TransportRoll(direction, roll, found_dir)));
    if (right_object) {
      view_errors.push_back(view_error);
      roll_errors.push_back(roll_error);
    }
    char truth[64];
    std::snprintf(truth, sizeof(truth), "(%6.3f,%6.3f,%6.3f)", direction.x(), direction.y(),
                  direction.z());
    std::printf("%-3d | %-10s %-24s %7.1f | %-10s %5d %7.1f %6.3f | %7.1f%s %7.1f%s %s\n", q,
                mesh.name.c_str(), truth, roll, found.c_str(), best.view, best.roll_deg,
                static_cast<double>(best.score), view_error, "d", roll_error, "d",
                right_object ? "" : "  <- wrong object");
    if (csv.is_open()) {
      csv << q << ',' << mesh.name << ',' << direction.x() << ',' << direction.y() << ','
          << direction.z() << ',' << roll << ',' << found << ',' << best.view << ','
          << best.roll_deg << ',' << best.score << ',' << view_error << ',' << roll_error << '\n';
    }
  }
  std::printf(
      "\nright object in %d of %d single silhouettes; on those, median view error %.1f deg "
      "(views are %.1f deg apart), median roll error %.1f deg; %.1f ms per match\n",
      right, arguments.queries, Median(view_errors),
      database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi, Median(roll_errors),
      match_ms_total / arguments.queries);
  std::printf(
      "A single silhouette can be ambiguous (symmetric objects, views that look alike); tracking "
      "over a video resolves that.\n");
  if (!output.empty())
    std::printf("wrote the database, query masks and demo.csv to %s\n", output.c_str());
}

}  // namespace

void AddDemoCommand(CLI::App& app) {
  auto arguments = std::make_shared<DemoArguments>();
  CLI::App* command = app.add_subcommand(
      "demo",
      "Build a database from the built-in sample models, render their silhouettes at random "
      "poses, match them and print what was found next to the truth. No arguments needed.");
  command->add_option("--models", arguments->models_dir,
                      "Folder of meshes to use instead of the sample models");
  command->add_option("--queries", arguments->queries, "Random silhouettes to match")
      ->capture_default_str();
  command->add_option("--views", arguments->views, "Viewpoints per model")->capture_default_str();
  command->add_option("--seed", arguments->seed, "Random seed of the poses")->capture_default_str();
  command->add_option("--threads", arguments->threads, "Worker threads for building (0 = all)")
      ->capture_default_str();
  command->add_option("-o,--output", arguments->output_dir,
                      "Also write the database, query masks and a CSV here");
  command->callback([arguments] { RunDemo(*arguments); });
}

}  // namespace silpose::cli
