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

namespace silpose {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

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
  std::ifstream err(err_path);
  std::stringstream text;
  text << err.rdbuf();
  run.err = text.str();
  std::filesystem::remove(err_path);
  return run;
}

inline int Lines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

}  // namespace silpose
