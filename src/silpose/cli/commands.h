#pragma once
// The subcommands of the silpose binary. Each Add*Command registers its options on `app` and a
// callback that calls the library; errors surface as silpose::Error and main() prints them.

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "silpose/track/tracker.h"

namespace silpose::cli {

void AddBuildDbCommand(CLI::App& app);
void AddMergeDbCommand(CLI::App& app);
void AddMatchCommand(CLI::App& app);
void AddRenderCommand(CLI::App& app);
void AddSynthCommand(CLI::App& app);
void AddTrackCommand(CLI::App& app);
void AddDemoCommand(CLI::App& app);
void AddEvalCommand(CLI::App& app);
void AddCalibrateCommand(CLI::App& app);
/// `silpose eval video` (eval_video_command.cc), added under `eval`.
void AddEvalVideoCommand(CLI::App* eval);
/// `silpose eval bop` (eval_bop_command.cc), added under `eval`.
void AddEvalBopCommand(CLI::App* eval);
/// `silpose eval handheld` (eval_handheld_command.cc), added under `eval`.
void AddEvalHandheldCommand(CLI::App* eval);
/// `silpose eval confidence` (eval_confidence_command.cc), added under `eval`.
void AddEvalConfidenceCommand(CLI::App* eval);
/// `silpose eval scale` (eval_scale_command.cc), added under `eval`.
void AddEvalScaleCommand(CLI::App* eval);

/// The models an evaluation uses by default: the meshes in the folder named by the environment
/// variable SILPOSE_EVAL_MODELS (a reference set), else the sample models. Throws silpose::Error
/// if the variable names no folder, or one without meshes.
std::vector<std::filesystem::path> DefaultEvalModels();

/// What `silpose track` does, as options (also run by `silpose demo`): read INPUT, track it with
/// `tracker` against the database file, write POSES.csv and the optional outputs.
struct TrackJob {
  std::string database;
  std::string input;
  std::string output;
  std::string camera;
  std::string json;
  std::string bop;
  std::string overlay;
  std::string plots;
  std::string ground_truth;
  std::vector<std::string> models;
  std::string masks_out;
  int max_frames = 0;
  /// Frames read (decoded and segmented) ahead on a thread of their own; 0: on the tracking thread.
  int read_ahead = 2;
  // Segmentation.
  std::string segment = "mask";
  std::string background_method = "mog2";
  std::string background_learning = "until-object";
  std::string threshold_method = "otsu";
  std::string object_polarity = "darker";
  std::string component = "largest";
  std::string hsv_range;
  // BOP.
  int bop_scene = 1;
  std::vector<int> bop_object_ids;
  double model_unit_mm = 1.0;
  TrackerOptions tracker;
  // Smoothing from the particle histories (track/smoother.h): each frame reported `lag` frames
  // late, or (smooth) every frame at the end.
  int lag = 0;
  bool smooth = false;
};

/// Runs a track job (see track_command.cc). Throws silpose::Error; on a fault while reading the
/// input, what was tracked before it is written out first.
void RunTrackJob(const TrackJob& job);

/// The project's sample models: `override_dir` if given, else the source tree's data/models, else
/// the installed share/silpose/models. Throws silpose::Error if none is found.
std::vector<std::filesystem::path> SampleModels(const std::string& override_dir = "");
/// The regular files in a folder whose extension (any case) is one of `extensions` (".png", ...),
/// sorted by name. Throws silpose::Error naming the folder if it cannot be listed.
std::vector<std::filesystem::path> FilesWithExtensions(const std::filesystem::path& directory,
                                                       const std::vector<std::string>& extensions);
/// All mesh files (by extension) in a folder, sorted by name.
std::vector<std::filesystem::path> MeshFilesIn(const std::filesystem::path& directory);
/// The meshes an eval command's --models names: every mesh in each folder, and each file. Throws
/// silpose::Error naming an item that is neither, or if no mesh is found.
std::vector<std::filesystem::path> MeshPathsFromModelsOption(const std::vector<std::string>& items);
/// The items joined by `separator`, for tables and messages.
std::string Joined(const std::vector<std::string>& items, const char* separator = ", ");
/// `value` printed with the printf `format`, or "-" if it is not finite (a table cell).
std::string Number(double value, const char* format = "%.2f");
/// Parses "X,Y,Z" into three finite numbers; throws silpose::Error naming `what` otherwise.
std::vector<double> ParseTriple(const std::string& text, const std::string& what);
/// Human-readable size ("12.3 MB").
std::string FormatBytes(uintmax_t bytes);
/// Creates an eval command's output folder (and its parents) if needed and returns it. Throws
/// silpose::Error naming the folder if it cannot be made or is not a folder.
std::filesystem::path CreateOutputFolder(const std::string& folder);
/// This process's command line, its arguments separated by spaces (for an experiment's README).
std::string CommandLine();

}  // namespace silpose::cli
