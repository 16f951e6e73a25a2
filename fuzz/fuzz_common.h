#pragma once
// Shared helpers of the libFuzzer targets (docs/fuzzing.md). Each target feeds its input to one
// reader of silpose; silpose::Error is the expected outcome for bad input, anything else (a crash,
// a sanitizer report, another exception, a hang or an out-of-memory) is a finding.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "silpose/util/error.h"

namespace silpose::fuzz {

/// A folder of this process for the files the targets write (removed at exit).
inline const std::filesystem::path& ScratchFolder() {
  static const std::filesystem::path folder = [] {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("silpose-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(path);
    return path;
  }();
  static const struct Remover {
    ~Remover() {
      std::error_code ignored;
      std::filesystem::remove_all(folder, ignored);
    }
  } remover;
  return folder;
}

/// Writes `bytes` to `path` (replacing it).
inline void WriteBytes(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream stream(path, std::ios::binary | std::ios::trunc);
  stream.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Writes `bytes` to ScratchFolder()/input<extension> and returns the path.
inline std::filesystem::path WriteInput(std::string_view bytes, const std::string& extension) {
  std::filesystem::path path = ScratchFolder() / ("input" + extension);
  WriteBytes(path, bytes);
  return path;
}

/// Runs `body`; silpose::Error (the documented outcome of bad input) is swallowed, anything else
/// propagates and ends the run as a finding.
template <typename Body>
void ExpectOnlySilposeErrors(Body&& body) {
  try {
    body();
  } catch (const silpose::Error&) {
  }
}

inline std::string_view AsView(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace silpose::fuzz
