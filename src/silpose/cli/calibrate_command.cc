#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "silpose/calib/calibration.h"
#include "silpose/cli/commands.h"
#include "silpose/io/camera_file.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct CalibrateArguments {
  std::vector<std::string> inputs;
  std::string board = "9x6";
  std::string output;
  std::string report;
  CalibrationOptions options;
};

const std::vector<std::string> kImageExtensions = {".png",  ".jpg", ".jpeg", ".bmp", ".tif",
                                                   ".tiff", ".pgm", ".ppm",  ".webp"};

// "9x6" -> 9 columns, 6 rows of inner corners.
void ParseBoard(const std::string& text, CalibrationOptions* options) {
  const size_t x = text.find_first_of("xX");
  auto parse = [&text](const std::string& part) {
    try {
      size_t used = 0;
      const int value = std::stoi(part, &used);
      if (used == part.size() && !part.empty() && part[0] != '-' && part[0] != '+') return value;
    } catch (const std::exception&) {
    }
    ThrowError("--board must be COLSxROWS inner corners, like 9x6, got '", text, "'");
  };
  if (x == std::string::npos) parse("");
  options->board_cols = parse(text.substr(0, x));
  options->board_rows = parse(text.substr(x + 1));
}

std::vector<std::filesystem::path> ImagePaths(const std::vector<std::string>& inputs) {
  std::vector<std::filesystem::path> paths;
  for (const std::string& input : inputs) {
    std::error_code error;
    if (std::filesystem::is_directory(input, error)) {
      const auto files = FilesWithExtensions(input, kImageExtensions);
      if (files.empty()) ThrowError(input, ": no images (.png .jpg .bmp .tif ...) in this folder");
      paths.insert(paths.end(), files.begin(), files.end());
    } else {
      paths.emplace_back(input);
    }
  }
  return paths;
}

void WriteReport(const std::string& path, const CalibrationResult& result) {
  std::ofstream file(path);
  if (!file) ThrowError(path, ": cannot open for writing");
  file << "image,status,corners,rms_error_px,distance\n";
  char line[64];
  for (const CalibrationView& view : result.views) {
    std::string quoted = view.name;  // CSV: double any quotes in the name
    for (size_t at = quoted.find('"'); at != std::string::npos; at = quoted.find('"', at + 2)) {
      quoted.insert(at, 1, '"');
    }
    file << '"' << quoted << "\"," << (view.board_found ? "found" : "not_found") << ','
         << view.corners_px.size() << ',';
    if (view.board_found) {
      std::snprintf(line, sizeof(line), "%.4f,%.6g", view.rms_error_px,
                    view.camera_from_board.translation.norm());
      file << line;
    } else {
      file << ',';
    }
    file << '\n';
  }
  if (!file) ThrowError(path, ": write failed");
}

void RunCalibrate(CalibrateArguments& arguments) {
  ParseBoard(arguments.board, &arguments.options);
  std::string problem;
  if (!arguments.options.Check(&problem)) ThrowError("invalid options: ", problem);
  const std::vector<std::filesystem::path> paths = ImagePaths(arguments.inputs);
  const CalibrationResult result = CalibrateCamera(paths, arguments.options);

  int width = 5;
  for (const CalibrationView& view : result.views) {
    width = std::max(width, static_cast<int>(view.name.size()));
  }
  std::printf("%-*s  %-9s  %s\n", width, "image", "board", "rms_px");
  for (const CalibrationView& view : result.views) {
    if (view.board_found) {
      std::printf("%-*s  %-9s  %.3f\n", width, view.name.c_str(), "found", view.rms_error_px);
    } else {
      std::printf("%-*s  %-9s  -\n", width, view.name.c_str(), "not found");
    }
  }
  const PinholeCamera& camera = result.camera;
  const int boards = result.NumBoardsFound();
  std::printf(
      "calibrated from %d of %zu images (%dx%d inner corners): RMS reprojection error %.3f px\n",
      boards, result.views.size(), arguments.options.board_cols, arguments.options.board_rows,
      result.rms_error_px);
  std::printf("image %dx%d, fx %.3f fy %.3f cx %.3f cy %.3f px\n", camera.width_px,
              camera.height_px, camera.focal_x_px, camera.focal_y_px, camera.principal_x_px,
              camera.principal_y_px);
  std::printf("distortion k1 %.6f k2 %.6f p1 %.6f p2 %.6f k3 %.6f\n", camera.distortion[0],
              camera.distortion[1], camera.distortion[2], camera.distortion[3],
              camera.distortion[4]);
  if (result.rms_error_px > 1.0) {
    std::fprintf(stderr,
                 "silpose calibrate: warning: RMS reprojection error %.2f px is above 1 px; check "
                 "for blurred images, a board that is not flat, or a wrong --board\n",
                 result.rms_error_px);
  }
  if (boards < 10) {
    std::fprintf(stderr,
                 "silpose calibrate: warning: only %d boards found; 10-20 views with the board "
                 "tilted and in all parts of the image give a more reliable calibration\n",
                 boards);
  }
  WriteCameraFile(arguments.output, camera);
  std::printf("wrote %s\n", arguments.output.c_str());
  if (!arguments.report.empty()) {
    WriteReport(arguments.report, result);
    std::printf("wrote %s\n", arguments.report.c_str());
  }
}

}  // namespace

void AddCalibrateCommand(CLI::App& app) {
  auto arguments = std::make_shared<CalibrateArguments>();
  CLI::App* command = app.add_subcommand(
      "calibrate",
      "Calibrate a camera from images of a flat chessboard (OpenCV, Zhang's method): writes the "
      "intrinsics and distortion as OpenCV YAML for --camera.");
  command
      ->add_option("images", arguments->inputs,
                   "Image files and/or folders of images (taken in name order)")
      ->required();
  command
      ->add_option("--board", arguments->board,
                   "Inner corners of the board, COLSxROWS (a board of 10x7 squares is 9x6)")
      ->capture_default_str();
  command
      ->add_option("--square", arguments->options.square_size,
                   "Side of a square, any unit (only the board distances in --report use it; the "
                   "camera matrix is in pixels)")
      ->capture_default_str();
  command->add_option("-o,--output", arguments->output, "Camera file to write (YAML)")->required();
  command->add_option("--report", arguments->report,
                      "CSV with one row per image: status, RMS error (px), board distance "
                      "(--square units)");
  command->add_flag("--fix-aspect-ratio", arguments->options.fix_aspect_ratio,
                    "Square pixels: fit one focal length (fx = fy)");
  command->add_flag("--zero-tangential", arguments->options.zero_tangential,
                    "Fit no tangential distortion (p1 = p2 = 0)");
  command->add_flag("--k3", arguments->options.estimate_k3,
                    "Also fit the radial coefficient k3 (wide-angle lenses)");
  command
      ->add_option("--subpixel-window", arguments->options.subpixel_half_window_px,
                   "Half size of the sub-pixel corner search window, px (0 = none)")
      ->capture_default_str();
  command->add_flag("--sector-based", arguments->options.sector_based_detector,
                    "Use OpenCV's sector-based corner detector (more robust to blur, slower)");
  command
      ->add_option("--min-boards", arguments->options.min_boards,
                   "Fewest images with a detected board to calibrate from (>= 3)")
      ->capture_default_str();
  command->callback([arguments] { RunCalibrate(*arguments); });
}

}  // namespace silpose::cli
