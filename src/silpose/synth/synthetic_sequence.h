#pragma once
// Synthetic silhouette sequences with exact ground truth (STYLE.md habit 8): a trajectory
// (synth/trajectory.h) rendered frame by frame with a pinhole camera, degraded as asked
// (synth/degradation.h), and written as a sequence folder (DESIGN.md, "synth DIR"):
//   DIR/masks/000000.png, 000001.png, ...   CV_8UC1 PNG, 255 = object (after degradation)
//   DIR/camera.yml                          OpenCV calibration YAML (io/camera_file.h)
//   DIR/groundtruth.csv                     one row per frame (synth/ground_truth.h)
//
// Frame k of a sequence shows object o = trajectory[k].object, with the camera at
//   camera_from_object = CameraFromObjectAtView(view_dir, roll_deg,
//                                               distance_in_radii * mesh.Radius(), mesh.Centre())
// (geometry/view_frame.h): the camera looks at the object centre, which therefore projects to the
// principal point. Every frame is generated independently of the others from the options alone,
// so frames can be rendered in any order and on any number of threads with identical results.

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/synth/degradation.h"
#include "silpose/synth/ground_truth.h"
#include "silpose/synth/trajectory.h"

namespace silpose {

/// silpose's default synthetic camera: 640 x 480 pixels, focal length 525 px in x and y, principal
/// point at the image centre (319.5, 239.5) in the pixel-centre convention of
/// geometry/pinhole_camera.h, no distortion (the VGA camera of the usual RGB-D datasets). At the
/// default distance of 3 object radii an object's bounding sphere spans 371 px, inside the image.
PinholeCamera DefaultSynthCamera();

struct SequenceOptions {
  /// The camera of every frame (see DefaultSynthCamera).
  PinholeCamera camera = DefaultSynthCamera();
  TrajectoryOptions trajectory;
  DegradationOptions degradation;

  bool Check(std::string* error = nullptr) const;
};

/// One generated frame.
struct SyntheticFrame {
  GroundTruthFrame truth;
  /// CV_8UC1, camera size, 255 = object: the rendered silhouette after degradation.
  cv::Mat mask;
  /// Object pixels of the rendered silhouette before degradation (0: the object is out of view).
  int rendered_area_px = 0;
  /// The rendered silhouette (before degradation) touches the image border: the object is cut off.
  bool touches_border = false;
};

/// A sequence, ready to be generated frame by frame.
class SyntheticSequence {
 public:
  /// Takes the models (object i of the trajectory is meshes[i]; names, the file stems, must be
  /// non-empty and unique) and computes the trajectory. Throws silpose::Error if the options are
  /// invalid, there is no mesh, a mesh has no extent, names clash, or an object switch names an
  /// object beyond the list.
  SyntheticSequence(std::vector<TriangleMesh> meshes, const SequenceOptions& options);

  int num_frames() const { return static_cast<int>(trajectory_.size()); }
  const SequenceOptions& options() const { return options_; }
  const PinholeCamera& camera() const { return options_.camera; }
  const std::vector<TriangleMesh>& meshes() const { return meshes_; }
  const std::vector<TrajectoryFrame>& trajectory() const { return trajectory_; }

  /// The ground truth of frame `index` (pose from the trajectory; degradation as it will be
  /// applied), without rendering.
  GroundTruthFrame Truth(int index) const;
  /// Renders and degrades frame `index`, 0 <= index < num_frames(). Deterministic; thread-safe.
  /// `frame->mask` is reused if it has the right size.
  void Generate(int index, SyntheticFrame* frame) const;
  SyntheticFrame Generate(int index) const;

 private:
  std::vector<TriangleMesh> meshes_;
  std::vector<Eigen::Vector3d> centres_;
  std::vector<double> radii_;
  SequenceOptions options_;
  std::vector<TrajectoryFrame> trajectory_;
};

/// How WriteSequence works.
struct SequenceWriteOptions {
  /// Worker threads; 0 = all cores. The output does not depend on it.
  int num_threads = 0;
  /// Show a progress bar on stderr when it is a terminal.
  bool show_progress = false;
  /// Write into a folder that already holds a sequence (groundtruth.csv or masks in masks/): its
  /// mask files (masks/<digits>.png) are deleted first, camera.yml and groundtruth.csv replaced;
  /// other files are left alone. Without it such a folder is refused.
  bool overwrite = false;

  bool Check(std::string* error = nullptr) const;
};

/// What WriteSequence did.
struct SequenceSummary {
  std::filesystem::path folder;
  int frames = 0;
  /// Frames recorded as missed / bad (FrameDegradation).
  int missed = 0;
  int bad = 0;
  /// Frames whose rendered silhouette was empty (object out of view) or touched the image border.
  int out_of_view = 0;
  int touching_border = 0;
  double seconds = 0.0;

  /// One line: "wrote 360 frames (...) to DIR in 1.2 s", with the counts that are not zero.
  std::string BriefReport() const;
};

/// The mask file of frame `frame` in a sequence folder: folder/masks/<frame, six digits>.png.
std::filesystem::path SequenceMaskPath(const std::filesystem::path& folder, int frame);

/// Generates every frame and writes the sequence folder (created if needed; see the top of this
/// file). groundtruth.csv is written last, so a folder with it is complete. Throws silpose::Error
/// naming the file or folder if it cannot be written, or the folder already holds a sequence and
/// `overwrite` is off.
SequenceSummary WriteSequence(const SyntheticSequence& sequence,
                              const std::filesystem::path& folder,
                              const SequenceWriteOptions& options = {});

}  // namespace silpose
