#pragma once
// The models the benchmarks run on: $SILPOSE_BENCH_MODELS if set, else the 20 reference models in
// ../shared/models beside the checkout, else the project's sample models.

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <vector>

namespace silpose {

inline std::vector<std::filesystem::path> BenchModels() {
  std::vector<std::filesystem::path> directories;
  if (const char* env = std::getenv("SILPOSE_BENCH_MODELS")) directories.emplace_back(env);
  directories.emplace_back(SILPOSE_SHARED_MODELS_DIR);
  directories.emplace_back(SILPOSE_SAMPLE_MODELS_DIR);
  for (const auto& directory : directories) {
    std::error_code error;
    if (!std::filesystem::is_directory(directory, error)) continue;
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(directory)) {
      if (entry.path().extension() == ".obj") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    if (!files.empty()) return files;
  }
  return {};
}

}  // namespace silpose
