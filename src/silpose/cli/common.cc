#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>

#include "silpose/cli/commands.h"
#include "silpose/util/error.h"

namespace silpose::cli {

std::vector<std::filesystem::path> FilesWithExtensions(const std::filesystem::path& directory,
                                                       const std::vector<std::string>& extensions) {
  std::vector<std::filesystem::path> files;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(directory, error)) {
    std::string extension = entry.path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (entry.is_regular_file() &&
        std::find(extensions.begin(), extensions.end(), extension) != extensions.end()) {
      files.push_back(entry.path());
    }
  }
  if (error) ThrowError(directory.string(), ": cannot list folder: ", error.message());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::filesystem::path> MeshFilesIn(const std::filesystem::path& directory) {
  return FilesWithExtensions(directory, {".obj", ".ply", ".stl", ".off", ".gltf", ".glb"});
}

std::vector<std::filesystem::path> MeshPathsFromModelsOption(
    const std::vector<std::string>& items) {
  std::vector<std::filesystem::path> paths;
  for (const std::string& item : items) {
    std::error_code error;
    if (std::filesystem::is_directory(item, error)) {
      for (const auto& file : MeshFilesIn(item)) paths.push_back(file);
    } else if (std::filesystem::is_regular_file(item, error)) {
      paths.emplace_back(item);
    } else {
      ThrowError(item, ": no such mesh file or folder (--models)");
    }
  }
  if (paths.empty()) ThrowError("--models: no mesh files found");
  return paths;
}

std::vector<std::filesystem::path> SampleModels(const std::string& override_dir) {
  std::vector<std::filesystem::path> candidates;
  if (!override_dir.empty()) {
    candidates.emplace_back(override_dir);
  } else {
    candidates.emplace_back(SILPOSE_SOURCE_MODELS_DIR);
    // An installed binary: <prefix>/bin/silpose next to <prefix>/share/silpose/models.
    std::error_code error;
    const auto executable = std::filesystem::read_symlink("/proc/self/exe", error);
    if (!error) {
      candidates.push_back(executable.parent_path().parent_path() / "share" / "silpose" / "models");
    }
    candidates.emplace_back(SILPOSE_INSTALL_MODELS_DIR);
  }
  for (const auto& directory : candidates) {
    std::error_code error;
    if (!std::filesystem::is_directory(directory, error)) continue;
    auto files = MeshFilesIn(directory);
    if (!files.empty()) return files;
  }
  if (!override_dir.empty())
    ThrowError(override_dir, ": no mesh files (.obj .ply .stl .off .gltf .glb) here");
  ThrowError("sample models not found (looked in ", SILPOSE_SOURCE_MODELS_DIR, " and ",
             SILPOSE_INSTALL_MODELS_DIR, "); pass --models DIR");
}

std::vector<double> ParseTriple(const std::string& text, const std::string& what) {
  std::vector<double> values;
  if (!text.empty() && text.back() == ',')
    ThrowError(what, " must be three numbers X,Y,Z, got '", text, "'");
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      size_t used = 0;
      const double value = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(value)) throw std::invalid_argument(item);
      values.push_back(value);
    } catch (const std::exception&) {
      ThrowError(what, " must be three numbers X,Y,Z, got '", text, "'");
    }
  }
  if (values.size() != 3) ThrowError(what, " must be three numbers X,Y,Z, got '", text, "'");
  return values;
}

std::string FormatBytes(uintmax_t bytes) {
  char text[32];
  if (bytes >= 1000ull * 1000 * 1000) {
    std::snprintf(text, sizeof(text), "%.1f GB", static_cast<double>(bytes) / 1e9);
  } else if (bytes >= 1000 * 1000) {
    std::snprintf(text, sizeof(text), "%.1f MB", static_cast<double>(bytes) / 1e6);
  } else if (bytes >= 1000) {
    std::snprintf(text, sizeof(text), "%.1f kB", static_cast<double>(bytes) / 1e3);
  } else {
    std::snprintf(text, sizeof(text), "%ju bytes", bytes);
  }
  return text;
}

std::filesystem::path CreateOutputFolder(const std::string& folder) {
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error || !std::filesystem::is_directory(folder)) {
    ThrowError(folder, ": cannot create the output folder",
               error ? ": " + error.message() : std::string());
  }
  return folder;
}

std::string CommandLine() {
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  std::string text, part;
  while (std::getline(file, part, '\0')) text += (text.empty() ? "" : " ") + part;
  return text;
}

std::string Joined(const std::vector<std::string>& items, const char* separator) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : separator) + item;
  return text;
}

std::string Number(double value, const char* format) {
  if (!std::isfinite(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

}  // namespace silpose::cli
