#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include "silpose/cli/commands.h"
#include "silpose/database/database_builder.h"
#include "silpose/eval/self_match.h"
#include "silpose/util/error.h"
#include "silpose/util/hash.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct SelfMatchArguments {
  std::vector<std::string> models;
  std::string database;
  std::string csv;
  std::string failures_csv;
  std::string scales = "0.5,2";
  int views = 1000;
  SelfMatchOptions options;
};

std::vector<std::filesystem::path> DefaultEvalModels() {
  // The shared reference set when run from a checkout beside it, else the sample models.
  for (const char* candidate : {"../shared/models", "../../shared/models"}) {
    std::error_code error;
    if (std::filesystem::is_directory(candidate, error)) {
      auto files = MeshFilesIn(candidate);
      if (!files.empty()) return files;
    }
  }
  return SampleModels();
}

double Percent(int part, int whole) { return whole > 0 ? 100.0 * part / whole : 0.0; }

void RunSelfMatchEval(const SelfMatchArguments& arguments) {
  std::vector<std::filesystem::path> paths(arguments.models.begin(), arguments.models.end());
  if (paths.empty()) paths = DefaultEvalModels();
  SelfMatchOptions options = arguments.options;
  options.scales.clear();
  std::stringstream stream(arguments.scales);
  for (std::string item; std::getline(stream, item, ',');) {
    try {
      size_t used = 0;
      options.scales.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      ThrowError("--scales must be numbers separated by commas, got '", arguments.scales, "'");
    }
  }
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);

  ViewDatabase database;
  if (!arguments.database.empty()) {
    database = ViewDatabase::Read(arguments.database);
    if (database.models.size() != paths.size()) {
      ThrowError(arguments.database, ": has ", database.models.size(), " models, ", paths.size(),
                 " meshes given");
    }
    for (size_t m = 0; m < paths.size(); ++m) {
      if (HashFile(paths[m]) != database.models[m].mesh_hash) {
        ThrowError(paths[m].string(), ": differs from the mesh the database '", arguments.database,
                   "' was built from (model ", database.models[m].name, ")");
      }
    }
  } else {
    DatabaseBuildOptions build;
    build.parameters.view_sphere.num_views = arguments.views;
    build.num_threads = options.num_threads;
    build.show_progress = true;
    database = BuildViewDatabase(paths, build);
  }
  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));

  const int per_model = (database.num_views() + options.view_stride - 1) / options.view_stride;
  ProgressBar progress("self-match",
                       static_cast<int64_t>(per_model) * static_cast<int64_t>(meshes.size()));
  const auto start = std::chrono::steady_clock::now();
  const std::vector<SelfMatchModelResult> results =
      RunSelfMatch(database, meshes, options, [&progress](int done) { progress.Advance(done); });
  progress.Finish();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::printf(
      "self-match: %d views x %zu scales (%s) per model, random roll, %zu models, "
      "roll tolerance %.1f bins\n",
      per_model, options.scales.size(), arguments.scales.c_str(), meshes.size(),
      options.roll_tolerance_bins);
  std::printf("%-24s %7s %8s %8s %9s %8s %10s %8s\n", "model", "queries", "object%", "own%",
              "own+nb%", "passed%", "ambiguous", "circular");
  SelfMatchModelResult total;
  total.name = "all";
  for (const auto& r : results) total.Add(r);
  std::ofstream csv;
  if (!arguments.csv.empty()) {
    csv.open(arguments.csv);
    if (!csv) ThrowError(arguments.csv, ": cannot open for writing");
    csv << "model,queries,right_model,own_view,own_or_neighbour,passed,"
           "failed_but_indistinguishable,nearly_circular,not_describable\n";
  }
  auto row = [&](const SelfMatchModelResult& r) {
    std::printf("%-24s %7d %8.2f %8.2f %9.2f %8.2f %10d %8d\n", r.name.c_str(), r.queries,
                Percent(r.right_model, r.queries), Percent(r.own_view, r.queries),
                Percent(r.own_or_neighbour, r.queries), Percent(r.passed, r.queries),
                r.failed_but_indistinguishable, r.nearly_circular);
    if (csv.is_open()) {
      csv << r.name << ',' << r.queries << ',' << r.right_model << ',' << r.own_view << ','
          << r.own_or_neighbour << ',' << r.passed << ',' << r.failed_but_indistinguishable << ','
          << r.nearly_circular << ',' << r.not_describable << '\n';
    }
  };
  for (const auto& r : results) row(r);
  row(total);
  std::printf(
      "passed = right model, own view or a neighbour, roll within tolerance; ambiguous = "
      "failures whose true and found database silhouettes correlate >= 0.99.\n");
  std::printf("%.1f s\n", seconds);
  if (!arguments.failures_csv.empty()) {
    std::ofstream failures(arguments.failures_csv);
    if (!failures) ThrowError(arguments.failures_csv, ": cannot open for writing");
    failures << "model,view,scale,true_roll_deg,found_model,found_view,found_roll_deg,score,"
                "silhouette_agreement\n";
    for (const auto& r : results) {
      for (const auto& f : r.failures) {
        failures << r.name << ',' << f.view << ',' << f.scale << ',' << f.true_roll_deg << ','
                 << (f.found_model >= 0 ? database.models[static_cast<size_t>(f.found_model)].name
                                        : "")
                 << ',' << f.found_view << ',' << f.found_roll_deg << ',' << f.found_score << ','
                 << f.silhouette_agreement << '\n';
      }
    }
  }
}

}  // namespace

void AddEvalCommand(CLI::App& app) {
  CLI::App* eval = app.add_subcommand("eval", "Measure silpose against ground truth.");
  eval->require_subcommand(1);
  auto arguments = std::make_shared<SelfMatchArguments>();
  CLI::App* self_match = eval->add_subcommand(
      "self-match",
      "Render every database view again with a random roll at other image sizes and check that "
      "it matches its own view (or a neighbour) with the right roll.");
  self_match->add_option("models", arguments->models,
                         "Meshes (default: ../shared/models when present, else the sample models)");
  self_match->add_option("-d,--database", arguments->database,
                         "Use this database (built from the same meshes, in order) instead of "
                         "building one");
  self_match->add_option("--views", arguments->views, "Viewpoints per model when building")
      ->capture_default_str();
  self_match
      ->add_option("--scales", arguments->scales,
                   "Image sizes relative to the database's, comma-separated")
      ->capture_default_str();
  self_match
      ->add_option("--roll-tolerance", arguments->options.roll_tolerance_bins,
                   "Roll tolerance in signature bins")
      ->capture_default_str();
  self_match->add_option("--stride", arguments->options.view_stride, "Test every n-th view only")
      ->capture_default_str();
  self_match->add_option("--seed", arguments->options.seed, "Seed of the random rolls")
      ->capture_default_str();
  self_match->add_option("--threads", arguments->options.num_threads, "Worker threads (0 = all)")
      ->capture_default_str();
  self_match->add_option("--csv", arguments->csv, "Write the per-model table as CSV");
  self_match->add_option("--failures", arguments->failures_csv, "Write every failed query as CSV");
  self_match->callback([arguments] { RunSelfMatchEval(*arguments); });
}

}  // namespace silpose::cli
