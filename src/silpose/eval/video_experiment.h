#pragma once
// The real-video check on synthetic ground truth: for each of a few models, a colour
// video of a static 640 x 480 camera (the object moving freely in front of a textured background,
// camera noise) is written as an MJPEG AVI, read back, segmented by background subtraction,
// tracked against the whole database and turned into 6-DOF poses, which are compared with the
// truth: % frames with the right object (after the first `skip_frames`), median rotation error
// (degrees) and median translation error (relative to the camera distance), and time per frame.
// `silpose eval video` runs it and writes the table, per-model POSES.csv and plots.

#include <filesystem>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/pose/pose_error.h"
#include "silpose/segment/segmenter.h"

namespace silpose {

struct VideoExperimentOptions {
  /// Database model names to film; empty: those of kDefaultVideoModels in the database (if none
  /// is, the first 5 models).
  std::vector<std::string> models;
  /// Frames per video (random walk of view, roll and distance 3-6 radii; trajectory.h).
  int frames = 300;
  /// Frames left out at the start of each video (the filter identifies the object).
  int skip_frames = 10;
  /// Seed of the walk, the noise and the filter (model i uses seed + i).
  uint64_t seed = 1;
  /// Camera noise, grey levels (standard deviation).
  double camera_noise = 3.0;
  /// How frames become silhouettes: bgsub from the empty scene's image by default.
  SegmenterOptions segmentation = DefaultSegmentation();
  /// Particles per object.
  int particles_per_object = 60;
  /// Folder for the videos, per-model POSES.csv and plots; empty: a temporary folder, removed.
  std::filesystem::path output_dir;

  static SegmenterOptions DefaultSegmentation();
  bool Check(std::string* error = nullptr) const;
};

/// Five of the shared reference models without rotational symmetry (a symmetric object's
/// rotation about its axis cannot be told from its silhouette, so its rotation error measures
/// the symmetry, not the method).
inline const std::vector<std::string> kDefaultVideoModels = {"bull", "bunny", "dino", "elephant",
                                                             "hand"};

struct VideoExperimentModel {
  std::string name;
  int frames = 0;
  /// Frames counted (after skip_frames) and those with the right object.
  int counted = 0;
  int right_object = 0;
  ErrorSummary rotation_deg;
  ErrorSummary translation_relative;
  ErrorSummary view_error;
  /// Mean time per frame: reading (MJPEG decoding) and tracking (segmentation to pose), ms.
  double read_ms = 0.0;
  double track_ms = 0.0;
  double RightObjectPercent() const { return counted > 0 ? 100.0 * right_object / counted : 0.0; }
};

struct VideoExperimentResult {
  std::vector<VideoExperimentModel> models;
  /// All models' frames pooled.
  VideoExperimentModel total;
  /// The database's view spacing, degrees (the rotation target is spacing + 2).
  double view_spacing_deg = 0.0;
};

/// Runs the experiment on `database`, whose models are `meshes` (same order). Throws
/// silpose::Error for invalid options, an unknown model name or a failure to write.
VideoExperimentResult RunVideoExperiment(const ViewDatabase& database,
                                         const std::vector<TriangleMesh>& meshes,
                                         const VideoExperimentOptions& options);

/// Header and rows of the table (CSV).
const char* VideoExperimentHeader();
void WriteVideoExperimentTable(const std::filesystem::path& path,
                               const VideoExperimentResult& result);

}  // namespace silpose
