// `silpose eval bop DIR`: silpose on a dataset in the BOP format (eval/bop_experiment.h).

#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>
#include <sstream>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/bop_dataset.h"
#include "silpose/eval/bop_experiment.h"
#include "silpose/eval/evaluation_database.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct EvalBopArguments {
  std::string dataset;
  std::string split;
  std::string models_folder = "models";
  std::string eval_models_folder;
  std::string database;
  std::string output = "eval-bop";
  std::vector<int> scenes;
  std::vector<int> objects;
  std::string masks = "visib";
  std::string segment;
  std::string hsv_range;
  std::string object_polarity = "darker";
  std::string bg_method = "mog2";
  std::string background;
  int views = 0;        // 0: 1000, or 300 with --quick
  int max_frames = -1;  // -1: all, or 30 with --quick
  int max_instances = -1;
  int threads = 0;
  bool quick = false;
  BopExperimentOptions options;
};

std::vector<double> ParseNumbers(const std::string& text, const std::string& what, size_t count) {
  std::vector<double> values;
  std::stringstream stream(text);
  for (std::string item; std::getline(stream, item, ',');) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      ThrowError(what, " must be ", count, " numbers separated by commas, got '", text, "'");
    }
  }
  if (values.size() != count)
    ThrowError(what, " must be ", count, " numbers separated by commas, got '", text, "'");
  return values;
}

std::string Percent(double fraction) {
  char text[16];
  std::snprintf(text, sizeof(text), "%.1f", 100.0 * fraction);
  return text;
}

void RunEvalBop(EvalBopArguments arguments) {
  BopExperimentOptions options = arguments.options;
  options.scene_ids = arguments.scenes;
  options.object_ids = arguments.objects;
  if (arguments.masks == "visib") {
    options.masks = BopMaskSource::kVisible;
  } else if (arguments.masks == "full") {
    options.masks = BopMaskSource::kFull;
  } else {
    ThrowError("--masks must be visib or full, got '", arguments.masks, "'");
  }
  if (!arguments.segment.empty()) {
    options.masks = BopMaskSource::kImage;
    options.segmentation.kind = ParseSegmenterKind(arguments.segment);
    if (options.segmentation.kind == SegmenterKind::kMask)
      ThrowError("--segment must be threshold or bgsub (without it the dataset's masks are used)");
    options.segmentation.background_method = ParseBackgroundMethod(arguments.bg_method);
    options.segmentation.background_image_path = arguments.background;
    options.segmentation.otsu_object = ParseObjectPolarity(arguments.object_polarity);
    if (!arguments.hsv_range.empty()) {
      const std::vector<double> v = ParseNumbers(arguments.hsv_range, "--hsv-range", 6);
      options.segmentation.threshold_method = ThresholdMethod::kHsvRange;
      options.segmentation.hsv_lower = cv::Scalar(v[0], v[1], v[2]);
      options.segmentation.hsv_upper = cv::Scalar(v[3], v[4], v[5]);
    }
  } else if (!arguments.hsv_range.empty() || !arguments.background.empty() ||
             arguments.object_polarity != EvalBopArguments{}.object_polarity ||
             arguments.bg_method != EvalBopArguments{}.bg_method) {
    ThrowError(
        "--hsv-range, --object-polarity, --bg-method and --background segment the images: they "
        "need --segment");
  }
  if (arguments.views < 0) ThrowError("--views must be > 0");
  if (arguments.views == 0) arguments.views = arguments.quick ? 300 : 1000;
  options.max_frames =
      arguments.max_frames >= 0 ? arguments.max_frames : (arguments.quick ? 30 : 0);
  options.max_instances =
      arguments.max_instances >= 0 ? arguments.max_instances : (arguments.quick ? 4 : 0);
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);

  const BopDataset dataset =
      OpenBopDataset(arguments.dataset, {.split = arguments.split,
                                         .models_folder = arguments.models_folder,
                                         .eval_models_folder = arguments.eval_models_folder});
  const std::filesystem::path output = CreateOutputFolder(arguments.output);

  std::vector<std::filesystem::path> meshes;
  for (const BopModel& model : dataset.models) meshes.push_back(model.mesh_path);
  const int frames = BopFrameCount(dataset, options);
  const ViewDatabase database = EvaluationDatabase(meshes, {.database_path = arguments.database,
                                                            .num_views = arguments.views,
                                                            .num_threads = arguments.threads,
                                                            .show_progress = true});
  const char* source = options.masks == BopMaskSource::kVisible ? "mask_visib/"
                       : options.masks == BopMaskSource::kFull  ? "mask/"
                                                                : "segmented images";
  std::printf(
      "eval bop: %s, split %s, %zu scenes, %zu models in the database (%d views, %.1f deg "
      "apart); silhouettes from %s; %s; %d frames\n",
      dataset.root.string().c_str(), dataset.split.c_str(), dataset.scene_folders.size(),
      database.models.size(), database.num_views(),
      database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi, source,
      options.brute_force ? "brute-force matching of every frame" : "particle filter", frames);

  ProgressBar progress("eval bop", frames);
  const BopExperimentResult result =
      RunBopExperiment(dataset, database, options, [&progress] { progress.Advance(); });
  progress.Finish();

  WriteBopFrames(output / "bop_frames.csv", result);
  WriteBopSummary(output / "bop_summary.csv", result);
  WriteBopResults(output / "bop_results.csv", result);

  std::printf("\n%-12s %9s %7s %8s %10s %12s %10s %9s %8s %8s %9s\n", "object", "instances",
              "frames", "object%", "rot. err", "transl. err", "transl.", "ADD(-S)", "AR_MSSD",
              "AR_MSPD", "ms/frame");
  std::printf("%-12s %9s %7s %8s %10s %12s %10s %9s %8s %8s %9s\n", "", "", "", "", "median deg",
              "median mm", "median %", "recall %", "%", "%", "");
  auto print = [](const BopSummary& s) {
    const bool errors = s.rotation_deg.count > 0;
    char rotation[32] = "-", translation[32] = "-", relative[32] = "-";
    if (errors) {
      std::snprintf(rotation, sizeof(rotation), "%.2f", s.rotation_deg.median);
      std::snprintf(translation, sizeof(translation), "%.1f", s.translation_mm.median);
      std::snprintf(relative, sizeof(relative), "%.2f", s.translation_percent.median);
    }
    std::printf("%-12s %9d %7d %8.1f %10s %12s %10s %9s %8s %8s %9.2f\n", s.name.c_str(),
                s.instances, s.frames, s.RightObjectPercent(), rotation, translation, relative,
                Percent(s.recall_add).c_str(), Percent(s.ar_mssd).c_str(),
                Percent(s.ar_mspd).c_str(), s.ms_per_frame);
  };
  for (const BopSummary& s : result.objects) print(s);
  print(result.total);
  std::printf(
      "\nerrors of frames with the right object and a pose; ADD(-S) recall: error < 0.1 diameter "
      "(ADD-S for objects with symmetries); AR_MSSD / AR_MSPD: BOP's average recalls (MSSD < "
      "0.05..0.5 diameter, MSPD < 5..50 px x 640/width); a frame without a pose or with the wrong "
      "object is a miss. VSD (needs depth) is not computed.\n");
  for (const std::string& warning : result.warnings) std::printf("warning: %s\n", warning.c_str());
  std::printf(
      "%.1f s; wrote %s, %s, %s\n", result.seconds, (output / "bop_summary.csv").string().c_str(),
      (output / "bop_frames.csv").string().c_str(), (output / "bop_results.csv").string().c_str());
}

}  // namespace

void AddEvalBopCommand(CLI::App* eval) {
  auto arguments = std::make_shared<EvalBopArguments>();
  CLI::App* command = eval->add_subcommand(
      "bop",
      "Evaluate on a dataset in the BOP format (LM, LM-O, T-LESS, ...): every object instance of "
      "every scene is tracked through the scene's images from its masks (or segmented images) "
      "against a database of the dataset's models, and compared with scene_gt.json: right "
      "object, rotation and translation errors, ADD(-S), MSSD and MSPD recalls. Writes "
      "OUTDIR/bop_summary.csv, bop_frames.csv and bop_results.csv (BOP19 format).");
  command
      ->add_option("dataset", arguments->dataset,
                   "The dataset folder (models/, models_info.json, <split>/<scene>/)")
      ->required();
  command->add_option("--split", arguments->split,
                      "Split folder (default: test, else the first one with scenes)");
  command->add_option("--scenes", arguments->scenes, "Scene ids to evaluate (default: all)")
      ->delimiter(',');
  command->add_option("--objects", arguments->objects, "obj_ids to evaluate (default: all)")
      ->delimiter(',');
  command
      ->add_option("--masks", arguments->masks,
                   "Silhouettes from mask_visib/ (visib: the visible part) or mask/ (full)")
      ->capture_default_str();
  command->add_option("--segment", arguments->segment,
                      "Segment the rgb/ (or gray/) images instead: threshold or bgsub");
  command->add_option("--hsv-range", arguments->hsv_range,
                      "threshold: H,S,V,H,S,V bounds (OpenCV ranges) instead of Otsu");
  command
      ->add_option("--object-polarity", arguments->object_polarity,
                   "threshold with Otsu: object darker or brighter")
      ->capture_default_str();
  command->add_option("--bg-method", arguments->bg_method, "bgsub: mog2, knn or gauss")
      ->capture_default_str();
  command->add_option("--background", arguments->background,
                      "bgsub: image of the empty scene (default: learn from the first frames)");
  command->add_flag("--brute-force", arguments->options.brute_force,
                    "Match every frame on its own instead of the particle filter");
  command->add_option("--particles", arguments->options.particles_per_object,
                      "Particles per object (default: the tracker's)");
  command->add_option("--seed", arguments->options.seed, "Filter seed")
      ->capture_default_str()
      ->check(SeedNumber());
  command->add_option("--max-frames", arguments->max_frames,
                      "At most this many frames per instance (default all; 30 with --quick)");
  command->add_option("--max-instances", arguments->max_instances,
                      "At most this many instances in all (default all; 4 with --quick)");
  command
      ->add_option("--min-visib", arguments->options.min_visible_fraction,
                   "Count only frames whose visible fraction (scene_gt_info.json) is at least "
                   "this (BOP: 0.1)")
      ->capture_default_str();
  command->add_option("-d,--database", arguments->database,
                      "Database built from the dataset's models (in obj_id order) instead of "
                      "building one");
  command->add_option("--views", arguments->views,
                      "Views per model when building (default 1000; 300 with --quick)");
  command->add_option("--threads", arguments->threads, "Threads for building (0 = all)")
      ->capture_default_str();
  command
      ->add_option("--models", arguments->models_folder,
                   "Models folder of the dataset (meshes and models_info.json)")
      ->capture_default_str();
  command->add_option("--eval-models", arguments->eval_models_folder,
                      "Models folder whose vertices the errors use (default: models_eval if "
                      "present, else --models)");
  command->add_option("-o,--output", arguments->output, "Output folder")->capture_default_str();
  command->add_flag("--quick", arguments->quick,
                    "Small variant for tests: 300 views, at most 4 instances of 30 frames");
  command->callback([arguments] { RunEvalBop(*arguments); });
}

}  // namespace silpose::cli
