// `silpose eval scale`: cost curves. How the database (file size, build time) and the time per
// frame of brute force, the filter and the adaptive filter grow with the number of objects and of
// views per object (eval/scale_experiment.h).

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/eval/scale_experiment.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct EvalScaleArguments {
  std::string output = "eval-scale";
  std::vector<std::string> models;
  std::vector<int> object_counts = {10, 20, 50, 100, 200};
  std::vector<int> view_counts = {500, 1000, 2000, 5000};
  int at_views = 1000;
  int at_objects = 20;
  std::vector<double> distances = {3.0};
  int flown = 3;
  int frames = 60;
  double step_deg = 2.0;
  int skip = 10;
  int particles = 60;
  int threads = 0;
  std::string work_dir;
  bool quick = false;
  bool objects_given = false, views_given = false, at_views_given = false, at_objects_given = false,
       frames_given = false, skip_given = false;
};

std::string JoinedInts(const std::vector<int>& values) {
  std::string text;
  for (int n : values) text += (text.empty() ? "" : ",") + std::to_string(n);
  return text;
}

void PrintPoint(const ScalePoint& p) {
  std::printf("%7d %6d %9.1f %8.1f | %9.3f %9.3f %9.3f %9.0f | %7.1f %7.1f %7.1f\n", p.objects,
              p.views_per_object, p.file_bytes / 1e6, p.build_seconds,
              p.brute_force.ms_per_frame_median, p.filter.ms_per_frame_median,
              p.adaptive.ms_per_frame_median, p.adaptive.particles_mean,
              p.brute_force.RightObjectPercent(), p.filter.RightObjectPercent(),
              p.adaptive.RightObjectPercent());
  std::fflush(stdout);
}

void WriteReadme(const std::filesystem::path& path, const ScaleExperimentResult& result,
                 const std::vector<std::filesystem::path>& meshes) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  const ScaleExperimentOptions& o = result.options;
  file << "silpose eval scale\n\ncommand: " << CommandLine() << "\n";
  file << "working directory: " << std::filesystem::current_path().string() << "\n\n";
  file << "meshes (" << meshes.size() << "), stretched ten ways each for more objects:";
  for (const auto& p : meshes) file << ' ' << p.string();
  file << "\nshells (radii):";
  for (double d : o.parameters.distances_in_radii) file << ' ' << d;
  file << "\nbuild threads: " << result.build_threads << "; tracking: one thread\n";
  file << "flights per point: " << o.num_flown << " orbits x " << o.frames << " frames, "
       << o.step_deg << " deg/frame, tilt 30 deg, at " << o.parameters.distances_in_radii.front()
       << " radii; frames " << o.skip_frames << " and later counted\n";
  file << "filter: " << o.particles_per_object
       << " particles per object; adaptive filter: KLD-sampling from that count\n";
  file << "\nfiles: costs.csv (one row per point), costs.svg / costs.png\n";
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

void RunEvalScale(const EvalScaleArguments& arguments) {
  ScaleExperimentOptions options;
  options.object_counts = arguments.object_counts;
  options.view_counts = arguments.view_counts;
  options.views_per_object = arguments.at_views;
  options.objects = arguments.at_objects;
  options.parameters.distances_in_radii = arguments.distances;
  options.num_flown = arguments.flown;
  options.frames = arguments.frames;
  options.step_deg = arguments.step_deg;
  options.skip_frames = arguments.skip;
  options.particles_per_object = arguments.particles;
  options.build_threads = arguments.threads;
  options.show_progress = true;
  std::vector<std::filesystem::path> paths;
  if (!arguments.models.empty()) paths = MeshPathsFromModelsOption(arguments.models);
  if (arguments.quick) {
    // The test variant: the sample models, small coarse databases, short flights.
    if (paths.empty()) paths = SampleModels();
    if (!arguments.objects_given) options.object_counts = {2, 6};
    if (!arguments.views_given) options.view_counts = {60, 120};
    if (!arguments.at_views_given) options.views_per_object = 60;
    if (!arguments.at_objects_given) options.objects = 2;
    if (!arguments.frames_given) options.frames = 16;
    if (!arguments.skip_given) options.skip_frames = 4;
    options.parameters.render.resolution_px = 256;
  }
  if (paths.empty()) paths = DefaultEvalModels();
  if (arguments.threads < 0) ThrowError("--threads must be >= 0");
  std::string problem;
  if (!options.Check(static_cast<int>(paths.size()), &problem)) ThrowError(problem);

  const std::filesystem::path folder = CreateOutputFolder(arguments.output);
  options.work_dir =
      arguments.work_dir.empty() ? folder : std::filesystem::path(arguments.work_dir);

  std::vector<TriangleMesh> meshes;
  for (const auto& path : paths) meshes.push_back(LoadMesh(path));
  std::printf(
      "eval scale: %zu meshes (up to ten stretched objects each); objects %s at %d views, views "
      "%s at %d objects; %d shell(s); %d orbits x %d frames per point, one thread\n",
      meshes.size(), JoinedInts(options.object_counts).c_str(), options.views_per_object,
      JoinedInts(options.view_counts).c_str(), options.objects, options.parameters.num_shells(),
      options.num_flown, options.frames);
  std::printf("%7s %6s %9s %8s | %9s %9s %9s %9s | %7s %7s %7s\n", "objects", "views", "file MB",
              "build s", "brute ms", "filter ms", "adapt ms", "adapt n", "brute%", "filter%",
              "adapt%");
  std::fflush(stdout);
  const ScaleExperimentResult result = RunScaleExperiment(
      meshes, options, [](int, int) {}, [](const ScalePoint& point) { PrintPoint(point); });

  WriteScaleTable(folder / "costs.csv", result);
  const Figure figure = ScaleFigure(result);
  figure.WriteSvg(folder / "costs.svg");
  figure.WritePng(folder / "costs.png");
  WriteReadme(folder / "README.txt", result, paths);
  std::printf(
      "\nms: median time per frame (signature extraction and match), frames %d and later; %%: "
      "frames with the right object; build: %d threads\n",
      options.skip_frames, result.build_threads);
  std::printf("%.1f s; wrote costs.csv, costs.svg, costs.png, README.txt in %s/\n", result.seconds,
              folder.string().c_str());
}

}  // namespace

void AddEvalScaleCommand(CLI::App* eval) {
  auto arguments = std::make_shared<EvalScaleArguments>();
  CLI::App* command = eval->add_subcommand(
      "scale",
      "Cost curves: builds databases of more and more objects (the meshes stretched ten ways "
      "each) and of more and more views per object, and measures each one's file size, build time "
      "and the time per frame and identification rate of brute force, the filter and the adaptive "
      "filter on orbits of a few of its objects. Writes OUT/costs.csv, costs.svg/.png and "
      "README.txt.");
  command->add_option("-o,--output", arguments->output, "Output folder")->capture_default_str();
  command->add_option("--models", arguments->models,
                      "Meshes: folders or files (default: the folder in $SILPOSE_EVAL_MODELS, "
                      "else the sample models); up to ten objects per mesh");
  command->add_option("--objects", arguments->object_counts, "Object counts of the object sweep")
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--views", arguments->view_counts, "Views per object of the view sweep")
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--at-views", arguments->at_views, "Views per object of the object sweep")
      ->capture_default_str();
  command->add_option("--at-objects", arguments->at_objects, "Objects of the view sweep")
      ->capture_default_str();
  command
      ->add_option("--distances", arguments->distances,
                   "Distance shells of the databases, object radii (the orbits fly at the first)")
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--flown", arguments->flown, "Objects flown around per point")
      ->capture_default_str();
  command->add_option("--frames", arguments->frames, "Frames per orbit")->capture_default_str();
  command->add_option("--step-deg", arguments->step_deg, "Degrees per frame of the orbits")
      ->capture_default_str();
  command->add_option("--skip", arguments->skip, "Frames left out at the start of each orbit")
      ->capture_default_str();
  command->add_option("--particles", arguments->particles, "Particles per object of the filter")
      ->capture_default_str();
  command->add_option("--threads", arguments->threads, "Threads building a database (0 = all)")
      ->capture_default_str();
  command->add_option("--work-dir", arguments->work_dir,
                      "Where the stretched meshes and databases are written while measuring "
                      "(default: the output folder; removed at the end)");
  command->add_flag("--quick", arguments->quick,
                    "Small variant for tests: sample models, 2 and 6 objects, 60 and 120 views, "
                    "256 px renderings, 16-frame orbits");
  command->callback([command, arguments] {
    EvalScaleArguments given = *arguments;
    given.objects_given = command->count("--objects") > 0;
    given.views_given = command->count("--views") > 0;
    given.at_views_given = command->count("--at-views") > 0;
    given.at_objects_given = command->count("--at-objects") > 0;
    given.frames_given = command->count("--frames") > 0;
    given.skip_given = command->count("--skip") > 0;
    RunEvalScale(given);
  });
}

}  // namespace silpose::cli
