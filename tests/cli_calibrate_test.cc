// `silpose calibrate` on synthetic chessboard images of a known camera.

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "cli_runner.h"
#include "silpose/calib/synthetic_chessboard.h"

namespace silpose {
namespace {

PinholeCamera TrueCamera() {
  PinholeCamera camera;
  camera.width_px = 640;
  camera.height_px = 480;
  camera.focal_x_px = 600.0;
  camera.focal_y_px = 606.0;
  camera.principal_x_px = 316.0;
  camera.principal_y_px = 243.0;
  camera.distortion = {-0.15, 0.0, 0.0, 0.0, 0.0};
  return camera;
}

SyntheticChessboardOptions Board() {
  SyntheticChessboardOptions board;
  board.board_cols = 9;
  board.board_rows = 6;
  board.square_size = 25.0;
  return board;
}

// Board pose from tilts about the camera's x and y axes and a roll (degrees), centre at `centre`.
Rigid3 BoardPose(double pitch_deg, double yaw_deg, double roll_deg, const Eigen::Vector3d& centre) {
  const double to_rad = 3.14159265358979323846 / 180.0;
  Rigid3 pose;
  pose.rotation = (Eigen::AngleAxisd(roll_deg * to_rad, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(yaw_deg * to_rad, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(pitch_deg * to_rad, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation = centre - pose.rotation * Eigen::Vector3d(100.0, 62.5, 0.0);
  return pose;
}

class CliCalibrateTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_cli_calibrate_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_ / "boards");
    const std::vector<Rigid3> poses = {
        BoardPose(0, 0, 0, {0, 0, 520}),          BoardPose(25, 0, 5, {-50, -35, 540}),
        BoardPose(-25, 0, -5, {50, 35, 540}),     BoardPose(0, 30, 10, {45, -40, 560}),
        BoardPose(0, -30, -10, {-45, 40, 560}),   BoardPose(20, 20, 0, {-70, 35, 600}),
        BoardPose(-20, -20, 15, {70, -35, 600}),  BoardPose(30, -15, -15, {0, 50, 540}),
        BoardPose(-30, 15, 20, {0, -50, 540}),    BoardPose(10, -35, 5, {75, 25, 620}),
        BoardPose(-15, 35, -20, {-75, -25, 620}), BoardPose(35, 25, 30, {25, 0, 650})};
    for (size_t i = 0; i < poses.size(); ++i) {
      const std::string name = "board" + std::to_string(10 + i) + ".png";
      ASSERT_TRUE(cv::imwrite((directory_ / "boards" / name).string(),
                              RenderSyntheticChessboard(TrueCamera(), poses[i], Board())));
    }
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory_); }

  static std::string Path(const std::string& name) { return (directory_ / name).string(); }

  static inline std::filesystem::path directory_;
};

TEST_F(CliCalibrateTest, CalibratesAFolderAndWritesCameraAndReport) {
  const CommandResult run = Silpose("calibrate " + Path("boards") + " --board 9x6 --square 25 -o " +
                                    Path("camera.yml") + " --report " + Path("report.csv"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("calibrated from 12 of 12 images"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("RMS reprojection error"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("board10.png"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("not found"), std::string::npos) << run.out;
  EXPECT_EQ(run.err.find("warning"), std::string::npos) << run.err;

  cv::FileStorage storage(Path("camera.yml"), cv::FileStorage::READ);
  ASSERT_TRUE(storage.isOpened());
  cv::Mat matrix;
  cv::Mat distortion;
  storage["camera_matrix"] >> matrix;
  storage["distortion_coefficients"] >> distortion;
  EXPECT_EQ(static_cast<int>(storage["image_width"]), 640);
  EXPECT_EQ(static_cast<int>(storage["image_height"]), 480);
  ASSERT_EQ(matrix.rows, 3);
  EXPECT_NEAR(matrix.at<double>(0, 0), 600.0, 6.0);
  EXPECT_NEAR(matrix.at<double>(1, 1), 606.0, 6.0);
  EXPECT_NEAR(matrix.at<double>(0, 2), 316.0, 3.0);
  EXPECT_NEAR(matrix.at<double>(1, 2), 243.0, 3.0);
  EXPECT_NEAR(distortion.at<double>(0), -0.15, 0.02);

  std::ifstream report(Path("report.csv"));
  std::string line;
  std::getline(report, line);
  EXPECT_EQ(line, "image,status,corners,rms_error_px,distance");
  int rows = 0;
  while (std::getline(report, line)) {
    ++rows;
    EXPECT_NE(line.find(",found,54,"), std::string::npos) << line;
  }
  EXPECT_EQ(rows, 12);
}

TEST_F(CliCalibrateTest, ReportsImagesWithoutABoardAndWarnsAboutFewBoards) {
  const std::string blank = Path("blank.png");
  ASSERT_TRUE(cv::imwrite(blank, cv::Mat(480, 640, CV_8UC1, cv::Scalar(200))));
  std::string arguments;
  for (int i = 10; i < 15; ++i)
    arguments += Path("boards/board" + std::to_string(i) + ".png") + " ";
  const CommandResult run =
      Silpose("calibrate " + arguments + blank + " --board 9x6 -o " + Path("few.yml"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("not found"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("calibrated from 5 of 6 images"), std::string::npos) << run.out;
  EXPECT_NE(run.err.find("warning: only 5 boards"), std::string::npos) << run.err;
  EXPECT_TRUE(std::filesystem::exists(Path("few.yml")));
}

TEST_F(CliCalibrateTest, ErrorsAreOneLineThatNamesTheProblem) {
  // Squares counted instead of inner corners: no board is found, the images are named.
  CommandResult run =
      Silpose("calibrate " + Path("boards") + " --board 10x7 -o " + Path("wrong.yml"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(Lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("board10.png"), std::string::npos) << run.err;
  EXPECT_FALSE(std::filesystem::exists(Path("wrong.yml")));

  run = Silpose("calibrate " + Path("boards") + " --board 9by6 -o " + Path("wrong.yml"));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("--board"), std::string::npos) << run.err;

  const std::string text = Path("notes.png");
  std::ofstream(text) << "not an image";
  run = Silpose("calibrate " + Path("boards") + " " + text + " -o " + Path("wrong.yml"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("notes.png"), std::string::npos) << run.err;

  const std::string small = Path("small.png");
  ASSERT_TRUE(cv::imwrite(small, cv::Mat(240, 320, CV_8UC1, cv::Scalar(200))));
  run = Silpose("calibrate " + Path("boards") + " " + small + " -o " + Path("wrong.yml"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("small.png"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("320x240"), std::string::npos) << run.err;

  run = Silpose("calibrate " + Path("missing_folder") + " -o " + Path("wrong.yml"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("missing_folder"), std::string::npos) << run.err;

  run = Silpose("calibrate --help");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_NE(run.out.find("--board"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace silpose
