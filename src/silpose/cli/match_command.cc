#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "silpose/cli/commands.h"
#include "silpose/io/mask_file.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct MatchArguments {
  std::string database;
  std::string mask;
  int top_k = 5;
  bool json = false;
  bool exhaustive = false;
};

void RunMatch(const MatchArguments& arguments) {
  const auto start = std::chrono::steady_clock::now();
  const ViewDatabase database = ViewDatabase::Read(arguments.database);
  const cv::Mat mask = ReadMask(arguments.mask);
  const SignatureResult silhouette = ExtractSignature(mask, database.parameters.signature);
  if (!silhouette.ok()) {
    ThrowError(
        arguments.mask, ": no usable silhouette (", ToString(silhouette.status),
        silhouette.status == SignatureStatus::kTooSmall
            ? ": it must enclose at least " +
                  std::to_string(static_cast<int>(database.parameters.signature.min_area_px)) +
                  " pixels"
            : std::string(": no non-zero pixel"),
        ")");
  }
  const ViewSpectra spectra(database);
  ViewMatcher matcher(spectra);
  MatchOptions options;
  options.top_k = arguments.top_k;
  options.exhaustive = arguments.exhaustive;
  const auto match_start = std::chrono::steady_clock::now();
  const std::vector<MatchCandidate> candidates = matcher.Match(silhouette.signature.radii, options);
  const auto end = std::chrono::steady_clock::now();
  const double match_ms = std::chrono::duration<double, std::milli>(end - match_start).count();
  const double total_ms = std::chrono::duration<double, std::milli>(end - start).count();

  const PolarSignature& signature = silhouette.signature;
  if (arguments.json) {
    nlohmann::json output;
    output["mask"] = arguments.mask;
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
    std::cout << output.dump(2) << "\n";
    return;
  }
  std::printf("%s: %s, centroid (%.1f, %.1f) px, mean radius %.1f px\n", arguments.mask.c_str(),
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
  std::printf("matched against %zu models x %d views in %.1f ms (%d correlated), %.0f ms in all\n",
              database.models.size(), database.num_views(), match_ms,
              matcher.last_stats().views_correlated, total_ms);
}

}  // namespace

void AddMatchCommand(CLI::App& app) {
  auto arguments = std::make_shared<MatchArguments>();
  CLI::App* command =
      app.add_subcommand("match",
                         "Match one mask image against every view of a database and print the best "
                         "(object, view, roll, score) candidates.");
  command->add_option("-d,--database", arguments->database, "Database file from build-db")
      ->required();
  command->add_option("mask", arguments->mask, "Mask image (8-bit, non-zero = object)")->required();
  command->add_option("--top", arguments->top_k, "Number of candidates to print")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  command->add_flag("--json", arguments->json, "Print JSON instead of a table");
  command->add_flag("--exhaustive", arguments->exhaustive,
                    "Correlate every view (the default prunes exactly, with the same result)");
  command->callback([arguments] { RunMatch(*arguments); });
}

}  // namespace silpose::cli
