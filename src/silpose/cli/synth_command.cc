#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "silpose/cli/cli_checks.h"
#include "silpose/cli/commands.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/video_writer.h"
#include "silpose/synth/colour_frames.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct SynthArguments {
  std::vector<std::string> models;
  std::string output;
  std::string trajectory = "orbit";
  int frames = 0;  // 0: orbit one loop, walk 360
  double step_deg = 1.0;
  double tilt_deg = 30.0;
  std::string camera;
  double distance_radii = 3.0;
  std::vector<double> distance_range;  // empty: walk 3,6; handheld 4,10
  HandheldOptions handheld;
  std::vector<double> speed_range = {handheld.speed_min_deg, handheld.speed_max_deg};
  double roll_deg = 0.0;
  double roll_speed_deg = 0.5;
  std::vector<int> switch_at;
  int switch_every = 0;
  uint64_t seed = 1;
  int threads = 0;
  bool overwrite = false;
  DegradationOptions degradation;
  std::string mask_quality = "perfect";
  // The mask effects given on the command line: they override the --mask-quality preset.
  std::vector<std::pair<CLI::Option*, void (*)(const DegradationOptions&, DegradationOptions*)>>
      effect_options;
  bool colour = false;
  std::string background;
  double camera_noise = 0.0;
  double flicker = 0.0;
  std::vector<double> object_colours;  // B,G,R per model, or one B,G,R for all
  // Options given on the command line (CLI11 counts), to refuse those that do not apply.
  CLI::Option* tilt_option = nullptr;
  CLI::Option* distance_option = nullptr;
  CLI::Option* range_option = nullptr;
  CLI::Option* roll_speed_option = nullptr;
  CLI::Option* step_option = nullptr;
  CLI::Option* roll_option = nullptr;
  std::vector<CLI::Option*> handheld_options;  // only for --trajectory handheld
  bool video = false;
  double fps = 30.0;
  std::vector<CLI::Option*> colour_options;  // need --colour
};

void RefuseFor(const CLI::Option* option, const char* trajectory) {
  if (option->count() > 0) {
    ThrowError(option->get_name(), " does not apply to --trajectory ", trajectory);
  }
}

// The handheld options from the command line, each checked with a message naming its option.
HandheldOptions MakeHandheld(const SynthArguments& arguments) {
  HandheldOptions hand = arguments.handheld;
  hand.seed = arguments.seed;
  if (arguments.speed_range.size() != 2) {
    ThrowError("--speed-range must be two numbers MIN,MAX (degrees per frame)");
  }
  hand.speed_min_deg = arguments.speed_range[0];
  hand.speed_max_deg = arguments.speed_range[1];
  if (!(hand.speed_min_deg >= 0.0 && hand.speed_max_deg >= hand.speed_min_deg &&
        hand.speed_max_deg <= 45.0)) {
    ThrowError("--speed-range must satisfy 0 <= MIN <= MAX <= 45 (degrees per frame), got ",
               hand.speed_min_deg, ",", hand.speed_max_deg);
  }
  const std::pair<double, const char*> probabilities[] = {
      {hand.pause_probability, "--pause-probability"},
      {hand.reverse_probability, "--reverse-probability"},
      {hand.cut_probability, "--cut-probability"}};
  for (const auto& [value, name] : probabilities) {
    if (!(value >= 0.0 && value <= 1.0)) ThrowError(name, " must be in [0, 1], got ", value);
  }
  if (!(hand.max_off_axis_deg >= 0.0 && hand.max_off_axis_deg <= 60.0)) {
    ThrowError("--max-off-axis-deg must be in [0, 60] degrees, got ", hand.max_off_axis_deg);
  }
  if (!arguments.distance_range.empty()) {
    hand.distance_min_radii = arguments.distance_range[0];
    hand.distance_max_radii = arguments.distance_range[1];
    if (!(hand.distance_min_radii > 1.0 && hand.distance_max_radii >= hand.distance_min_radii &&
          std::isfinite(hand.distance_max_radii))) {
      ThrowError("--distance-range must satisfy 1 < MIN <= MAX (object radii), got ",
                 hand.distance_min_radii, ",", hand.distance_max_radii);
    }
  }
  std::string problem;
  if (!hand.Check(&problem)) ThrowError("invalid handheld trajectory: ", problem);
  return hand;
}

TrajectoryOptions MakeTrajectory(const SynthArguments& arguments, int num_models) {
  TrajectoryOptions trajectory;
  if (arguments.frames < 0) ThrowError("--frames must be >= 1 (or 0 for the default)");
  if (arguments.trajectory != "handheld") {
    for (const CLI::Option* option : arguments.handheld_options) {
      RefuseFor(option, arguments.trajectory.c_str());
    }
  }
  if (!arguments.distance_range.empty() && arguments.distance_range.size() != 2) {
    ThrowError("--distance-range must be two numbers MIN,MAX (object radii)");
  }
  if (arguments.trajectory == "handheld") {
    for (const CLI::Option* option :
         {arguments.step_option, arguments.tilt_option, arguments.distance_option,
          arguments.roll_option, arguments.roll_speed_option}) {
      RefuseFor(option, "handheld");
    }
    trajectory.kind = TrajectoryKind::kHandheld;
    trajectory.handheld = MakeHandheld(arguments);
    trajectory.num_frames = arguments.frames > 0 ? arguments.frames : 360;
  } else if (arguments.trajectory == "orbit") {
    RefuseFor(arguments.range_option, "orbit");
    RefuseFor(arguments.roll_speed_option, "orbit");
    trajectory.kind = TrajectoryKind::kOrbit;
    OrbitOptions& orbit = trajectory.orbit;
    orbit.step_deg = arguments.step_deg;
    orbit.tilt_deg = arguments.tilt_deg;
    orbit.roll_deg = arguments.roll_deg;
    orbit.distance_in_radii = arguments.distance_radii;
    std::string problem;
    if (!orbit.Check(&problem)) {
      ThrowError("invalid orbit (--step-deg, --tilt-deg, ...): ", problem);
    }
    trajectory.num_frames = arguments.frames > 0 ? arguments.frames : orbit.FramesPerLoop();
  } else {
    RefuseFor(arguments.tilt_option, "walk");
    trajectory.kind = TrajectoryKind::kWalk;
    WalkOptions& walk = trajectory.walk;
    walk.seed = arguments.seed;
    walk.speed_sigma_deg = arguments.step_deg;
    walk.start_roll_deg = arguments.roll_deg;
    walk.roll_speed_sigma_deg = arguments.roll_speed_deg;
    if (!arguments.distance_range.empty()) {
      walk.distance_min_radii = arguments.distance_range[0];
      walk.distance_max_radii = arguments.distance_range[1];
    }
    if (arguments.distance_option->count() > 0) {
      walk.start_distance_radii = arguments.distance_radii;
    }
    std::string problem;
    if (!walk.Check(&problem)) {
      ThrowError("invalid walk (--step-deg, --distance-range, --distance, ...): ", problem);
    }
    trajectory.num_frames = arguments.frames > 0 ? arguments.frames : 360;
  }

  // Which model when: explicit switch frames, a fixed period, or equal segments.
  if (!arguments.switch_at.empty()) {
    if (arguments.switch_every > 0) ThrowError("give --switch-at or --switch-every, not both");
    if (static_cast<int>(arguments.switch_at.size()) != num_models - 1) {
      ThrowError("--switch-at needs one frame per model after the first: ", num_models,
                 " model(s) need ", num_models - 1, " frame(s), got ", arguments.switch_at.size());
    }
    for (size_t i = 0; i < arguments.switch_at.size(); ++i) {
      const int frame = arguments.switch_at[i];
      if (frame < 1 || frame >= trajectory.num_frames ||
          (i > 0 && frame <= arguments.switch_at[i - 1])) {
        ThrowError("--switch-at frames must increase, within 1..", trajectory.num_frames - 1,
                   "; got ", frame);
      }
      trajectory.object_switches.push_back({frame, static_cast<int>(i) + 1});
    }
  } else {
    if (arguments.switch_every < 0) ThrowError("--switch-every must be >= 1");
    if (arguments.switch_every > 0 && num_models < 2) {
      ThrowError("--switch-every needs at least two models");
    }
    trajectory.object_switches =
        CyclicObjectSwitches(num_models, trajectory.num_frames, arguments.switch_every);
  }
  std::string problem;
  if (!trajectory.Check(&problem)) ThrowError("invalid trajectory: ", problem);
  return trajectory;
}

ColourOptions MakeColour(const SynthArguments& arguments, int num_models) {
  if (!arguments.colour) {
    for (const CLI::Option* option : arguments.colour_options) {
      if (option->count() > 0) ThrowError(option->get_name(), " needs --colour");
    }
    return {};
  }
  ColourOptions colour;
  colour.enabled = true;
  colour.seed = arguments.seed;
  colour.background_seed = arguments.seed;
  colour.noise_sigma = arguments.camera_noise;
  colour.flicker = arguments.flicker;
  const std::vector<double>& values = arguments.object_colours;
  if (!values.empty()) {
    if (values.size() % 3 != 0 ||
        (values.size() != 3 && values.size() != 3 * static_cast<size_t>(num_models))) {
      ThrowError("--object-colour needs B,G,R (all models) or one B,G,R per model (",
                 3 * num_models, " numbers), got ", values.size(), " numbers");
    }
    for (size_t i = 0; i < values.size(); i += 3) {
      colour.object_colours_bgr.emplace_back(values[i], values[i + 1], values[i + 2]);
    }
  }
  std::string problem;
  if (!colour.Check(&problem)) {
    ThrowError("invalid colour frames (--camera-noise, --flicker, --object-colour): ", problem);
  }
  if (!arguments.background.empty()) {
    colour.background_image = ReadBackgroundImage(arguments.background);
  }
  return colour;
}

// How the sequence is written. Its colour_frame_sink, when set, receives every colour frame in
// frame order while the frames are generated (a video encoder goes there).
SequenceWriteOptions MakeWriteOptions(const SynthArguments& arguments) {
  SequenceWriteOptions write;
  write.num_threads = arguments.threads;
  write.show_progress = true;
  write.overwrite = arguments.overwrite;
  write.write_colour_frames = arguments.colour;
  return write;
}

// The degradations: the --mask-quality preset, then the effects given one by one, each checked
// with a message naming its option.
DegradationOptions MakeDegradation(const SynthArguments& arguments) {
  MaskQuality quality = MaskQuality::kPerfect;
  if (!ParseMaskQuality(arguments.mask_quality, &quality)) {
    ThrowError("--mask-quality must be perfect or threshold, got '", arguments.mask_quality, "'");
  }
  const DegradationOptions& given = arguments.degradation;
  DegradationOptions degradation = WithMaskQuality(given, quality);
  for (const auto& [option, copy] : arguments.effect_options) {
    if (option->count() > 0) copy(given, &degradation);
  }
  degradation.seed = arguments.seed;
  const auto in = [](double value, double low, double high) {
    return std::isfinite(value) && value >= low && value <= high;
  };
  const struct {
    bool ok;
    const char* message;
  } checks[] = {
      {in(degradation.ragged_px, 0, 20), "--ragged must be in [0, 20] pixels"},
      {in(degradation.ragged_scale_px, 1, 100), "--ragged-scale must be in [1, 100] pixels"},
      {degradation.holes >= 0 && degradation.holes <= 100, "--holes must be in [0, 100]"},
      {in(degradation.hole_radius_px, 1, 50), "--hole-radius must be in [1, 50] pixels"},
      {in(degradation.stick_width_px, 1, 100), "--stick-width must be in [1, 100] pixels"},
      {in(degradation.stick_length, 1e-9, 5), "--stick-length must be in (0, 5]"},
      {degradation.fingers >= 0 && degradation.fingers <= 5, "--fingers must be in [0, 5]"},
      {in(degradation.shadow, 0, 1), "--shadow must be in [0, 1]"},
      {degradation.specks >= 0 && degradation.specks <= 1000, "--specks must be in [0, 1000]"},
      {in(degradation.passing_share, 0, 1), "--passing must be in [0, 1] (a share of the frames)"},
      {degradation.pass_frames >= 2 && degradation.pass_frames <= 1000,
       "--pass-frames must be in [2, 1000]"},
      {in(degradation.pass_size, 1e-9, 2), "--pass-size must be in (0, 2]"},
  };
  for (const auto& check : checks) {
    if (!check.ok) ThrowError(check.message);
  }
  std::string problem;
  if (!degradation.Check(&problem)) {
    ThrowError("invalid degradation (--noise, --erode, --missed, --bad, ...): ", problem);
  }
  return degradation;
}

void RunSynth(const SynthArguments& arguments) {
  SequenceOptions options;
  options.trajectory = MakeTrajectory(arguments, static_cast<int>(arguments.models.size()));
  options.degradation = MakeDegradation(arguments);
  if (arguments.threads < 0) ThrowError("--threads must be >= 0 (0 = all cores)");
  if (!(arguments.fps > 0.0 && arguments.fps <= 1000.0)) ThrowError("--fps must be in (0, 1000]");
  if (!arguments.camera.empty()) options.camera = ReadCameraFile(arguments.camera);
  options.colour = MakeColour(arguments, static_cast<int>(arguments.models.size()));

  std::vector<TriangleMesh> meshes;
  for (const std::string& model : arguments.models) {
    for (const TriangleMesh& other : meshes) {
      if (other.name == std::filesystem::path(model).stem().string()) {
        ThrowError(model, ": another model is also named '", other.name,
                   "' (model names are file stems and must be unique)");
      }
    }
    meshes.push_back(LoadMesh(model));
  }
  const SyntheticSequence sequence(std::move(meshes), options);
  SequenceWriteOptions write = MakeWriteOptions(arguments);
  std::unique_ptr<VideoWriter> video;
  if (arguments.video) {
    // DIR/video.avi: the colour frames as one MJPEG video, what a camera would record.
    std::error_code error;
    std::filesystem::create_directories(arguments.output, error);
    video =
        OpenVideoWriter(std::filesystem::path(arguments.output) / "video.avi",
                        cv::Size(options.camera.width_px, options.camera.height_px), arguments.fps);
    write.colour_frame_sink = [&video](int, const cv::Mat& frame) { video->Write(frame); };
  }
  const SequenceSummary summary = WriteSequence(sequence, arguments.output, write);
  if (video) video->Close();
  std::printf("%s: %s trajectory, %s, %dx%d camera\n", summary.BriefReport().c_str(),
              TrajectoryKindName(options.trajectory.kind),
              sequence.meshes().size() == 1
                  ? sequence.meshes().front().name.c_str()
                  : (std::to_string(sequence.meshes().size()) + " models").c_str(),
              options.camera.width_px, options.camera.height_px);
  if (summary.touching_border > 0) {
    std::fprintf(stderr,
                 "silpose synth: warning: in %d frames the object is cut by the image border; "
                 "increase --distance\n",
                 summary.touching_border);
  }
  if (summary.out_of_view > 0) {
    std::fprintf(stderr, "silpose synth: warning: in %d frames the object is out of view\n",
                 summary.out_of_view);
  }
}

}  // namespace

void AddSynthCommand(CLI::App& app) {
  auto arguments = std::make_shared<SynthArguments>();
  CLI::App* command = app.add_subcommand(
      "synth",
      "Render a synthetic silhouette sequence with exact ground truth: masks/000000.png..., "
      "camera.yml and groundtruth.csv (frame, object, view, roll, 6-DOF pose, distance, "
      "degradation), and with --colour shaded colour frames/000000.png... With several models "
      "the sequence shows them in turn.");
  command
      ->add_option("models", arguments->models,
                   "Mesh files; the first is shown first (see --switch-at, --switch-every)")
      ->required();
  command->add_option("-o,--output", arguments->output, "Sequence folder to write")->required();
  command
      ->add_option("--trajectory", arguments->trajectory,
                   "orbit: a great circle around the object at a constant step, distance and "
                   "roll (the paper's flight); walk: a smooth seeded random walk of view, roll "
                   "and distance; handheld: the object turned by hand in front of a static "
                   "camera (bursts of rotation, pauses, reversals, rare cuts, wandering distance "
                   "and position in the image; see --speed-range ... --max-off-axis-deg)")
      ->check(CLI::IsMember({"orbit", "walk", "handheld"}))
      ->capture_default_str();
  command->add_option(
      "--frames", arguments->frames,
      "Frames to render (0 = default: orbit one full loop, 360 / step; walk and handheld 360)");
  arguments->step_option =
      command
          ->add_option("--step-deg", arguments->step_deg,
                       "orbit: degrees along the circle per frame; walk: spread of the angular "
                       "speed, degrees per frame (per axis, steps capped at 3x)")
          ->capture_default_str();
  arguments->tilt_option =
      command
          ->add_option("--tilt-deg", arguments->tilt_deg,
                       "orbit: inclination of the circle to the model's XY plane, degrees (0: "
                       "equator, 90: over the poles)")
          ->capture_default_str();
  command->add_option(
      "--camera", arguments->camera,
      "OpenCV calibration YAML (camera_matrix, image_width, ...); default: 640x480, "
      "focal 525 px, principal point at the image centre");
  arguments->distance_option =
      command
          ->add_option("--distance", arguments->distance_radii,
                       "Camera distance from the object centre, object radii (walk: the start; "
                       "default there: the geometric mean of --distance-range)")
          ->capture_default_str();
  arguments->range_option =
      command
          ->add_option("--distance-range", arguments->distance_range,
                       "walk and handheld: smallest and largest distance, object radii, MIN,MAX "
                       "(default: walk 3,6; handheld 4,10)")
          ->delimiter(',')
          ->expected(2);
  arguments->roll_option =
      command
          ->add_option("--roll", arguments->roll_deg,
                       "Camera roll about its optical axis, degrees (orbit: constant; walk: start)")
          ->capture_default_str();
  arguments->roll_speed_option =
      command
          ->add_option("--roll-speed-deg", arguments->roll_speed_deg,
                       "walk: spread of the roll speed, degrees per frame")
          ->capture_default_str();
  HandheldOptions& hand = arguments->handheld;
  arguments->handheld_options = {
      command
          ->add_option("--speed-range", arguments->speed_range,
                       "handheld: range of the rotation speeds of the hand's movements, degrees "
                       "per frame, MIN,MAX (MAX <= 45)")
          ->delimiter(',')
          ->expected(2)
          ->capture_default_str(),
      command
          ->add_option("--pause-probability", hand.pause_probability,
                       "handheld: probability that a movement (3 to 40 frames) is a pause, 0..1")
          ->capture_default_str(),
      command
          ->add_option("--reverse-probability", hand.reverse_probability,
                       "handheld: probability that a movement turns the object back, 0..1")
          ->capture_default_str(),
      command
          ->add_option("--cut-probability", hand.cut_probability,
                       "handheld: probability per frame of a cut (the view jumps to a random "
                       "view and roll), 0..1")
          ->capture_default_str(),
      command
          ->add_option("--max-off-axis-deg", hand.max_off_axis_deg,
                       "handheld: largest angle of the object centre from the optical axis, "
                       "degrees (the object is also kept inside the image)")
          ->capture_default_str()};
  command
      ->add_option("--switch-at", arguments->switch_at,
                   "Frames where the next model takes over, F1,F2,... (one per model after the "
                   "first). Default with several models: equal segments, one per model, in order")
      ->delimiter(',');
  command->add_option("--switch-every", arguments->switch_every,
                      "Change to the next model every N frames, cycling through the models");
  DegradationOptions& degradation = arguments->degradation;
  command
      ->add_option("--noise", degradation.noise_fraction,
                   "Salt-and-pepper noise on the masks: fraction of pixels flipped, 0..1 (for "
                   "noise on colour frames see --camera-noise)")
      ->capture_default_str();
  command
      ->add_option("--erode", degradation.erode_px,
                   "Erode every silhouette by N pixels (elliptic element)")
      ->capture_default_str();
  command
      ->add_option("--dilate", degradation.dilate_px,
                   "Dilate every silhouette by N pixels (after erosion)")
      ->capture_default_str();
  command
      ->add_option("--occluders", degradation.occluders,
                   "Random ellipses per frame that cut pieces out of the silhouette")
      ->capture_default_str();
  command
      ->add_option("--occluder-size", degradation.occluder_size,
                   "Largest occluder semi-axes, relative to the silhouette's bounding box")
      ->capture_default_str();
  command
      ->add_option("--passing", degradation.passing_share,
                   "Share of frames, 0..1, in which an occluder passes in front of the object: it "
                   "enters the silhouette from one side, crosses it and leaves on the other over "
                   "--pass-frames frames (recorded as 'passing' in groundtruth.csv)")
      ->capture_default_str();
  command->add_option("--pass-frames", degradation.pass_frames, "Frames one passing occluder takes")
      ->capture_default_str();
  command
      ->add_option("--pass-size", degradation.pass_size,
                   "Largest semi-axes of the passing occluder, relative to the silhouette's size")
      ->capture_default_str();
  command
      ->add_option("--clutter", degradation.clutter_blobs,
                   "Random background blobs per frame (spurious segments)")
      ->capture_default_str();
  command
      ->add_option("--clutter-size", degradation.clutter_size,
                   "Largest clutter semi-axes, relative to the silhouette's bounding box")
      ->capture_default_str();
  command
      ->add_option("--missed", degradation.missed_probability,
                   "Probability that a frame is missed (empty mask), 0..1")
      ->capture_default_str();
  command
      ->add_option("--bad", degradation.bad_probability,
                   "Probability that a frame is badly segmented (large occluder, heavy erosion "
                   "or merged blob), 0..1; recorded in groundtruth.csv")
      ->capture_default_str();
  command
      ->add_option("--mask-quality", arguments->mask_quality,
                   "perfect: the rendered silhouettes; threshold: imperfect masks as an HSV colour "
                   "threshold gives them (ragged boundary, small holes, two fingers, a shadow, "
                   "specks; IoU with the true mask about 0.85-0.9 for silhouettes 70-150 px "
                   "across). The options below override its values")
      ->check(CLI::IsMember({"perfect", "threshold"}))
      ->capture_default_str();
  using Copy = void (*)(const DegradationOptions&, DegradationOptions*);
  const auto effect = [&](CLI::Option* option, Copy copy) {
    arguments->effect_options.emplace_back(option, copy);
  };
  effect(command->add_option("--ragged", degradation.ragged_px,
                             "Ragged mask boundary: standard deviation of the outline's in-and-out "
                             "movement, pixels (0 = off)"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->ragged_px = a.ragged_px; });
  effect(command->add_option("--ragged-scale", degradation.ragged_scale_px,
                             "Width of the ragged boundary's bumps, pixels (default 6)"),
         [](const DegradationOptions& a, DegradationOptions* b) {
           b->ragged_scale_px = a.ragged_scale_px;
         });
  effect(command->add_option("--holes", degradation.holes,
                             "Small holes per frame inside the silhouette"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->holes = a.holes; });
  effect(command->add_option("--hole-radius", degradation.hole_radius_px,
                             "Largest hole semi-axis, pixels (default 4)"),
         [](const DegradationOptions& a, DegradationOptions* b) {
           b->hole_radius_px = a.hole_radius_px;
         });
  effect(command->add_flag("--stick", degradation.stick,
                           "A thin bar attached to the silhouette, pointing away from it on one "
                           "side (a stick holding the object)"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->stick = a.stick; });
  effect(command->add_option("--stick-width", degradation.stick_width_px,
                             "Width of the stick, pixels (default 6)"),
         [](const DegradationOptions& a, DegradationOptions* b) {
           b->stick_width_px = a.stick_width_px;
         });
  effect(
      command->add_option("--stick-length", degradation.stick_length,
                          "Length of the stick beyond the silhouette, relative to its size "
                          "(default 1)"),
      [](const DegradationOptions& a, DegradationOptions* b) { b->stick_length = a.stick_length; });
  effect(command->add_option("--fingers", degradation.fingers,
                             "Fingers holding the object (0..5): short round bars side by side on "
                             "one side of the silhouette"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->fingers = a.fingers; });
  effect(command->add_option("--shadow", degradation.shadow,
                             "Shadow merged into the mask: the silhouette shifted by this fraction "
                             "of its size, 0..1 (0 = off)"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->shadow = a.shadow; });
  effect(command->add_option("--specks", degradation.specks,
                             "Small false-positive specks per frame around the silhouette"),
         [](const DegradationOptions& a, DegradationOptions* b) { b->specks = a.specks; });
  command->add_flag(
      "--colour", arguments->colour,
      "Also render colour frames, frames/000000.png...: the object shaded (one colour "
      "per model) in front of a static background, with optional camera noise and "
      "flicker; for testing --segment bgsub / threshold. The masks stay as they are");
  arguments->colour_options = {
      command->add_option("--background", arguments->background,
                          "Background image for the colour frames, scaled to cover the camera "
                          "image and cropped at its centre (default: a generated wall-and-table "
                          "texture, from --seed)"),
      command
          ->add_option("--camera-noise", arguments->camera_noise,
                       "Gaussian noise on the colour frames: standard deviation in grey levels "
                       "(every channel of every pixel, drawn anew in each frame)")
          ->capture_default_str(),
      command
          ->add_option(
              "--flicker", arguments->flicker,
              "Brightness flicker of the colour frames: each frame is scaled by 1 + F * u, "
              "u uniform in [-1, 1], 0..0.5")
          ->capture_default_str(),
      command
          ->add_option("--object-colour", arguments->object_colours,
                       "Colour of the models in the colour frames: B,G,R (0..255) for all, or "
                       "B,G,R,B,G,R,... one per model (default: a distinct colour per model)")
          ->delimiter(','),
      command->add_flag("--video", arguments->video,
                        "Also write the colour frames as one video, DIR/video.avi (MJPEG), as a "
                        "camera would record it"),
      command->add_option("--fps", arguments->fps, "Frame rate of DIR/video.avi")
          ->capture_default_str()};
  command
      ->add_option("--seed", arguments->seed,
                   "Seed of the walk and handheld trajectories, the degradations and the colour "
                   "frames' texture and noise")
      ->capture_default_str()
      ->check(SeedNumber());
  command->add_option("--threads", arguments->threads, "Worker threads (0 = all cores)")
      ->capture_default_str();
  command->add_flag("--overwrite", arguments->overwrite,
                    "Replace a sequence already in the output folder (its masks are deleted)");
  command->callback([arguments] { RunSynth(*arguments); });
}

}  // namespace silpose::cli
