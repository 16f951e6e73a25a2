// Hostile input at the command line (docs/limits.md): values out of range, cameras beyond their
// bounds, masks in unusual encodings, degenerate meshes, images and databases beyond the size
// limits, output paths that are devices, FIFOs, symbolic links or being written by another
// process. Each gets one clear message and a non-zero exit, or correct output; nothing is left
// half-written.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.h"
#include "silpose/cli/cli_checks.h"

namespace silpose {
namespace {

int Fields(const std::string& line) {
  int fields = 1;
  for (char c : line) fields += c == ',';
  return fields;
}

// The camera file of a 160x120 camera with these intrinsics.
std::string CameraYaml(double fx, double fy, double cx, double cy, double k1) {
  std::ostringstream text;
  text.precision(17);
  text << "%YAML:1.0\n---\nimage_width: 160\nimage_height: 120\ncamera_matrix: !!opencv-matrix\n"
       << "   rows: 3\n   cols: 3\n   dt: d\n   data: [ " << fx << ", 0., " << cx << ", 0., " << fy
       << ", " << cy << ", 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n"
       << "   cols: 5\n   dt: d\n   data: [ " << k1 << ", 0., 0., 0., 0. ]\n";
  return text.str();
}

class CliLimitsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_limits_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
    database_ = Path("small.db");
    CommandResult run = Silpose("build-db " + models + "/bunny.obj " + models + "/hand.obj -o " +
                                database_ + " --views 150 --distances 3,7 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    sequence_ = Path("sequence");
    std::ofstream(Path("camera.yml")) << CameraYaml(150.0, 150.0, 79.5, 59.5, 0.0);
    run = Silpose("synth " + models + "/bunny.obj -o " + sequence_ +
                  " --trajectory walk --frames 8 --threads 2 --camera " + Path("camera.yml"));
    ASSERT_EQ(run.exit_code, 0) << run.err;
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  // `track` on INPUT writing -o OUT, first frames only.
  static CommandResult Track(const std::string& input, const std::string& out,
                             const std::string& options = "") {
    return Silpose("track -d " + database_ + " " + input + " --camera " + Path("camera.yml") +
                   " -o " + out + " " + options);
  }

  // Copies the sequence's masks into a folder, each converted by `convert`.
  template <typename Convert>
  static std::string ConvertedMasks(const std::string& name, Convert convert) {
    const std::filesystem::path folder = Path(name);
    std::filesystem::create_directories(folder);
    for (const auto& entry : std::filesystem::directory_iterator(sequence_ + "/masks")) {
      const cv::Mat mask = cv::imread(entry.path().string(), cv::IMREAD_GRAYSCALE);
      EXPECT_TRUE(cv::imwrite((folder / entry.path().filename()).string(), convert(mask)));
    }
    return folder.string();
  }

  static int MeasuredRows(const std::string& poses) {
    int measured = 0;
    for (const std::string& line : ReadLines(poses)) {
      measured += line.find(",measured,") != std::string::npos;
    }
    return measured;
  }

  static inline std::filesystem::path directory_;
  static inline std::string database_;
  static inline std::string sequence_;
};

TEST_F(CliLimitsTest, SeedsMustBeWholeNumbersInRange) {
  for (const char* seed :
       {"-1", "18446744073709551616", "99999999999999999999", "\"\"", "1.5", "0x10", "' 7'"}) {
    const CommandResult run =
        Track(sequence_, Path("seed.csv"), std::string("--max-frames 1 --seed ") + seed);
    EXPECT_NE(run.exit_code, 0) << seed;
    EXPECT_EQ(Lines(run.err), 1) << seed << ": " << run.err;
    EXPECT_NE(run.err.find("seed"), std::string::npos) << run.err;
  }
  const CommandResult largest =
      Track(sequence_, Path("seed.csv"), "--max-frames 1 --seed 18446744073709551615");
  EXPECT_EQ(largest.exit_code, 0) << largest.err;
  const CommandResult synth =
      Silpose("synth " + std::string(SILPOSE_SAMPLE_MODELS_DIR) + "/bunny.obj -o " +
              Path("seed_seq") + " --frames 2 --seed -1");
  EXPECT_NE(synth.exit_code, 0);
  EXPECT_NE(synth.err.find("seed"), std::string::npos) << synth.err;
}

TEST_F(CliLimitsTest, EvalModelsFolderFromTheEnvironmentMustHoldMeshes) {
  // SILPOSE_EVAL_MODELS names the evaluation's default meshes; a wrong folder is one clear line.
  const std::string missing = Path("no_such_models");
  ::setenv("SILPOSE_EVAL_MODELS", missing.c_str(), 1);
  CommandResult run = Silpose("eval self-match");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find(missing + " (SILPOSE_EVAL_MODELS): not a folder"), std::string::npos)
      << run.err;
  const std::string empty = Path("empty_models");
  std::filesystem::create_directories(empty);
  ::setenv("SILPOSE_EVAL_MODELS", empty.c_str(), 1);
  run = Silpose("eval self-match");
  ::unsetenv("SILPOSE_EVAL_MODELS");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("no mesh files in it"), std::string::npos) << run.err;
}

TEST_F(CliLimitsTest, ParticleCountsAreBoundedByLimitsTheUserCanSee) {
  // Fixed counts below and above the adaptive defaults (10..300) just work.
  for (const char* particles : {"5", "500"}) {
    const CommandResult run = Track(sequence_, Path("particles.csv"),
                                    std::string("--max-frames 2 --particles ") + particles);
    EXPECT_EQ(run.exit_code, 0) << particles << ": " << run.err;
  }
  // Adaptive: the cap is a soft limit the message names, and raising it works.
  CommandResult run = Track(sequence_, Path("particles.csv"), "--adaptive --particles 500");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("--max-particles"), std::string::npos) << run.err;
  run = Track(sequence_, Path("particles.csv"),
              "--max-frames 2 --adaptive --particles 500 --max-particles 600");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  // The hard limit over all objects: 600000 x 2 models.
  run = Track(sequence_, Path("particles.csv"), "--particles 600000");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("1000000"), std::string::npos) << run.err;
  run = Track(sequence_, Path("particles.csv"), "--particles 0");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("--particles"), std::string::npos) << run.err;
}

TEST_F(CliLimitsTest, CamerasBeyondTheirBoundsAreRefusedNamingTheFileAndValue) {
  struct Case {
    std::string yaml;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {CameraYaml(1e300, 1e300, 79.5, 59.5, 0.0), "focal"},
      {CameraYaml(150.0, 150.0, 1e9, 59.5, 0.0), "principal point"},
      {CameraYaml(150.0, 150.0, 79.5, 59.5, 1e10), "k1"},
      {CameraYaml(1e-3, 1e-3, 79.5, 59.5, 0.0), "focal"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string camera = Path("bad_camera_" + std::to_string(i) + ".yml");
    std::ofstream(camera) << cases[i].yaml;
    const std::string poses = Path("bad_camera.csv");
    std::filesystem::remove(poses);
    const CommandResult run =
        Silpose("track -d " + database_ + " " + sequence_ + " --camera " + camera + " -o " + poses);
    EXPECT_NE(run.exit_code, 0) << cases[i].expected;
    EXPECT_EQ(Lines(run.err), 1) << run.err;
    EXPECT_NE(run.err.find(camera), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(cases[i].expected), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(poses));
    const CommandResult synth =
        Silpose("synth " + std::string(SILPOSE_SAMPLE_MODELS_DIR) + "/bunny.obj -o " +
                Path("bad_camera_seq") + " --frames 2 --camera " + camera);
    EXPECT_NE(synth.exit_code, 0);
    EXPECT_NE(synth.err.find(camera), std::string::npos) << synth.err;
  }
}

TEST_F(CliLimitsTest, NoOutputHoldsANonFiniteNumber) {
  // The rule the track command applies to every row before it is written.
  FrameResult result;
  result.status = "measured";
  result.camera_from_object = Rigid3();
  result.camera_from_object->translation.z() = std::numeric_limits<double>::infinity();
  cli::DropNonFinitePose(&result);
  EXPECT_FALSE(result.camera_from_object.has_value());
  EXPECT_EQ(result.status, "measured-pose-not-finite");
  // And the rows of a normal run: every number finite.
  const CommandResult run = Track(sequence_, Path("finite.csv"), "--json " + Path("finite.json"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const std::string& file : {Path("finite.csv"), Path("finite.json")}) {
    for (const std::string& line : ReadLines(file)) {
      EXPECT_EQ(line.find("inf"), std::string::npos) << line;
      EXPECT_EQ(line.find("nan"), std::string::npos) << line;
    }
  }
}

TEST_F(CliLimitsTest, MatchAndTrackDecodeMasksByOneRule) {
  const std::string eight = sequence_ + "/masks";
  // 16-bit masks with object value 1.
  const std::string sixteen = ConvertedMasks("masks16", [](const cv::Mat& mask) {
    cv::Mat out;
    cv::Mat(mask > 0).convertTo(out, CV_16U, 1.0 / 255.0);
    return out;
  });
  // BGRA masks whose object is only in the alpha channel.
  const std::string alpha = ConvertedMasks("masks_alpha", [](const cv::Mat& mask) {
    std::vector<cv::Mat> planes(3, cv::Mat::zeros(mask.size(), CV_8U));
    planes.push_back(mask);
    cv::Mat out;
    cv::merge(planes, out);
    return out;
  });
  // BGRA masks opaque everywhere: the colour channels decide.
  const std::string opaque = ConvertedMasks("masks_opaque", [](const cv::Mat& mask) {
    std::vector<cv::Mat> planes = {mask, mask, mask, cv::Mat(mask.size(), CV_8U, cv::Scalar(255))};
    cv::Mat out;
    cv::merge(planes, out);
    return out;
  });
  const CommandResult reference = Track(eight, Path("masks8.csv"));
  ASSERT_EQ(reference.exit_code, 0) << reference.err;
  const int measured = MeasuredRows(Path("masks8.csv"));
  ASSERT_GT(measured, 4);
  auto area = [](const std::string& match_output) {
    const auto at = match_output.find("\"area_px\":");
    return at == std::string::npos ? -1.0 : std::atof(match_output.c_str() + at + 10);
  };
  const CommandResult reference_match =
      Silpose("match -d " + database_ + " " + eight + "/000003.png --json");
  ASSERT_EQ(reference_match.exit_code, 0) << reference_match.err;
  const double reference_area = area(reference_match.out);
  ASSERT_GT(reference_area, 100.0);
  for (const std::string& folder : {sixteen, alpha, opaque}) {
    const std::string poses = Path("decoded.csv");
    const CommandResult run = Track(folder, poses);
    ASSERT_EQ(run.exit_code, 0) << folder << ": " << run.err;
    EXPECT_EQ(MeasuredRows(poses), measured) << folder;
    const CommandResult match =
        Silpose("match -d " + database_ + " " + folder + "/000003.png --json");
    ASSERT_EQ(match.exit_code, 0) << folder << ": " << match.err;
    EXPECT_NEAR(area(match.out), reference_area, 1.0) << folder;
  }
}

TEST_F(CliLimitsTest, DegenerateMeshesAreRefusedByBuildDb) {
  const std::string mesh = Path("needle.obj");
  std::ofstream(mesh) << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
  const CommandResult run =
      Silpose("build-db " + mesh + " -o " + Path("needle.db") + " --views 50 --threads 1");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("needle"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("degenerate"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(Path("needle.db")));
}

// The file size in "a file of about 612.2 kB" (or MB, GB) of build-db's estimate, in MB.
double EstimatedMegabytes(const std::string& out) {
  const auto at = out.find("a file of about ");
  if (at == std::string::npos) return -1.0;
  char* end = nullptr;
  const double value = std::strtod(out.c_str() + at + 16, &end);
  const std::string unit(end, std::min<size_t>(3, std::strlen(end)));
  if (unit == " kB") return value / 1e3;
  if (unit == " GB") return value * 1e3;
  if (unit == " MB") return value;
  return -1.0;
}

TEST_F(CliLimitsTest, BuildDbEstimatesTheSizeAndRefusesHugeDatabasesUpFront) {
  const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
  CommandResult run =
      Silpose("build-db " + models + "/bunny.obj -o " + Path("huge.db") + " --views 1000000");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("--force"), std::string::npos) << run.err;
  EXPECT_NE(run.out.find("estimate:"), std::string::npos) << run.out;
  EXPECT_FALSE(std::filesystem::exists(Path("huge.db")));
  // Beyond any machine's memory even with --force, before anything is allocated.
  run = Silpose("build-db " + models + "/bunny.obj -o " + Path("huge.db") +
                " --views 1000000 --signature-length 65536 --distances 2,3,4,5,6,7,8,9 --force");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("memory"), std::string::npos) << run.err;
  // The estimate printed before a normal build is close to the file written.
  run = Silpose("build-db " + models + "/bunny.obj -o " + Path("estimated.db") +
                " --views 100 --threads 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto at = run.out.find("a file of about ");
  ASSERT_NE(at, std::string::npos) << run.out;
  const double written_mb =
      static_cast<double>(std::filesystem::file_size(Path("estimated.db"))) / 1e6;
  EXPECT_NEAR(EstimatedMegabytes(run.out), written_mb, 0.1 * written_mb) << run.out;
  // With every view's signature kept, the file is larger by 4 kB a view and shell (M = 1000), and
  // so is the estimate.
  run = Silpose("build-db " + models + "/bunny.obj -o " + Path("full.db") +
                " --views 100 --threads 2 --full-signatures");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const double full_mb = static_cast<double>(std::filesystem::file_size(Path("full.db"))) / 1e6;
  EXPECT_NEAR(full_mb - written_mb, 100 * 4 * 4000 / 1e6, 0.05 * full_mb);
  EXPECT_NEAR(EstimatedMegabytes(run.out), full_mb, 0.1 * full_mb) << run.out;
}

TEST_F(CliLimitsTest, BuildDbNeverReplacesDevicesFifosOrSymlinksAndIgnoresStaleTemporaries) {
  const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
  const std::string fifo = Path("fifo.db");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string target = Path("target.db");
  std::ofstream(target) << "kept";
  const std::string link = Path("link.db");
  std::filesystem::create_symlink(target, link);
  for (const auto& [path, kind] :
       std::vector<std::pair<std::string, std::string>>{{fifo, "FIFO"}, {link, "symbolic link"}}) {
    const CommandResult run =
        Silpose("build-db " + models + "/bunny.obj -o " + path + " --views 50 --threads 1");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_EQ(Lines(run.err), 1) << run.err;
    EXPECT_NE(run.err.find(path), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(kind), std::string::npos) << run.err;
  }
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(ReadLines(target), std::vector<std::string>{"kept"});
  // A <out>.tmp left by a killed build is neither used nor removed.
  const std::string out = Path("fresh.db");
  std::ofstream(out + ".tmp") << "stale";
  const CommandResult run =
      Silpose("build-db " + models + "/bunny.obj -o " + out + " --views 50 --threads 1");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(ReadLines(out + ".tmp"), std::vector<std::string>{"stale"});
  EXPECT_EQ(Silpose("match -d " + out + " " + sequence_ + "/masks/000000.png").exit_code, 0);
}

TEST_F(CliLimitsTest, AnOutputBeingWrittenByAnotherProcessIsRefused) {
  const std::string poses = Path("locked.csv");
  // Another process holds the lock (flock(1) takes the same kind of lock silpose takes).
  const std::string holder = "flock " + poses + ".lock sleep 4 & sleep 0.5; ";
  const std::string command = holder + SILPOSE_BINARY + std::string(" track -d ") + database_ +
                              " " + sequence_ + " -o " + poses + " > /dev/null 2> " +
                              Path("locked.err") + "; echo $? > " + Path("locked.rc") + "; wait";
  ASSERT_EQ(std::system(command.c_str()), 0);
  EXPECT_EQ(ReadLines(Path("locked.rc")), std::vector<std::string>{"1"});
  const std::vector<std::string> err = ReadLines(Path("locked.err"));
  ASSERT_EQ(err.size(), 1u);
  EXPECT_NE(err[0].find("being written by another silpose process"), std::string::npos) << err[0];
  EXPECT_NE(err[0].find(poses), std::string::npos) << err[0];
  EXPECT_FALSE(std::filesystem::exists(poses));
  // Four runs at once on one output: the file holds one run's rows, never a mix.
  const std::string shared = Path("shared.csv");
  std::string four;
  for (int i = 0; i < 4; ++i) {
    four += std::string(SILPOSE_BINARY) + " track -d " + database_ + " " + sequence_ + " -o " +
            shared + " --json " + Path("shared.json") + " > /dev/null 2>> " + Path("four.err") +
            " & ";
  }
  four += "wait";
  ASSERT_EQ(std::system(four.c_str()), 0);
  const std::vector<std::string> rows = ReadLines(shared);
  ASSERT_EQ(rows.size(), 9u);  // header + 8 frames
  for (const std::string& row : rows) EXPECT_EQ(Fields(row), Fields(rows[0])) << row;
  for (const std::string& line : ReadLines(Path("four.err"))) {
    if (line.find("error") != std::string::npos) {
      EXPECT_NE(line.find("another silpose process"), std::string::npos) << line;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(shared + ".lock"));
}

TEST_F(CliLimitsTest, AnOutputThatCannotBeOpenedLeavesNothingBehind) {
  for (const std::string& option : {std::string("--json ") + Path("missing/x.json"),
                                    std::string("--bop ") + directory_.string(),
                                    std::string("--overlay ") + Path("overlay.unknown")}) {
    const std::string poses = Path("nothing.csv");
    std::filesystem::remove(poses);
    const CommandResult run = Track(sequence_, poses, option);
    EXPECT_NE(run.exit_code, 0) << option;
    EXPECT_EQ(Lines(run.err), 1) << run.err;
    EXPECT_FALSE(std::filesystem::exists(poses)) << option;
  }
  // A write failure names the rows really written.
  const CommandResult run = Track(sequence_, Path("full.csv"), "--json /dev/full");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("/dev/full"), std::string::npos) << run.err;
  const size_t rows = ReadLines(Path("full.csv")).size() - 1;
  EXPECT_NE(run.err.find("stopped after " + std::to_string(rows) + " frames"), std::string::npos)
      << run.err << " (" << rows << " rows)";
}

TEST_F(CliLimitsTest, ImagesBeyondTheSizeLimitAreRefusedBeforeDecoding) {
  // A PNG whose header announces 20000 x 20000 pixels (its data need not exist: nothing is
  // decoded).
  const std::filesystem::path folder = Path("huge_frames");
  std::filesystem::create_directories(folder);
  const unsigned char png[] = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1a, '\n', 0,    0, 0,
                               13,   'I',  'H', 'D', 'R',  0,    0,    0x4e, 0x20, 0, 0,
                               0x4e, 0x20, 8,   0,   0,    0,    0,    0,    0,    0, 0};
  std::ofstream(folder / "000000.png", std::ios::binary)
      .write(reinterpret_cast<const char*>(png), sizeof(png));
  for (const std::string& command :
       {"track -d " + database_ + " " + folder.string() + " -o " + Path("huge.csv"),
        "track -d " + database_ + " " + folder.string() + " --segment bgsub -o " + Path("huge.csv"),
        "match -d " + database_ + " " + (folder / "000000.png").string(),
        "track -d " + database_ + " " + sequence_ + " --segment bgsub --background " +
            (folder / "000000.png").string() + " -o " + Path("huge.csv")}) {
    const CommandResult run = Silpose(command);
    EXPECT_EQ(run.exit_code, 1) << command;
    EXPECT_EQ(Lines(run.err), 1) << run.err;
    EXPECT_NE(run.err.find("000000.png"), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("20000x20000"), std::string::npos) << run.err;
  }
}

TEST_F(CliLimitsTest, ATruncatedPngIsOneMessageFromSilposeAlone) {
  const std::filesystem::path folder = Path("truncated");
  std::filesystem::create_directories(folder);
  for (const char* name : {"000000.png", "000001.png"}) {
    std::filesystem::copy_file(std::filesystem::path(sequence_) / "masks" / name, folder / name);
  }
  std::ifstream whole(std::filesystem::path(sequence_) / "masks" / "000002.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
  std::ofstream(folder / "000002.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  for (const std::string& command :
       {"track -d " + database_ + " " + folder.string() + " --camera " + Path("camera.yml") +
            " -o " + Path("truncated.csv"),
        "match -d " + database_ + " " + (folder / "000002.png").string()}) {
    const CommandResult run = Silpose(command);
    EXPECT_EQ(run.exit_code, 1) << command;
    EXPECT_EQ(Lines(run.err), 1) << run.err;  // no libpng line before it
    EXPECT_NE(run.err.find("000002.png"), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("truncated"), std::string::npos) << run.err;
  }
  EXPECT_EQ(ReadLines(Path("truncated.csv")).size(), 3u);  // header + frames 0 and 1
}

TEST_F(CliLimitsTest, BackgroundSubtractionOnLargeFramesRunsDownscaled) {
  // Two 3200 x 3000 frames (9.6 million pixels): over the background model's bound.
  const std::filesystem::path folder = Path("large_frames");
  std::filesystem::create_directories(folder);
  cv::Mat frame(3000, 3200, CV_8UC3, cv::Scalar(40, 90, 160));
  for (const char* name : {"000000.png", "000001.png"}) {
    ASSERT_TRUE(cv::imwrite((folder / name).string(), frame));
  }
  const CommandResult run = Silpose("track -d " + database_ + " " + folder.string() +
                                    " --segment bgsub -o " + Path("large.csv"));
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("--downscale 2"), std::string::npos) << run.err;
  EXPECT_EQ(ReadLines(Path("large.csv")).size(), 3u);
}

TEST_F(CliLimitsTest, DistortedSequencesAreRenderedAndTrackedThroughTheLens) {
  const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
  std::ofstream(Path("distorted.yml")) << CameraYaml(150.0, 150.0, 79.5, 59.5, -0.3);
  // Orbits and walks keep the object at the image centre, where a lens hardly moves the outline
  // (a few pixels here); a hand-held object wanders off-axis, where it does.
  for (const char* trajectory : {"handheld"}) {
    const std::string plain = Path(std::string("plain_") + trajectory);
    const std::string distorted = Path(std::string("distorted_") + trajectory);
    ASSERT_EQ(Silpose("synth " + models + "/bunny.obj -o " + plain + " --frames 3 --trajectory " +
                      trajectory + " --camera " + Path("camera.yml"))
                  .exit_code,
              0);
    ASSERT_EQ(
        Silpose("synth " + models + "/bunny.obj -o " + distorted + " --frames 3 --trajectory " +
                trajectory + " --camera " + Path("distorted.yml"))
            .exit_code,
        0);
    const cv::Mat a = cv::imread(plain + "/masks/000001.png", cv::IMREAD_GRAYSCALE);
    const cv::Mat b = cv::imread(distorted + "/masks/000001.png", cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(a.empty());
    ASSERT_FALSE(b.empty());
    // The lens moves the outline: the masks differ by more than a few boundary pixels.
    EXPECT_GT(cv::countNonZero(a != b), cv::countNonZero(a) / 50) << trajectory;
  }
  // Tracking a distorted orbit with its camera gives the pose, not a distance off by the lens.
  const std::string sequence = Path("distorted_track");
  ASSERT_EQ(
      Silpose("synth " + models + "/bunny.obj -o " + sequence +
              " --frames 30 --trajectory orbit --step-deg 3 --camera " + Path("distorted.yml"))
          .exit_code,
      0);
  const CommandResult run =
      Silpose("track -d " + database_ + " " + sequence + " -o " + Path("distorted.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto at = run.out.find("translation error median ");
  ASSERT_NE(at, std::string::npos) << run.out;
  EXPECT_LT(std::atof(run.out.c_str() + at + 25), 3.0) << run.out;
}

}  // namespace
}  // namespace silpose
