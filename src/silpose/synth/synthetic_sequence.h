#pragma once
// Synthetic silhouette sequences with exact ground truth (the library's own test and evaluation
// data): a trajectory (synth/trajectory.h) rendered frame by frame with a pinhole camera, degraded
// as asked (synth/degradation.h), and written as a sequence folder (docs/conventions.md, "synth
// DIR"):
//   DIR/masks/000000.png, 000001.png, ...   CV_8UC1 PNG, 255 = object (after degradation)
//   DIR/background.png                      CV_8UC3 PNG, the empty scene (with colour frames)
//   DIR/frames/000000.png, ...              CV_8UC3 PNG, the colour frames (when asked for:
//                                           SequenceOptions::colour, synth/colour_frames.h)
//   DIR/camera.yml                          OpenCV calibration YAML (io/camera_file.h)
//   DIR/groundtruth.csv                     one row per frame (synth/ground_truth.h)
//
// Frame k of a sequence shows object o = trajectory[k].object, with the camera at
//   camera_from_object: R = Q * CameraFromObjectRotation(view_dir, roll_deg),  t = D * u - R * c
// (synth/trajectory.h): u = trajectory[k].centre_ray_in_camera, Q the minimal rotation taking
// (0, 0, 1) to u, D = distance_in_radii * mesh.Radius(), c = mesh.Centre(). For orbit and walk,
// u = (0, 0, 1) and this is CameraFromObjectAtView(view_dir, roll_deg, D, c)
// (geometry/view_frame.h): the camera looks at the object centre, which projects to the principal
// point. The handheld trajectory moves the object centre off the axis, to the ideal image position
// (u_x/u_z, u_y/u_z). The colour frame shows the same pose, shaded over the sequence's background;
// the degradations only concern the masks. Every frame is generated independently of the others
// from the options alone, so frames can be rendered in any order and on any number of threads with
// identical results.
//
// Lens distortion. If the camera has distortion coefficients, masks and colour frames are those of
// the distorted image: each frame is rendered with the ideal pinhole camera (same intrinsics, on a
// canvas large enough for the undistorted image), then each output pixel takes the nearest canvas
// pixel at its undistorted position (pose/lens_distortion.h), for the mask and the object's colour
// alike; the background image is not distorted.

#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/synth/colour_frames.h"
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
  /// Colour frames (off by default).
  ColourOptions colour;

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
  /// CV_8UC3 (BGR), camera size: the colour frame, when the options ask for colour (empty
  /// otherwise). Its object pixels are exactly the rendered silhouette's (before degradation).
  cv::Mat colour;
};

/// A sequence, ready to be generated frame by frame.
class SyntheticSequence {
 public:
  /// Takes the models (object i of the trajectory is meshes[i]; names, the file stems, must be
  /// non-empty and unique), computes the trajectory (a handheld trajectory without a camera of its
  /// own keeps the object inside this sequence's camera image) and, with colour, the background.
  /// Throws silpose::Error if the options are invalid, there is no mesh, a mesh has no extent,
  /// names clash, an object switch names an object beyond the list, or there are object colours but
  /// neither one nor one per model.
  SyntheticSequence(std::vector<TriangleMesh> meshes, const SequenceOptions& options);

  int num_frames() const { return static_cast<int>(trajectory_.size()); }
  const SequenceOptions& options() const { return options_; }
  const PinholeCamera& camera() const { return options_.camera; }
  const std::vector<TriangleMesh>& meshes() const { return meshes_; }
  const std::vector<TrajectoryFrame>& trajectory() const { return trajectory_; }
  /// True if the frames have colour (options().colour.enabled).
  bool has_colour() const { return options_.colour.enabled; }
  /// The background of every colour frame (CV_8UC3, camera size); empty without colour.
  const cv::Mat& background() const { return background_; }
  /// Surface colour of object i (B, G, R), as the options say.
  const Eigen::Vector3d& object_colour_bgr(int object) const {
    return object_colours_[static_cast<size_t>(object)];
  }

  /// The ground truth of frame `index` (pose from the trajectory; degradation as it will be
  /// applied), without rendering.
  GroundTruthFrame Truth(int index) const;
  /// Renders and degrades frame `index`, 0 <= index < num_frames(), and renders its colour frame
  /// when asked for. Deterministic; thread-safe. `frame->mask` and `frame->colour` are reused if
  /// they have the right size.
  void Generate(int index, SyntheticFrame* frame) const;
  SyntheticFrame Generate(int index) const;

 private:
  std::vector<TriangleMesh> meshes_;
  std::vector<Eigen::Vector3d> centres_;
  std::vector<double> radii_;
  std::vector<Eigen::Vector3d> object_colours_;
  SequenceOptions options_;
  cv::Mat background_;
  // With lens distortion: the ideal pinhole camera of the render canvas, and for each output pixel
  // the canvas pixel to take (CV_32FC1 x and y; -1 outside the canvas). Empty without distortion.
  PinholeCamera canvas_camera_;
  cv::Mat distortion_map_x_;
  cv::Mat distortion_map_y_;
  std::vector<TrajectoryFrame> trajectory_;
};

/// How WriteSequence works.
struct SequenceWriteOptions {
  /// Worker threads; 0 = all cores. The output does not depend on it.
  int num_threads = 0;
  /// Show a progress bar on stderr when it is a terminal.
  bool show_progress = false;
  /// Write into a folder that already holds a sequence (groundtruth.csv, or images in masks/ or
  /// frames/): its mask and frame files (masks/<digits>.png, frames/<digits>.png) are deleted
  /// first, camera.yml and groundtruth.csv replaced; other files are left alone. Without it such
  /// a folder is refused.
  bool overwrite = false;
  /// With a colour sequence: write the colour frames as frames/<frame, six digits>.png.
  bool write_colour_frames = true;
  /// With a colour sequence, optional: receives every colour frame (CV_8UC3, BGR), in frame
  /// order, one call at a time, on the thread that called WriteSequence (e.g. to encode a video
  /// while the frames are generated). An exception it throws ends WriteSequence (and is passed
  /// on) before groundtruth.csv is written.
  std::function<void(int frame, const cv::Mat& colour_bgr)> colour_frame_sink;

  bool Check(std::string* error = nullptr) const;
};

/// What WriteSequence did.
struct SequenceSummary {
  std::filesystem::path folder;
  int frames = 0;
  /// Colour frames were generated (written to frames/ if asked for).
  bool colour = false;
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

/// The colour frame file of frame `frame`: folder/frames/<frame, six digits>.png.
std::filesystem::path SequenceFramePath(const std::filesystem::path& folder, int frame);

/// Generates every frame and writes the sequence folder (created if needed; see the top of this
/// file). groundtruth.csv is written last, so a folder with it is complete. Throws silpose::Error
/// naming the file or folder if it cannot be written, or the folder already holds a sequence and
/// `overwrite` is off, or a colour frame sink is given for a sequence without colour.
SequenceSummary WriteSequence(const SyntheticSequence& sequence,
                              const std::filesystem::path& folder,
                              const SequenceWriteOptions& options = {});

}  // namespace silpose
