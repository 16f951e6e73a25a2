#pragma once
// Checks of command-line values shared by the subcommands (docs/limits.md).

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "silpose/filter/particle_filter.h"
#include "silpose/pose/pose_output.h"
#include "silpose/util/error.h"
#include "silpose/util/output_file.h"

namespace silpose::cli {

/// The names a database built from `mesh_paths` gives its models: the files' stems, in order.
inline std::vector<std::string> MeshModelNames(
    const std::vector<std::filesystem::path>& mesh_paths) {
  std::vector<std::string> names;
  for (const auto& path : mesh_paths) names.push_back(path.stem().string());
  return names;
}

/// A seed: a decimal whole number from 0 to 2^64 - 1, nothing else (no sign, no blanks, not
/// empty). CLI11 alone would wrap "-1" and clamp "99999999999999999999" to 2^64 - 1 silently.
inline CLI::Validator SeedNumber() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const std::string problem =
            "a seed must be a whole number from 0 to 18446744073709551615, got '" + text + "'";
        if (text.empty() || text.size() > 20) return problem;
        uint64_t value = 0;
        for (char c : text) {
          if (c < '0' || c > '9') return problem;
          const auto digit = static_cast<uint64_t>(c - '0');
          if (value > (std::numeric_limits<uint64_t>::max() - digit) / 10) return problem;
          value = value * 10 + digit;
        }
        return std::string();
      },
      "SEED", "seed");
}

/// At most this many particles over all objects (particles per object x models): every particle
/// is scored against the frame each frame, so time and memory grow with the count; beyond a
/// million a frame takes seconds. A hard limit.
inline constexpr int64_t kMaxTotalParticles = 1'000'000;
/// From this many particles over all objects (a fixed count), `track` suggests --adaptive: about
/// 50 objects at the default 60 per object.
inline constexpr int64_t kManyParticlesHint = 3000;

/// Makes --particles, --min-particles and --max-particles consistent (docs/limits.md). Without
/// --adaptive the count is fixed: the floor and cap follow it. With --adaptive the count moves
/// between --min-particles and --max-particles, a soft cap the user can raise; a start outside
/// them is refused, saying which option to change.
inline void FitParticleBounds(ParticleFilterOptions* filter) {
  const int particles = filter->particles_per_object;
  if (particles < 1) ThrowError("--particles must be >= 1, got ", particles);
  if (particles > kMaxTotalParticles) {
    ThrowError("--particles ", particles, " is above the limit of ", kMaxTotalParticles,
               " particles in all (every particle is scored each frame)");
  }
  if (!filter->adaptive) {
    filter->min_particles_per_object = std::min(filter->min_particles_per_object, particles);
    filter->max_particles_per_object = std::max(filter->max_particles_per_object, particles);
    return;
  }
  if (filter->min_particles_per_object < 0) {
    ThrowError("--min-particles must be >= 0, got ", filter->min_particles_per_object);
  }
  if (particles < filter->min_particles_per_object) {
    ThrowError("--particles ", particles, " is below --min-particles ",
               filter->min_particles_per_object,
               " (with --adaptive the count per object stays between --min-particles and "
               "--max-particles): lower --min-particles");
  }
  if (particles > filter->max_particles_per_object) {
    ThrowError("--particles ", particles, " is above --max-particles ",
               filter->max_particles_per_object,
               " (with --adaptive the count per object stays between --min-particles and "
               "--max-particles): raise --max-particles");
  }
}

/// Refuses more than kMaxTotalParticles particles over `num_models` objects.
inline void CheckTotalParticles(const ParticleFilterOptions& filter, size_t num_models,
                                const std::string& database) {
  const int per_object =
      filter.adaptive ? filter.max_particles_per_object : filter.particles_per_object;
  const int64_t total = static_cast<int64_t>(per_object) * static_cast<int64_t>(num_models);
  if (total > kMaxTotalParticles) {
    ThrowError(per_object, " particles per object x ", num_models, " models in ", database, " = ",
               total, " particles, above the limit of ", kMaxTotalParticles,
               " (every particle is scored each frame): use fewer --particles",
               filter.adaptive ? " or a lower --max-particles" : "");
  }
}

/// A frame's result as the outputs may show it: a pose with a non-finite entry (inf, NaN) is
/// dropped and the status says so ("...-pose-not-finite"), so that no output holds such numbers.
inline void DropNonFinitePose(FrameResult* result) {
  if (result->camera_from_object && (!result->camera_from_object->rotation.allFinite() ||
                                     !result->camera_from_object->translation.allFinite())) {
    result->camera_from_object.reset();
    result->status += "-pose-not-finite";
  }
  if (result->view_dir_in_object && !result->view_dir_in_object->allFinite()) {
    result->view_dir_in_object.reset();
    result->status += "-view-not-finite";
  }
}

/// The output files of a run, checked and locked before any is created: each path must be
/// writable (CheckOutputPath) and not being written by another silpose process (OutputLock). Until
/// Opened() is called, the files this run created are removed again when the object goes away (a
/// failure to open one output leaves none behind).
class OutputGuard {
 public:
  /// (path, option) pairs; empty paths are skipped.
  explicit OutputGuard(const std::vector<std::pair<std::string, std::string>>& outputs) {
    for (const auto& [path, option] : outputs) {
      if (path.empty()) continue;
      CheckOutputPath(path, option);
    }
    for (const auto& [path, option] : outputs) {
      if (path.empty()) continue;
      std::error_code error;
      if (!std::filesystem::exists(path, error)) created_.push_back(path);
      locks_.emplace_back(path);
    }
  }
  ~OutputGuard() {
    if (opened_) return;
    for (const std::string& path : created_) {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  }
  OutputGuard(const OutputGuard&) = delete;
  OutputGuard& operator=(const OutputGuard&) = delete;

  /// Every output is open: from now on files stay, whatever happens.
  void Opened() { opened_ = true; }

 private:
  std::vector<std::string> created_;
  std::vector<OutputLock> locks_;
  bool opened_ = false;
};

}  // namespace silpose::cli
