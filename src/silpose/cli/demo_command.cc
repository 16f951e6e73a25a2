#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numbers>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/database/database_builder.h"
#include "silpose/io/video_writer.h"
#include "silpose/match/view_matcher.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct DemoArguments {
  std::string models_dir;
  std::string output_dir = "silpose-demo";
  int frames_per_object = 100;
  int views = 1000;
  uint64_t seed = 1;
  int threads = 0;
};

// The objects the demo video shows, in turn (sample models; any others are in the database only).
const char* const kShown[] = {"hand", "bunny", "cow"};

void RunDemo(const DemoArguments& arguments) {
  if (arguments.frames_per_object < 20) ThrowError("--frames-per-object must be >= 20");
  const std::vector<std::filesystem::path> models = SampleModels(arguments.models_dir);
  const std::filesystem::path output = arguments.output_dir;
  std::error_code error;
  std::filesystem::create_directories(output, error);
  if (error) ThrowError(output.string(), ": cannot create folder: ", error.message());
  std::printf("silpose demo: %zu models from %s; everything goes to %s/\n\n", models.size(),
              models.front().parent_path().c_str(), output.c_str());

  // 1. The view database (paper 4.1), as 'silpose build-db' makes it.
  DatabaseBuildOptions build;
  build.parameters.view_sphere.num_views = arguments.views;
  build.num_threads = arguments.threads;
  build.show_progress = true;
  const auto build_start = std::chrono::steady_clock::now();
  ViewDatabase database = BuildViewDatabase(models, build);
  StoreViewSpectra(&database, CorrelationOptions{}, arguments.threads);
  database.DropSignatures();
  const std::filesystem::path database_path = output / "demo.db";
  database.Write(database_path);
  std::printf("1. database: %zu models x %d views (%.1f deg apart) in %.1f s -> %s\n",
              database.models.size(), database.num_views(),
              database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - build_start).count(),
              database_path.c_str());

  // 2. A colour video of a static camera: the objects in turn, moving freely in front of a
  //    textured background, with camera noise ('silpose synth --colour --video').
  std::vector<TriangleMesh> meshes;
  for (const char* name : kShown) {
    for (const auto& path : models) {
      if (path.stem() == name) meshes.push_back(LoadMesh(path));
    }
  }
  if (meshes.empty()) meshes.push_back(LoadMesh(models.front()));
  SequenceOptions sequence_options;
  sequence_options.trajectory.kind = TrajectoryKind::kWalk;
  sequence_options.trajectory.walk.seed = arguments.seed;
  sequence_options.trajectory.num_frames =
      arguments.frames_per_object * static_cast<int>(meshes.size());
  for (size_t m = 0; m < meshes.size(); ++m) {
    sequence_options.trajectory.object_switches.push_back(
        {static_cast<int>(m) * arguments.frames_per_object, static_cast<int>(m)});
  }
  sequence_options.colour.enabled = true;
  sequence_options.colour.noise_sigma = 3.0;
  sequence_options.colour.seed = arguments.seed;
  const SyntheticSequence sequence(meshes, sequence_options);
  const std::filesystem::path sequence_dir = output / "sequence";
  const std::filesystem::path video_path = sequence_dir / "video.avi";
  std::filesystem::create_directories(sequence_dir, error);
  std::unique_ptr<VideoWriter> video = OpenVideoWriter(
      video_path, cv::Size(sequence.camera().width_px, sequence.camera().height_px), 30.0);
  SequenceWriteOptions write;
  write.overwrite = true;
  write.num_threads = arguments.threads;
  write.show_progress = true;
  write.colour_frame_sink = [&video](int, const cv::Mat& frame) { video->Write(frame); };
  WriteSequence(sequence, sequence_dir, write);
  video->Close();
  std::string shown;
  for (const TriangleMesh& mesh : meshes) shown += (shown.empty() ? "" : ", then ") + mesh.name;
  std::printf("2. video: %d frames of 640x480 (%s, %d frames each) -> %s\n", sequence.num_frames(),
              shown.c_str(), arguments.frames_per_object, video_path.c_str());

  // 3. Tracking ('silpose track'): background subtraction, particle filter, 6-DOF pose, overlay.
  std::printf("3. tracking with background subtraction and the particle filter:\n");
  TrackJob job;
  job.database = database_path.string();
  job.input = video_path.string();
  job.camera = (sequence_dir / "camera.yml").string();
  job.ground_truth = (sequence_dir / "groundtruth.csv").string();
  job.segment = "bgsub";
  job.tracker.segmentation.background_image_path = (sequence_dir / "background.png").string();
  job.tracker.filter.seed = arguments.seed;
  job.output = (output / "POSES.csv").string();
  job.json = (output / "poses.jsonl").string();
  job.bop = (output / "bop_results.csv").string();
  job.overlay = (output / "overlay.avi").string();
  job.plots = (output / "plots").string();
  RunTrackJob(job);
  std::printf(
      "\nLook at %s (red: segmentation, green: the model at the estimated pose) and at %s/plots "
      "(trajectory on the view sphere, pose error over the frames).\n",
      job.overlay.c_str(), output.c_str());
}

}  // namespace

void AddDemoCommand(CLI::App& app) {
  auto arguments = std::make_shared<DemoArguments>();
  CLI::App* command = app.add_subcommand(
      "demo",
      "The whole pipeline on the built-in sample models, no arguments needed: build the view "
      "database, render a colour video of the objects in turn (static camera, textured "
      "background, noise), track it with background subtraction and the particle filter, and "
      "write the poses, an overlay video and plots.");
  command->add_option("--models", arguments->models_dir,
                      "Folder of meshes to use instead of the sample models");
  command->add_option("-o,--output", arguments->output_dir, "Folder for everything written")
      ->capture_default_str();
  command
      ->add_option("--frames-per-object", arguments->frames_per_object,
                   "Frames each object is in view")
      ->capture_default_str();
  command->add_option("--views", arguments->views, "Viewpoints per model")->capture_default_str();
  command->add_option("--seed", arguments->seed, "Seed of the motion, noise and particle filter")
      ->capture_default_str()
      ->check(SeedNumber());
  command->add_option("--threads", arguments->threads, "Worker threads for building (0 = all)")
      ->capture_default_str();
  command->callback([arguments] { RunDemo(*arguments); });
}

}  // namespace silpose::cli
