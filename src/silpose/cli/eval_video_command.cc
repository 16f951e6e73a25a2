// `silpose eval video`: 6-DOF tracking accuracy on colour videos with background subtraction
// (eval/video_experiment.h).

#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/evaluation_database.h"
#include "silpose/eval/video_experiment.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct EvalVideoArguments {
  std::vector<std::string> models;
  std::string database;
  std::vector<std::string> filmed;
  std::string output = "eval-video";
  std::string bg_method = "mog2";
  int views = 0;   // 0: 1000, or 300 with --quick
  int frames = 0;  // 0: 300, or 40 with --quick
  int threads = 0;
  bool quick = false;
  VideoExperimentOptions options;
};

void RunEvalVideo(EvalVideoArguments arguments) {
  std::vector<std::filesystem::path> paths(arguments.models.begin(), arguments.models.end());
  VideoExperimentOptions options = arguments.options;
  options.models = arguments.filmed;
  options.segmentation.background_method = ParseBackgroundMethod(arguments.bg_method);
  if (arguments.quick) {
    // The test variant: the sample models, 2 of them filmed for 40 frames, a coarse database.
    if (paths.empty()) paths = SampleModels();
    if (options.models.empty()) options.models = {"bunny", "hand"};
  }
  if (arguments.views == 0) arguments.views = arguments.quick ? 300 : 1000;
  options.frames = arguments.frames != 0 ? arguments.frames : (arguments.quick ? 40 : 300);
  if (arguments.frames < 0 || arguments.views < 0) ThrowError("--frames and --views must be > 0");
  if (paths.empty()) paths = DefaultEvalModels();
  options.output_dir = arguments.output;
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);

  EvaluationDatabaseOptions database_options;
  database_options.database_path = arguments.database;
  database_options.num_views = arguments.views;
  database_options.num_threads = arguments.threads;
  database_options.show_progress = true;
  const ViewDatabase database = EvaluationDatabase(paths, database_options);
  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));
  std::printf(
      "eval video: %zu models in the database (%d views, %.1f deg apart), %d frames per "
      "video, background subtraction (%s), camera noise %.1f\n",
      database.models.size(), database.num_views(),
      database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi, options.frames,
      arguments.bg_method.c_str(), options.camera_noise);

  const VideoExperimentResult result = RunVideoExperiment(database, meshes, options);
  const std::filesystem::path table = std::filesystem::path(arguments.output) / "video.csv";
  WriteVideoExperimentTable(table, result);

  std::printf("\n%-12s %7s %13s %14s %14s %12s %10s\n", "model", "frames", "right object",
              "rotation err", "translation", "view error", "ms/frame");
  std::printf("%-12s %7s %13s %14s %14s %12s %10s\n", "", "", "(after 10)", "median deg",
              "median %", "mean", "read+track");
  auto print = [](const VideoExperimentModel& row) {
    std::printf("%-12s %7d %12.1f%% %14.2f %14.2f %12.3f %5.2f+%.2f\n", row.name.c_str(),
                row.frames, row.RightObjectPercent(), row.rotation_deg.median,
                100.0 * row.translation_relative.median, row.view_error.mean, row.read_ms,
                row.track_ms);
  };
  for (const VideoExperimentModel& row : result.models) print(row);
  print(result.total);
  std::printf(
      "\ntargets: right object >= 98 %% after the first 10 frames; median rotation error <= view "
      "spacing + 2 = %.1f deg; median translation error <= 5 %% of the distance\n",
      result.view_spacing_deg + 2.0);
  std::printf("wrote %s and, per model, the video, POSES.csv and plots in %s/\n", table.c_str(),
              arguments.output.c_str());
}

}  // namespace

void AddEvalVideoCommand(CLI::App* eval) {
  auto arguments = std::make_shared<EvalVideoArguments>();
  CLI::App* command = eval->add_subcommand(
      "video",
      "6-DOF tracking on colour videos: each filmed model moves in front of a static camera "
      "(640x480, textured background, camera noise); the MJPEG video is segmented by background "
      "subtraction and tracked against the whole database; prints and writes the % of frames "
      "with the right object and the median rotation and translation errors.");
  command->add_option("models", arguments->models,
                      "Meshes of the database (default: the folder in $SILPOSE_EVAL_MODELS, "
                      "else the "
                      "sample models)");
  command->add_option("-d,--database", arguments->database,
                      "Database built from exactly these meshes (default: build one)");
  command
      ->add_option(
          "--filmed", arguments->filmed,
          "Models to film, by name (default: those of bull, bunny, dino, elephant, hand in the "
          "database)")
      ->delimiter(',');
  command->add_option("-o,--output", arguments->output, "Output folder")->capture_default_str();
  command->add_option("--frames", arguments->frames, "Frames per video (default 300; 40 --quick)");
  command
      ->add_option("--particles", arguments->options.particles_per_object, "Particles per object")
      ->capture_default_str();
  command
      ->add_option("--camera-noise", arguments->options.camera_noise, "Camera noise, grey levels")
      ->capture_default_str();
  command->add_option("--bg-method", arguments->bg_method, "mog2, knn or gauss")
      ->capture_default_str();
  command->add_option("--seed", arguments->options.seed, "Seed")
      ->capture_default_str()
      ->check(SeedNumber());
  command->add_option("--views", arguments->views,
                      "Views per model when building (default 1000; 300 --quick)");
  command->add_option("--threads", arguments->threads, "Threads for building (0 = all)")
      ->capture_default_str();
  command->add_flag("--quick", arguments->quick,
                    "Small variant for tests: sample models, bunny and hand, 40 frames");
  command->callback([arguments] { RunEvalVideo(*arguments); });
}

}  // namespace silpose::cli
