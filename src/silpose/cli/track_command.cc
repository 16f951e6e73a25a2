#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>

#include "silpose/cli/commands.h"
#include "silpose/filter/particle_filter.h"
#include "silpose/io/mask_file.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct TrackArguments {
  std::string database;
  std::string input;
  std::string output;
  std::string segment = "mask";
  bool brute_force = false;
  ParticleFilterOptions filter;
};

std::vector<std::filesystem::path> ImagesIn(const std::filesystem::path& directory) {
  return FilesWithExtensions(
      directory, {".png", ".pgm", ".pbm", ".bmp", ".tif", ".tiff", ".jpg", ".jpeg", ".webp"});
}

// The frames of INPUT: a folder of images in name order (a synth folder's masks/ is used when
// INPUT is the synth folder itself).
std::vector<std::filesystem::path> InputFrames(const std::string& input) {
  std::error_code error;
  if (!std::filesystem::exists(input, error)) ThrowError(input, ": no such file or folder");
  if (!std::filesystem::is_directory(input, error)) {
    ThrowError(input, ": video files are not read yet (issue 4); give a folder of mask images");
  }
  std::filesystem::path folder = input;
  if (std::filesystem::is_directory(folder / "masks", error) && ImagesIn(folder).empty()) {
    folder /= "masks";
  }
  std::vector<std::filesystem::path> frames = ImagesIn(folder);
  if (frames.empty())
    ThrowError(input, ": no images (.png .pgm .bmp .tif .jpg .webp) in this folder");
  return frames;
}

void RunTrack(const TrackArguments& arguments) {
  if (arguments.segment != "mask") {
    ThrowError("--segment ", arguments.segment, " is not available yet; only 'mask' (issue 4)");
  }
  const std::vector<std::filesystem::path> frames = InputFrames(arguments.input);
  const ViewDatabase database = ViewDatabase::Read(arguments.database);
  const ViewSpectra spectra(database);
  std::unique_ptr<ParticleFilter> filter;
  std::unique_ptr<ViewMatcher> matcher;
  if (arguments.brute_force) {
    matcher = std::make_unique<ViewMatcher>(spectra);
  } else {
    ParticleFilterOptions options = arguments.filter;
    // POSES.csv needs each frame's estimate only: keep little history so that memory stays
    // bounded on long videos (a full history costs ~1.6 kB per frame with 20 objects).
    options.max_history_frames = 100;
    filter = std::make_unique<ParticleFilter>(database.sphere, spectra, options);
  }
  std::ofstream csv(arguments.output);
  if (!csv) ThrowError(arguments.output, ": cannot open for writing");
  csv << "frame,object,score,probability,view_x,view_y,view_z,roll_deg,status,time_ms,"
         "particles,effective_particles\n";
  csv.precision(9);

  ProgressBar progress("track", static_cast<int64_t>(frames.size()));
  int measured = 0;
  double total_ms = 0.0;
  std::string last_object;
  double last_probability = 0.0;
  for (size_t f = 0; f < frames.size(); ++f) {
    const auto start = std::chrono::steady_clock::now();
    const cv::Mat mask = ReadMask(frames[f]);
    const SignatureResult silhouette = ExtractSignature(mask, database.parameters.signature);
    std::string status =
        silhouette.ok() ? "measured" : std::string("no-silhouette-") + ToString(silhouette.status);
    int object = -1, view = -1, particles = 0;
    double roll = std::nan(""), probability = std::nan(""), effective = std::nan("");
    float score = std::nanf("");
    if (filter) {
      const FilterEstimate estimate =
          silhouette.ok() ? filter->Step(silhouette.signature.radii) : filter->Predict();
      if (!estimate.measured) status = "predicted-" + status;
      object = estimate.object;
      view = estimate.view;
      if (estimate.roll_known) roll = estimate.roll_deg;
      score = estimate.score;
      probability = estimate.object_probability[static_cast<size_t>(object)];
      particles = estimate.num_particles;
      effective = estimate.effective_particles;
    } else if (silhouette.ok()) {
      const std::vector<MatchCandidate> top =
          matcher->Match(silhouette.signature.radii, {.top_k = 1});
      if (!top.empty()) {
        object = top.front().model;
        view = top.front().view;
        roll = top.front().roll_deg;
        score = top.front().score;
      }
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    total_ms += ms;
    measured += silhouette.ok();
    csv << f << ',';
    if (object >= 0) {
      const Eigen::Vector3d& d = database.sphere.directions[static_cast<size_t>(view)];
      last_object = database.models[static_cast<size_t>(object)].name;
      last_probability = probability;
      csv << last_object << ',' << score << ',';
      if (!std::isnan(probability)) csv << probability;
      csv << ',' << d.x() << ',' << d.y() << ',' << d.z() << ',';
      if (!std::isnan(roll)) csv << roll;
    } else {
      csv << ",,,,,,";
    }
    csv << ',' << status << ',' << ms << ',';
    if (particles > 0)
      csv << particles << ',' << effective;
    else
      csv << ',';
    csv << '\n';
    progress.Advance();
  }
  progress.Finish();
  csv.close();
  if (!csv) ThrowError(arguments.output, ": write failed");
  std::printf("tracked %zu frames (%d with a usable silhouette) from %s, %.2f ms per frame%s\n",
              frames.size(), measured, arguments.input.c_str(),
              total_ms / static_cast<double>(frames.size()),
              arguments.brute_force ? " (brute force)" : "");
  if (!last_object.empty()) {
    std::printf("last frame: %s", last_object.c_str());
    if (!arguments.brute_force) std::printf(" (probability %.3f)", last_probability);
    std::printf("; wrote %s\n", arguments.output.c_str());
  }
}

}  // namespace

void AddTrackCommand(CLI::App& app) {
  auto arguments = std::make_shared<TrackArguments>();
  CLI::App* command = app.add_subcommand(
      "track",
      "Identify the object and follow its pose through a sequence of masks with the particle "
      "filter over (object, view, roll) of the paper; writes one POSES.csv row per frame.");
  command->add_option("-d,--database", arguments->database, "Database file from build-db")
      ->required();
  command
      ->add_option("input", arguments->input,
                   "Folder of mask images, taken in name order (or a synth folder)")
      ->required();
  command->add_option("-o,--output", arguments->output, "POSES.csv to write")->required();
  command
      ->add_option("--particles", arguments->filter.particles_per_object,
                   "Particles per object (paper: 60)")
      ->capture_default_str();
  command->add_flag("--adaptive", arguments->filter.adaptive,
                    "Adapt the particle count per object by KLD-sampling (paper 4.3)");
  command->add_flag("--brute-force", arguments->brute_force,
                    "Match every frame against the whole database independently (the paper's "
                    "baseline) instead of filtering");
  command->add_option("--seed", arguments->filter.seed, "Seed of the particle filter")
      ->capture_default_str();
  command
      ->add_option("--segment", arguments->segment,
                   "How frames become silhouettes: mask (frames are masks)")
      ->capture_default_str();
  command->callback([arguments] { RunTrack(*arguments); });
}

}  // namespace silpose::cli
