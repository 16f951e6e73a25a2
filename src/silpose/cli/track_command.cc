#include <algorithm>
#include <any>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/image_codec.h"
#include "silpose/io/image_limits.h"
#include "silpose/io/mask_file.h"
#include "silpose/io/read_ahead_source.h"
#include "silpose/io/video_writer.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/render/overlay.h"
#include "silpose/synth/ground_truth.h"
#include "silpose/track/segment_ahead.h"
#include "silpose/track/smoother.h"
#include "silpose/track/track_report.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

// --read-ahead: more frames ahead only hold more memory (a colour frame is about 1 MB).
constexpr int kMaxReadAhead = 64;

// The number an image file is named by ("000012.png" -> 12), else -1 (videos: "video.avi#12").
int NumericStem(const std::string& name) {
  const std::string stem = std::filesystem::path(name).stem().string();
  if (stem.empty() || stem.size() > 9 || name.find('#') != std::string::npos) return -1;
  for (char c : stem) {
    if (c < '0' || c > '9') return -1;
  }
  return std::stoi(stem);
}

// "H,S,V,H,S,V" -> lower and upper HSV bounds.
void ParseHsvRange(const std::string& text, SegmenterOptions* options) {
  std::vector<double> values;
  std::stringstream stream(text);
  bool valid = true;
  for (std::string item; valid && std::getline(stream, item, ',');) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      valid = used == item.size();
    } catch (const std::exception&) {
      valid = false;
    }
  }
  if (!valid) values.clear();
  if (values.size() != 6) {
    ThrowError(
        "--hsv-range must be six numbers H,S,V,H,S,V (lower then upper bound, H in "
        "[0, 180), S and V in [0, 255]), got '",
        text, "'");
  }
  options->hsv_lower = cv::Scalar(values[0], values[1], values[2]);
  options->hsv_upper = cv::Scalar(values[3], values[4], values[5]);
}

// The camera: --camera, else INPUT/camera.yml for a sequence folder, else a default (warned).
PinholeCamera ChooseCamera(const TrackJob& arguments, cv::Size frame_size) {
  std::filesystem::path path = arguments.camera;
  std::error_code error;
  if (path.empty() && std::filesystem::is_directory(arguments.input, error) &&
      std::filesystem::is_regular_file(std::filesystem::path(arguments.input) / "camera.yml",
                                       error)) {
    path = std::filesystem::path(arguments.input) / "camera.yml";
  }
  if (!path.empty()) {
    PinholeCamera camera = ReadCameraFile(path);
    if (camera.width_px != frame_size.width || camera.height_px != frame_size.height) {
      ThrowError(path.string(), ": the camera is ", camera.width_px, "x", camera.height_px,
                 " pixels but the frames of ", arguments.input, " are ", frame_size.width, "x",
                 frame_size.height, ": wrong calibration file?");
    }
    return camera;
  }
  const PinholeCamera camera = DefaultCamera(frame_size.width, frame_size.height);
  std::fprintf(stderr,
               "warning: no --camera given: assuming focal length %.1f px and the principal point "
               "at the image centre; object and view do not depend on it, the 6-DOF pose's "
               "distance does\n",
               camera.focal_x_px);
  return camera;
}

// Ground truth: --ground-truth, else INPUT/groundtruth.csv for a sequence folder.
std::vector<GroundTruthFrame> ChooseGroundTruth(const TrackJob& arguments) {
  std::filesystem::path path = arguments.ground_truth;
  std::error_code error;
  if (path.empty() && std::filesystem::is_directory(arguments.input, error) &&
      std::filesystem::is_regular_file(std::filesystem::path(arguments.input) / "groundtruth.csv",
                                       error)) {
    path = std::filesystem::path(arguments.input) / "groundtruth.csv";
  }
  if (path.empty()) return {};
  return ReadGroundTruth(path);
}

// The meshes drawn in the overlay, by model index: --models (files or folders, matched to the
// database's models by file stem), else the paths the database was built from. A model whose mesh
// cannot be read is drawn without its outline (one warning).
std::vector<std::optional<TriangleMesh>> OverlayMeshes(const TrackJob& arguments,
                                                       const ViewDatabase& database) {
  std::map<std::string, std::filesystem::path> by_name;
  for (const std::string& item : arguments.models) {
    std::error_code error;
    if (std::filesystem::is_directory(item, error)) {
      for (const auto& file : MeshFilesIn(item)) by_name[file.stem().string()] = file;
    } else {
      by_name[std::filesystem::path(item).stem().string()] = item;
    }
  }
  std::vector<std::optional<TriangleMesh>> meshes(database.models.size());
  for (size_t m = 0; m < database.models.size(); ++m) {
    const ModelViews& model = database.models[m];
    const auto found = by_name.find(model.name);
    const std::filesystem::path path =
        found != by_name.end() ? found->second : std::filesystem::path(model.source_path);
    try {
      meshes[m] = LoadMesh(path);
    } catch (const Error& error) {
      std::fprintf(stderr,
                   "warning: overlay without the outline of '%s': %s (give the meshes with "
                   "--models)\n",
                   model.name.c_str(), error.what());
    }
  }
  return meshes;
}

// Background subtraction keeps a model of every pixel (MOG2: about 70 bytes each): on frames of
// more than kMaxBackgroundPixels it runs on the frame shrunk by the smallest --downscale factor
// that brings it under (docs/limits.md), and says so.
constexpr double kMaxBackgroundPixels = 9e6;

// The --downscale that background subtraction runs at on frames of this size (at least the one
// asked for; LimitBackgroundSubtraction).
int BackgroundDownscale(cv::Size frame_size, const SegmenterOptions& segment) {
  if (segment.kind != SegmenterKind::kBackground) return segment.downscale;
  const double pixels = static_cast<double>(frame_size.width) * frame_size.height;
  int factor = segment.downscale;
  while (pixels / (static_cast<double>(factor) * factor) > kMaxBackgroundPixels) ++factor;
  return factor;
}

void LimitBackgroundSubtraction(cv::Size frame_size, SegmenterOptions* segment) {
  const int factor = BackgroundDownscale(frame_size, *segment);
  if (factor == segment->downscale) return;
  std::fprintf(stderr,
               "note: background subtraction on %dx%d frames runs at --downscale %d (at most %.0f "
               "million pixels are modelled)\n",
               frame_size.width, frame_size.height, factor, kMaxBackgroundPixels / 1e6);
  segment->downscale = factor;
}

struct Outputs {
  std::unique_ptr<PosesCsvWriter> csv;
  std::unique_ptr<JsonLinesWriter> json;
  std::unique_ptr<BopCsvWriter> bop;
  std::unique_ptr<VideoWriter> overlay;

  void Close() {
    if (csv) csv->Close();
    if (json) json->Close();
    if (bop) bop->Close();
    if (overlay) overlay->Close();
  }
};

void CreatePlotFolder(const TrackJob& arguments) {
  if (arguments.plots.empty()) return;
  std::error_code error;
  std::filesystem::create_directories(arguments.plots, error);
  if (error || !std::filesystem::is_directory(arguments.plots, error)) {
    ThrowError(arguments.plots, ": cannot create the plot folder",
               error ? ": " + error.message() : std::string());
  }
}

// --config FILE: the options the command line did not give, from a TOML or INI file (CLI11's
// reader): `name = value` with track's long option names (and `input`), also under [track].
void ApplyConfigFile(CLI::App* command, const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    ThrowError(path, ": config file not found (--config)");
  }
  std::vector<CLI::ConfigItem> items;
  try {
    items = CLI::ConfigTOML().from_file(path);
  } catch (const CLI::Error& fault) {
    ThrowError(path, ": cannot read the config file (--config): ", fault.what());
  }
  for (const CLI::ConfigItem& item : items) {
    const bool in_track =
        item.parents.empty() || (item.parents.size() == 1 && item.parents[0] == "track");
    CLI::Option* option = nullptr;
    if (in_track && item.name != "config" && item.name != "help") {
      option = command->get_option_no_throw("--" + item.name);
      if (option == nullptr && item.name == "input") option = command->get_option_no_throw("input");
    }
    if (option == nullptr) {
      ThrowError(path, ": unknown option '", item.fullname(),
                 "' (track's long option names without the dashes; see track --help)");
    }
    if (option->count() > 0) continue;  // the command line wins
    std::vector<std::string> values = item.inputs;
    try {
      if (option->get_expected_min() == 0) {  // a flag: true / false
        if (values.size() != 1) ThrowError("a flag takes true or false");
        values = {option->get_flag_value(item.name, values[0])};
      }
      option->add_result(values);
      option->run_callback();
    } catch (const CLI::Error& fault) {
      ThrowError(path, ": option '", item.name, "': ", fault.what());
    } catch (const Error& fault) {
      ThrowError(path, ": option '", item.name, "': ", fault.what());
    }
  }
}

// --masks-out: the folder for each frame's segmentation mask.
void CreateMasksFolder(const TrackJob& arguments) {
  if (arguments.masks_out.empty()) return;
  std::error_code error;
  std::filesystem::create_directories(arguments.masks_out, error);
  if (error || !std::filesystem::is_directory(arguments.masks_out, error)) {
    ThrowError(arguments.masks_out, ": cannot create the mask folder (--masks-out)",
               error ? ": " + error.message() : std::string());
  }
}

void WritePlots(const TrackJob& arguments, const TrackReport& report) {
  if (arguments.plots.empty() || report.num_frames() == 0) return;
  const std::filesystem::path folder = arguments.plots;
  const std::string title = std::filesystem::path(arguments.input).filename().string();
  const Figure trajectory = report.TrajectoryFigure(title);
  trajectory.WriteSvg(folder / "trajectory.svg");
  trajectory.WritePng(folder / "trajectory.png");
  if (report.has_truth()) {
    const Figure errors = report.ErrorFigure(title);
    errors.WriteSvg(folder / "error.svg");
    errors.WritePng(folder / "error.png");
  }
}

void PrintSmoothing(const TrackJob& arguments, const TrackSmoother& smoother, int frames) {
  std::printf(
      "smoothing (%s): %d of %d frames re-posed from the particle histories; %d kept as tracked "
      "(the smoothed pose fitted the silhouette worse)\n",
      arguments.smooth ? "offline" : ("lag " + std::to_string(arguments.lag)).c_str(),
      smoother.num_revised(), frames, smoother.num_kept_live());
}

// `wall_ms`: from the first frame's processing to the end of the last, reading included.
void PrintSummary(const TrackJob& arguments, const TrackReport& report, int measured,
                  double total_ms, double decode_ms, double wall_ms) {
  const int frames = report.num_frames();
  if (frames == 0) return;
  const std::string input =
      arguments.input + (arguments.tracker.brute_force ? ", brute force" : "");
  const double frames_per_second = 1000.0 * frames / std::max(wall_ms, 1e-3);
  if (arguments.read_ahead > 0) {
    std::printf(
        "tracked %d frames (%d with a usable silhouette) from %s: %.2f ms per frame, segmentation "
        "included (done on the reading thread; + %.2f ms waiting for frames), %.0f frames/s\n",
        frames, measured, input.c_str(), total_ms / frames, decode_ms / frames, frames_per_second);
  } else {
    std::printf(
        "tracked %d frames (%d with a usable silhouette) from %s: %.2f ms per frame (+ %.2f ms "
        "reading), %.0f frames/s\n",
        frames, measured, input.c_str(), total_ms / frames, decode_ms / frames, frames_per_second);
  }
  const TrackReport::StageTimes stages = report.MeanStageTimes();
  std::printf(
      "mean ms per stage (frames where it ran): segment %.3f, describe %.3f, match %.3f, "
      "pose %.3f, refine %.3f\n",
      stages.segment_ms, stages.describe_ms, stages.match_ms, stages.pose_ms, stages.refine_ms);
  const std::array<int, 6> states = report.StateCounts();
  std::printf("states (docs/confidence.md):");
  for (size_t s = 0; s < states.size(); ++s) {
    if (states[s] > 0)
      std::printf(" %s %.1f %%", TrackStateName(static_cast<TrackState>(s)),
                  100.0 * states[s] / frames);
  }
  std::printf("\n");
  if (report.has_truth()) {
    const int skip = std::min(10, frames - 1);
    const TrackAccuracy accuracy = report.Accuracy(skip);
    std::printf("against the ground truth, frames %d..%d: right object %.1f %%", skip, frames - 1,
                accuracy.RightObjectPercent());
    if (accuracy.view_error.count == 0) {
      std::printf(", no estimates");
    } else {
      std::printf(", pose error (view direction) mean %.3f median %.3f", accuracy.view_error.mean,
                  accuracy.view_error.median);
      if (accuracy.view_error.count < accuracy.frames) {
        std::printf(" (%d frames without an estimate left out)",
                    accuracy.frames - accuracy.view_error.count);
      }
    }
    if (accuracy.rotation_deg.count > 0) {
      std::printf(", rotation error median %.1f deg, translation error median %.1f %%",
                  accuracy.rotation_deg.median, 100.0 * accuracy.translation_relative.median);
    }
    std::printf("\n");
    // Only where the symmetry makes a difference (rounding aside): a symmetric true object.
    const bool symmetric =
        accuracy.view_error_symmetric.mean < accuracy.view_error.mean - 1e-9 ||
        accuracy.rotation_deg_symmetric.median < accuracy.rotation_deg.median - 1e-9;
    if (symmetric) {
      // An object that turns onto itself: its pose is known only up to that (docs/symmetry.md).
      std::printf("modulo the object's symmetry: pose error mean %.3f median %.3f",
                  accuracy.view_error_symmetric.mean, accuracy.view_error_symmetric.median);
      if (accuracy.rotation_deg_symmetric.count > 0)
        std::printf(", rotation error median %.1f deg", accuracy.rotation_deg_symmetric.median);
      std::printf("\n");
    }
    for (const TrackReport::ObjectChange& change : report.ObjectChanges()) {
      if (change.delay >= 0) {
        std::printf("the object changes at frame %d: identified %d frames later\n", change.frame,
                    change.delay);
      } else {
        std::printf("the object changes at frame %d: not identified afterwards\n", change.frame);
      }
    }
  }
}

}  // namespace

void RunTrackJob(const TrackJob& arguments) {
  TrackerOptions options = arguments.tracker;
  SegmenterOptions& segment = options.segmentation;
  segment.kind = ParseSegmenterKind(arguments.segment);
  segment.background_method = ParseBackgroundMethod(arguments.background_method);
  segment.background_learning = ParseBackgroundLearning(arguments.background_learning);
  segment.threshold_method = ParseThresholdMethod(arguments.threshold_method);
  segment.otsu_object = ParseObjectPolarity(arguments.object_polarity);
  segment.component = ParseSegmentComponent(arguments.component);
  if (!arguments.hsv_range.empty()) {
    ParseHsvRange(arguments.hsv_range, &segment);
    segment.threshold_method = ThresholdMethod::kHsvRange;
  }
  if (arguments.max_frames < 0) ThrowError("--max-frames must be >= 0");
  if (arguments.read_ahead < 0 || arguments.read_ahead > kMaxReadAhead) {
    ThrowError("--read-ahead must be 0 (read on the tracking thread) to ", kMaxReadAhead,
               " frames, got ", arguments.read_ahead);
  }
  FitParticleBounds(&options.filter);
  // Options of another segmentation kind would be ignored: refuse them.
  const TrackJob defaults;
  auto refuse_unless = [&](SegmenterKind kind, bool given, const char* option) {
    if (given && segment.kind != kind) {
      ThrowError(option, " applies to --segment ", ToString(kind), " only (this run: --segment ",
                 ToString(segment.kind), ")");
    }
  };
  refuse_unless(SegmenterKind::kThreshold, !arguments.hsv_range.empty(), "--hsv-range");
  refuse_unless(SegmenterKind::kThreshold, arguments.threshold_method != defaults.threshold_method,
                "--threshold-method");
  refuse_unless(SegmenterKind::kThreshold, arguments.object_polarity != defaults.object_polarity,
                "--object-polarity");
  refuse_unless(SegmenterKind::kBackground,
                arguments.background_method != defaults.background_method, "--bg-method");
  refuse_unless(SegmenterKind::kBackground, !segment.background_image_path.empty(), "--background");
  const SegmenterOptions& default_segment = defaults.tracker.segmentation;
  refuse_unless(SegmenterKind::kBackground,
                segment.learning_frames != default_segment.learning_frames, "--learning-frames");
  refuse_unless(SegmenterKind::kBackground,
                arguments.background_learning != defaults.background_learning, "--bg-learning");
  refuse_unless(SegmenterKind::kBackground,
                segment.min_learning_frames != default_segment.min_learning_frames,
                "--min-learning-frames");
  refuse_unless(SegmenterKind::kBackground,
                segment.object_confirm_frames != default_segment.object_confirm_frames,
                "--confirm-frames");
  refuse_unless(SegmenterKind::kBackground, segment.learning_rate != default_segment.learning_rate,
                "--learning-rate");
  refuse_unless(SegmenterKind::kBackground,
                segment.background_image_noise != default_segment.background_image_noise,
                "--background-noise");
  refuse_unless(SegmenterKind::kBackground,
                segment.detect_shadows != default_segment.detect_shadows, "--no-shadows");
  refuse_unless(SegmenterKind::kBackground,
                segment.mog2_variance_threshold != default_segment.mog2_variance_threshold,
                "--mog2-threshold");
  refuse_unless(SegmenterKind::kBackground,
                segment.knn_distance2_threshold != default_segment.knn_distance2_threshold,
                "--knn-threshold");
  refuse_unless(SegmenterKind::kBackground,
                segment.gauss_variance_threshold != default_segment.gauss_variance_threshold,
                "--gauss-threshold");
  refuse_unless(SegmenterKind::kBackground,
                segment.relearn_after_frames != default_segment.relearn_after_frames,
                "--relearn-after");
  refuse_unless(SegmenterKind::kMask,
                segment.mask_threshold != defaults.tracker.segmentation.mask_threshold,
                "--mask-threshold");
  if (!arguments.bop_object_ids.empty() && arguments.bop.empty())
    ThrowError("--bop-object-ids applies with --bop only");
  // A synth folder holds its empty scene: learn the background from it rather than from frames
  // that already show the object.
  std::error_code error;
  if (segment.kind == SegmenterKind::kBackground && segment.background_image_path.empty() &&
      std::filesystem::is_directory(arguments.input, error) &&
      std::filesystem::is_regular_file(std::filesystem::path(arguments.input) / "background.png",
                                       error)) {
    segment.background_image_path =
        (std::filesystem::path(arguments.input) / "background.png").string();
    std::printf("background subtraction from %s\n", segment.background_image_path.c_str());
  }
  if (arguments.smooth && arguments.lag > 0) ThrowError("give --smooth or --lag, not both");
  // The particle histories are read only by the smoothing: without it the filter keeps none
  // (the same estimates, a cheaper step).
  options.filter.keep_history = arguments.smooth || arguments.lag > 0;
  if (arguments.smooth || arguments.lag > 0) {
    if (options.brute_force) {
      ThrowError(arguments.smooth ? "--smooth" : "--lag",
                 " needs the particle filter's histories: not with --brute-force");
    }
    // The filter keeps the history the smoothing reads.
    int64_t& kept = options.filter.max_history_frames;
    if (arguments.smooth) {
      kept = 0;
    } else if (kept != 0 && kept <= arguments.lag) {
      kept = arguments.lag + 1;
    }
  }
  std::string problem;
  if (!options.Check(&problem)) ThrowError(problem);
  if (!segment.background_image_path.empty()) {
    CheckImageFileSize(segment.background_image_path);  // the image size limit, before decoding
  }

  FrameSourceOptions source_options;
  source_options.sequence_folder =
      segment.kind == SegmenterKind::kMask ? SequenceFolder::kMasks : SequenceFolder::kFrames;
  if (segment.kind == SegmenterKind::kMask) {
    // Masks are decoded by the one rule `match` uses too (io/mask_file.h): 16-bit values, alpha.
    source_options.color = FrameColor::kMask;
    source_options.mask_threshold = segment.mask_threshold;
  }
  std::unique_ptr<FrameSource> source = OpenFrameSource(arguments.input, source_options);
  // With --read-ahead the frames are also segmented on the reading thread, in order, with the
  // tracker's options (made at the first frame, whose size can change them).
  ReadAheadSource* ahead = nullptr;
  if (arguments.read_ahead > 0) {
    ReadAheadSource::FrameWork segment_frame =
        SegmentAhead(options.segmentation, [](cv::Size size, SegmenterOptions* at_size) {
          at_size->downscale = BackgroundDownscale(size, *at_size);
        });
    auto reader = std::make_unique<ReadAheadSource>(std::move(source), arguments.read_ahead,
                                                    std::move(segment_frame));
    ahead = reader.get();
    source = std::move(reader);
  }
  const ViewDatabase database = ViewDatabase::Read(arguments.database);
  if (!options.brute_force)
    CheckTotalParticles(options.filter, database.models.size(), arguments.database);
  if (!options.brute_force && !options.filter.adaptive &&
      static_cast<int64_t>(options.filter.particles_per_object) *
              static_cast<int64_t>(database.models.size()) >=
          kManyParticlesHint) {
    // A fixed count scores every object's particles every frame; the adaptive count keeps one
    // particle per unlikely object (docs/PERFORMANCE.md, "Scale").
    std::fprintf(stderr,
                 "note: %zu objects x %d particles = %lld particles scored every frame; with "
                 "--adaptive an unlikely object keeps one particle (at 200 objects about 500 in "
                 "all, 1.7 ms instead of 23 ms per frame, as accurate: docs/PERFORMANCE.md)\n",
                 database.models.size(), options.filter.particles_per_object,
                 static_cast<long long>(options.filter.particles_per_object) *
                     static_cast<long long>(database.models.size()));
  }

  // The first frame fixes the size (cameras and unindexed videos do not say it before).
  cv::Mat frame;
  auto read_start = std::chrono::steady_clock::now();
  if (!source->Read(&frame)) ThrowError(arguments.input, ": no frames");
  double decode_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - read_start)
          .count();
  const PinholeCamera camera = ChooseCamera(arguments, frame.size());
  LimitBackgroundSubtraction(frame.size(), &options.segmentation);
  Tracker tracker(database, camera, options);

  const std::vector<GroundTruthFrame> truth = ChooseGroundTruth(arguments);
  TrackReport report(database);

  // Every output is checked and locked before the first is created; if one cannot be opened,
  // those created are removed again.
  OutputGuard guard({{arguments.output, "-o"},
                     {arguments.json, "--json"},
                     {arguments.bop, "--bop"},
                     {arguments.overlay, "--overlay"}});
  Outputs outputs;
  outputs.csv = std::make_unique<PosesCsvWriter>(arguments.output);
  if (!arguments.json.empty()) outputs.json = std::make_unique<JsonLinesWriter>(arguments.json);
  if (!arguments.bop.empty()) {
    BopOutputOptions bop;
    bop.scene_id = arguments.bop_scene;
    bop.object_ids = arguments.bop_object_ids;
    bop.model_unit_mm = arguments.model_unit_mm;
    if (!bop.object_ids.empty() && bop.object_ids.size() != database.models.size()) {
      ThrowError("--bop-object-ids gives ", bop.object_ids.size(), " ids for ",
                 database.models.size(), " models in ", arguments.database);
    }
    outputs.bop = std::make_unique<BopCsvWriter>(arguments.bop, bop);
  }
  CreatePlotFolder(arguments);
  CreateMasksFolder(arguments);
  std::vector<std::optional<TriangleMesh>> meshes;
  if (!arguments.overlay.empty()) {
    const double fps = source->fps() > 0.0 ? source->fps() : 30.0;
    outputs.overlay = OpenVideoWriter(arguments.overlay, frame.size(), fps);
    meshes = OverlayMeshes(arguments, database);
  }

  guard.Opened();
  std::optional<int> total = source->num_frames();
  if (total && arguments.max_frames > 0) total = std::min(*total, arguments.max_frames);
  ProgressBar progress("track", total.value_or(0));
  int measured = 0;
  int rows_written = 0;  // POSES.csv rows on disk
  double total_ms = 0.0;
  const auto loop_start = std::chrono::steady_clock::now();
  const auto wall_ms = [&loop_start] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - loop_start)
        .count();
  };
  std::unique_ptr<TrackSmoother> smoother;
  if (arguments.smooth || arguments.lag > 0) {
    smoother = std::make_unique<TrackSmoother>(
        tracker, arguments.smooth ? TrackSmoother::kOffline : arguments.lag);
  }
  // What each frame needs once its result is final (later, with smoothing): its name, number and
  // (for the overlay) the image; offline the image waits JPEG-compressed.
  struct Waiting {
    int frame = 0;  // the tracker's frame number
    std::string name;
    int image_id = -1;
    int index = 0;
    cv::Mat image;
    std::vector<unsigned char> jpeg;
  };
  std::deque<Waiting> waiting;
  const auto emit = [&](TrackedFrame tracked) {
    // Frames come out in order; one whose result was lost to a fault is skipped.
    while (!waiting.empty() && waiting.front().frame < tracked.result.frame) waiting.pop_front();
    Waiting info;
    info.index = tracked.result.frame;
    if (!waiting.empty() && waiting.front().frame == tracked.result.frame) {
      info = std::move(waiting.front());
      waiting.pop_front();
    }
    cv::Mat image = info.image;
    if (!info.jpeg.empty()) image = DecodeImage(info.jpeg, cv::IMREAD_COLOR);
    tracked.result.frame_name = info.name;
    tracked.result.image_id = info.image_id;
    const int index = info.index;
    DropNonFinitePose(&tracked.result);
    const FrameResult& result = tracked.result;
    total_ms += result.time_ms;
    measured += tracked.silhouette.ok();
    outputs.csv->Write(result);
    ++rows_written;
    if (outputs.json) outputs.json->Write(result);
    if (outputs.bop) outputs.bop->Write(result);
    std::optional<TruthFrame> frame_truth;
    const auto row =
        std::lower_bound(truth.begin(), truth.end(), index,
                         [](const GroundTruthFrame& a, int value) { return a.frame < value; });
    if (row != truth.end() && row->frame == index) {
      frame_truth =
          MakeTruthFrame(database, row->object, row->view_dir_in_object, row->camera_from_object);
    }
    report.Add(result, frame_truth);
    if (!arguments.masks_out.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.png", index);
      WriteMask(std::filesystem::path(arguments.masks_out) / name, tracked.segmentation.mask);
    }
    if (outputs.overlay && !image.empty()) {
      OverlayOptions overlay;
      overlay.frame_number = index;
      PosedModel posed;
      const PosedModel* model = nullptr;
      if (result.camera_from_object && result.object >= 0 &&
          meshes[static_cast<size_t>(result.object)]) {
        posed.mesh = &*meshes[static_cast<size_t>(result.object)];
        posed.camera = camera;
        posed.camera_from_object = *result.camera_from_object;
        model = &posed;
      }
      const std::string label =
          result.object >= 0 ? result.object_name : std::string("(no estimate)");
      outputs.overlay->Write(
          DrawOverlay(image, tracked.segmentation.mask, model, label, result.score, overlay));
    }
  };
  try {
    do {
      Waiting info;
      info.frame = tracker.num_frames();
      info.name = source->name();
      info.image_id = NumericStem(info.name);
      // Ground truth rows are matched by the image's number when it has one, else by the index.
      info.index = info.image_id >= 0 ? info.image_id : source->frame_index();
      if (outputs.overlay) {
        if (!smoother) {
          info.image = frame;
        } else if (arguments.smooth) {
          if (!EncodeImage(".jpg", frame, &info.jpeg, {cv::IMWRITE_JPEG_QUALITY, 90}))
            ThrowError(info.name, ": could not keep the frame for the overlay");
        } else {
          info.image = frame.clone();
        }
      }
      waiting.push_back(std::move(info));
      if (ahead != nullptr) {
        // Segmented on the reading thread.
        auto& segmented = std::any_cast<AheadSegmentation&>(ahead->work_result());
        if (smoother) {
          for (TrackedFrame& done :
               smoother->Process(frame, std::move(segmented.result), segmented.ms))
            emit(std::move(done));
        } else {
          emit(tracker.Process(frame, std::move(segmented.result), segmented.ms));
        }
      } else if (smoother) {
        for (TrackedFrame& done : smoother->Process(frame)) emit(std::move(done));
      } else {
        emit(tracker.Process(frame));
      }
      progress.Advance();
      if (arguments.max_frames > 0 && tracker.num_frames() >= arguments.max_frames) break;
      read_start = std::chrono::steady_clock::now();
      const bool more = source->Read(&frame);
      decode_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - read_start)
              .count();
      if (!more) break;
    } while (true);
    if (smoother) {
      for (TrackedFrame& done : smoother->Finish()) emit(std::move(done));
      PrintSmoothing(arguments, *smoother, tracker.num_frames());
    }
  } catch (const Error& fault) {
    // Keep what was tracked before the fault: the rows are on disk already (those the smoother
    // still holds are written now, smoothed by what was seen); finish the overlay video and the
    // plots, then report the fault.
    progress.Finish();
    try {
      if (smoother) {
        for (TrackedFrame& done : smoother->Finish()) emit(std::move(done));
      }
    } catch (const Error&) {
      // The output that failed: the rows written so far stay.
    }
    try {
      outputs.Close();
      WritePlots(arguments, report);
    } catch (const Error& second) {
      // The file that failed usually fails again when closed: one message about it is enough.
      const std::string first_text = fault.what();
      const std::string second_text = second.what();
      if (second_text.substr(0, second_text.find(':')) !=
          first_text.substr(0, first_text.find(':'))) {
        std::fprintf(stderr, "warning: %s\n", second.what());
      }
    }
    PrintSummary(arguments, report, measured, total_ms, decode_ms, wall_ms());
    ThrowError(fault.what(), " (stopped after ", rows_written, " frames; their results are in ",
               arguments.output, ")");
  }
  progress.Finish();
  outputs.Close();
  WritePlots(arguments, report);
  PrintSummary(arguments, report, measured, total_ms, decode_ms, wall_ms());
  std::printf("wrote %s", arguments.output.c_str());
  for (const std::string* extra : {&arguments.json, &arguments.bop, &arguments.overlay,
                                   &arguments.plots, &arguments.masks_out}) {
    if (!extra->empty()) std::printf(", %s", extra->c_str());
  }
  std::printf("\n");
}

void AddTrackCommand(CLI::App& app) {
  auto arguments = std::make_shared<TrackJob>();
  CLI::App* command = app.add_subcommand(
      "track",
      "Identify the object and follow its 6-DOF pose through a video, an image folder or a camera "
      "with the particle filter over (object, view, roll) of the paper; writes one POSES.csv row "
      "per frame, and on request JSON Lines, BOP19 results, an overlay video and plots.");
  // -d, input and -o are required, from the command line or the --config file (checked then).
  command->add_option("-d,--database", arguments->database,
                      "Database file from build-db (required)");
  command->add_option("input", arguments->input,
                      "Folder of images (name order; a synth folder's masks/ or, with --segment "
                      "bgsub/threshold, frames/), a video file (.avi; .mp4 and others in a "
                      "SILPOSE_WITH_VIDEOIO build), or a live camera (/dev/video0 or its number 0; "
                      "Video4Linux2); required");
  command->add_option("-o,--output", arguments->output, "POSES.csv to write (required)");
  command->add_option("--camera", arguments->camera,
                      "OpenCV calibration YAML of the camera (silpose calibrate); default: "
                      "INPUT/camera.yml for a synth folder, else focal 0.82 x width (a warning)");
  command->add_option("--json", arguments->json, "Also write the results as JSON Lines");
  command->add_option("--bop", arguments->bop,
                      "Also write a BOP19 results CSV (scene_id,im_id,obj_id,score,R,t,time)");
  command->add_option("--bop-scene", arguments->bop_scene, "BOP scene_id")->capture_default_str();
  command
      ->add_option("--bop-object-ids", arguments->bop_object_ids,
                   "BOP obj_id of each database model, in database order (default 1, 2, ...)")
      ->delimiter(',');
  command
      ->add_option("--model-unit-mm", arguments->model_unit_mm,
                   "Millimetres per model unit, for BOP's t in mm (1000 for meshes in metres)")
      ->capture_default_str();
  command->add_option("--overlay", arguments->overlay,
                      "Write a video of the frames with the segmentation (red) and the model at "
                      "the estimated pose (green): .avi (MJPEG), or .mp4 in a SILPOSE_WITH_VIDEOIO "
                      "build");
  command->add_option("--models", arguments->models,
                      "Meshes (files or folders) for the overlay, matched to the database models "
                      "by name; default: the paths the database was built from");
  command->add_option("--plots", arguments->plots,
                      "Folder for trajectory.svg/png (view sphere, paper Fig. 5) and, with ground "
                      "truth, error.svg/png (pose error over frames, Fig. 6)");
  command->add_option("--ground-truth", arguments->ground_truth,
                      "groundtruth.csv to compare with (default: INPUT/groundtruth.csv of a synth "
                      "folder)");
  command->add_option("--masks-out", arguments->masks_out,
                      "Write each frame's segmentation mask to this folder as a PNG named like "
                      "the frame (000012.png; the frame's index for videos), all black where the "
                      "segmentation found nothing: to see the masks while tuning the options");
  command->add_option("--max-frames", arguments->max_frames, "Stop after N frames (0: all)");
  command
      ->add_option("--read-ahead", arguments->read_ahead,
                   "Frames decoded and segmented ahead of the tracking on a second thread, so "
                   "that both overlap it (0: on the tracking thread)")
      ->capture_default_str();
  ParticleFilterOptions& filter = arguments->tracker.filter;
  command
      ->add_option("--particles", filter.particles_per_object,
                   "Particles per object (paper: 60); at most 1000000 over all objects")
      ->capture_default_str();
  command
      ->add_option("--min-particles", filter.min_particles_per_object,
                   "--adaptive: the fewest particles an object keeps")
      ->capture_default_str();
  command
      ->add_option("--dormant-particles", filter.dormant_particles_per_object,
                   "--adaptive: the fewest particles an object keeps while its probability is "
                   "below 1 % (at most --min-particles)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command
      ->add_option("--max-particles", filter.max_particles_per_object,
                   "--adaptive: the most particles an object may grow to (raise it with more "
                   "--particles)")
      ->capture_default_str();
  command->add_flag("--adaptive", filter.adaptive,
                    "Adapt the particle count per object by KLD-sampling (paper 4.3)");
  command->add_flag("--brute-force", arguments->tracker.brute_force,
                    "Match every frame against the whole database independently (the paper's "
                    "baseline) instead of filtering");
  command->add_option("--seed", filter.seed, "Seed of the particle filter")
      ->capture_default_str()
      ->check(SeedNumber());
  command
      ->add_option("--lag", arguments->lag,
                   "Report each frame N frames late, corrected by what the particle filter saw "
                   "after it (live smoothing from the particle histories; docs/tracking.md)")
      ->check(CLI::Range(0, 100000));
  command->add_flag("--smooth", arguments->smooth,
                    "Report every frame at the end of the input from the particle history that "
                    "explains the whole input best (offline smoothing; docs/tracking.md)");
  command->add_flag("!--no-refine", arguments->tracker.refine,
                    "Report the database view's pose without the continuous contour refinement");
  command->add_flag_callback(
      "--no-fit-arbitration", [arguments] { arguments->tracker.fit_arbitration_ratio = 0.0; },
      "Let the scores alone decide when the frame's best-scoring hypothesis lies outside the "
      "filter's mode (by default both are refined and the better fit is reported; "
      "docs/tracking.md); also turns off the mirror-twin check, which uses the same rule");
  command->add_flag("!--no-motion-start", arguments->tracker.refine_from_motion,
                    "Refine every frame's pose from its database view alone, not also from the "
                    "previous frame's refined pose carried on by the motion (docs/tracking.md)");
  command->add_flag_callback(
      "--no-view-polish", [arguments] { arguments->tracker.polish_steps = 0; },
      "Start the pose from the filter's estimated view as it is, not from the best-scoring view "
      "next to it (docs/tracking.md)");
  command->add_flag("!--no-twin-check", arguments->tracker.mirror_twin_check,
                    "Report the matched pose of an object with a mirror plane without also "
                    "fitting its mirror twin, the pose that casts the same outline from far away "
                    "(docs/tracking.md)");
  command->add_flag("!--no-other-pose-check", arguments->tracker.other_pose_check,
                    "Report the matched pose without also fitting the object's best-scoring pose "
                    "more than 15 degrees away, which is reported when it fits the outline far "
                    "closer (docs/tracking.md)");
  command
      ->add_option("--min-confidence", arguments->tracker.state.min_confidence,
                   "Confidence from which a frame's state is 'tracking' (docs/confidence.md)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  command->add_flag("!--no-canonical-poses", arguments->tracker.canonical_poses,
                    "Report the poses of symmetric objects as matched, not in the canonical form "
                    "of docs/symmetry.md");
  command->add_flag("!--no-on-axis", arguments->tracker.on_axis_matching,
                    "Match the raw silhouette instead of the on-axis, undistorted one");
  static const std::map<std::string, MotionModel> kMotionModels = {
      {"adaptive", MotionModel::kAdaptive}, {"neighbour", MotionModel::kNeighbour}};
  command
      ->add_option("--motion", filter.motion_model,
                   "Motion model: adaptive (rotation walk with velocity, any speed) or neighbour "
                   "(the paper's: one neighbouring view per frame)")
      ->transform(CLI::CheckedTransformer(kMotionModels, CLI::ignore_case));
  command->add_flag("!--no-proposal", filter.data_driven_proposal,
                    "No particles from the frame's best database views (the paper's filter)");
  SegmenterOptions& segment = arguments->tracker.segmentation;
  command
      ->add_option("--segment", arguments->segment,
                   "How frames become silhouettes: mask (frames are masks), bgsub (static camera: "
                   "background subtraction), threshold (Otsu or --hsv-range)")
      ->capture_default_str();
  command
      ->add_option("--bg-method", arguments->background_method,
                   "bgsub: mog2, knn or gauss (one Gaussian per pixel: the cheapest, for a "
                   "background that does not flicker)")
      ->capture_default_str();
  command->add_option("--background", segment.background_image_path,
                      "bgsub: image of the empty scene (default: learn from the first frames)");
  command
      ->add_option("--bg-learning", arguments->background_learning,
                   "bgsub without --background: until-object (learn every frame in which no "
                   "object is found, until one is found in --confirm-frames frames in a row) or "
                   "frames (learn the first --learning-frames frames, whatever they show)")
      ->capture_default_str();
  command
      ->add_option("--learning-frames", segment.learning_frames,
                   "bgsub: frames learned with --bg-learning frames (the scene should be empty "
                   "or the object moving); the running average's window with until-object")
      ->capture_default_str();
  command
      ->add_option("--min-learning-frames", segment.min_learning_frames,
                   "bgsub until-object: frames learned before looking for an object")
      ->capture_default_str();
  command
      ->add_option("--confirm-frames", segment.object_confirm_frames,
                   "bgsub until-object: learning stops once an object is found in this many "
                   "frames in a row")
      ->capture_default_str();
  command
      ->add_option("--learning-rate", segment.learning_rate,
                   "bgsub: model update rate after learning, [0, 1); 0 = frozen (a still object "
                   "must not fade into the background)")
      ->capture_default_str();
  command
      ->add_option("--background-noise", segment.background_image_noise,
                   "bgsub --background: camera noise (grey levels) added to the image of the "
                   "empty scene while learning it")
      ->capture_default_str();
  command->add_flag("!--no-shadows", segment.detect_shadows,
                    "bgsub: count shadows as object (by default darker pixels of the same "
                    "chromaticity are background)");
  command
      ->add_option("--mog2-threshold", segment.mog2_variance_threshold,
                   "bgsub mog2: squared Mahalanobis distance of a foreground pixel (16 = 4 "
                   "sigma); lower finds objects of lower contrast")
      ->capture_default_str();
  command
      ->add_option("--knn-threshold", segment.knn_distance2_threshold,
                   "bgsub knn: squared distance of a foreground pixel, grey levels squared "
                   "summed over channels (400 = 20 levels)")
      ->capture_default_str();
  command
      ->add_option("--gauss-threshold", segment.gauss_variance_threshold,
                   "bgsub gauss: squared distance of a foreground pixel from the background's "
                   "mean, in variances (16 = 4 sigma); lower finds objects of lower contrast")
      ->capture_default_str();
  command
      ->add_option("--relearn-after", segment.relearn_after_frames,
                   "bgsub: learn the background anew after this many frames in a row with too "
                   "much foreground (0 = never)")
      ->capture_default_str();
  command->add_option("--threshold-method", arguments->threshold_method, "threshold: otsu or hsv")
      ->capture_default_str();
  command
      ->add_option("--object-polarity", arguments->object_polarity,
                   "threshold otsu: the object is darker or brighter than the background")
      ->capture_default_str();
  command->add_option("--hsv-range", arguments->hsv_range,
                      "threshold: object colours H,S,V,H,S,V (OpenCV ranges H 0-179, S, V 0-255)");
  command
      ->add_option("--mask-threshold", segment.mask_threshold,
                   "mask: a pixel is object above this value (0: non-zero; 127 for lossy masks)")
      ->capture_default_str();
  command
      ->add_option("--morphology", segment.morphology_px,
                   "Radius of the clean-up opening/closing, pixels (-1: 0 for masks, 2 otherwise)")
      ->capture_default_str();
  command
      ->add_option("--component", arguments->component,
                   "Which blob is the object: largest, or nearest (to the last frame's)")
      ->capture_default_str();
  command
      ->add_option("--min-area", segment.min_area_fraction,
                   "Blobs smaller than this fraction of the frame are ignored, [0, 1)")
      ->capture_default_str();
  command
      ->add_option("--max-foreground", segment.max_foreground_fraction,
                   "A frame with more than this fraction of foreground fails (too-large: "
                   "lighting change, camera moved), (0, 1]")
      ->capture_default_str();
  command
      ->add_option("--downscale", segment.downscale,
                   "bgsub/threshold: segment a frame shrunk by this factor (faster)")
      ->capture_default_str();
  auto config = std::make_shared<std::string>();
  command->add_option("--config", *config,
                      "Read options from this TOML or INI file: option = value, long names without "
                      "the dashes (docs/segmentation.md); the command line wins");
  command->callback([arguments, command, config] {
    if (!config->empty()) ApplyConfigFile(command, *config);
    if (arguments->database.empty()) ThrowError("--database is required (see --help)");
    if (arguments->input.empty()) ThrowError("input is required (see --help)");
    if (arguments->output.empty()) ThrowError("--output is required (see --help)");
    RunTrackJob(*arguments);
  });
}

}  // namespace silpose::cli
