// `silpose eval handheld`: accuracy on objects turned by hand in front of a static camera, and on
// the paper's orbits at several distances, binned by distance, off-axis angle, speed and mask
// quality (eval/handheld_experiment.h).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <set>
#include <sstream>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/evaluation_database.h"
#include "silpose/eval/handheld_experiment.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct EvalHandheldArguments {
  std::string output = "eval-handheld";
  std::vector<std::string> models;
  std::vector<std::string> evaluate;
  std::string database;
  int sequences = 3;
  int frames = 120;
  int orbit_frames = 120;
  std::string distances = "3,7,15,30";
  std::string mask_quality = "both";
  int threads = 0;
  int views = 1000;
  uint64_t seed = 1000;
  int skip = 10;
  bool ablation = false;
  std::vector<std::string> trackers;
  bool quick = false;
  // Which options were given (--quick does not override them).
  bool sequences_given = false, frames_given = false, orbit_frames_given = false,
       views_given = false, evaluate_given = false, distances_given = false;
};

std::vector<double> ParseDistances(const std::string& text) {
  std::vector<double> values;
  if (text == "none") return values;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size() || !std::isfinite(values.back())) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      ThrowError(
          "--distances must be numbers of object radii separated by commas (or 'none'), "
          "got '",
          text, "'");
    }
  }
  if (values.empty()) ThrowError("--distances needs at least one distance (or 'none')");
  return values;
}

std::vector<MaskQuality> ParseQualities(const std::string& text) {
  if (text == "both") return {MaskQuality::kPerfect, MaskQuality::kThreshold};
  MaskQuality quality;
  if (!ParseMaskQuality(text, &quality)) {
    ThrowError("--mask-quality must be perfect, threshold or both, got '", text, "'");
  }
  return {quality};
}

void PrintSummary(const HandheldExperimentResult& result) {
  std::printf("\nsummary (frames %d and later; 'all' columns: every frame)\n",
              result.options.skip_frames);
  std::printf("%-10s %-9s %-19s %4s %6s %8s %6s %8s %8s %8s %8s %7s %8s %8s %5s\n", "kind", "masks",
              "tracker", "seqs", "frames", "object%", "no-est", "rot med", "rot mean", "trans%",
              "view err", "roll", "all obj%", "all rot", "twin");
  for (const HandheldSummaryRow& row : result.summary) {
    const HandheldStats& s = row.counted;
    std::printf(
        "%-10s %-9s %-19s %4d %6d %8.2f %6d %8s %8s %8s %8s %7s %8.2f %8s %5d\n", row.kind.c_str(),
        MaskQualityName(row.mask_quality), HandheldTrackerName(row.tracker), row.sequences,
        s.frames, s.RightObjectPercent(), s.no_estimate, Number(s.rotation_median_deg).c_str(),
        Number(s.rotation_mean_deg).c_str(), Number(s.translation_median_percent).c_str(),
        Number(s.view_error_mean, "%.4f").c_str(), Number(s.roll_median_deg).c_str(),
        row.all.RightObjectPercent(), Number(row.all.rotation_median_deg).c_str(), s.wrong_twin);
  }
}

void PrintBins(const HandheldExperimentResult& result) {
  const std::vector<HandheldTracker>& trackers = result.options.trackers;
  for (HandheldBinAxis axis : AllHandheldBinAxes()) {
    const std::vector<std::string> labels =
        HandheldBinLabels(axis, result.options.orbit_distances_radii);
    std::printf(
        "\nby %s (every mask quality run; frames %d and later): frames, right object %%, "
        "median rotation error modulo symmetry deg\n",
        HandheldBinAxisName(axis), result.options.skip_frames);
    std::printf("%-10s", "bin");
    for (HandheldTracker tracker : trackers) std::printf(" | %-25s", HandheldTrackerName(tracker));
    std::printf("\n");
    for (size_t bin = 0; bin < labels.size(); ++bin) {
      std::printf("%-10s", labels[bin].c_str());
      for (HandheldTracker tracker : trackers) {
        const HandheldBinRow* row = result.Bin(axis, static_cast<int>(bin), "all", tracker);
        if (row == nullptr || row->stats.frames == 0) {
          std::printf(" | %-25s", "-");
          continue;
        }
        std::printf(" | %6d %8.2f %9s", row->stats.frames, row->stats.RightObjectPercent(),
                    Number(row->stats.rotation_median_symmetric_deg).c_str());
      }
      std::printf("\n");
    }
  }
}

// Each tracker against brute force, sequence by sequence (when brute force ran).
void PrintComparisons(const HandheldExperimentResult& result) {
  const std::vector<HandheldTracker>& trackers = result.options.trackers;
  if (std::find(trackers.begin(), trackers.end(), HandheldTracker::kBruteForce) == trackers.end())
    return;
  for (HandheldTracker tracker : trackers) {
    if (tracker == HandheldTracker::kBruteForce) continue;
    const std::vector<HandheldComparisonRow> rows =
        CompareHandheldTrackers(result, tracker, HandheldTracker::kBruteForce);
    int sequences = 0, above = 0;
    std::string parts;
    for (const HandheldComparisonRow& row : rows) {
      sequences += row.sequences;
      above += row.above;
      if (!parts.empty()) parts += ", ";
      parts += row.kind + " " + MaskQualityName(row.mask_quality) + " " +
               std::to_string(row.above) + "/" + std::to_string(row.sequences);
    }
    if (sequences == 0) continue;
    std::printf(
        "\n%s above brute force in mean view error modulo symmetry (frames %d and later) on %d of "
        "%d sequences (sequences.csv): %s\n",
        HandheldTrackerName(tracker), result.options.skip_frames, above, sequences, parts.c_str());
  }
}

void WriteReadme(const std::filesystem::path& path, const HandheldExperimentResult& result,
                 const ViewDatabase& database, const std::vector<std::filesystem::path>& paths,
                 const std::string& models_note) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  const HandheldExperimentOptions& o = result.options;
  file << "silpose eval handheld\n\n";
  file << "command: " << CommandLine() << "\n";
  file << "working directory: " << std::filesystem::current_path().string() << "\n\n";
  file << "database: " << database.models.size() << " models x " << database.num_views()
       << " views:";
  for (const auto& p : paths) file << ' ' << p.string();
  file << "\nevaluated models (" << result.models.size() << "): " << Joined(result.models) << "\n";
  if (!models_note.empty()) file << models_note << "\n";
  file << "hand-held: " << o.sequences_per_model << " sequences per model, " << o.frames
       << " frames, seeds first_seed + model_order * " << o.sequences_per_model
       << " + sequence (first_seed " << o.first_seed << ")\n";
  file << "orbits: distances";
  for (double d : o.orbit_distances_radii) file << ' ' << d;
  file << " radii, " << o.orbit_frames << " frames, 1 deg/frame, seeds first_seed + 500000 + ...\n";
  file << "mask qualities:";
  for (MaskQuality q : o.mask_qualities) file << ' ' << MaskQualityName(q);
  file << "\ntrackers:";
  for (HandheldTracker t : o.trackers) file << ' ' << HandheldTrackerName(t);
  file << "\nskip frames: " << o.skip_frames << "\nseeds used:";
  for (uint64_t seed : result.Seeds()) file << ' ' << seed;
  file << "\n\nfiles: summary.csv (kind x mask quality x tracker), bins.csv (axis x bin x mask "
          "quality x tracker), sequences.csv (each sequence x tracker), frames.csv (every frame), "
          "handheld.svg / handheld.png\n";
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

void RunEvalHandheld(const EvalHandheldArguments& arguments) {
  HandheldExperimentOptions options;
  options.sequences_per_model = arguments.sequences;
  options.frames = arguments.frames;
  options.orbit_frames = arguments.orbit_frames;
  options.orbit_distances_radii = ParseDistances(arguments.distances);
  options.mask_qualities = ParseQualities(arguments.mask_quality);
  options.num_threads = arguments.threads;
  options.first_seed = arguments.seed;
  options.skip_frames = arguments.skip;
  if (arguments.ablation) {
    options.trackers = {HandheldTracker::kFilter, HandheldTracker::kBruteForce,
                        HandheldTracker::kFilterNoRefine, HandheldTracker::kFilterPaperMotion};
  }
  if (!arguments.trackers.empty()) {
    if (arguments.ablation) ThrowError("give --ablation or --trackers, not both");
    options.trackers.clear();
    for (const std::string& name : arguments.trackers) {
      HandheldTracker tracker;
      if (!ParseHandheldTracker(name, &tracker)) {
        ThrowError("--trackers: unknown tracker '", name,
                   "' (filter, brute-force, filter-no-refine, filter-paper-motion, "
                   "filter-lag-10, filter-smooth, filter-adaptive)");
      }
      options.trackers.push_back(tracker);
    }
  }
  int views = arguments.views;
  std::vector<std::string> evaluate = arguments.evaluate;
  std::vector<std::filesystem::path> paths;
  if (!arguments.models.empty()) paths = MeshPathsFromModelsOption(arguments.models);
  if (arguments.quick) {
    // The test variant: the sample models, a coarse database, bunny and hand, short sequences.
    if (paths.empty()) paths = SampleModels();
    if (!arguments.views_given) views = 150;
    if (!arguments.sequences_given) options.sequences_per_model = 1;
    if (!arguments.frames_given) options.frames = 40;
    if (!arguments.orbit_frames_given) options.orbit_frames = 30;
    if (!arguments.evaluate_given) evaluate = {"bunny", "hand"};
    if (!arguments.distances_given) options.orbit_distances_radii = {3.0, 7.0, 15.0};
  }
  if (views < 1) ThrowError("--views must be >= 1");
  if (options.sequences_per_model < 0) ThrowError("--sequences must be >= 0");
  if (options.frames < 1) ThrowError("--frames must be >= 1");
  if (options.orbit_frames < 1) ThrowError("--orbit-frames must be >= 1");
  if (options.skip_frames < 0) ThrowError("--skip must be >= 0");
  if (options.num_threads < 0) ThrowError("--threads must be >= 0");
  if (paths.empty()) paths = DefaultEvalModels();
  const std::vector<std::string> known = MeshModelNames(paths);
  for (const std::string& name : evaluate) {
    if (std::find(known.begin(), known.end(), name) == known.end())
      ThrowError("--evaluate: no model '", name, "' among the database's (", Joined(known), ")");
  }
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);

  // The evaluation set: the held-out models (not the project's tuning / sample models).
  std::string models_note;
  if (evaluate.empty()) {
    std::set<std::string> tuning;
    for (const auto& sample : SampleModels()) tuning.insert(sample.stem().string());
    for (const auto& p : paths) {
      if (tuning.count(p.stem().string()) == 0) evaluate.push_back(p.stem().string());
    }
    if (evaluate.empty()) {
      for (const auto& p : paths) evaluate.push_back(p.stem().string());
      models_note = "note: no held-out models (every database model is a tuning / sample model: " +
                    Joined(evaluate) +
                    "); evaluating those, so the figures are not held-out figures. Give more "
                    "models with --models for held-out figures.";
    } else {
      models_note = "held out: every database model except the tuning / sample models (" +
                    Joined({tuning.begin(), tuning.end()}) + ")";
    }
  }
  options.models = evaluate;

  const std::filesystem::path folder = CreateOutputFolder(arguments.output);

  const ViewDatabase database = EvaluationDatabase(paths, {.database_path = arguments.database,
                                                           .num_views = views,
                                                           .num_threads = arguments.threads,
                                                           .show_progress = true});
  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));
  std::vector<std::string> tracker_names;
  for (HandheldTracker t : options.trackers) tracker_names.push_back(HandheldTrackerName(t));
  std::printf(
      "eval handheld: database %zu models x %d views (%.1f deg apart); evaluating %zu: %s\n",
      database.models.size(), database.num_views(),
      database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi, evaluate.size(),
      Joined(evaluate).c_str());
  if (!models_note.empty()) std::printf("%s\n", models_note.c_str());
  std::printf(
      "per model: %d hand-held sequences x %d frames (4-10 radii, <= 25 deg off-axis, 2-15 "
      "deg/frame), orbits at %s radii x %d frames (1 deg/frame); masks %s; trackers %s; "
      "640x480, f = 525 px\n",
      options.sequences_per_model, options.frames,
      options.orbit_distances_radii.empty() ? "none" : arguments.distances.c_str(),
      options.orbit_frames, arguments.mask_quality.c_str(), Joined(tracker_names).c_str());

  ProgressBar progress("handheld",
                       HandheldTaskCount(options, static_cast<int>(options.models.size())));
  const HandheldExperimentResult result = RunHandheldExperiment(
      database, meshes, options, [&progress](int done) { progress.Advance(done); });
  progress.Finish();

  WriteHandheldSummary(folder / "summary.csv", result);
  WriteHandheldBins(folder / "bins.csv", result);
  WriteHandheldSequences(folder / "sequences.csv", result);
  WriteHandheldFrames(folder / "frames.csv", result, database);
  const Figure figure = HandheldFigure(result);
  figure.WriteSvg(folder / "handheld.svg");
  figure.WritePng(folder / "handheld.png");
  WriteReadme(folder / "README.txt", result, database, paths, models_note);

  PrintSummary(result);
  PrintBins(result);
  PrintComparisons(result);
  std::printf(
      "\nrotation / translation errors: right-object frames with a pose; view error: every frame "
      "with an estimate; 'no-est': frames without any estimate (counted as wrong object)\n");
  std::printf(
      "%.1f s; wrote summary.csv, bins.csv, sequences.csv, frames.csv, handheld.svg, "
      "handheld.png, "
      "README.txt (command and seeds) in %s/\n",
      result.seconds, folder.string().c_str());
}

}  // namespace

void AddEvalHandheldCommand(CLI::App* eval) {
  auto arguments = std::make_shared<EvalHandheldArguments>();
  CLI::App* command = eval->add_subcommand(
      "handheld",
      "Accuracy where users film: held-out models turned by hand in front of a static 640x480 "
      "camera (4-10 radii, off-axis, 2-15 deg/frame with pauses, reversals and cuts) and the "
      "paper's orbits at 3, 7 and 15 radii, with perfect and threshold-like masks, tracked by the "
      "filter and by brute force against the whole database; errors binned by distance, "
      "off-axis angle, speed and mask quality. Writes OUT/summary.csv, bins.csv, sequences.csv, "
      "frames.csv, "
      "handheld.svg/.png and README.txt.");
  command->add_option("-o,--output", arguments->output, "Output folder")->capture_default_str();
  command->add_option("--models", arguments->models,
                      "Database meshes: folders or files (default: the folder in "
                      "$SILPOSE_EVAL_MODELS, else the sample models)");
  command
      ->add_option("--evaluate", arguments->evaluate,
                   "Models to film, by name (default: the database models that are not sample "
                   "/ tuning models; all of them if none is)")
      ->delimiter(',');
  command->add_option("-d,--database", arguments->database,
                      "Database built from exactly these meshes, in order (default: build one)");
  command->add_option("--sequences", arguments->sequences, "Hand-held sequences per model")
      ->capture_default_str();
  command->add_option("--frames", arguments->frames, "Frames per hand-held sequence")
      ->capture_default_str();
  command->add_option("--orbit-frames", arguments->orbit_frames, "Frames per orbit")
      ->capture_default_str();
  command
      ->add_option("--distances", arguments->distances,
                   "Orbit distances, object radii, comma-separated, or 'none'")
      ->capture_default_str();
  command->add_option("--mask-quality", arguments->mask_quality, "perfect, threshold or both")
      ->capture_default_str();
  command->add_option("--threads", arguments->threads, "Sequences in parallel (0 = all cores)")
      ->capture_default_str();
  command->add_option("--views", arguments->views, "Views per model when building")
      ->capture_default_str();
  command->add_option("--seed", arguments->seed, "First seed of the sequences")
      ->capture_default_str()
      ->check(SeedNumber());
  command->add_option("--skip", arguments->skip, "Frames left out at the start of each sequence")
      ->capture_default_str();
  command->add_flag("--ablation", arguments->ablation,
                    "Also run the filter without refinement and with the paper's motion model");
  command
      ->add_option("--trackers", arguments->trackers,
                   "Trackers to compare, comma-separated: filter, brute-force, filter-no-refine, "
                   "filter-paper-motion, filter-lag-10 (track --lag 10), filter-smooth (track "
                   "--smooth), filter-adaptive (track --adaptive); default filter,brute-force")
      ->delimiter(',');
  command->add_flag("--quick", arguments->quick,
                    "Small variant for tests: sample models, 150 views, bunny and hand, one "
                    "40-frame hand-held sequence and 30-frame orbits each");
  command->callback([command, arguments] {
    EvalHandheldArguments given = *arguments;
    given.sequences_given = command->count("--sequences") > 0;
    given.frames_given = command->count("--frames") > 0;
    given.orbit_frames_given = command->count("--orbit-frames") > 0;
    given.views_given = command->count("--views") > 0;
    given.evaluate_given = command->count("--evaluate") > 0;
    given.distances_given = command->count("--distances") > 0;
    RunEvalHandheld(given);
  });
}

}  // namespace silpose::cli
