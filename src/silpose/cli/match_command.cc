#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "silpose/cli/commands.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/mask_file.h"
#include "silpose/match/view_matcher.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct MatchArguments {
  std::string database;
  std::vector<std::string> masks;
  std::string camera;
  bool no_refine = false;
  int top_k = 5;
  bool json = false;
  bool exhaustive = false;
};

// Matches one mask: prints its table, or returns its JSON object. Throws silpose::Error naming the
// mask (or camera file) if it cannot be matched.
nlohmann::json MatchOne(const ViewSpectra& spectra, const MatchArguments& arguments,
                        const std::string& mask_path) {
  const ViewDatabase& database = spectra.database();
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat mask = ReadMask(mask_path);
  const SignatureResult silhouette = ExtractSignature(mask, database.parameters.signature);
  if (!silhouette.ok()) {
    ThrowError(
        mask_path, ": no usable silhouette (", ToString(silhouette.status),
        silhouette.status == SignatureStatus::kTooSmall
            ? ": it must enclose at least " +
                  std::to_string(static_cast<int>(database.parameters.signature.min_area_px)) +
                  " pixels"
            : std::string(": no non-zero pixel"),
        ")");
  }
  // The camera of the mask: --camera, else the default one (the pose's distance depends on it).
  PinholeCamera camera = DefaultCamera(mask.cols, mask.rows);
  if (!arguments.camera.empty()) {
    camera = ReadCameraFile(arguments.camera);
    if (camera.width_px != mask.cols || camera.height_px != mask.rows) {
      ThrowError(arguments.camera, ": the camera is ", camera.width_px, "x", camera.height_px,
                 " pixels but ", mask_path, " is ", mask.cols, "x", mask.rows,
                 ": wrong calibration file?");
    }
  }
  // What `track --brute-force` does with one frame: the silhouette seen straight on, matched in
  // the distance shell its size chooses, the 6-DOF pose and its contour refinement.
  TrackerOptions tracker_options;
  tracker_options.brute_force = true;
  tracker_options.refine = !arguments.no_refine;
  Tracker tracker(spectra, camera, tracker_options);
  const TrackedFrame tracked = tracker.Process(mask);
  std::span<const float> radii = silhouette.signature.radii;
  double apparent_radius =
      silhouette.signature.mean_radius_px / std::sqrt(camera.focal_x_px * camera.focal_y_px);
  if (tracked.on_axis) {
    radii = tracked.on_axis->signature.radii;
    apparent_radius = tracked.on_axis->apparent_radius;
  }
  ViewMatcher matcher(spectra);  // the spectra the tracker already used
  MatchOptions options;
  options.top_k = arguments.top_k;
  options.exhaustive = arguments.exhaustive;
  options.apparent_radius = apparent_radius;
  const auto match_start = std::chrono::steady_clock::now();
  const std::vector<MatchCandidate> candidates = matcher.Match(radii, options);
  const auto end = std::chrono::steady_clock::now();
  const double match_ms = std::chrono::duration<double, std::milli>(end - match_start).count();
  const double total_ms = std::chrono::duration<double, std::milli>(end - start).count();
  const FrameResult& best = tracked.result;

  const PolarSignature& signature = silhouette.signature;
  if (arguments.json) {
    nlohmann::json output;
    output["mask"] = mask_path;
    output["database"] = arguments.database;
    output["silhouette"] = {{"status", ToString(silhouette.status)},
                            {"flags", DescribeSilhouetteFlags(silhouette.flags)},
                            {"area_px", signature.area_px},
                            {"centroid_px", {signature.centroid_px.x(), signature.centroid_px.y()}},
                            {"mean_radius_px", signature.mean_radius_px}};
    output["match_ms"] = match_ms;
    output["views_correlated"] = matcher.last_stats().views_correlated;
    nlohmann::json list = nlohmann::json::array();
    for (size_t i = 0; i < candidates.size(); ++i) {
      const MatchCandidate& c = candidates[i];
      const Eigen::Vector3d& d = database.sphere.directions[static_cast<size_t>(c.view)];
      list.push_back({{"rank", i + 1},
                      {"object", database.models[static_cast<size_t>(c.model)].name},
                      {"view", c.view},
                      {"view_dir", {d.x(), d.y(), d.z()}},
                      {"roll_deg", c.roll_deg},
                      {"score", c.score}});
    }
    output["candidates"] = list;
    output["camera"] = arguments.camera.empty() ? std::string("default") : arguments.camera;
    if (best.camera_from_object) {
      const Eigen::Matrix3d& r = best.camera_from_object->rotation;
      const Eigen::Vector3d& t = best.camera_from_object->translation;
      nlohmann::json rows = nlohmann::json::array();
      for (int i = 0; i < 3; ++i) rows.push_back({r(i, 0), r(i, 1), r(i, 2)});
      output["pose"] = {{"object", best.object_name},
                        {"R", rows},
                        {"t", {t.x(), t.y(), t.z()}},
                        {"refined", tracked.refinement.has_value()}};
    } else {
      output["pose"] = nullptr;
    }
    output["status"] = best.status;
    output["confidence"] =
        std::isfinite(best.confidence) ? nlohmann::json(best.confidence) : nlohmann::json(nullptr);
    output["state"] = TrackStateName(best.state);
    output["iou"] = std::isfinite(best.iou) ? nlohmann::json(best.iou) : nlohmann::json(nullptr);
    return output;
  }
  std::printf("%s: %s, centroid (%.1f, %.1f) px, mean radius %.1f px\n", mask_path.c_str(),
              silhouette.Describe().c_str(), signature.centroid_px.x(), signature.centroid_px.y(),
              signature.mean_radius_px);
  std::printf("%4s  %-24s %6s  %-26s %9s %8s\n", "rank", "object", "view", "view direction",
              "roll_deg", "score");
  for (size_t i = 0; i < candidates.size(); ++i) {
    const MatchCandidate& c = candidates[i];
    const Eigen::Vector3d& d = database.sphere.directions[static_cast<size_t>(c.view)];
    std::printf("%4zu  %-24s %6d  (%7.4f, %7.4f, %7.4f) %9.2f %8.4f\n", i + 1,
                database.models[static_cast<size_t>(c.model)].name.c_str(), c.view, d.x(), d.y(),
                d.z(), c.roll_deg, static_cast<double>(c.score));
  }
  if (best.camera_from_object) {
    const Eigen::Matrix3d& r = best.camera_from_object->rotation;
    const Eigen::Vector3d& t = best.camera_from_object->translation;
    std::printf(
        "6-DOF pose of %s (x_cam = R x_obj + t, %s camera%s):\n  R = [%9.6f %9.6f %9.6f; %9.6f "
        "%9.6f %9.6f; %9.6f %9.6f %9.6f]\n  t = [%.6g %.6g %.6g] (model units)\n",
        best.object_name.c_str(), arguments.camera.empty() ? "the default" : "the given",
        tracked.refinement ? ", refined" : "", r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2),
        r(2, 0), r(2, 1), r(2, 2), t.x(), t.y(), t.z());
  } else {
    std::printf("no 6-DOF pose (%s)\n", best.status.c_str());
  }
  if (std::isfinite(best.confidence)) {
    std::printf("confidence %.3f, state %s", best.confidence, TrackStateName(best.state));
    if (std::isfinite(best.iou)) std::printf(", IoU of the model at the pose %.3f", best.iou);
    std::printf(" (docs/confidence.md; one frame: no history)\n");
  }
  if (arguments.camera.empty()) {
    std::printf(
        "camera: default (focal length %.1f px, principal point at the image centre); give "
        "--camera for the true distance\n",
        camera.focal_x_px);
  }
  std::printf("matched against %zu models x %d views in %.1f ms (%d correlated), %.0f ms in all\n",
              database.models.size(), database.num_views(), match_ms,
              matcher.last_stats().views_correlated, total_ms);
  return nullptr;
}

void RunMatch(const MatchArguments& arguments) {
  const auto start = std::chrono::steady_clock::now();
  const ViewDatabase database = ViewDatabase::Read(arguments.database);
  const double open_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // One set of spectra for every mask: each view's spectrum is made (or checked) once.
  const ViewSpectra spectra(database);
  if (arguments.masks.size() == 1) {
    const nlohmann::json output = MatchOne(spectra, arguments, arguments.masks.front());
    if (arguments.json) std::cout << output.dump(2) << "\n";
    return;
  }
  // Several masks: each matched on its own against the database opened once. A mask that cannot
  // be matched gets its message (and, in JSON, an entry with an "error"), the others go on, and
  // the command fails at the end.
  nlohmann::json list = nlohmann::json::array();
  size_t failed = 0;
  for (size_t i = 0; i < arguments.masks.size(); ++i) {
    const std::string& mask = arguments.masks[i];
    try {
      if (!arguments.json && i > 0) std::printf("\n");
      nlohmann::json output = MatchOne(spectra, arguments, mask);
      if (arguments.json) list.push_back(std::move(output));
    } catch (const Error& error) {
      ++failed;
      std::fflush(stdout);
      std::fprintf(stderr, "silpose match: %s\n", error.what());
      if (arguments.json) list.push_back({{"mask", mask}, {"error", error.what()}});
    }
  }
  const double total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (arguments.json) {
    std::cout << list.dump(2) << "\n";
  } else {
    std::printf("\n%zu masks matched in %.0f ms (the database opened once, in %.0f ms)\n",
                arguments.masks.size() - failed, total_ms, open_ms);
  }
  if (failed > 0) {
    ThrowError(failed, " of ", arguments.masks.size(), " masks could not be matched (named above)");
  }
}

}  // namespace

void AddMatchCommand(CLI::App& app) {
  auto arguments = std::make_shared<MatchArguments>();
  CLI::App* command =
      app.add_subcommand("match",
                         "Match mask images, each on its own, against every view of a database and "
                         "print the best (object, view, roll, score) candidates and the 6-DOF pose "
                         "of the best (JSON: one object per mask, a list for several).");
  command->add_option("-d,--database", arguments->database, "Database file from build-db")
      ->required();
  command
      ->add_option("masks", arguments->masks,
                   "Mask images (8-bit, non-zero = object); several are matched one by one "
                   "against the database opened once")
      ->required();
  command->add_option("--top", arguments->top_k, "Number of candidates to print")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  command->add_option("--camera", arguments->camera,
                      "Camera file of the mask (YAML/XML/JSON, docs/conventions.md) for the 6-DOF "
                      "pose (default: principal point at the centre, focal length 0.82 x width)");
  command->add_flag("--no-refine", arguments->no_refine,
                    "Report the best view's pose without the contour refinement");
  command->add_flag("--json", arguments->json, "Print JSON instead of a table");
  command->add_flag("--exhaustive", arguments->exhaustive,
                    "Correlate every view (the default prunes exactly, with the same result)");
  command->callback([arguments] { RunMatch(*arguments); });
}

}  // namespace silpose::cli
