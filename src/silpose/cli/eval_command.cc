#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/evaluation_database.h"
#include "silpose/eval/self_match.h"
#include "silpose/eval/tracking_experiment.h"
#include "silpose/util/error.h"
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

}  // namespace

std::vector<std::filesystem::path> DefaultEvalModels() {
  // A reference set named by the environment, else the sample models.
  const char* folder = std::getenv("SILPOSE_EVAL_MODELS");
  if (folder != nullptr && *folder != '\0') {
    std::error_code error;
    if (!std::filesystem::is_directory(folder, error))
      ThrowError(folder, " (SILPOSE_EVAL_MODELS): not a folder");
    auto files = MeshFilesIn(folder);
    if (files.empty()) ThrowError(folder, " (SILPOSE_EVAL_MODELS): no mesh files in it");
    return files;
  }
  return SampleModels();
}

namespace {

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

  const ViewDatabase database = EvaluationDatabase(paths, {.database_path = arguments.database,
                                                           .num_views = arguments.views,
                                                           .num_threads = options.num_threads,
                                                           .show_progress = true});
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

struct TrackingArguments {
  std::vector<std::string> models;
  std::string database;
  std::string output;
  std::string flown;
  std::string particles = "10,20,30,40,50,60,70,80,90,100";
  std::string per_frame;
  int frames = 360;
  int repeats = 5;
  int views = 1000;
  bool no_brute_force = false;
  bool quick = false;
  int num_threads = 1;
  // Set by the parser: which options were given (--quick does not override them).
  bool frames_given = false, repeats_given = false, particles_given = false, flown_given = false;
};

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

std::vector<int> ParseCounts(const std::string& text) {
  std::vector<int> counts;
  for (const std::string& item : SplitList(text)) {
    try {
      size_t used = 0;
      counts.push_back(std::stoi(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      ThrowError("--particles must be whole numbers separated by commas, got '", text, "'");
    }
  }
  if (counts.empty()) ThrowError("--particles needs at least one count");
  return counts;
}

void RunTrackingEval(const TrackingArguments& arguments) {
  std::vector<std::filesystem::path> paths(arguments.models.begin(), arguments.models.end());
  TrackingExperimentOptions options;
  options.frames = arguments.frames;
  options.repeats = arguments.repeats;
  options.particle_counts = ParseCounts(arguments.particles);
  options.flown_models = SplitList(arguments.flown);
  options.brute_force = !arguments.no_brute_force;
  options.num_threads = arguments.num_threads;
  if (arguments.quick) {
    // The sample models, 2 flown, 60 frames, 20 and 60 particles, 2 seeds (options given
    // explicitly win).
    if (paths.empty()) paths = SampleModels();
    if (!arguments.flown_given) options.num_flown = 2;
    if (!arguments.frames_given) options.frames = 60;
    if (!arguments.particles_given) options.particle_counts = {20, 60};
    if (!arguments.repeats_given) options.repeats = 2;
  }
  if (paths.empty()) paths = DefaultEvalModels();
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);
  // A database built here names its models after the mesh files: a model to fly that is not among
  // them is refused before the build (which takes seconds). A given database (-d) is checked
  // against its own names once read.
  if (arguments.database.empty()) {
    const std::vector<std::string> known = MeshModelNames(paths);
    for (const std::string& name : options.flown_models) {
      if (std::find(known.begin(), known.end(), name) == known.end())
        ThrowError("model to fly '", name, "' is not in the database (", Joined(known), ")");
    }
  }
  const std::filesystem::path folder = CreateOutputFolder(arguments.output);

  const ViewDatabase database = EvaluationDatabase(paths, {.database_path = arguments.database,
                                                           .num_views = arguments.views,
                                                           .num_threads = arguments.num_threads,
                                                           .show_progress = true});
  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));
  const std::vector<int> flown = FlownModelIndices(database, options);

  ProgressBar progress("tracking", TrackingRunCount(options, static_cast<int>(flown.size())));
  const TrackingExperimentResult result = RunTrackingExperiment(
      database, meshes, options, [&progress](int done) { progress.Advance(done); });
  progress.Finish();

  WriteTrackingTable(folder / "tracking.csv", result);
  WriteTrackingRuns(folder / "tracking_runs.csv", result);
  if (!arguments.per_frame.empty()) WriteTrackingFrames(arguments.per_frame, result, database);
  const Figure figure = TrackingFigure(result);
  figure.WriteSvg(folder / "tracking.svg");
  figure.WritePng(folder / "tracking.png");

  std::printf(
      "tracking (paper 5.1): %zu of %d models flown (%s), %d frames each, orbit at %g deg per "
      "frame; database %d views per model; %zu particle counts x %d seeds; adaptive off\n",
      result.flown_models.size(), result.num_models, Joined(result.flown_models).c_str(),
      result.frames_per_flight, options.orbit.step_deg, database.num_views(),
      options.particle_counts.size(), options.repeats);
  std::printf("%-16s %9s %5s %7s %10s %9s %10s %8s %9s\n", "method", "particles", "runs", "frames",
              "pose_error", "std", "mod_sym", "object%", "ms/frame");
  for (const TrackingRow& row : result.rows) {
    const TrackingStats& s = row.stats;
    std::printf("%-16s %9s %5d %7d %10.4f %9.4f %10.4f %8.2f %9.3f\n", row.method.c_str(),
                row.particles > 0 ? std::to_string(row.particles).c_str() : "-", s.runs, s.frames,
                s.pose_error_mean, s.pose_error_std, s.symmetric_pose_error_mean,
                s.right_object_percent(), s.ms_per_frame_mean);
  }
  std::printf(
      "pose error: distance between estimated and true unit view directions, every frame "
      "(wrong-object frames included); mod_sym: the same modulo the model's symmetry "
      "(docs/symmetry.md)\n");
  std::printf("%-34s %18s %18s\n", "paper comparison", "ours", "paper");
  if (const TrackingRow* brute = result.BruteForce()) {
    std::printf("%-34s %10.3f +- %5.3f %10.3f +- %5.3f\n", "brute force: pose error",
                brute->stats.pose_error_mean, brute->stats.pose_error_std,
                PaperTrackingFigures::kBruteForcePoseErrorMean,
                PaperTrackingFigures::kBruteForcePoseErrorStd);
    std::printf("%-34s %16.1f %% %16.1f %%\n", "brute force: right object",
                brute->stats.right_object_percent(),
                PaperTrackingFigures::kBruteForceRightObjectPercent);
  }
  if (const TrackingRow* at60 = result.Filter(60)) {
    std::printf("%-34s %16.1f %% %16.1f %%\n", "filter, 60 particles: right object",
                at60->stats.right_object_percent(),
                PaperTrackingFigures::kFilterRightObjectPercentAt60);
  }
  if (result.num_threads == 1) {
    std::printf("times: one thread, signature extraction included\n");
  } else {
    std::printf(
        "times: %d runs in parallel on %d threads (per-frame times are inflated by sharing the "
        "cores; use --threads 1 for single-thread times), signature extraction included\n",
        result.num_threads, result.num_threads);
  }
  std::printf(
      "%.1f s; wrote %s, %s, %s, %s\n", result.seconds, (folder / "tracking.csv").string().c_str(),
      (folder / "tracking_runs.csv").string().c_str(), (folder / "tracking.svg").string().c_str(),
      (folder / "tracking.png").string().c_str());
}

void AddTrackingCommand(CLI::App* eval) {
  auto arguments = std::make_shared<TrackingArguments>();
  CLI::App* command = eval->add_subcommand(
      "tracking",
      "The paper's experiment 5.1: fly around some models at 1 degree per frame and track each "
      "flight with 10..100 particles per object (5 seeds each, adaptive count off), against "
      "brute-force matching of every frame. Writes OUTDIR/tracking.csv (one row per particle "
      "count and a brute-force row), tracking_runs.csv, tracking.svg and tracking.png.");
  command->add_option("models", arguments->models,
                      "Meshes of the database (default: the folder in $SILPOSE_EVAL_MODELS, "
                      "else the sample models)");
  command->add_option("-d,--database", arguments->database,
                      "Use this database (built from the same meshes, in order) instead of "
                      "building one");
  command->add_option("-o,--output", arguments->output, "Folder for the tables and the figure")
      ->required();
  command->add_option("--views", arguments->views, "Viewpoints per model when building")
      ->capture_default_str();
  command->add_option("--flown", arguments->flown,
                      "Models to fly around, comma-separated names (default: bunny, cow, dino, "
                      "elephant, rotor when present, else 5 spread over the list)");
  command->add_option("--frames", arguments->frames, "Frames per flight (1 degree each)")
      ->capture_default_str();
  command
      ->add_option("--particles", arguments->particles,
                   "Particles per object, comma-separated counts")
      ->capture_default_str();
  command->add_option("--repeats", arguments->repeats, "Runs per count and model (seeds 1..N)")
      ->capture_default_str();
  command->add_flag("--no-brute-force", arguments->no_brute_force, "Skip the brute-force baseline");
  command
      ->add_option("--threads", arguments->num_threads,
                   "Runs in parallel (0 = all cores); times are single-thread times only with 1")
      ->capture_default_str();
  command->add_option("--per-frame", arguments->per_frame,
                      "Also write every frame of every run to this CSV");
  command->add_flag("--quick", arguments->quick,
                    "Sample models, 2 flown, 60 frames, 20 and 60 particles, 2 seeds (seconds)");
  command->callback([command, arguments] {
    TrackingArguments given = *arguments;
    given.frames_given = command->count("--frames") > 0;
    given.repeats_given = command->count("--repeats") > 0;
    given.particles_given = command->count("--particles") > 0;
    given.flown_given = command->count("--flown") > 0;
    RunTrackingEval(given);
  });
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
                         "Meshes (default: the folder in $SILPOSE_EVAL_MODELS, else the sample "
                         "models)");
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
      ->capture_default_str()
      ->check(SeedNumber());
  self_match->add_option("--threads", arguments->options.num_threads, "Worker threads (0 = all)")
      ->capture_default_str();
  self_match->add_option("--csv", arguments->csv, "Write the per-model table as CSV");
  self_match->add_option("--failures", arguments->failures_csv, "Write every failed query as CSV");
  self_match->callback([arguments] { RunSelfMatchEval(*arguments); });
  AddTrackingCommand(eval);
  AddEvalVideoCommand(eval);
  AddEvalBopCommand(eval);
  AddEvalHandheldCommand(eval);
  AddEvalConfidenceCommand(eval);
  AddEvalScaleCommand(eval);
}

}  // namespace silpose::cli
