#include "silpose/eval/video_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>
#include <opencv2/imgcodecs.hpp>

#include "silpose/io/frame_source.h"
#include "silpose/io/image_codec.h"
#include "silpose/io/video_writer.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/track_report.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose {

SegmenterOptions VideoExperimentOptions::DefaultSegmentation() {
  SegmenterOptions options;
  options.kind = SegmenterKind::kBackground;
  return options;
}

bool VideoExperimentOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (frames < 2) return fail("frames must be >= 2");
  if (skip_frames < 0 || skip_frames >= frames) return fail("skip_frames must be in [0, frames)");
  if (!(camera_noise >= 0.0 && camera_noise <= 50.0))
    return fail("camera_noise must be in [0, 50]");
  if (particles_per_object < 1) return fail("particles_per_object must be >= 1");
  std::string problem;
  if (!segmentation.Check(&problem)) return fail("segmentation: " + problem);
  return true;
}

namespace {

std::vector<int> ChosenModels(const ViewDatabase& database, const VideoExperimentOptions& options) {
  std::vector<int> chosen;
  if (!options.models.empty()) {
    for (const std::string& name : options.models) {
      const int index = database.FindModel(name);
      if (index < 0) ThrowError("eval video: no model '", name, "' in the database");
      chosen.push_back(index);
    }
    return chosen;
  }
  for (const std::string& name : kDefaultVideoModels) {
    const int index = database.FindModel(name);
    if (index >= 0) chosen.push_back(index);
  }
  if (chosen.empty()) {
    for (int m = 0; m < static_cast<int>(database.models.size()) && m < 5; ++m) chosen.push_back(m);
  }
  return chosen;
}

double Ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since)
      .count();
}

}  // namespace

VideoExperimentResult RunVideoExperiment(const ViewDatabase& database,
                                         const std::vector<TriangleMesh>& meshes,
                                         const VideoExperimentOptions& options) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("eval video: ", problem);
  if (meshes.size() != database.models.size())
    ThrowError("eval video: ", meshes.size(), " meshes for ", database.models.size(), " models");
  const std::vector<int> chosen = ChosenModels(database, options);

  std::filesystem::path folder = options.output_dir;
  const bool temporary = folder.empty();
  if (temporary) {
    folder = std::filesystem::temp_directory_path() /
             ("silpose_eval_video_" + std::to_string(::getpid()));
  }
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error) ThrowError(folder.string(), ": cannot create folder: ", error.message());

  VideoExperimentResult result;
  result.view_spacing_deg = database.sphere.typical_spacing_rad * 180.0 / std::numbers::pi;
  std::vector<double> all_rotation, all_translation, all_view;
  ProgressBar progress("eval video", static_cast<int64_t>(chosen.size()) * options.frames);
  for (size_t k = 0; k < chosen.size(); ++k) {
    const int m = chosen[k];
    const TriangleMesh& mesh = meshes[static_cast<size_t>(m)];
    const uint64_t seed = options.seed + k;
    SequenceOptions sequence_options;
    sequence_options.trajectory.kind = TrajectoryKind::kWalk;
    sequence_options.trajectory.num_frames = options.frames;
    sequence_options.trajectory.walk.seed = seed;
    sequence_options.colour.enabled = true;
    sequence_options.colour.noise_sigma = options.camera_noise;
    sequence_options.colour.seed = seed;
    sequence_options.colour.background_seed = seed;
    const SyntheticSequence sequence({mesh}, sequence_options);
    const PinholeCamera& camera = sequence.camera();

    // The video as a camera would record it (MJPEG), and the empty scene.
    const std::filesystem::path model_dir = folder / database.models[static_cast<size_t>(m)].name;
    std::filesystem::create_directories(model_dir, error);
    if (error) ThrowError(model_dir.string(), ": cannot create folder: ", error.message());
    const std::filesystem::path video_path = model_dir / "video.avi";
    const std::filesystem::path background_path = model_dir / "background.png";
    {
      auto video = OpenVideoWriter(video_path, cv::Size(camera.width_px, camera.height_px), 30.0);
      for (int f = 0; f < sequence.num_frames(); ++f) video->Write(sequence.Generate(f).colour);
      video->Close();
    }
    bool written = false;
    try {
      written = WriteImage(background_path.string(), sequence.background());
    } catch (const cv::Exception& exception) {
      ThrowError(background_path.string(), ": cannot write (", exception.err, ")");
    }
    if (!written) ThrowError(background_path.string(), ": cannot write");

    TrackerOptions tracker_options;
    tracker_options.segmentation = options.segmentation;
    if (tracker_options.segmentation.kind == SegmenterKind::kBackground)
      tracker_options.segmentation.background_image_path = background_path.string();
    tracker_options.filter.particles_per_object = options.particles_per_object;
    // A fixed count: the adaptive floor and cap follow it (any count works).
    tracker_options.filter.min_particles_per_object =
        std::min(tracker_options.filter.min_particles_per_object, options.particles_per_object);
    tracker_options.filter.max_particles_per_object =
        std::max(tracker_options.filter.max_particles_per_object, options.particles_per_object);
    tracker_options.filter.seed = seed;
    tracker_options.filter.keep_history = false;  // as `track` without smoothing
    Tracker tracker(database, camera, tracker_options);
    TrackReport report(database);
    PosesCsvWriter poses(model_dir / "POSES.csv");
    std::unique_ptr<FrameSource> source = OpenFrameSource(video_path.string());
    VideoExperimentModel row;
    row.name = database.models[static_cast<size_t>(m)].name;
    cv::Mat frame;
    for (;;) {
      const auto read_start = std::chrono::steady_clock::now();
      if (!source->Read(&frame)) break;
      row.read_ms += Ms(read_start);
      const TrackedFrame tracked = tracker.Process(frame);
      row.track_ms += tracked.result.time_ms;
      poses.Write(tracked.result);
      const GroundTruthFrame truth = sequence.Truth(source->frame_index());
      report.Add(tracked.result, MakeTruthFrame(database, truth.object, truth.view_dir_in_object,
                                                truth.camera_from_object));
      ++row.frames;
      progress.Advance();
    }
    poses.Close();
    const Figure trajectory = report.TrajectoryFigure(row.name);
    trajectory.WriteSvg(model_dir / "trajectory.svg");
    const Figure errors = report.ErrorFigure(row.name);
    errors.WriteSvg(model_dir / "error.svg");
    errors.WritePng(model_dir / "error.png");

    const TrackAccuracy accuracy = report.Accuracy(options.skip_frames);
    row.counted = accuracy.frames;
    row.right_object = accuracy.right_object;
    row.rotation_deg = accuracy.rotation_deg;
    row.translation_relative = accuracy.translation_relative;
    row.view_error = accuracy.view_error;
    all_rotation.insert(all_rotation.end(), accuracy.rotation_values_deg.begin(),
                        accuracy.rotation_values_deg.end());
    all_translation.insert(all_translation.end(), accuracy.translation_values_relative.begin(),
                           accuracy.translation_values_relative.end());
    all_view.insert(all_view.end(), accuracy.view_values.begin(), accuracy.view_values.end());
    row.read_ms /= std::max(row.frames, 1);
    row.track_ms /= std::max(row.frames, 1);
    // Pool the per-frame errors for the total row.
    result.total.frames += row.frames;
    result.total.counted += row.counted;
    result.total.right_object += row.right_object;
    result.total.read_ms += row.read_ms * row.frames;
    result.total.track_ms += row.track_ms * row.frames;
    result.models.push_back(row);
  }
  progress.Finish();
  result.total.name = "all";
  result.total.rotation_deg = Summarize(all_rotation);
  result.total.translation_relative = Summarize(all_translation);
  result.total.view_error = Summarize(all_view);
  result.total.read_ms /= std::max(result.total.frames, 1);
  result.total.track_ms /= std::max(result.total.frames, 1);
  if (temporary) std::filesystem::remove_all(folder, error);
  return result;
}

const char* VideoExperimentHeader() {
  return "model,frames,counted,right_object_percent,rotation_error_median_deg,"
         "rotation_error_p90_deg,translation_error_median_percent,"
         "translation_error_p90_percent,view_error_mean,read_ms_per_frame,track_ms_per_frame";
}

void WriteVideoExperimentTable(const std::filesystem::path& path,
                               const VideoExperimentResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file << VideoExperimentHeader() << '\n';
  for (const VideoExperimentModel& row : result.models) {
    file << row.name << ',' << row.frames << ',' << row.counted << ',' << row.RightObjectPercent()
         << ',' << row.rotation_deg.median << ',' << row.rotation_deg.percentile_90 << ','
         << 100.0 * row.translation_relative.median << ','
         << 100.0 * row.translation_relative.percentile_90 << ',' << row.view_error.mean << ','
         << row.read_ms << ',' << row.track_ms << '\n';
  }
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

}  // namespace silpose
