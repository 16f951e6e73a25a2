#include "silpose/synth/synthetic_sequence.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "silpose/geometry/view_frame.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/image_codec.h"
#include "silpose/io/mask_file.h"
#include "silpose/pose/lens_distortion.h"
#include "silpose/pose/pose_from_silhouette.h"
#include "silpose/render/shaded_renderer.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"
#include "silpose/util/parallel.h"
#include "silpose/util/progress.h"

namespace silpose {
namespace {

bool TouchesBorder(const cv::Mat& mask) {
  const int last_row = mask.rows - 1;
  const int last_col = mask.cols - 1;
  return cv::countNonZero(mask.row(0)) > 0 || cv::countNonZero(mask.row(last_row)) > 0 ||
         cv::countNonZero(mask.col(0)) > 0 || cv::countNonZero(mask.col(last_col)) > 0;
}

// A mask file name: digits only, then ".png".
bool IsMaskFileName(const std::filesystem::path& path) {
  if (path.extension() != ".png") return false;
  const std::string stem = path.stem().string();
  if (stem.empty()) return false;
  for (char c : stem) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

// The numbered images (<digits>.png) in `folder`, if it exists.
std::vector<std::filesystem::path> NumberedImages(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> images;
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) return images;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    if (IsMaskFileName(entry.path())) images.push_back(entry.path());
  }
  if (error) ThrowError(folder.string(), ": cannot list the folder: ", error.message());
  return images;
}

void PrepareFolder(const std::filesystem::path& folder, bool overwrite, bool colour) {
  std::error_code error;
  std::filesystem::create_directories(folder / "masks", error);
  if (error) ThrowError(folder.string(), ": cannot create the folder: ", error.message());
  const std::vector<std::filesystem::path> old_masks = NumberedImages(folder / "masks");
  const std::vector<std::filesystem::path> old_frames = NumberedImages(folder / "frames");
  const bool has_truth = std::filesystem::exists(folder / "groundtruth.csv", error);
  if ((has_truth || !old_masks.empty() || !old_frames.empty()) && !overwrite) {
    ThrowError(folder.string(),
               ": already holds a sequence (groundtruth.csv, masks/*.png or frames/*.png); "
               "choose another folder or allow overwriting (--overwrite)");
  }
  // The old ground truth goes first: a folder with groundtruth.csv is always complete.
  if (has_truth) {
    std::filesystem::remove(folder / "groundtruth.csv", error);
    if (error) {
      ThrowError((folder / "groundtruth.csv").string(), ": cannot remove: ", error.message());
    }
  }
  for (const std::vector<std::filesystem::path>* old : {&old_masks, &old_frames}) {
    for (const auto& path : *old) {
      std::filesystem::remove(path, error);
      if (error) ThrowError(path.string(), ": cannot remove the old image: ", error.message());
    }
  }
  if (colour) {
    std::filesystem::create_directories(folder / "frames", error);
    if (error) {
      ThrowError((folder / "frames").string(), ": cannot create the folder: ", error.message());
    }
  }
}

void WriteColourFrame(const std::filesystem::path& path, const cv::Mat& image) {
  bool written = false;
  try {
    written = WriteImage(path.string(), image);
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot write the frame: ", exception.what());
  }
  if (!written) ThrowError(path.string(), ": cannot write the frame");
}

// The largest canvas side, in image sides, for rendering a distorted camera's ideal image.
constexpr double kMaxCanvasFactor = 3.0;

// For a camera with distortion: the ideal pinhole camera of a canvas covering the undistorted
// positions of all pixels (limited to kMaxCanvasFactor image sides), and the canvas position of
// each pixel's centre.
void MakeDistortionMaps(const PinholeCamera& camera, PinholeCamera* canvas, cv::Mat* map_x,
                        cv::Mat* map_y) {
  const int width = camera.width_px;
  const int height = camera.height_px;
  cv::Mat ideal_x(height, width, CV_64FC1);
  cv::Mat ideal_y(height, width, CV_64FC1);
  cv::Mat valid(height, width, CV_8UC1, cv::Scalar(0));
  double low_x = 0.0;
  double high_x = width - 1.0;
  double low_y = 0.0;
  double high_y = height - 1.0;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      Eigen::Vector2d ideal;
      if (!PixelToIdealNormalized(camera, Eigen::Vector2d(u, v), &ideal)) continue;
      const double x = camera.focal_x_px * ideal.x() + camera.principal_x_px;
      const double y = camera.focal_y_px * ideal.y() + camera.principal_y_px;
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      ideal_x.at<double>(v, u) = x;
      ideal_y.at<double>(v, u) = y;
      valid.at<uchar>(v, u) = 1;
      low_x = std::min(low_x, x);
      high_x = std::max(high_x, x);
      low_y = std::min(low_y, y);
      high_y = std::max(high_y, y);
    }
  }
  // Canvas: the ideal positions' bounding box (whole pixels, one of margin), limited in size.
  const double limit_x = (kMaxCanvasFactor - 1.0) / 2.0 * width;
  const double limit_y = (kMaxCanvasFactor - 1.0) / 2.0 * height;
  const int left = static_cast<int>(std::ceil(std::min(-low_x, limit_x))) + 1;
  const int top = static_cast<int>(std::ceil(std::min(-low_y, limit_y))) + 1;
  const int right = static_cast<int>(std::ceil(std::min(high_x - (width - 1.0), limit_x))) + 1;
  const int bottom = static_cast<int>(std::ceil(std::min(high_y - (height - 1.0), limit_y))) + 1;
  *canvas = camera;
  canvas->distortion = {0, 0, 0, 0, 0};
  canvas->width_px = width + left + right;
  canvas->height_px = height + top + bottom;
  canvas->principal_x_px = camera.principal_x_px + left;
  canvas->principal_y_px = camera.principal_y_px + top;
  map_x->create(height, width, CV_32FC1);
  map_y->create(height, width, CV_32FC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      float x = -1.0F;
      float y = -1.0F;
      if (valid.at<uchar>(v, u) != 0) {
        const double cx = ideal_x.at<double>(v, u) + left;
        const double cy = ideal_y.at<double>(v, u) + top;
        if (cx >= -0.5 && cy >= -0.5 && cx < canvas->width_px - 0.5 &&
            cy < canvas->height_px - 0.5) {
          x = static_cast<float>(cx);
          y = static_cast<float>(cy);
        }
      }
      map_x->at<float>(v, u) = x;
      map_y->at<float>(v, u) = y;
    }
  }
}

}  // namespace

PinholeCamera DefaultSynthCamera() { return PinholeCamera::Centered(640, 480, 525.0); }

bool SequenceOptions::Check(std::string* error) const {
  std::string problem;
  if (!camera.Check(&problem)) {
    if (error != nullptr) *error = "invalid camera: " + problem;
    return false;
  }
  if (!trajectory.Check(error)) return false;
  if (!degradation.Check(error)) return false;
  if (!colour.Check(&problem)) {
    if (error != nullptr) *error = "colour frames: " + problem;
    return false;
  }
  return true;
}

SyntheticSequence::SyntheticSequence(std::vector<TriangleMesh> meshes,
                                     const SequenceOptions& options)
    : meshes_(std::move(meshes)), options_(options) {
  std::string problem;
  if (!options_.Check(&problem)) ThrowError("invalid synthetic sequence options: ", problem);
  if (meshes_.empty()) ThrowError("no model given: a synthetic sequence needs at least one mesh");
  std::set<std::string> names;
  for (size_t i = 0; i < meshes_.size(); ++i) {
    const TriangleMesh& mesh = meshes_[i];
    if (mesh.name.empty()) ThrowError("model ", i + 1, " has no name (the file stem)");
    if (!names.insert(mesh.name).second) {
      ThrowError(mesh.name,
                 ": two models have this name (model names are file stems and must be "
                 "unique in a sequence)");
    }
    const double radius = mesh.Radius();
    if (mesh.vertices.empty() || !(radius > 0.0) || !std::isfinite(radius)) {
      ThrowError(mesh.name, ": the mesh has no extent (all vertices coincide), nothing to render");
    }
    centres_.push_back(mesh.Centre());
    radii_.push_back(radius);
  }
  for (const ObjectSwitch& s : options_.trajectory.object_switches) {
    if (s.object >= static_cast<int>(meshes_.size())) {
      ThrowError("object switch at frame ", s.frame, " names object ", s.object + 1, " but only ",
                 meshes_.size(), " model(s) were given");
    }
  }
  if (options_.trajectory.kind == TrajectoryKind::kHandheld &&
      !options_.trajectory.handheld.camera) {
    options_.trajectory.handheld.camera = options_.camera;
  }
  trajectory_ = GenerateTrajectory(options_.trajectory);
  if (HasDistortion(options_.camera)) {
    MakeDistortionMaps(options_.camera, &canvas_camera_, &distortion_map_x_, &distortion_map_y_);
  }

  const ColourOptions& colour = options_.colour;
  const size_t num_colours = colour.object_colours_bgr.size();
  if (num_colours > 1 && num_colours != meshes_.size()) {
    ThrowError("give one object colour for all models or one per model: ", meshes_.size(),
               " model(s), ", num_colours, " colours");
  }
  for (size_t i = 0; i < meshes_.size(); ++i) {
    object_colours_.push_back(num_colours == 0   ? DefaultObjectColour(static_cast<int>(i))
                              : num_colours == 1 ? colour.object_colours_bgr.front()
                                                 : colour.object_colours_bgr[i]);
  }
  if (colour.enabled) {
    const PinholeCamera& camera = options_.camera;
    background_ =
        colour.background_image.empty()
            ? GenerateBackgroundTexture(camera.width_px, camera.height_px, colour.background_seed)
            : FitBackground(colour.background_image, camera.width_px, camera.height_px);
  }
}

GroundTruthFrame SyntheticSequence::Truth(int index) const {
  SILPOSE_ASSERT(index >= 0 && index < num_frames());
  const TrajectoryFrame& step = trajectory_[static_cast<size_t>(index)];
  const auto object = static_cast<size_t>(step.object);
  GroundTruthFrame truth;
  truth.frame = index;
  truth.object = meshes_[object].name;
  truth.view_dir_in_object = step.view_dir_in_object;
  truth.roll_deg = step.roll_deg;
  truth.distance_in_radii = step.distance_in_radii;
  truth.centre_ray_in_camera = step.centre_ray_in_camera;
  const double distance = step.distance_in_radii * radii_[object];
  if (step.centre_ray_in_camera == Eigen::Vector3d::UnitZ()) {
    truth.camera_from_object =
        CameraFromObjectAtView(step.view_dir_in_object, step.roll_deg, distance, centres_[object]);
  } else {
    // Off the axis: the virtual on-axis camera turned by Q (synth/trajectory.h).
    const Eigen::Vector3d ray = step.centre_ray_in_camera.normalized();
    const Eigen::Matrix3d rotation =
        RotationFromOpticalAxisTo(ray) *
        CameraFromObjectRotation(step.view_dir_in_object, step.roll_deg);
    truth.camera_from_object.rotation = rotation;
    truth.camera_from_object.translation = distance * ray - rotation * centres_[object];
  }
  truth.degradation = ChooseFrameDegradation(options_.degradation, index);
  truth.mask_effects = AppliedMaskEffects(options_.degradation, index);
  return truth;
}

void SyntheticSequence::Generate(int index, SyntheticFrame* frame) const {
  frame->truth = Truth(index);
  const auto object = static_cast<size_t>(trajectory_[static_cast<size_t>(index)].object);
  const TriangleMesh& mesh = meshes_[object];
  const bool distorted = !distortion_map_x_.empty();
  if (options_.colour.enabled) {
    // The shaded renderer's mask is RenderSilhouette's (same pixel rule): one pass for both.
    ShadedRenderOptions shading = options_.colour.shading;
    shading.base_colour_bgr = object_colours_[object];
    if (distorted) {
      cv::Mat canvas_colour;
      cv::Mat canvas_mask;
      RenderShaded(mesh, canvas_camera_, frame->truth.camera_from_object, shading, &canvas_colour,
                   &canvas_mask);
      cv::Mat colour;
      cv::remap(canvas_colour, colour, distortion_map_x_, distortion_map_y_, cv::INTER_NEAREST,
                cv::BORDER_CONSTANT, cv::Scalar::all(0));
      cv::remap(canvas_mask, frame->mask, distortion_map_x_, distortion_map_y_, cv::INTER_NEAREST,
                cv::BORDER_CONSTANT, cv::Scalar(0));
      background_.copyTo(frame->colour);
      colour.copyTo(frame->colour, frame->mask);
    } else {
      shading.background = background_;
      RenderShaded(mesh, options_.camera, frame->truth.camera_from_object, shading, &frame->colour,
                   &frame->mask);
    }
    ApplyCameraEffects(options_.colour, index, &frame->colour);
  } else {
    if (distorted) {
      cv::Mat canvas_mask;
      RenderSilhouette(mesh, canvas_camera_, frame->truth.camera_from_object, &canvas_mask);
      cv::remap(canvas_mask, frame->mask, distortion_map_x_, distortion_map_y_, cv::INTER_NEAREST,
                cv::BORDER_CONSTANT, cv::Scalar(0));
    } else {
      RenderSilhouette(mesh, options_.camera, frame->truth.camera_from_object, &frame->mask);
    }
    frame->colour.release();
  }
  frame->rendered_area_px = cv::countNonZero(frame->mask);
  frame->touches_border = frame->rendered_area_px > 0 && TouchesBorder(frame->mask);
  const FrameDegradation applied = DegradeMask(options_.degradation, index, &frame->mask);
  SILPOSE_ASSERT(applied == frame->truth.degradation);
}

SyntheticFrame SyntheticSequence::Generate(int index) const {
  SyntheticFrame frame;
  Generate(index, &frame);
  return frame;
}

bool SequenceWriteOptions::Check(std::string* error) const {
  if (num_threads < 0) {
    if (error != nullptr) *error = "thread count must be >= 0 (0 = all cores)";
    return false;
  }
  return true;
}

std::string SequenceSummary::BriefReport() const {
  std::ostringstream report;
  report << "wrote " << frames << (colour ? " frames (masks and colour frames)" : " frames")
         << " to " << folder.string();
  std::vector<std::string> notes;
  if (missed > 0) notes.push_back(std::to_string(missed) + " missed");
  if (bad > 0) notes.push_back(std::to_string(bad) + " badly segmented");
  if (out_of_view > 0) {
    notes.push_back(std::to_string(out_of_view) + " with the object out of view");
  }
  if (touching_border > 0) {
    notes.push_back(std::to_string(touching_border) + " with the object cut by the image border");
  }
  if (!notes.empty()) {
    report << " (";
    for (size_t i = 0; i < notes.size(); ++i) report << (i > 0 ? ", " : "") << notes[i];
    report << ")";
  }
  char seconds_text[32];
  std::snprintf(seconds_text, sizeof(seconds_text), " in %.1f s", seconds);
  report << seconds_text;
  return report.str();
}

std::filesystem::path SequenceMaskPath(const std::filesystem::path& folder, int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", frame);
  return folder / "masks" / name;
}

std::filesystem::path SequenceFramePath(const std::filesystem::path& folder, int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", frame);
  return folder / "frames" / name;
}

SequenceSummary WriteSequence(const SyntheticSequence& sequence,
                              const std::filesystem::path& folder,
                              const SequenceWriteOptions& options) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("invalid sequence writing options: ", problem);
  const bool colour = sequence.has_colour();
  if (options.colour_frame_sink && !colour) {
    ThrowError("a colour frame consumer was given but the sequence has no colour frames");
  }
  const bool write_frames = colour && options.write_colour_frames;
  const auto start = std::chrono::steady_clock::now();
  PrepareFolder(folder, options.overwrite, write_frames);
  WriteCameraFile(folder / "camera.yml", sequence.camera());
  // The empty scene, for background subtraction from an image (track --background).
  if (write_frames) WriteColourFrame(folder / "background.png", sequence.background());

  const int num_frames = sequence.num_frames();
  std::vector<GroundTruthFrame> truths(static_cast<size_t>(num_frames));
  std::vector<int> areas(static_cast<size_t>(num_frames), 0);
  std::vector<char> border(static_cast<size_t>(num_frames), 0);
  ProgressBar progress("synth", num_frames,
                       options.show_progress && ProgressBar::StderrIsTerminal());
  // With a sink, frames are generated in batches and handed over in order after each batch; the
  // batch bounds the colour frames held in memory.
  const bool to_sink = static_cast<bool>(options.colour_frame_sink);
  const int batch_size = to_sink ? 32 : std::max(num_frames, 1);
  std::vector<cv::Mat> batch_colour(to_sink ? static_cast<size_t>(batch_size) : 0);
  int batch_begin = 0;
  auto generate = [&](int first, int last) {
    SyntheticFrame frame;
    for (int k = first; k != last; ++k) {
      sequence.Generate(k, &frame);
      WriteMask(SequenceMaskPath(folder, k), frame.mask);
      if (write_frames) WriteColourFrame(SequenceFramePath(folder, k), frame.colour);
      if (to_sink) {
        // A copy of its own: `frame` is reused for the next one.
        frame.colour.copyTo(batch_colour[static_cast<size_t>(k - batch_begin)]);
      }
      const auto i = static_cast<size_t>(k);
      areas[i] = frame.rendered_area_px;
      border[i] = frame.touches_border ? 1 : 0;
      truths[i] = std::move(frame.truth);
    }
    progress.Advance(last - first);
  };
  for (batch_begin = 0; batch_begin < num_frames; batch_begin += batch_size) {
    const int batch_end = std::min(batch_begin + batch_size, num_frames);
    if (options.num_threads == 1) {
      constexpr int kChunk = 8;  // report progress as frames are done
      for (int begin = batch_begin; begin < batch_end; begin += kChunk) {
        generate(begin, std::min(begin + kChunk, batch_end));
      }
    } else {
      ParallelFor(batch_begin, batch_end, 4, options.num_threads, generate);
    }
    if (to_sink) {
      for (int k = batch_begin; k < batch_end; ++k) {
        options.colour_frame_sink(k, batch_colour[static_cast<size_t>(k - batch_begin)]);
      }
    }
  }
  progress.Finish();
  WriteGroundTruth(folder / "groundtruth.csv", truths);

  SequenceSummary summary;
  summary.folder = folder;
  summary.frames = num_frames;
  summary.colour = colour;
  for (size_t i = 0; i < truths.size(); ++i) {
    summary.missed += truths[i].degradation == FrameDegradation::kMissed;
    summary.bad += truths[i].degradation == FrameDegradation::kBad;
    summary.out_of_view += areas[i] == 0;
    summary.touching_border += border[i] != 0;
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace silpose
