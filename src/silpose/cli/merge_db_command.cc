#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "silpose/cli/commands.h"
#include "silpose/database/database_merge.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct MergeDbArguments {
  std::vector<std::string> databases;
  std::string output;
};

void RunMergeDb(const MergeDbArguments& arguments) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::filesystem::path> paths(arguments.databases.begin(), arguments.databases.end());
  for (const auto& path : paths) {
    std::error_code error;
    if (std::filesystem::equivalent(path, arguments.output, error)) {
      ThrowError(arguments.output,
                 ": the output is also an input; write the merged database to "
                 "another file");
    }
  }
  ViewDatabase merged = MergeViewDatabases(paths);
  // Databases of format 3 have no stored spectra, those of format 4 no amplitudes: the merged
  // file gets them (fast to open, and format 5).
  if (std::any_of(merged.models.begin(), merged.models.end(), NeedsStoredSpectra)) {
    StoreViewSpectra(&merged);
  }
  merged.Write(arguments.output);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::error_code error;
  const auto size = std::filesystem::file_size(arguments.output, error);
  std::printf(
      "wrote %s: %zu models from %zu files x %d views x %d distance shells, %s, in %.1f s\n",
      arguments.output.c_str(), merged.models.size(), paths.size(), merged.num_views(),
      merged.num_shells(), error ? "?" : FormatBytes(size).c_str(), seconds);
}

}  // namespace

void AddMergeDbCommand(CLI::App& app) {
  auto arguments = std::make_shared<MergeDbArguments>();
  CLI::App* command = app.add_subcommand(
      "merge-db",
      "Merge database files built with the same build-db options (e.g. one per model, on several "
      "machines) into one: the same file, byte for byte, as build-db of all their models at once "
      "in the order given.");
  command->add_option("databases", arguments->databases, "Database files from build-db, in order")
      ->required();
  command->add_option("-o,--output", arguments->output, "Database file to write")->required();
  command->callback([arguments] { RunMergeDb(*arguments); });
}

}  // namespace silpose::cli
