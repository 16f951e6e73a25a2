// silpose: which known rigid object a camera sees, and where it is, from its silhouette.
// Subcommands are listed in commands.h; each parses its options and calls the library.

#include <algorithm>
#include <cstdio>
#include <exception>
#include <opencv2/core.hpp>

#include "silpose/cli/commands.h"
#include "silpose/io/image_limits.h"
#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace {

// Error messages are one line on stderr (OpenCV's texts carry line breaks).
std::string OneLine(const char* text) {
  std::string line(text);
  std::replace(line.begin(), line.end(), '\n', ' ');
  while (!line.empty() && line.back() == ' ') line.pop_back();
  return line;
}

}  // namespace

int main(int argc, char** argv) {
  // Sets OpenCV's decoder limit in the environment now, while this is the only thread: later,
  // setenv would race with other threads' getenv.
  silpose::LimitOpenCvDecoders();
  CLI::App app{
      "silpose: identify a known rigid object and its pose from its silhouette.\n"
      "Typical use: 'silpose build-db MODELS... -o models.db', then 'silpose match -d models.db "
      "mask.png'.\nRun 'silpose demo' to see the whole pipeline on built-in sample models."};
  app.name("silpose");
  // The build of the innermost loops this process runs (docs/conventions.md, "Matching").
  app.set_version_flag("--version", std::string("silpose ") + SILPOSE_VERSION +
                                        (silpose::Avx2Enabled() ? " (inner loops: AVX2)"
                                                                : " (inner loops: baseline)"));
  app.require_subcommand(1);
  app.failure_message([](const CLI::App* failed, const CLI::Error& error) {
    std::string name = failed->get_name();
    if (name != "silpose") name = "silpose " + name;
    return name + ": error: " + error.what() + " (see --help)\n";
  });
  silpose::cli::AddBuildDbCommand(app);
  silpose::cli::AddMergeDbCommand(app);
  silpose::cli::AddMatchCommand(app);
  silpose::cli::AddRenderCommand(app);
  silpose::cli::AddSynthCommand(app);
  silpose::cli::AddTrackCommand(app);
  silpose::cli::AddDemoCommand(app);
  silpose::cli::AddEvalCommand(app);
  silpose::cli::AddCalibrateCommand(app);

  if (argc > 1 && argv[1][0] != '-') {
    bool known = false;
    std::string names;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
      known |= sub->get_name() == argv[1];
      names += (names.empty() ? "" : ", ") + sub->get_name();
    }
    if (!known) {
      std::fprintf(stderr, "silpose: error: unknown command '%s' (commands: %s; see --help)\n",
                   argv[1], names.c_str());
      return 2;
    }
  }
  std::string command = "silpose";
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  } catch (const silpose::Error& error) {
    // The innermost subcommand that ran ("silpose eval video").
    for (const CLI::App* level = &app; !level->get_subcommands().empty();) {
      level = level->get_subcommands().front();
      command += " " + level->get_name();
    }
    std::fprintf(stderr, "%s: error: %s\n", command.c_str(), OneLine(error.what()).c_str());
    return 1;
  } catch (const cv::Exception& error) {
    std::fprintf(stderr, "silpose: OpenCV error: %s\n", OneLine(error.what()).c_str());
    return 3;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "silpose: out of memory\n");
    return 3;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "silpose: internal error: %s\n", OneLine(error.what()).c_str());
    return 3;
  }
  return 0;
}
