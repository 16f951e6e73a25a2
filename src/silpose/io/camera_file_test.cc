#include "silpose/io/camera_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "silpose/util/error.h"

namespace silpose {
namespace {

std::filesystem::path TempPath(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("silpose_camera_" + name);
}

std::string ErrorOf(const std::filesystem::path& path) {
  try {
    ReadCameraFile(path);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST(CameraFile, WriteThenReadGivesTheSameCamera) {
  PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.0);
  camera.focal_y_px = 527.5;
  camera.principal_x_px = 321.25;
  camera.distortion = {0.1, -0.2, 0.001, 0.002, 0.05};
  const auto path = TempPath("roundtrip.yml");
  WriteCameraFile(path, camera);
  const PinholeCamera loaded = ReadCameraFile(path);
  std::filesystem::remove(path);
  EXPECT_EQ(loaded.width_px, 640);
  EXPECT_EQ(loaded.height_px, 480);
  EXPECT_DOUBLE_EQ(loaded.focal_x_px, 525.0);
  EXPECT_DOUBLE_EQ(loaded.focal_y_px, 527.5);
  EXPECT_DOUBLE_EQ(loaded.principal_x_px, 321.25);
  EXPECT_DOUBLE_EQ(loaded.principal_y_px, 239.5);
  EXPECT_EQ(loaded.distortion, camera.distortion);
}

TEST(CameraFile, ReadsTheLayoutOpenCvCalibrationWrites) {
  const auto path = TempPath("opencv.yml");
  std::ofstream(path) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                         "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                         "   data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]\n"
                         "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n"
                         "   dt: d\n   data: [ -0.1, 0.01, 0., 0., 0. ]\n";
  const PinholeCamera camera = ReadCameraFile(path);
  std::filesystem::remove(path);
  EXPECT_EQ(camera.width_px, 320);
  EXPECT_DOUBLE_EQ(camera.focal_x_px, 300.0);
  EXPECT_DOUBLE_EQ(camera.principal_y_px, 120.0);
  EXPECT_DOUBLE_EQ(camera.distortion[0], -0.1);
}

TEST(CameraFile, BadFilesGiveOneClearMessageNamingTheFile) {
  EXPECT_NE(ErrorOf(TempPath("missing.yml")).find("silpose_camera_missing.yml: no such"),
            std::string::npos);
  const auto garbage = TempPath("garbage.yml");
  std::ofstream(garbage) << "\x01\x02 this is { not yaml : [";
  EXPECT_NE(ErrorOf(garbage).find("silpose_camera_garbage.yml"), std::string::npos);
  const auto no_matrix = TempPath("nomatrix.yml");
  std::ofstream(no_matrix) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n";
  EXPECT_NE(ErrorOf(no_matrix).find("no camera_matrix"), std::string::npos);
  const auto bad_focal = TempPath("badfocal.yml");
  std::ofstream(bad_focal) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                              "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                              "   data: [ -5., 0., 160., 0., 300., 120., 0., 0., 1. ]\n";
  EXPECT_NE(ErrorOf(bad_focal).find("focal"), std::string::npos);
  const auto wrong_shape = TempPath("shape.yml");
  std::ofstream(wrong_shape) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                                "camera_matrix: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
                                "   data: [ 1., 0., 0., 1. ]\n";
  EXPECT_NE(ErrorOf(wrong_shape).find("3x3"), std::string::npos);
  const auto nan_skew = TempPath("nanskew.yml");
  std::ofstream(nan_skew) << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n"
                             "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                             "   data: [ 300., .nan, 160., 0., 300., 120., 0., 0., 1. ]\n";
  EXPECT_NE(ErrorOf(nan_skew).find("camera_matrix must have the form"), std::string::npos)
      << ErrorOf(nan_skew);
  const auto fractional = TempPath("fractional.yml");
  std::ofstream(fractional) << "%YAML:1.0\n---\nimage_width: 320.5\nimage_height: 240\n"
                               "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                               "   data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]\n";
  EXPECT_NE(ErrorOf(fractional).find("whole numbers"), std::string::npos) << ErrorOf(fractional);
  for (const auto& path : {garbage, no_matrix, bad_focal, wrong_shape, nan_skew, fractional}) {
    std::filesystem::remove(path);
  }
}

// Found by fuzzing (camera_file_fuzzer): OpenCV allocates a matrix's rows x cols before reading
// its data, so a file announcing a huge matrix must be refused before that.
TEST(CameraFile, AHugeMatrixIsRefusedBeforeItIsAllocated) {
  for (const char* field : {"camera_matrix", "distortion_coefficients"}) {
    const auto path = TempPath(std::string("huge_") + field + ".yml");
    std::ofstream stream(path);
    stream << "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n";
    if (std::string(field) == "distortion_coefficients") {
      stream << "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                "   data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]\n";
    }
    stream << field << ": !!opencv-matrix\n   rows: 2000000000\n   cols: 3\n   dt: d\n"
           << "   data: [ 1., 0., 0. ]\n";
    stream.close();
    const std::string error = ErrorOf(path);
    EXPECT_NE(error.find(path.filename().string()), std::string::npos) << error;
    EXPECT_NE(error.find(std::string(field) + " has 2000000000x3 elements"), std::string::npos)
        << error;
    std::filesystem::remove(path);
  }
}

// Found by fuzzing (camera_file_fuzzer): an XML file with NUL bytes crashed OpenCV's parser.
TEST(CameraFile, BinaryAndHugeFilesAreRefusedBeforeOpenCvParsesThem) {
  const auto binary = TempPath("binary.xml");
  const std::string xml_with_nul("<?xml version=\0\0\"1.0\"?>\n<opencv_storage>\n", 40);
  std::ofstream(binary, std::ios::binary) << xml_with_nul;
  std::string error = ErrorOf(binary);
  EXPECT_NE(error.find("silpose_camera_binary.xml: a binary file"), std::string::npos) << error;
  const auto huge = TempPath("huge.yml");
  {
    std::ofstream stream(huge);
    stream << "%YAML:1.0\n---\n";
    for (int i = 0; i < 100000; ++i) stream << "comment_" << i << ": 0\n";
  }
  error = ErrorOf(huge);
  EXPECT_NE(error.find("too large for a camera file"), std::string::npos) << error;
  std::filesystem::remove(binary);
  std::filesystem::remove(huge);
}

// Found by fuzzing (camera_file_fuzzer): a key with bytes that are not UTF-8 made OpenCV's YAML
// parser throw std::length_error, which is not a cv::Exception.
TEST(CameraFile, ParserExceptionsOtherThanOpenCvsAreOneClearMessage) {
  const auto path = TempPath("badkey.yml");
  std::ofstream(path, std::ios::binary)
      << "%YAML:1.0\n"
         "---\n"
         "image_width: 64\n"
         "image_height: 48\n"
         "camera_matrix: !!opencv-matrix\n"
         "   rows: 3\n"
         "   cols: 3\n"
         "   dt: d\n"
         "   data: [ 60., 0., 32., 0., 60., 24., 0., 0., 1. ]\n"
         "distortion_coef\xff"
         "\xff\xff"
         "\xff\xff"
         "\xff\xff"
         "\xff"
         "ficients: !!opencv-matrix\n"
         "   rows: 1\n"
         "   cols: 5\n"
         "   :dt d\n"
         "   data: [ -1.0000000000000001e-01, 1.0000000000000000e-02, 0., 0., 0. ]\n";
  const std::string error = ErrorOf(path);
  EXPECT_NE(error.find("silpose_camera_badkey.yml"), std::string::npos) << error;
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace silpose
