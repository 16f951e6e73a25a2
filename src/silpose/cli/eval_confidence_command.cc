// `silpose eval confidence`: fits the tracker's confidence on the tuning models and measures on
// held-out models and an object not in the database how well it and the states tell right frames
// from wrong ones (eval/confidence_experiment.h, docs/confidence.md).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/confidence_experiment.h"
#include "silpose/eval/evaluation_database.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct EvalConfidenceArguments {
  std::string output = "eval-confidence";
  std::vector<std::string> models;
  std::vector<std::string> fit = {"bunny", "cow"};
  std::vector<std::string> evaluate;
  std::vector<std::string> unknown;
  std::string database;
  int sequences = 2;
  int frames = 100;
  int threads = 0;
  int views = 1000;
  uint64_t seed = 3000;
  bool no_fit = false;
  bool quick = false;
  double min_confidence = TrackStateOptions().min_confidence;
  bool sequences_given = false, frames_given = false, views_given = false, unknown_given = false,
       evaluate_given = false;
};

void PrintMetrics(const char* label, const ConfidenceMetrics& m) {
  std::printf("%-22s %6d %7d %7s %8d %9s %9s %7d %9s\n", label, m.frames, m.correct,
              std::isfinite(m.auc) ? Number(100.0 * m.auc).c_str() : "-", m.tracking,
              Number(m.WrongTrackingPercent()).c_str(), Number(m.CorrectTrackingPercent()).c_str(),
              m.unknown_frames, Number(m.UnknownReportedPercent()).c_str());
}

void WriteSummary(const std::filesystem::path& path, const ConfidenceExperimentResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(7);
  file << "set,frames,correct,auc,tracking,tracking_wrong_percent,correct_tracking_percent,"
          "unknown_frames,unknown_reported_percent";
  for (int s = 0; s < 6; ++s) file << ',' << TrackStateName(static_cast<TrackState>(s));
  file << '\n';
  const auto row = [&](const std::string& name, const ConfidenceMetrics& m) {
    file << name << ',' << m.frames << ',' << m.correct << ',' << m.auc << ',' << m.tracking << ','
         << m.WrongTrackingPercent() << ',' << m.CorrectTrackingPercent() << ',' << m.unknown_frames
         << ',' << m.UnknownReportedPercent();
    for (int count : m.states) file << ',' << count;
    file << '\n';
  };
  row("fit", result.fit_set);
  row("held-out", result.eval_set);
  for (int c = 0; c < 3; ++c)
    row(std::string("held-out ") + ConfidenceConditionName(static_cast<ConfidenceCondition>(c)),
        result.eval_by_condition[static_cast<size_t>(c)]);
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

void WriteModel(const std::filesystem::path& path, const ConfidenceModel& model) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(9);
  file << "bias " << model.bias << '\n';
  for (int j = 0; j < ConfidenceFeatures::kSize; ++j)
    file << ConfidenceFeatures::Names()[static_cast<size_t>(j)] << ' '
         << model.weights[static_cast<size_t>(j)] << '\n';
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

void WriteReliability(const std::filesystem::path& path, const ConfidenceExperimentResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file.precision(7);
  file << "lower,upper,frames,mean_confidence,accuracy\n";
  for (const ReliabilityBin& bin : result.reliability)
    file << bin.lower << ',' << bin.upper << ',' << bin.frames << ',' << bin.mean_confidence << ','
         << bin.accuracy << '\n';
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

void RunEvalConfidence(const EvalConfidenceArguments& arguments) {
  ConfidenceExperimentOptions options;
  options.sequences = arguments.sequences;
  options.frames = arguments.frames;
  options.num_threads = arguments.threads;
  options.first_seed = arguments.seed;
  options.fit = !arguments.no_fit;
  options.state.min_confidence = arguments.min_confidence;
  // The tuning models: fitted on, or (--no-fit) those the built-in model was fitted on; never
  // evaluated.
  options.fit_models = arguments.fit;
  options.eval_models = arguments.evaluate;
  int views = arguments.views;
  std::vector<std::string> unknown_names = arguments.unknown;
  std::vector<std::filesystem::path> paths;
  if (!arguments.models.empty()) paths = MeshPathsFromModelsOption(arguments.models);
  if (arguments.quick) {
    if (paths.empty()) paths = SampleModels();
    if (!arguments.views_given) views = 150;
    if (!arguments.sequences_given) options.sequences = 1;
    if (!arguments.frames_given) options.frames = 40;
  }
  if (paths.empty()) paths = DefaultEvalModels();
  if (views < 1) ThrowError("--views must be >= 1");
  std::set<std::string> all_names;
  for (const auto& p : paths) all_names.insert(p.stem().string());
  if (!arguments.unknown_given) {
    // The last model (by name) that is neither a fit nor an evaluation model.
    for (auto it = all_names.rbegin(); it != all_names.rend(); ++it) {
      const bool fit = std::find(options.fit_models.begin(), options.fit_models.end(), *it) !=
                       options.fit_models.end();
      const bool eval = std::find(options.eval_models.begin(), options.eval_models.end(), *it) !=
                        options.eval_models.end();
      if (!fit && !eval) {
        unknown_names = {*it};
        break;
      }
    }
  }
  for (const std::vector<std::string>* list :
       {&options.fit_models, &options.eval_models, &unknown_names}) {
    for (const std::string& name : *list) {
      if (all_names.count(name) == 0) {
        ThrowError("no model '", name, "' among the models (",
                   Joined({all_names.begin(), all_names.end()}), ")");
      }
    }
  }
  for (const std::string& name : unknown_names) {
    if (std::find(options.fit_models.begin(), options.fit_models.end(), name) !=
        options.fit_models.end())
      ThrowError("--unknown: '", name, "' is also a fit model");
  }
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);

  std::vector<std::filesystem::path> database_paths, unknown_paths;
  for (const auto& p : paths) {
    const bool unknown = std::find(unknown_names.begin(), unknown_names.end(), p.stem().string()) !=
                         unknown_names.end();
    (unknown ? unknown_paths : database_paths).push_back(p);
  }
  if (database_paths.empty()) ThrowError("every model is an unknown object: nothing to track");

  const std::filesystem::path folder = CreateOutputFolder(arguments.output);
  const ViewDatabase database =
      EvaluationDatabase(database_paths, {.database_path = arguments.database,
                                          .num_views = views,
                                          .num_threads = arguments.threads,
                                          .show_progress = true});
  std::vector<TriangleMesh> meshes, unknown;
  for (const auto& path : database_paths) meshes.push_back(LoadMesh(path));
  for (const auto& path : unknown_paths) unknown.push_back(LoadMesh(path));

  std::vector<std::string> eval_names = options.eval_models;
  if (eval_names.empty()) {
    for (const auto& p : database_paths) {
      const std::string name = p.stem().string();
      if (std::find(options.fit_models.begin(), options.fit_models.end(), name) ==
          options.fit_models.end())
        eval_names.push_back(name);
    }
  }
  std::printf(
      "eval confidence: database %zu models x %d views; fit on %s; held out: %s; not in the "
      "database: %s\n%d sequence(s) x %d frames per model and condition (clean, degraded, "
      "occluded; unknown objects clean and degraded), hand-held motion, 640x480\n",
      database.models.size(), database.num_views(),
      options.fit ? Joined(options.fit_models).c_str() : "(no fit: the built-in model)",
      Joined(eval_names).c_str(), unknown_names.empty() ? "none" : Joined(unknown_names).c_str(),
      options.sequences, options.frames);

  ProgressBar progress(
      "confidence",
      ConfidenceTaskCount(options, static_cast<int>(options.fit_models.size()),
                          static_cast<int>(eval_names.size()), static_cast<int>(unknown.size())));
  const ConfidenceExperimentResult result = RunConfidenceExperiment(
      database, meshes, unknown, options, [&progress](int done) { progress.Advance(done); });
  progress.Finish();

  WriteSummary(folder / "summary.csv", result);
  WriteConfidenceFrames(folder / "frames.csv", result);
  WriteReliability(folder / "reliability.csv", result);
  WriteModel(folder / "model.txt", result.model);
  const Figure figure = ConfidenceFigure(result);
  figure.WriteSvg(folder / "confidence.svg");
  figure.WritePng(folder / "confidence.png");

  std::printf("\nmodel (%s): bias %.6g", options.fit ? "fitted" : "built-in", result.model.bias);
  for (int j = 0; j < ConfidenceFeatures::kSize; ++j)
    std::printf(", %s %.6g", ConfidenceFeatures::Names()[static_cast<size_t>(j)],
                result.model.weights[static_cast<size_t>(j)]);
  std::printf(
      "\n\nframes with a silhouette; 'correct': right object and rotation <= 10 deg "
      "modulo symmetry; threshold %.2f\n",
      options.state.min_confidence);
  if (options.fit) {
    std::printf(
        "lowest threshold with at most 1 %% of the fit set's frames above it wrong: %.3f (the "
        "fit set's states below were tracked with the built-in model)\n",
        result.fit_threshold);
  }
  std::printf("%-22s %6s %7s %7s %8s %9s %9s %7s %9s\n", "set", "frames", "correct", "AUC%",
              "tracking", "wrong%", "corr.trk%", "unknown", "unk.rep%");
  PrintMetrics("fit (tuning)", result.fit_set);
  PrintMetrics("held-out", result.eval_set);
  for (int c = 0; c < 3; ++c) {
    const std::string label =
        std::string("  ") + ConfidenceConditionName(static_cast<ConfidenceCondition>(c));
    PrintMetrics(label.c_str(), result.eval_by_condition[static_cast<size_t>(c)]);
  }
  std::printf("\nheld-out states:");
  for (int s = 0; s < 6; ++s)
    std::printf(" %s %d", TrackStateName(static_cast<TrackState>(s)),
                result.eval_set.states[static_cast<size_t>(s)]);
  std::printf(
      "\n%.1f s; wrote summary.csv, frames.csv, reliability.csv, model.txt, confidence.svg, "
      "confidence.png in %s/\n",
      result.seconds, folder.string().c_str());
}

}  // namespace

void AddEvalConfidenceCommand(CLI::App* eval) {
  auto arguments = std::make_shared<EvalConfidenceArguments>();
  CLI::App* command = eval->add_subcommand(
      "confidence",
      "Fits the per-frame confidence on the tuning models' hand-held sequences (clean, degraded, "
      "occluded) and measures on held-out models and an object not in the database how well the "
      "confidence and the states tell right frames from wrong ones (ROC AUC, wrong 'tracking' "
      "frames, unknown objects found). Writes OUT/summary.csv, frames.csv, reliability.csv, "
      "model.txt and confidence.svg/.png (reliability diagram and ROC curve).");
  command->add_option("-o,--output", arguments->output, "Output folder")->capture_default_str();
  command->add_option("--models", arguments->models,
                      "Meshes: folders or files (default: the folder in $SILPOSE_EVAL_MODELS, "
                      "else the sample models)");
  command->add_option("--fit", arguments->fit, "Models the confidence is fitted on, by name")
      ->delimiter(',')
      ->capture_default_str();
  command
      ->add_option("--evaluate", arguments->evaluate,
                   "Held-out models, by name (default: every database model not fitted on)")
      ->delimiter(',');
  command
      ->add_option("--unknown", arguments->unknown,
                   "Models left out of the database and shown as unknown objects, by name "
                   "(default: the last model by name that is neither fitted on nor evaluated)")
      ->delimiter(',');
  command->add_option("-d,--database", arguments->database,
                      "Database built from exactly the models that are not --unknown, in order "
                      "(default: build one)");
  command->add_option("--sequences", arguments->sequences, "Sequences per model and condition")
      ->capture_default_str();
  command->add_option("--frames", arguments->frames, "Frames per sequence")->capture_default_str();
  command->add_option("--threads", arguments->threads, "Sequences in parallel (0 = all cores)")
      ->capture_default_str();
  command->add_option("--views", arguments->views, "Views per model when building")
      ->capture_default_str();
  command->add_option("--seed", arguments->seed, "First seed of the sequences")
      ->capture_default_str()
      ->check(SeedNumber());
  command
      ->add_option("--min-confidence", arguments->min_confidence,
                   "Confidence from which a frame is 'tracking'")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  command->add_flag("--no-fit", arguments->no_fit,
                    "Evaluate the built-in confidence model instead of fitting one");
  command->add_flag("--quick", arguments->quick,
                    "Small variant for tests: sample models, 150 views, one 40-frame sequence "
                    "per model and condition");
  command->callback([command, arguments] {
    EvalConfidenceArguments given = *arguments;
    given.sequences_given = command->count("--sequences") > 0;
    given.frames_given = command->count("--frames") > 0;
    given.views_given = command->count("--views") > 0;
    given.unknown_given = command->count("--unknown") > 0;
    given.evaluate_given = command->count("--evaluate") > 0;
    RunEvalConfidence(given);
  });
}

}  // namespace silpose::cli
