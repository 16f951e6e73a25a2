#include "silpose/pose/pose_output.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

std::vector<std::string> ReadLines(const std::filesystem::path& path) {
  std::ifstream stream(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> Split(const std::string& line, char separator) {
  std::vector<std::string> fields;
  std::stringstream stream(line);
  for (std::string field; std::getline(stream, field, separator);) fields.push_back(field);
  if (!line.empty() && line.back() == separator) fields.emplace_back();
  return fields;
}

class PoseOutputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_pose_output_" + std::to_string(::getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  // Three frames: with a pose and everything, with an estimate but no pose or probability, and
  // without silhouette or estimate.
  static std::vector<FrameResult> Frames() {
    std::vector<FrameResult> frames(3);
    frames[0].frame = 0;
    frames[0].frame_name = "000000.png";
    frames[0].status = "measured";
    frames[0].object = 1;
    frames[0].object_name = "bunny";
    frames[0].score = 0.975;
    frames[0].probability = 0.8;
    frames[0].view_dir_in_object = Eigen::Vector3d(0.6, 0.0, 0.8);
    frames[0].roll_deg = -12.5;
    frames[0].time_ms = 2.5;
    frames[0].time_segment_ms = 0.5;
    frames[0].time_describe_ms = 0.25;
    frames[0].time_match_ms = 1.25;
    frames[0].time_pose_ms = 0.125;
    frames[0].particles = 600;
    frames[0].effective_particles = 123.4;
    frames[0].camera_from_object =
        CameraFromObjectAtView(Eigen::Vector3d(0.6, 0.0, 0.8), -12.5, 0.3, {0.01, 0.02, 0.03});
    frames[0].confidence = 0.875;
    frames[0].state = TrackState::kAmbiguous;
    frames[0].iou = 0.96875;
    frames[0].runner_up_object = 0;
    frames[0].runner_up_name = "cow";
    frames[0].runner_up_mass = 0.25;
    frames[0].runner_up_view_dir = Eigen::Vector3d(0.0, 0.6, 0.8);
    frames[0].runner_up_roll_deg = 45.0;
    frames[1].confidence = 0.125;
    frames[1].state = TrackState::kLost;
    frames[1].frame = 1;
    frames[1].status = "measured";
    frames[1].object = 0;
    frames[1].object_name = "cow";
    frames[1].score = 0.5;
    frames[1].view_dir_in_object = Eigen::Vector3d(0, 0, 1);
    frames[1].roll_deg = 3.0;
    frames[1].time_ms = 1.0;
    frames[2].frame = 2;
    frames[2].status = "no-silhouette-empty";
    frames[2].time_ms = 0.25;
    return frames;
  }

  std::filesystem::path directory_;
};

TEST_F(PoseOutputTest, PosesCsvHasTheHeaderAndOneRowPerFrame) {
  const std::filesystem::path path = directory_ / "POSES.csv";
  PosesCsvWriter writer(path);
  for (const FrameResult& frame : Frames()) {
    writer.Write(frame);
    // Flushed per row: the file already holds it.
    EXPECT_EQ(ReadLines(path).size(), static_cast<size_t>(frame.frame + 2));
  }
  writer.Close();
  const std::vector<std::string> lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0],
            "frame,object,score,probability,view_x,view_y,view_z,roll_deg,status,time_ms,"
            "particles,effective_particles,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,"
            "time_segment_ms,time_describe_ms,time_match_ms,time_pose_ms,time_refine_ms,"
            "confidence,state,iou,runner_up_object,runner_up_mass,runner_up_view_x,"
            "runner_up_view_y,runner_up_view_z,runner_up_roll_deg");
  for (const std::string& line : lines) EXPECT_EQ(Split(line, ',').size(), 38u) << line;
  const std::vector<std::string> first = Split(lines[1], ',');
  EXPECT_EQ(first[0], "0");
  EXPECT_EQ(first[1], "bunny");
  EXPECT_EQ(std::stod(first[2]), 0.975);
  EXPECT_EQ(first[8], "measured");
  EXPECT_EQ(first[10], "600");
  const Rigid3 pose = *Frames()[0].camera_from_object;  // a copy: Frames() is a temporary
  for (int i = 0; i < 9; ++i) EXPECT_EQ(std::stod(first[12 + i]), pose.rotation(i / 3, i % 3));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(std::stod(first[21 + i]), pose.translation[i]);
  EXPECT_EQ(std::stod(first[24]), 0.5);  // stage times, in the order of the header
  EXPECT_EQ(std::stod(first[25]), 0.25);
  EXPECT_EQ(std::stod(first[26]), 1.25);
  EXPECT_EQ(std::stod(first[27]), 0.125);
  EXPECT_EQ(first[28], "");  // refinement did not run
  EXPECT_EQ(std::stod(first[29]), 0.875);
  EXPECT_EQ(first[30], "ambiguous");
  EXPECT_EQ(std::stod(first[31]), 0.96875);
  EXPECT_EQ(first[32], "cow");
  EXPECT_EQ(std::stod(first[33]), 0.25);
  EXPECT_EQ(std::stod(first[35]), 0.6);
  EXPECT_EQ(std::stod(first[37]), 45.0);
  const std::vector<std::string> second = Split(lines[2], ',');
  EXPECT_EQ(second[1], "cow");
  EXPECT_EQ(second[3], "");   // probability unknown
  EXPECT_EQ(second[10], "");  // no particles
  for (int i = 12; i < 24; ++i) EXPECT_EQ(second[i], "");
  EXPECT_EQ(second[30], "lost");
  for (int i = 31; i < 38; ++i) EXPECT_EQ(second[i], "");  // no IoU, no runner-up
  EXPECT_EQ(lines[3], "2,,,,,,,,no-silhouette-empty,0.25,,,,,,,,,,,,,,,,,,,,,no-silhouette,,,,,,,");
  EXPECT_THROW(writer.Write(Frames()[0]), Error);  // after Close
}

TEST_F(PoseOutputTest, PosesCsvQuotesNamesWithCommas) {
  const std::filesystem::path path = directory_ / "POSES.csv";
  PosesCsvWriter writer(path);
  FrameResult frame = Frames()[1];
  frame.object_name = "a,\"b\"";
  writer.Write(frame);
  writer.Close();
  EXPECT_EQ(ReadLines(path)[1].substr(0, 12), "1,\"a,\"\"b\"\"\",");
}

TEST_F(PoseOutputTest, JsonLinesParseBack) {
  const std::filesystem::path path = directory_ / "poses.jsonl";
  JsonLinesWriter writer(path);
  for (const FrameResult& frame : Frames()) writer.Write(frame);
  writer.Close();
  const std::vector<std::string> lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 3u);
  std::vector<nlohmann::json> objects;
  for (const std::string& line : lines) objects.push_back(nlohmann::json::parse(line));
  EXPECT_EQ(objects[0]["frame"], 0);
  EXPECT_EQ(objects[0]["frame_name"], "000000.png");
  EXPECT_EQ(objects[0]["object"], "bunny");
  EXPECT_EQ(objects[0]["object_index"], 1);
  EXPECT_EQ(objects[0]["score"].get<double>(), 0.975);
  EXPECT_EQ(objects[0]["particles"], 600);
  EXPECT_EQ(objects[0]["view_dir"].size(), 3u);
  EXPECT_EQ(objects[0]["time_match_ms"].get<double>(), 1.25);
  EXPECT_TRUE(objects[0]["time_refine_ms"].is_null());
  const Rigid3 pose = *Frames()[0].camera_from_object;  // a copy: Frames() is a temporary
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(objects[0]["pose"]["R"][r][c].get<double>(), pose.rotation(r, c));
    }
    EXPECT_EQ(objects[0]["pose"]["t"][r].get<double>(), pose.translation[r]);
  }
  EXPECT_EQ(objects[0]["confidence"].get<double>(), 0.875);
  EXPECT_EQ(objects[0]["state"], "ambiguous");
  EXPECT_EQ(objects[0]["runner_up"]["object"], "cow");
  EXPECT_EQ(objects[0]["runner_up"]["mass"].get<double>(), 0.25);
  EXPECT_EQ(objects[0]["runner_up"]["view_dir"].size(), 3u);
  EXPECT_TRUE(objects[1]["runner_up"].is_null());
  EXPECT_TRUE(objects[1]["iou"].is_null());
  EXPECT_EQ(objects[2]["state"], "no-silhouette");
  EXPECT_TRUE(objects[2]["confidence"].is_null());
  EXPECT_TRUE(objects[1]["probability"].is_null());
  EXPECT_TRUE(objects[1]["pose"].is_null());
  EXPECT_TRUE(objects[1]["frame_name"].is_null());
  EXPECT_TRUE(objects[2]["object"].is_null());
  EXPECT_TRUE(objects[2]["view_dir"].is_null());
  EXPECT_EQ(objects[2]["status"], "no-silhouette-empty");
}

TEST_F(PoseOutputTest, BopCsvWritesFramesWithAPoseInMillimetres) {
  const std::filesystem::path path = directory_ / "results.csv";
  BopOutputOptions options;
  options.scene_id = 3;
  options.model_unit_mm = 1000.0;  // model in metres
  BopCsvWriter writer(path, options);
  int written = 0;
  for (const FrameResult& frame : Frames()) written += writer.Write(frame);
  writer.Close();
  EXPECT_EQ(written, 1);
  const std::vector<std::string> lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], "scene_id,im_id,obj_id,score,R,t,time");
  const std::vector<std::string> fields = Split(lines[1], ',');
  ASSERT_EQ(fields.size(), 7u);
  EXPECT_EQ(fields[0], "3");
  EXPECT_EQ(fields[1], "0");
  EXPECT_EQ(fields[2], "2");  // model index 1 + 1
  EXPECT_EQ(std::stod(fields[3]), 0.975);
  const std::vector<std::string> rotation = Split(fields[4], ' ');
  const std::vector<std::string> translation = Split(fields[5], ' ');
  ASSERT_EQ(rotation.size(), 9u);
  ASSERT_EQ(translation.size(), 3u);
  const Rigid3 pose = *Frames()[0].camera_from_object;  // a copy: Frames() is a temporary
  for (int i = 0; i < 9; ++i) EXPECT_EQ(std::stod(rotation[i]), pose.rotation(i / 3, i % 3));
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(std::stod(translation[i]), 1000.0 * pose.translation[i]);
  }
  EXPECT_DOUBLE_EQ(std::stod(fields[6]), 0.0025);  // seconds
}

TEST_F(PoseOutputTest, BopObjectIdsAreUserGiven) {
  const std::filesystem::path path = directory_ / "results.csv";
  BopOutputOptions options;
  options.object_ids = {7, 21};
  BopCsvWriter writer(path, options);
  FrameResult frame = Frames()[0];
  frame.time_ms = std::nan("");
  writer.Write(frame);
  frame.object = 2;
  EXPECT_THROW(writer.Write(frame), Error);
  writer.Close();
  const std::vector<std::string> fields = Split(ReadLines(path)[1], ',');
  EXPECT_EQ(fields[2], "21");
  EXPECT_EQ(fields[6], "-1");
  options.model_unit_mm = 0.0;
  EXPECT_THROW(BopCsvWriter(directory_ / "other.csv", options), Error);
}

TEST_F(PoseOutputTest, ErrorsNameTheFile) {
  const std::filesystem::path missing = directory_ / "no" / "such" / "POSES.csv";
  try {
    PosesCsvWriter writer(missing);
    FAIL() << "expected an error";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find(missing.string()), std::string::npos) << error.what();
  }
  EXPECT_THROW(JsonLinesWriter(directory_ / "no" / "x.jsonl"), Error);
  EXPECT_THROW(BopCsvWriter(directory_ / "no" / "x.csv"), Error);
  // A device that is always full: the first flushed row fails.
  if (std::filesystem::exists("/dev/full")) {
    try {
      PosesCsvWriter writer("/dev/full");
      FAIL() << "expected a write error";
    } catch (const Error& error) {
      EXPECT_NE(std::string(error.what()).find("/dev/full"), std::string::npos) << error.what();
    }
  }
}

}  // namespace
}  // namespace silpose
