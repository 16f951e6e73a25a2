#include "silpose/calib/calibration.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "silpose/calib/synthetic_chessboard.h"
#include "silpose/io/camera_file.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The camera the synthetic images are taken with: non-square pixels, off-centre principal point,
// barrel distortion.
PinholeCamera TrueCamera() {
  PinholeCamera camera;
  camera.width_px = 640;
  camera.height_px = 480;
  camera.focal_x_px = 620.0;
  camera.focal_y_px = 610.0;
  camera.principal_x_px = 331.0;
  camera.principal_y_px = 236.5;
  camera.distortion = {-0.18, 0.0, 0.0, 0.0, 0.0};
  return camera;
}

SyntheticChessboardOptions Board() {
  SyntheticChessboardOptions board;
  board.board_cols = 9;
  board.board_rows = 6;
  board.square_size = 25.0;  // millimetres
  return board;
}

Eigen::Vector3d BoardCentre(const SyntheticChessboardOptions& board) {
  return {0.5 * (board.board_cols - 1) * board.square_size,
          0.5 * (board.board_rows - 1) * board.square_size, 0.0};
}

// Board pose from tilts about the camera's x and y axes and a roll about its z axis (degrees), with
// the board's centre at `centre_in_camera` (millimetres).
Rigid3 BoardPose(double pitch_deg, double yaw_deg, double roll_deg,
                 const Eigen::Vector3d& centre_in_camera) {
  const double to_rad = kPi / 180.0;
  Rigid3 pose;
  pose.rotation = (Eigen::AngleAxisd(roll_deg * to_rad, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(yaw_deg * to_rad, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(pitch_deg * to_rad, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation = centre_in_camera - pose.rotation * BoardCentre(Board());
  return pose;
}

// Twelve varied views: tilted up to 35 degrees, rolled, at 0.5-0.65 m, off-centre.
std::vector<Rigid3> TruePoses() {
  return {BoardPose(0, 0, 0, {0, 0, 520}),          BoardPose(25, 0, 5, {-50, -35, 540}),
          BoardPose(-25, 0, -5, {50, 35, 540}),     BoardPose(0, 30, 10, {45, -40, 560}),
          BoardPose(0, -30, -10, {-45, 40, 560}),   BoardPose(20, 20, 0, {-70, 35, 600}),
          BoardPose(-20, -20, 15, {70, -35, 600}),  BoardPose(30, -15, -15, {0, 50, 540}),
          BoardPose(-30, 15, 20, {0, -50, 540}),    BoardPose(10, -35, 5, {75, 25, 620}),
          BoardPose(-15, 35, -20, {-75, -25, 620}), BoardPose(35, 25, 30, {25, 0, 650})};
}

class CalibrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    for (const Rigid3& pose : TruePoses()) {
      images_.push_back(RenderSyntheticChessboard(TrueCamera(), pose, Board()));
    }
  }
  static CalibrationOptions Options() {
    CalibrationOptions options;
    options.board_cols = 9;
    options.board_rows = 6;
    options.square_size = 25.0;
    return options;
  }
  static inline std::vector<cv::Mat> images_;
};

TEST(SyntheticChessboardTest, UndistortInvertsDistort) {
  const PinholeCamera camera = TrueCamera();
  for (double x : {-0.5, -0.1, 0.0, 0.3, 0.55}) {
    for (double y : {-0.4, 0.0, 0.2, 0.4}) {
      const Eigen::Vector2d p(x, y);
      Eigen::Vector2d back;
      ASSERT_TRUE(
          UndistortNormalized(camera.distortion, DistortNormalized(camera.distortion, p), &back));
      EXPECT_LT((back - p).norm(), 1e-10);
    }
  }
}

TEST(SyntheticChessboardTest, AllCornersAreInsideTheImages) {
  const PinholeCamera camera = TrueCamera();
  for (const Rigid3& pose : TruePoses()) {
    for (const Eigen::Vector3d& corner : ChessboardCornersInBoard(Board())) {
      const Eigen::Vector2d pixel = ProjectDistorted(camera, pose * corner);
      EXPECT_GT(pixel.x(), 15.0);
      EXPECT_GT(pixel.y(), 15.0);
      EXPECT_LT(pixel.x(), camera.width_px - 16.0);
      EXPECT_LT(pixel.y(), camera.height_px - 16.0);
    }
  }
}

TEST_F(CalibrationTest, RecoversTheKnownCamera) {
  const CalibrationResult result = CalibrateCamera(images_, Options());
  const PinholeCamera truth = TrueCamera();
  ASSERT_EQ(result.views.size(), images_.size());
  EXPECT_EQ(result.NumBoardsFound(), static_cast<int>(images_.size()));
  EXPECT_EQ(result.camera.width_px, truth.width_px);
  EXPECT_EQ(result.camera.height_px, truth.height_px);
  EXPECT_NEAR(result.camera.focal_x_px, truth.focal_x_px, 0.01 * truth.focal_x_px);
  EXPECT_NEAR(result.camera.focal_y_px, truth.focal_y_px, 0.01 * truth.focal_y_px);
  EXPECT_NEAR(result.camera.principal_x_px, truth.principal_x_px, 3.0);
  EXPECT_NEAR(result.camera.principal_y_px, truth.principal_y_px, 3.0);
  EXPECT_NEAR(result.camera.distortion[0], truth.distortion[0], 0.02);
  EXPECT_NEAR(result.camera.distortion[1], 0.0, 0.1);
  EXPECT_NEAR(result.camera.distortion[2], 0.0, 2e-3);
  EXPECT_NEAR(result.camera.distortion[3], 0.0, 2e-3);
  EXPECT_EQ(result.camera.distortion[4], 0.0);  // k3 is fixed by default
  EXPECT_LT(result.rms_error_px, 0.5);
  EXPECT_TRUE(result.camera.Check());

  const std::vector<Rigid3> poses = TruePoses();
  const std::vector<Eigen::Vector3d> corners = ChessboardCornersInBoard(Board());
  for (size_t v = 0; v < result.views.size(); ++v) {
    const CalibrationView& view = result.views[v];
    SCOPED_TRACE(view.name);
    EXPECT_EQ(view.name, "image " + std::to_string(v));
    ASSERT_TRUE(view.board_found);
    ASSERT_EQ(view.corners_px.size(), corners.size());
    EXPECT_LT(view.rms_error_px, 0.5);
    // The detected corners lie on the true ones (numbered from either end of the board).
    double forward = 0.0;
    double backward = 0.0;
    for (size_t k = 0; k < corners.size(); ++k) {
      const Eigen::Vector2d truth_px = ProjectDistorted(truth, poses[v] * corners[k]);
      const cv::Point2f a = view.corners_px[k];
      const cv::Point2f b = view.corners_px[corners.size() - 1 - k];
      forward = std::max(forward, (truth_px - Eigen::Vector2d(a.x, a.y)).norm());
      backward = std::max(backward, (truth_px - Eigen::Vector2d(b.x, b.y)).norm());
    }
    EXPECT_LT(std::min(forward, backward), 0.3);
    // The board's centre (whatever the numbering) is where it was put, in millimetres.
    const Eigen::Vector3d centre = view.camera_from_board * BoardCentre(Board());
    const Eigen::Vector3d true_centre = poses[v] * BoardCentre(Board());
    EXPECT_LT((centre - true_centre).norm(), 0.01 * true_centre.norm());
    EXPECT_NEAR(view.camera_from_board.rotation.determinant(), 1.0, 1e-9);
  }
}

TEST_F(CalibrationTest, FixedAspectRatioGivesSquarePixels) {
  CalibrationOptions options = Options();
  options.fix_aspect_ratio = true;
  options.zero_tangential = true;
  options.estimate_k3 = true;
  const CalibrationResult result = CalibrateCamera(images_, options);
  EXPECT_NEAR(result.camera.focal_x_px / result.camera.focal_y_px, 1.0, 1e-9);
  EXPECT_NEAR(result.camera.focal_x_px, 615.0, 0.02 * 615.0);
  EXPECT_EQ(result.camera.distortion[2], 0.0);
  EXPECT_EQ(result.camera.distortion[3], 0.0);
}

TEST_F(CalibrationTest, SectorBasedDetectorAlsoRecoversTheCamera) {
  CalibrationOptions options = Options();
  options.sector_based_detector = true;
  const std::vector<cv::Mat> some(images_.begin(), images_.begin() + 8);
  const CalibrationResult result = CalibrateCamera(some, options);
  EXPECT_EQ(result.NumBoardsFound(), 8);
  EXPECT_NEAR(result.camera.focal_x_px, 620.0, 0.01 * 620.0);
  EXPECT_NEAR(result.camera.focal_y_px, 610.0, 0.01 * 610.0);
  EXPECT_LT(result.rms_error_px, 0.5);
}

TEST_F(CalibrationTest, CameraFileRoundTrip) {
  const CalibrationResult result = CalibrateCamera(images_, Options());
  const auto path = std::filesystem::temp_directory_path() /
                    ("silpose_calibration_" + std::to_string(::getpid()) + ".yml");
  WriteCameraFile(path, result.camera);
  const PinholeCamera read = ReadCameraFile(path);
  std::filesystem::remove(path);
  EXPECT_EQ(read.width_px, result.camera.width_px);
  EXPECT_EQ(read.height_px, result.camera.height_px);
  EXPECT_NEAR(read.focal_x_px, result.camera.focal_x_px, 1e-9);
  EXPECT_NEAR(read.focal_y_px, result.camera.focal_y_px, 1e-9);
  EXPECT_NEAR(read.principal_x_px, result.camera.principal_x_px, 1e-9);
  EXPECT_NEAR(read.principal_y_px, result.camera.principal_y_px, 1e-9);
  for (size_t i = 0; i < 5; ++i)
    EXPECT_NEAR(read.distortion[i], result.camera.distortion[i], 1e-12);
}

// Runs `function` and returns the silpose::Error message it throws ("" if none).
template <typename Function>
std::string ErrorFrom(Function function) {
  try {
    function();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST_F(CalibrationTest, RefusesImagesOfDifferentSizes) {
  std::vector<cv::Mat> images(images_.begin(), images_.begin() + 4);
  cv::Mat smaller;
  images[2](cv::Rect(0, 0, 600, 480)).copyTo(smaller);
  images[2] = smaller;
  const std::string message = ErrorFrom([&] {
    CalibrateCamera(images, Options(), {"a.png", "b.png", "c.png", "d.png"});
  });
  EXPECT_NE(message.find("c.png"), std::string::npos) << message;
  EXPECT_NE(message.find("600x480"), std::string::npos) << message;
  EXPECT_NE(message.find("a.png"), std::string::npos) << message;
  EXPECT_NE(message.find("640x480"), std::string::npos) << message;
}

TEST_F(CalibrationTest, TooFewBoardsNamesTheImagesWithoutOne) {
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  const std::vector<cv::Mat> images = {images_[0], blank, images_[1], blank};
  const std::string message = ErrorFrom([&] {
    CalibrateCamera(images, Options(), {"good0.png", "blank1.png", "good2.png", "blank3.png"});
  });
  EXPECT_NE(message.find("only 2 of 4"), std::string::npos) << message;
  EXPECT_NE(message.find("blank1.png"), std::string::npos) << message;
  EXPECT_NE(message.find("blank3.png"), std::string::npos) << message;
  EXPECT_EQ(message.find("good0.png"), std::string::npos) << message;

  // With enough boards, the images without one are statuses, not errors.
  const std::vector<cv::Mat> more = {images_[0], blank, images_[1], images_[2], images_[3]};
  const CalibrationResult result = CalibrateCamera(more, Options());
  EXPECT_EQ(result.NumBoardsFound(), 4);
  EXPECT_FALSE(result.views[1].board_found);
  EXPECT_TRUE(result.views[1].corners_px.empty());
  EXPECT_TRUE(std::isnan(result.views[1].rms_error_px));
}

TEST_F(CalibrationTest, AWrongBoardSizeIsNotFound) {
  CalibrationOptions options = Options();
  options.board_cols = 10;  // squares, not inner corners
  options.board_rows = 7;
  std::vector<cv::Point2f> corners;
  EXPECT_FALSE(DetectChessboard(images_[0], options, &corners));
  EXPECT_TRUE(corners.empty());
}

TEST(CalibrationErrorsTest, RefusesNoImagesBadOptionsAndUnreadableFiles) {
  EXPECT_NE(ErrorFrom([] {
              CalibrateCamera(std::vector<cv::Mat>{}, CalibrationOptions{});
            }).find("no images"),
            std::string::npos);

  CalibrationOptions options;
  options.square_size = 0.0;
  std::string problem;
  EXPECT_FALSE(options.Check(&problem));
  EXPECT_NE(problem.find("square"), std::string::npos);
  EXPECT_NE(ErrorFrom([&] { CalibrateCamera(std::vector<cv::Mat>{}, options); }).find("square"),
            std::string::npos);
  options = CalibrationOptions{};
  options.board_cols = 1;
  EXPECT_FALSE(options.Check());
  options = CalibrationOptions{};
  options.min_boards = 2;
  EXPECT_FALSE(options.Check());
  EXPECT_TRUE(CalibrationOptions{}.Check());

  const auto directory = std::filesystem::temp_directory_path() /
                         ("silpose_calibration_errors_" + std::to_string(::getpid()));
  std::filesystem::create_directories(directory);
  const auto text = directory / "not_an_image.png";
  std::ofstream(text) << "hello";
  const auto missing = directory / "missing.png";
  options = CalibrationOptions{};
  const std::string unreadable =
      ErrorFrom([&] { CalibrateCamera(std::vector<std::filesystem::path>{text}, options); });
  const std::string absent =
      ErrorFrom([&] { CalibrateCamera(std::vector<std::filesystem::path>{missing}, options); });
  std::filesystem::remove_all(directory);
  EXPECT_NE(unreadable.find("not_an_image.png"), std::string::npos) << unreadable;
  EXPECT_NE(absent.find("missing.png"), std::string::npos) << absent;

  const std::string unsupported = ErrorFrom([] {
    CalibrateCamera(std::vector<cv::Mat>{cv::Mat(10, 10, CV_32FC1, cv::Scalar(0))},
                    CalibrationOptions{});
  });
  EXPECT_NE(unsupported.find("image 0"), std::string::npos) << unsupported;
}

}  // namespace
}  // namespace silpose
