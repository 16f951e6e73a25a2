// Runs the silpose binary as a user would and checks its output, files and exit codes.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Dense>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "cli_runner.h"
#include "silpose/database/view_database.h"

namespace silpose {
namespace {

class CliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ =
        std::filesystem::temp_directory_path() / ("silpose_cli_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
    models_ = std::string(SILPOSE_SAMPLE_MODELS_DIR);
    // A small database shared by the tests: two sample models, 200 views.
    database_ = (directory_ / "small.db").string();
    const CommandResult run = Silpose("build-db " + models_ + "/bunny.obj " + models_ +
                                      "/hand.obj -o " + database_ + " --views 200 --threads 2");
    ASSERT_EQ(run.exit_code, 0) << run.err;
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static inline std::filesystem::path directory_;
  static inline std::string models_;
  static inline std::string database_;
};

TEST_F(CliTest, EveryCommandHasHelp) {
  for (const char* command :
       {"", "build-db", "match", "render", "demo", "eval", "eval self-match", "synth", "track"}) {
    const CommandResult run = Silpose(std::string(command) + " --help");
    EXPECT_EQ(run.exit_code, 0) << command;
    EXPECT_NE(run.out.find("Usage"), std::string::npos) << command << ": " << run.out;
  }
  EXPECT_NE(Silpose("--version").out.find("silpose "), std::string::npos);
}

TEST_F(CliTest, BuildDbWritesALoadableDatabaseAndReportsIt) {
  const ViewDatabase database = ViewDatabase::Read(database_);
  ASSERT_EQ(database.models.size(), 2u);
  EXPECT_EQ(database.models[0].name, "bunny");
  EXPECT_EQ(database.models[1].name, "hand");
  EXPECT_EQ(database.num_views(), 200);
  EXPECT_EQ(database.signature_length(), 1000);
}

TEST_F(CliTest, RenderThenMatchFindsTheRenderedViewAndRoll) {
  const ViewDatabase database = ViewDatabase::Read(database_);
  const Eigen::Vector3d d = database.sphere.directions[57];
  std::ostringstream view;
  view << d.x() << ',' << d.y() << ',' << d.z();
  const std::string mask = Path("hand57.png");
  const CommandResult render = Silpose("render " + models_ + "/hand.obj --view=" + view.str() +
                                       " --roll 33 --resolution 300 -o " + mask);
  ASSERT_EQ(render.exit_code, 0) << render.err;
  EXPECT_EQ(cv::imread(mask, cv::IMREAD_UNCHANGED).cols, 300);

  const CommandResult table = Silpose("match -d " + database_ + " " + mask + " --top 3");
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("hand"), std::string::npos) << table.out;

  const CommandResult json = Silpose("match -d " + database_ + " " + mask + " --top 3 --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json result = nlohmann::json::parse(json.out);
  ASSERT_EQ(result["candidates"].size(), 3u);
  const auto& best = result["candidates"][0];
  EXPECT_EQ(best["object"], "hand");
  EXPECT_EQ(best["view"], 57);
  EXPECT_NEAR(best["roll_deg"].get<double>(), 33.0, 0.72);
  EXPECT_GT(best["score"].get<double>(), 0.98);
  EXPECT_EQ(result["silhouette"]["status"], "ok");
  // The 6-DOF pose of the best candidate (default camera): a rotation, in front of the camera.
  ASSERT_TRUE(result["pose"].is_object()) << json.out;
  EXPECT_EQ(result["pose"]["object"], "hand");
  Eigen::Matrix3d rotation;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rotation(r, c) = result["pose"]["R"][r][c].get<double>();
  EXPECT_TRUE((rotation.transpose() * rotation).isIdentity(1e-6));
  EXPECT_NEAR(rotation.determinant(), 1.0, 1e-6);
  EXPECT_GT(result["pose"]["t"][2].get<double>(), 0.0);
  EXPECT_EQ(result["camera"], "default");
  EXPECT_GE(result["confidence"].get<double>(), 0.0);
  EXPECT_LE(result["confidence"].get<double>(), 1.0);
  EXPECT_TRUE(result["state"].is_string());
  EXPECT_NE(table.out.find("6-DOF pose of hand"), std::string::npos) << table.out;
  // A camera of another size than the mask is refused, naming the file.
  const std::string camera = Path("match_camera.yml");
  std::ofstream(camera) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 200\n"
                           "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                           "   data: [ 250., 0., 160., 0., 250., 100., 0., 0., 1. ]\n";
  const CommandResult wrong_camera =
      Silpose("match -d " + database_ + " " + mask + " --camera " + camera);
  EXPECT_NE(wrong_camera.exit_code, 0);
  EXPECT_NE(wrong_camera.err.find("match_camera.yml: the camera is 320x200 pixels"),
            std::string::npos)
      << wrong_camera.err;
}

TEST_F(CliTest, RenderWithACameraFileUsesItsImageSize) {
  const std::string camera = Path("camera.yml");
  std::ofstream(camera) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 200\n"
                           "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                           "   data: [ 250., 0., 160., 0., 250., 100., 0., 0., 1. ]\n";
  const std::string mask = Path("camera.png");
  const CommandResult run = Silpose("render " + models_ + "/bunny.obj --view 1,0,0 --camera " +
                                    camera + " --distance 5 -o " + mask);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const cv::Mat image = cv::imread(mask, cv::IMREAD_UNCHANGED);
  EXPECT_EQ(image.cols, 320);
  EXPECT_EQ(image.rows, 200);
  EXPECT_GT(cv::countNonZero(image), 1000);
}

TEST_F(CliTest, MatchTakesManyMasksAndGoesOnPastOneThatCannotBeMatched) {
  const ViewDatabase database = ViewDatabase::Read(database_);
  std::vector<std::string> masks;
  for (int view : {12, 80}) {
    const Eigen::Vector3d d = database.sphere.directions[static_cast<size_t>(view)];
    std::ostringstream direction;
    direction << d.x() << ',' << d.y() << ',' << d.z();
    masks.push_back(Path("many" + std::to_string(view) + ".png"));
    ASSERT_EQ(Silpose("render " + models_ + "/hand.obj --view=" + direction.str() +
                      " --roll -20 --resolution 240 -o " + masks.back())
                  .exit_code,
              0);
  }
  const std::string empty = Path("many_empty.png");
  cv::imwrite(empty, cv::Mat::zeros(40, 40, CV_8UC1));
  const std::string all = masks[0] + " " + empty + " " + masks[1];
  // JSON: one entry per mask, in order; the empty one carries its error.
  const CommandResult json = Silpose("match -d " + database_ + " " + all + " --top 1 --json");
  EXPECT_NE(json.exit_code, 0);
  const nlohmann::json list = nlohmann::json::parse(json.out);
  ASSERT_TRUE(list.is_array());
  ASSERT_EQ(list.size(), 3u);
  EXPECT_EQ(list[0]["mask"], masks[0]);
  EXPECT_EQ(list[0]["candidates"][0]["object"], "hand");
  EXPECT_EQ(list[0]["candidates"][0]["view"], 12);
  EXPECT_EQ(list[1]["mask"], empty);
  EXPECT_NE(list[1]["error"].get<std::string>().find("no usable silhouette"), std::string::npos);
  EXPECT_EQ(list[2]["candidates"][0]["view"], 80);
  EXPECT_NE(json.err.find("many_empty.png: no usable silhouette"), std::string::npos) << json.err;
  EXPECT_NE(json.err.find("1 of 3 masks could not be matched"), std::string::npos) << json.err;
  // Tables: each mask's, the same as matching it alone.
  const CommandResult table = Silpose("match -d " + database_ + " " + all + " --top 1");
  EXPECT_NE(table.exit_code, 0);
  EXPECT_NE(table.out.find("2 masks matched"), std::string::npos) << table.out;
  const CommandResult alone = Silpose("match -d " + database_ + " " + masks[1] + " --top 1");
  ASSERT_EQ(alone.exit_code, 0);
  const std::string first_line = alone.out.substr(0, alone.out.find("6-DOF"));
  EXPECT_NE(table.out.find(first_line), std::string::npos) << table.out;
}

// Bad input: one clear line on stderr naming the file or parameter, a non-zero exit, no crash.
TEST_F(CliTest, BadInputGivesOneClearLineAndANonZeroExit) {
  const std::string empty_mask = Path("empty.png");
  cv::imwrite(empty_mask, cv::Mat::zeros(50, 50, CV_8UC1));
  const std::string not_a_database = Path("not.db");
  std::ofstream(not_a_database) << "hello";
  const std::string truncated = Path("truncated.db");
  {
    std::ifstream in(database_, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const std::string camera_file = Path("bad_input_camera.yml");
  std::ofstream(camera_file) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 200\n"
                                "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                                "   data: [ 250., 0., 160., 0., 250., 100., 0., 0., 1. ]\n";
  const std::string garbage_mesh = Path("garbage.obj");
  std::ofstream(garbage_mesh) << "this is not a mesh\n";
  struct Case {
    std::string arguments;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"build-db /nonexistent/thing.obj -o " + Path("x.db"), "/nonexistent/thing.obj"},
      {"build-db " + garbage_mesh + " -o " + Path("x.db"), "garbage.obj"},
      {"build-db " + models_ + "/bunny.obj -o " + Path("x.db") + " --views 2", "num_views"},
      {"build-db " + models_ + "/bunny.obj -o " + Path("x.db") + " --signature-length 999", "999"},
      {"build-db " + models_ + "/bunny.obj -o /nonexistent/dir/x.db --views 20",
       "/nonexistent/dir/x.db"},
      {"match -d " + database_ + " " + empty_mask, "empty.png: no usable silhouette"},
      {"match -d " + database_ + " /nonexistent/mask.png", "/nonexistent/mask.png: no such file"},
      {"match -d " + not_a_database + " " + empty_mask, "not.db: not a silpose view database"},
      {"match -d " + truncated + " " + empty_mask, "truncated.db: truncated"},
      {"match -d " + database_ + " " + empty_mask + " --top 0", "--top"},
      {"render " + models_ + "/bunny.obj --view 0,0,0 -o " + Path("r.png"), "--view"},
      {"render " + models_ + "/bunny.obj --view 1,2 -o " + Path("r.png"), "--view"},
      {"render " + models_ + "/bunny.obj --view 1,2,3, -o " + Path("r.png"), "--view"},
      {"render " + models_ + "/bunny.obj --view=1e200,1e200,1e200 --camera " + camera_file +
           " -o " + Path("r.png"),
       "--view"},
      {"build-db " + models_ + "/bunny.obj -o " + Path("x.db") + " --views 50 --neighbour-radius 8",
       "neighbour_radius_factor"},
      {"eval self-match " + models_ + "/bunny.obj --views 20 --scales 0.5abc", "--scales"},
      {"render " + models_ + "/bunny.obj --camera /nonexistent/cam.yml -o " + Path("r.png"),
       "cam.yml"},
      {"render " + models_ + "/bunny.obj --resolution 5 -o " + Path("r.png"), "resolution"},
      {"frobnicate", "frobnicate"},
      {"match " + empty_mask, "--database"},
  };
  for (const Case& c : cases) {
    const CommandResult run = Silpose(c.arguments);
    EXPECT_NE(run.exit_code, 0) << c.arguments;
    EXPECT_LT(run.exit_code, 128) << "crashed: " << c.arguments;
    EXPECT_EQ(Lines(run.err), 1) << c.arguments << "\n" << run.err;
    EXPECT_NE(run.err.find(c.expected), std::string::npos) << c.arguments << "\n" << run.err;
  }
}

std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
  std::ifstream file(path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(file, line);) {
    std::vector<std::string> fields;
    std::stringstream stream(line);
    for (std::string field; std::getline(stream, field, ',');) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    rows.push_back(fields);
  }
  return rows;
}

// End to end: a synthetic flight around one model that switches to another half-way, tracked
// with a fixed seed from no initial pose.
TEST_F(CliTest, SynthThenTrackIdentifiesBothObjectsOfASwitchingSequence) {
  const std::string sequence = Path("switch_sequence");
  const CommandResult synth = Silpose("synth " + models_ + "/bunny.obj " + models_ +
                                      "/hand.obj -o " + sequence + " --frames 60 --switch-at 30");
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const std::string poses = Path("switch_poses.csv");
  const CommandResult track =
      Silpose("track -d " + database_ + " " + sequence + " -o " + poses + " --seed 3");
  ASSERT_EQ(track.exit_code, 0) << track.err;
  const auto rows = ReadCsv(poses);
  ASSERT_EQ(rows.size(), 61u);
  EXPECT_EQ(rows[0][0], "frame");
  EXPECT_EQ(rows[0][8], "status");
  for (int frame = 10; frame < 30; ++frame) {
    EXPECT_EQ(rows[static_cast<size_t>(frame) + 1][1], "bunny") << "frame " << frame;
  }
  for (int frame = 40; frame < 60; ++frame) {
    EXPECT_EQ(rows[static_cast<size_t>(frame) + 1][1], "hand") << "frame " << frame;
  }
  // The baseline matches every frame on its own.
  const CommandResult brute = Silpose("track -d " + database_ + " " + sequence + " -o " +
                                      Path("switch_brute.csv") + " --brute-force");
  ASSERT_EQ(brute.exit_code, 0) << brute.err;
  EXPECT_EQ(ReadCsv(Path("switch_brute.csv")).size(), 61u);
}

TEST_F(CliTest, TrackReportsFramesWithoutASilhouetteAndRefusesBadInput) {
  const std::string folder = Path("blank_frames");
  std::filesystem::create_directories(folder);
  for (int i = 0; i < 3; ++i) {
    cv::imwrite(folder + "/" + std::to_string(i) + ".png", cv::Mat::zeros(40, 40, CV_8UC1));
  }
  const std::string poses = Path("blank_poses.csv");
  const CommandResult run = Silpose("track -d " + database_ + " " + folder + " -o " + poses);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto rows = ReadCsv(poses);
  ASSERT_EQ(rows.size(), 4u);
  for (size_t i = 1; i < rows.size(); ++i) {
    EXPECT_NE(rows[i][8].find("predicted"), std::string::npos) << rows[i][8];
  }
  const CommandResult missing =
      Silpose("track -d " + database_ + " /nonexistent/frames -o " + poses);
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("/nonexistent/frames"), std::string::npos);
  const CommandResult bad_particles =
      Silpose("track -d " + database_ + " " + folder + " -o " + poses + " --particles 0");
  EXPECT_NE(bad_particles.exit_code, 0);
  EXPECT_EQ(Lines(bad_particles.err), 1) << bad_particles.err;
}

TEST_F(CliTest, DemoRunsTheWholePipelineOnItsOwnColourVideo) {
  const CommandResult run =
      Silpose("demo --views 400 --frames-per-object 40 --threads 2 -o " + Path("demo"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("right object"), std::string::npos) << run.out;
  for (const char* file :
       {"demo.db", "sequence/video.avi", "sequence/background.png", "POSES.csv", "poses.jsonl",
        "bop_results.csv", "overlay.avi", "plots/trajectory.svg", "plots/error.png"}) {
    EXPECT_TRUE(std::filesystem::is_regular_file(Path(std::string("demo/") + file))) << file;
  }
  // The video shows the hand, the bunny and the cow for 40 frames each: after 10 frames of each,
  // the right object in at least 90 % of the frames.
  std::ifstream csv(Path("demo/POSES.csv"));
  std::string line;
  std::getline(csv, line);
  int rows = 0, settled = 0, right = 0;
  const char* shown[] = {"hand", "bunny", "cow"};
  while (std::getline(csv, line)) {
    std::stringstream fields(line);
    std::vector<std::string> values;
    for (std::string value; std::getline(fields, value, ',');) values.push_back(value);
    if (!line.empty() && line.back() == ',') values.emplace_back();  // an empty last cell
    ASSERT_EQ(values.size(), 38u) << line;
    const int frame = std::stoi(values[0]);
    if (frame % 40 >= 10) {
      ++settled;
      right += values[1] == shown[frame / 40];
    }
    ++rows;
  }
  EXPECT_EQ(rows, 120);
  EXPECT_GE(right, settled * 9 / 10) << right << " of " << settled;
}

}  // namespace
}  // namespace silpose
