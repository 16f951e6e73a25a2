#pragma once
// Runs the silpose binary as a user would (for the CLI tests): `Silpose("track ...")` returns the
// exit code and what the command wrote on stdout and stderr.

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace silpose {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// A text file's content.
inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

// Runs `silpose <arguments>` through the shell, capturing stdout and stderr.
inline CommandResult Silpose(const std::string& arguments) {
  static int counter = 0;
  const auto err_path =
      std::filesystem::temp_directory_path() /
      ("silpose_cli_err_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string command =
      std::string(SILPOSE_BINARY) + " " + arguments + " 2>" + err_path.string() + " </dev/null";
  CommandResult run;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 4096> buffer{};
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    run.out.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  run.err = ReadText(err_path);
  std::filesystem::remove(err_path);
  return run;
}

// A text file's lines.
inline std::vector<std::string> ReadLines(const std::filesystem::path& path) {
  std::ifstream file(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(file, line);) lines.push_back(line);
  return lines;
}

// The fields of a line between `separator`s (an empty last field after a trailing separator too).
inline std::vector<std::string> SplitLine(const std::string& line, char separator) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  for (std::string field; std::getline(stream, field, separator);) fields.push_back(field);
  if (!line.empty() && line.back() == separator) fields.emplace_back();
  return fields;
}

// The comma-separated cells of a CSV line.
inline std::vector<std::string> CsvCells(const std::string& line) { return SplitLine(line, ','); }

inline int Lines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

}  // namespace silpose
