// `silpose track` end to end on videos and image folders: the outputs (POSES.csv with 6-DOF
// poses, JSON Lines, BOP19, overlay video, plots) and the faults a user meets (a truncated video,
// an unreadable frame, a wrong calibration file, a camera that does not exist): one clear message,
// a non-zero exit code, and what was tracked before the fault kept on disk.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_runner.h"

namespace silpose {
namespace {

// The cells of POSES.csv rows without the time columns (which differ between runs).
std::vector<std::vector<std::string>> CellsWithoutTimes(const std::vector<std::string>& rows) {
  std::vector<std::vector<std::string>> cells;
  const std::vector<std::string> header = CsvCells(rows.at(0));
  for (const std::string& row : rows) {
    std::vector<std::string> kept;
    const std::vector<std::string> fields = CsvCells(row);
    for (size_t c = 0; c < fields.size() && c < header.size(); ++c) {
      if (header[c].rfind("time", 0) != 0) kept.push_back(fields[c]);
    }
    cells.push_back(kept);
  }
  return cells;
}

class CliTrackTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_track_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    const std::string models(SILPOSE_SAMPLE_MODELS_DIR);
    database_ = Path("small.db");
    CommandResult run = Silpose("build-db " + models + "/bunny.obj " + models + "/hand.obj -o " +
                                database_ + " --views 300 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    // 40 colour frames of the hand, then 20 of the bunny, with a video and the empty scene.
    sequence_ = Path("sequence");
    run = Silpose("synth " + models + "/hand.obj " + models + "/bunny.obj -o " + sequence_ +
                  " --trajectory walk --frames 60 --switch-at 40 --colour --video "
                  "--camera-noise 2 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static inline std::filesystem::path directory_;
  static inline std::string database_;
  static inline std::string sequence_;
};

TEST_F(CliTrackTest, ColourVideoWithBackgroundSubtractionGivesPosesAndAllOutputs) {
  const std::string poses = Path("poses.csv");
  const CommandResult run =
      Silpose("track -d " + database_ + " " + sequence_ + "/video.avi --camera " + sequence_ +
              "/camera.yml --segment bgsub --background " + sequence_ + "/background.png -o " +
              poses + " --json " + Path("poses.jsonl") + " --bop " + Path("bop.csv") +
              " --model-unit-mm 1000 --overlay " + Path("overlay.avi") + " --plots " +
              Path("plots") + " --ground-truth " + sequence_ + "/groundtruth.csv --seed 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  EXPECT_NE(run.out.find("right object"), std::string::npos) << run.out;

  const std::vector<std::string> rows = ReadLines(poses);
  ASSERT_EQ(rows.size(), 61u);
  EXPECT_EQ(rows[0].substr(0, 40), "frame,object,score,probability,view_x,vi");
  ASSERT_EQ(CsvCells(rows[0]).size(), 38u);
  int right = 0, with_pose = 0;
  for (size_t r = 1; r < rows.size(); ++r) {
    const std::vector<std::string> fields = CsvCells(rows[r]);
    ASSERT_EQ(fields.size(), 38u) << rows[r];
    const int frame = std::stoi(fields[0]);
    EXPECT_EQ(frame, static_cast<int>(r) - 1);
    const std::string truth = frame < 40 ? "hand" : "bunny";
    // Settled frames: 10 after the start and after the switch.
    if ((frame >= 10 && frame < 40) || frame >= 50) right += fields[1] == truth;
    with_pose += !fields[23].empty();
  }
  EXPECT_GE(right, 38);  // of 40 settled frames
  EXPECT_GE(with_pose, 55);

  const std::vector<std::string> json = ReadLines(Path("poses.jsonl"));
  ASSERT_EQ(json.size(), 60u);
  const nlohmann::json last = nlohmann::json::parse(json.back());
  EXPECT_EQ(last["frame"], 59);
  EXPECT_EQ(last["object"], "bunny");
  ASSERT_TRUE(last["pose"].is_object());
  EXPECT_EQ(last["pose"]["R"].size(), 3u);

  // BOP: t in millimetres = model units x 1000; the camera is 3-6 radii of a unit-size model away.
  const std::vector<std::string> bop = ReadLines(Path("bop.csv"));
  ASSERT_GE(bop.size(), 50u);
  EXPECT_EQ(bop[0], "scene_id,im_id,obj_id,score,R,t,time");
  const std::vector<std::string> fields = CsvCells(bop.back());
  ASSERT_EQ(fields.size(), 7u);
  EXPECT_EQ(SplitLine(fields[4], ' ').size(), 9u);
  const std::vector<std::string> t = SplitLine(fields[5], ' ');
  ASSERT_EQ(t.size(), 3u);
  EXPECT_GT(std::stod(t[2]), 100.0);  // mm: the mesh units are ~0.1-1

  EXPECT_GT(std::filesystem::file_size(Path("overlay.avi")), 60u * 5000u);
  for (const char* plot : {"trajectory.svg", "trajectory.png", "error.svg", "error.png"}) {
    EXPECT_TRUE(std::filesystem::is_regular_file(directory_ / "plots" / plot)) << plot;
  }
}

TEST_F(CliTrackTest, TruncatedVideoKeepsTheFramesBeforeTheCut) {
  const std::string cut = Path("cut.avi");
  std::filesystem::copy_file(sequence_ + "/video.avi", cut,
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) / 2);
  const std::string poses = Path("cut.csv");
  const CommandResult run =
      Silpose("track -d " + database_ + " " + cut + " --camera " + sequence_ + "/camera.yml -o " +
              poses + " --segment bgsub --background " + sequence_ + "/background.png");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("cut.avi"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("stopped after"), std::string::npos) << run.err;
  const size_t rows = ReadLines(poses).size();
  EXPECT_GE(rows, 20u);  // about half of the 60 frames, plus the header
  EXPECT_LT(rows, 40u);
}

TEST_F(CliTrackTest, SmoothingReportsEveryFrameInOrderWithAllOutputs) {
  const std::string common = "track -d " + database_ + " " + sequence_ + "/video.avi --camera " +
                             sequence_ + "/camera.yml --segment bgsub --background " + sequence_ +
                             "/background.png --seed 2 --ground-truth " + sequence_ +
                             "/groundtruth.csv";
  for (const std::string smoothing : {"--lag 10", "--smooth"}) {
    SCOPED_TRACE(smoothing);
    const std::string poses = Path("smoothed.csv");
    const std::string overlay = Path("smoothed.avi");
    const CommandResult run = Silpose(common + " " + smoothing + " -o " + poses + " --json " +
                                      Path("smoothed.jsonl") + " --overlay " + overlay);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("smoothing ("), std::string::npos) << run.out;
    const std::vector<std::string> rows = ReadLines(poses);
    ASSERT_EQ(rows.size(), 61u);
    int right = 0;
    for (size_t r = 1; r < rows.size(); ++r) {
      const std::vector<std::string> fields = CsvCells(rows[r]);
      ASSERT_EQ(fields.size(), 38u) << rows[r];
      const int frame = std::stoi(fields[0]);
      EXPECT_EQ(frame, static_cast<int>(r) - 1);
      const std::string truth = frame < 40 ? "hand" : "bunny";
      if ((frame >= 10 && frame < 40) || frame >= 50) right += fields[1] == truth;
    }
    EXPECT_GE(right, 38);  // of 40 settled frames, as without smoothing
    EXPECT_EQ(ReadLines(Path("smoothed.jsonl")).size(), 60u);
    EXPECT_GT(std::filesystem::file_size(overlay), 60u * 5000u);
  }
  // What cannot be smoothed is refused up front.
  CommandResult run = Silpose(common + " --smooth --brute-force -o " + Path("refused.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("--brute-force"), std::string::npos) << run.err;
  run = Silpose(common + " --smooth --lag 5 -o " + Path("refused.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("not both"), std::string::npos) << run.err;
  run = Silpose(common + " --lag -1 -o " + Path("refused.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("--lag"), std::string::npos) << run.err;
}

TEST_F(CliTrackTest, TheBaselineBuildOfTheInnerLoopsTracksAlike) {
  // SILPOSE_NO_AVX2=1 makes the process run the baseline build of the loops that also have an
  // AVX2 build (docs/conventions.md): POSES.csv must be the same but for the times.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "this processor has no AVX2";
#else
  GTEST_SKIP() << "no AVX2 build on this platform";
#endif
  const std::string common = "track -d " + database_ + " " + sequence_ + "/video.avi --camera " +
                             sequence_ + "/camera.yml --segment bgsub --background " + sequence_ +
                             "/background.png --seed 4 -o ";
  const CommandResult vector = Silpose(common + Path("vector.csv"));
  ASSERT_EQ(vector.exit_code, 0) << vector.err;
  EXPECT_NE(Silpose("--version").out.find("(inner loops: AVX2)"), std::string::npos);
  ::setenv("SILPOSE_NO_AVX2", "1", 1);
  const CommandResult baseline = Silpose(common + Path("baseline.csv"));
  const CommandResult version = Silpose("--version");
  ::unsetenv("SILPOSE_NO_AVX2");
  // The variable did select the baseline build.
  EXPECT_NE(version.out.find("(inner loops: baseline)"), std::string::npos) << version.out;
  ASSERT_EQ(baseline.exit_code, 0) << baseline.err;
  const std::vector<std::string> vector_rows = ReadLines(Path("vector.csv"));
  ASSERT_EQ(vector_rows.size(), 61u);
  EXPECT_EQ(CellsWithoutTimes(vector_rows), CellsWithoutTimes(ReadLines(Path("baseline.csv"))));
}

TEST_F(CliTrackTest, FramesReadAheadTrackAlike) {
  // By default the frames are decoded on a second thread, two ahead; --read-ahead 0 decodes each
  // on the tracking thread when it is needed. The results must be the same but for the times.
  const std::string common = "track -d " + database_ + " " + sequence_ + "/video.avi --camera " +
                             sequence_ + "/camera.yml --segment bgsub --background " + sequence_ +
                             "/background.png --seed 4 -o ";
  const CommandResult ahead = Silpose(common + Path("ahead.csv"));
  ASSERT_EQ(ahead.exit_code, 0) << ahead.err;
  EXPECT_NE(ahead.out.find("(done on the reading thread; + "), std::string::npos) << ahead.out;
  const CommandResult in_turn = Silpose(common + Path("in_turn.csv") + " --read-ahead 0");
  ASSERT_EQ(in_turn.exit_code, 0) << in_turn.err;
  EXPECT_NE(in_turn.out.find(" ms reading), "), std::string::npos) << in_turn.out;
  const CommandResult deep = Silpose(common + Path("deep.csv") + " --read-ahead 7");
  ASSERT_EQ(deep.exit_code, 0) << deep.err;
  const std::vector<std::string> rows = ReadLines(Path("ahead.csv"));
  ASSERT_EQ(rows.size(), 61u);
  EXPECT_EQ(CellsWithoutTimes(rows), CellsWithoutTimes(ReadLines(Path("in_turn.csv"))));
  EXPECT_EQ(CellsWithoutTimes(rows), CellsWithoutTimes(ReadLines(Path("deep.csv"))));
  for (const char* bad : {" --read-ahead -1", " --read-ahead 65"}) {
    const CommandResult refused = Silpose(common + Path("bad.csv") + bad);
    EXPECT_NE(refused.exit_code, 0) << bad;
    EXPECT_EQ(Lines(refused.err), 1) << refused.err;
    EXPECT_NE(refused.err.find("--read-ahead must be 0"), std::string::npos) << refused.err;
  }
}

TEST_F(CliTrackTest, UnreadableFrameIsNamedAndEarlierFramesKept) {
  const std::filesystem::path folder = directory_ / "broken";
  std::filesystem::create_directories(folder);
  for (int k = 0; k < 15; ++k) {
    char name[16];
    std::snprintf(name, sizeof(name), "%06d.png", k);
    std::filesystem::copy_file(std::filesystem::path(sequence_) / "masks" / name, folder / name,
                               std::filesystem::copy_options::overwrite_existing);
  }
  std::ofstream(folder / "000010.png", std::ios::trunc) << "not a png";
  // With the frames read ahead (the default) and without.
  for (const char* read_ahead : {"", " --read-ahead 0"}) {
    const std::string poses = Path("broken.csv");
    const CommandResult run =
        Silpose("track -d " + database_ + " " + folder.string() + " --camera " + sequence_ +
                "/camera.yml -o " + poses + read_ahead);
    EXPECT_NE(run.exit_code, 0);
    EXPECT_EQ(Lines(run.err), 1) << run.err;
    EXPECT_NE(run.err.find("000010.png"), std::string::npos) << run.err;
    EXPECT_EQ(ReadLines(poses).size(), 11u) << read_ahead;  // header + frames 0..9
  }
}

TEST_F(CliTrackTest, WrongCalibrationFileIsRefused) {
  // A calibration of another camera size.
  std::ofstream(Path("small_camera.yml"))
      << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\ncamera_matrix: !!opencv-matrix\n"
         "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 300., 0., 159.5, 0., 300., 119.5, 0., 0., "
         "1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
         "   data: [ 0., 0., 0., 0., 0. ]\n";
  CommandResult run = Silpose("track -d " + database_ + " " + sequence_ + " --camera " +
                              Path("small_camera.yml") + " -o " + Path("x.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("small_camera.yml"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("320x240"), std::string::npos) << run.err;
  // Not a calibration file at all.
  std::ofstream(Path("garbage.yml")) << "this: is\nnot: [a camera\n";
  run = Silpose("track -d " + database_ + " " + sequence_ + " --camera " + Path("garbage.yml") +
                " -o " + Path("x.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("garbage.yml"), std::string::npos) << run.err;
}

TEST_F(CliTrackTest, CameraThatDoesNotExistIsAClearError) {
  const CommandResult run = Silpose("track -d " + database_ + " 97 -o " + Path("cam.csv"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("97"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("camera"), std::string::npos) << run.err;
}

TEST_F(CliTrackTest, WithoutACameraFileADefaultIsUsedWithAWarning) {
  const CommandResult run = Silpose("track -d " + database_ + " " + sequence_ + "/masks -o " +
                                    Path("default.csv") + " --max-frames 5");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning: no --camera"), std::string::npos) << run.err;
  EXPECT_EQ(ReadLines(Path("default.csv")).size(), 6u);
}

TEST_F(CliTrackTest, ManyFixedParticlesSuggestTheAdaptiveCount) {
  // Two objects x 1500 particles reach the 3000 from which a fixed count is pointed to --adaptive;
  // the default 60 per object, or --adaptive itself, say nothing.
  const std::string masks = " " + sequence_ + "/masks --camera " + sequence_ + "/camera.yml";
  CommandResult run = Silpose("track -d " + database_ + masks + " -o " + Path("many.csv") +
                              " --max-frames 2 --particles 1500");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("note: 2 objects x 1500 particles = 3000 particles"), std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("--adaptive"), std::string::npos) << run.err;
  run = Silpose("track -d " + database_ + masks + " -o " + Path("few.csv") + " --max-frames 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err.find("note:"), std::string::npos) << run.err;
  run = Silpose("track -d " + database_ + masks + " -o " + Path("adaptive.csv") +
                " --max-frames 2 --particles 1500 --max-particles 1500 --adaptive");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err.find("note:"), std::string::npos) << run.err;
}

TEST_F(CliTrackTest, BadSegmentationOptionsAreRefused) {
  for (const char* options :
       {"--segment grabcut", "--segment bgsub --bg-method foo", "--hsv-range 1,2,3",
        "--segment bgsub --background /nonexistent/bg.png", "--downscale 0",
        "--segment threshold --hsv-range 0x,10,20,30,170,250,250", "--hsv-range 0,0,0,179,255,255",
        "--segment threshold --background x.png", "--bop-object-ids 1,2"}) {
    const CommandResult run = Silpose("track -d " + database_ + " " + sequence_ + " -o " +
                                      Path("bad.csv") + " " + options);
    EXPECT_NE(run.exit_code, 0) << options;
    EXPECT_EQ(Lines(run.err), 1) << options << ": " << run.err;
  }
}

}  // namespace
}  // namespace silpose
