#include "silpose/io/camera_file.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

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

// Writes `text` to a temporary file named `name` and returns the error reading it gives ("" if
// none). Every error must name the file and be one line.
std::string ErrorOfText(const std::string& name, const std::string& text) {
  const auto path = TempPath(name);
  std::ofstream(path, std::ios::binary) << text;
  const std::string error = ErrorOf(path);
  std::filesystem::remove(path);
  EXPECT_NE(error.find(path.string() + ": "), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  return error;
}

PinholeCamera ReadCameraText(const std::string& name, const std::string& text) {
  const auto path = TempPath(name);
  std::ofstream(path, std::ios::binary) << text;
  const PinholeCamera camera = ReadCameraFile(path);
  std::filesystem::remove(path);
  return camera;
}

std::string ReadText(const std::filesystem::path& path) {
  std::ifstream stream(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>());
}

// A camera whose numbers need all 17 digits OpenCV writes.
PinholeCamera TestCamera() {
  PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.123456789);
  camera.focal_y_px = 527.5 + 1.0 / 3.0;
  camera.principal_x_px = 321.25;
  camera.principal_y_px = 239.0 + 1.0 / 7.0;
  camera.distortion = {-0.1234567890123, 0.01, 0.001, -0.002, 1.0 / 3000.0};
  return camera;
}

cv::Mat CameraMatrix(const PinholeCamera& camera) {
  return (cv::Mat_<double>(3, 3) << camera.focal_x_px, 0.0, camera.principal_x_px, 0.0,
          camera.focal_y_px, camera.principal_y_px, 0.0, 0.0, 1.0);
}

void ExpectSameCamera(const PinholeCamera& read, const PinholeCamera& expected,
                      const std::string& where) {
  EXPECT_EQ(read.width_px, expected.width_px) << where;
  EXPECT_EQ(read.height_px, expected.height_px) << where;
  EXPECT_EQ(read.focal_x_px, expected.focal_x_px) << where;
  EXPECT_EQ(read.focal_y_px, expected.focal_y_px) << where;
  EXPECT_EQ(read.principal_x_px, expected.principal_x_px) << where;
  EXPECT_EQ(read.principal_y_px, expected.principal_y_px) << where;
  EXPECT_EQ(read.distortion, expected.distortion) << where;
}

constexpr const char* kFormats[] = {".yml", ".yaml", ".xml", ".json"};

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
  EXPECT_NE(ErrorOf(nan_skew).find("camera_matrix: value 2 of the data is not a finite number"),
            std::string::npos)
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

// Found by fuzzing (camera_file_fuzzer) when OpenCV parsed camera files: it allocated a matrix's
// rows x cols before reading its data. A matrix announcing more elements than a camera file holds
// is refused by its size.
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

// Found by fuzzing (camera_file_fuzzer): an XML file with NUL bytes crashed OpenCV's parser, which
// read camera files then. Binary and huge files are refused before they are parsed.
TEST(CameraFile, BinaryAndHugeFilesAreRefusedBeforeTheyAreParsed) {
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
// parser, which read camera files then, throw std::length_error, which is not a silpose::Error.
TEST(CameraFile, AKeyOfNonUtf8BytesGivesOneClearMessage) {
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
  EXPECT_NE(error.find("silpose_camera_badkey.yml: line 13"), std::string::npos) << error;
  // The same key in a well-formed file is an unknown key, skipped.
  std::ofstream(path, std::ios::binary) << "%YAML:1.0\n"
                                           "image_width: 64\n"
                                           "image_height: 48\n"
                                           "camera_matrix: !!opencv-matrix\n"
                                           "   rows: 3\n"
                                           "   cols: 3\n"
                                           "   dt: d\n"
                                           "   data: [ 60., 0., 32., 0., 60., 24., 0., 0., 1. ]\n"
                                           "distortion_coef\xff\xff\xff"
                                           "ficients: !!opencv-matrix\n"
                                           "   rows: 1\n"
                                           "   cols: 5\n"
                                           "   dt: d\n"
                                           "   data: [ -0.1, 0.01, 0., 0., 0. ]\n";
  EXPECT_EQ(ReadCameraFile(path).distortion[0], 0.0);
  std::filesystem::remove(path);
}

TEST(CameraFile, RoundTripsInEveryFormatAndOpenCvReadsWhatIsWritten) {
  const PinholeCamera camera = TestCamera();
  for (const char* format : kFormats) {
    const auto path = TempPath(std::string("roundtrip") + format);
    WriteCameraFile(path, camera);
    ExpectSameCamera(ReadCameraFile(path), camera, format);
    cv::FileStorage storage(path.string(), cv::FileStorage::READ);
    ASSERT_TRUE(storage.isOpened()) << format;
    cv::Mat matrix;
    cv::Mat distortion;
    storage["camera_matrix"] >> matrix;
    storage["distortion_coefficients"] >> distortion;
    EXPECT_EQ(static_cast<int>(storage["image_width"]), 640) << format;
    EXPECT_EQ(static_cast<int>(storage["image_height"]), 480) << format;
    ASSERT_EQ(matrix.size(), cv::Size(3, 3)) << format;
    EXPECT_EQ(cv::norm(matrix, CameraMatrix(camera), cv::NORM_INF), 0.0) << format;
    ASSERT_EQ(distortion.total(), 5u) << format;
    for (int i = 0; i < 5; ++i) {
      EXPECT_EQ(distortion.at<double>(i), camera.distortion[static_cast<size_t>(i)]) << format;
    }
    std::filesystem::remove(path);
  }
}

// What OpenCV's calibration sample writes around the camera (a date, counts, flags and a comment,
// reprojection errors, extrinsics and image points: matrices larger than a camera's), and other
// structures cv::FileStorage writes: nested and flow maps and sequences, empty ones, strings that
// need quotes and escapes, non-finite numbers, a 3-dimensional matrix.
void WriteLikeTheCalibrationSample(cv::FileStorage& storage, const PinholeCamera& camera,
                                   bool camera_first, bool key_with_spaces) {
  auto write_camera = [&] {
    storage << "image_width" << camera.width_px << "image_height" << camera.height_px;
    storage << "camera_matrix" << CameraMatrix(camera);
    cv::Mat distortion(5, 1, CV_64F);
    for (int i = 0; i < 5; ++i)
      distortion.at<double>(i) = camera.distortion[static_cast<size_t>(i)];
    storage << "distortion_coefficients" << distortion;
  };
  if (camera_first) write_camera();
  storage << "calibration_time"
          << "Mon Jan  1 10:00:00 2024";
  storage << "nframes" << 12 << "board_width" << 9 << "board_height" << 6;
  storage << "square_size" << 25.0 << "aspectRatio" << 1.0;
  storage.writeComment("flags: +fix_aspectRatio +zero_tangent_dist", false);
  storage << "flags" << 12;
  if (!camera_first) write_camera();
  storage << "avg_reprojection_error" << 0.3123;
  storage << "per_view_reprojection_errors" << cv::Mat(12, 1, CV_32F, cv::Scalar(0.25));
  storage << "extrinsic_parameters" << cv::Mat(12, 6, CV_64F, cv::Scalar(-1.0 / 3.0));
  storage << "image_points" << cv::Mat(12, 54, CV_32FC2, cv::Scalar(100.5, 200.25));
  storage << "grid_points" << std::vector<cv::Point3f>(54, cv::Point3f(25.f, 50.f, 0.f));
  storage << "strings"
          << "["
          << "a b"
          << "x:y # not a comment"
          << "\"q\\uote'"
          << "-5"
          << ""
          << "<&>"
          << "]";
  storage << "flow_map"
          << "{:"
          << "a" << 1 << "b"
          << "[:" << 1 << 2 << "]"
          << "}";
  storage << "views"
          << "["
          << "{"
          << "rvec" << cv::Mat::zeros(3, 1, CV_64F) << "id" << 1 << "}"
          << "{"
          << "id" << 2 << "}"
          << "]";
  storage << "nested"
          << "{"
          << "inner"
          << "{"
          << "deep"
          << "[" << 1 << "[" << 2 << 3 << "]"
          << "]"
          << "}"
          << "}";
  storage << "empty_sequence"
          << "["
          << "]"
          << "empty_map"
          << "{"
          << "}";
  storage << "not_a_number" << std::nan("") << "minus_infinity" << -HUGE_VAL;
  const int sizes[] = {2, 2, 2};
  storage << "cube" << cv::Mat(3, sizes, CV_8U, cv::Scalar(1));
  storage.writeComment("a comment at the end of a line", true);
  if (key_with_spaces) storage << "a key with spaces" << 3;
}

TEST(CameraFile, ReadsWhatOpenCvWritesWithTheCalibrationSamplesOtherKeys) {
  const PinholeCamera camera = TestCamera();
  for (const char* format : kFormats) {
    for (const bool camera_first : {true, false}) {
      const std::string where = std::string(format) + (camera_first ? " camera first" : "");
      const auto path = TempPath(std::string("sample") + format);
      {
        cv::FileStorage storage(path.string(), cv::FileStorage::WRITE);
        WriteLikeTheCalibrationSample(storage, camera, camera_first, std::string(format) == ".yml");
      }
      ExpectSameCamera(ReadCameraFile(path), camera, where);
      cv::FileStorage storage(path.string(), cv::FileStorage::READ);  // a file OpenCV reads
      EXPECT_EQ(storage["image_points"].mat().size(), cv::Size(54, 12)) << where;
      EXPECT_EQ(static_cast<std::string>(storage["calibration_time"]), "Mon Jan  1 10:00:00 2024");
      std::filesystem::remove(path);
    }
  }
}

TEST(CameraFile, ReadsWindowsLineEndsCommentsAndTheOptionalPartsOfTheLayouts) {
  const PinholeCamera camera = TestCamera();
  const auto path = TempPath("crlf.yml");
  WriteCameraFile(path, camera);
  std::string text = ReadText(path);
  std::string crlf;
  for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  std::ofstream(path, std::ios::binary) << crlf;
  ExpectSameCamera(ReadCameraFile(path), camera, "CR LF");
  std::filesystem::remove(path);

  // Without "---" and the !!opencv-matrix tag, with comments, flow maps, a 1x1 matrix in XML (one
  // value), integer and float element types, a matrix of 8 coefficients whose extra ones are zero.
  const std::string yaml =
      "%YAML:1.0\n# made by hand\nimage_width: 320 # pixels\nimage_height: +240\n"
      "camera_matrix: { rows:3, cols:3, dt:i, data:[ 300, 0, 160, 0, 300, 120, 0, 0, 1 ] }\n"
      "distortion_coefficients:\n   rows: 1\n   cols: 8\n   dt: f\n"
      "   # k1 k2 p1 p2 k3 k4 k5 k6\n   data: [ 0.1, 0, 0, 0, 0,\n      0, 0, 0 ]\n";
  const auto yaml_path = TempPath("byhand.yml");
  std::ofstream(yaml_path, std::ios::binary) << yaml;
  const PinholeCamera by_hand = ReadCameraFile(yaml_path);
  std::filesystem::remove(yaml_path);
  EXPECT_EQ(by_hand.width_px, 320);
  EXPECT_EQ(by_hand.height_px, 240);
  EXPECT_EQ(by_hand.focal_x_px, 300.0);
  EXPECT_EQ(by_hand.distortion[0], static_cast<double>(0.1f));  // dt f: a float, as OpenCV reads it
}

// Found by fuzzing (camera_file_fuzzer): this 84-byte file made cv::FileStorage::open (OpenCV 4.6),
// which read camera files then, loop forever. It is a clear error at once, and so are files like
// it.
TEST(CameraFile, TheFileThatHungOpenCvsYamlParserIsAClearErrorAtOnce) {
  const std::string hang = "%YAML:1.0\n" + std::string(57, '-') + "map-----\nim--- ]\n";
  ASSERT_EQ(hang.size(), 84u);
  const std::vector<std::string> files = {
      hang,
      hang.substr(0, hang.size() - 1),
      "%YAML:1.0\n---map---\nim--- ]\n",
      "%YAML:1.0\n---\n------map-----\nim--- ]\n",
      "%YAML:1.0\n--- map\nim--- ]\n",
      "%YAML:1.0\n---\nmap: --- ]\nim--- ]\n",
      "%YAML:1.0\n---\nmap:\n   --- ]\n",
      "%YAML:1.0\n---\nim: [ --- ]\n",
      "%YAML:1.0\n-\nmap\n- ]\n",
      "%YAML:1.0\n" + std::string(57, '-') + "map-----\n" + std::string(57, '-') + "\nim--- ]\n",
  };
  for (const std::string& text : files) {
    const auto start = std::chrono::steady_clock::now();
    const std::string error = ErrorOfText("hang.yml", text);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_FALSE(error.empty()) << text;
    EXPECT_LT(seconds, 1.0) << text;
  }
  EXPECT_NE(ErrorOfText("hang.yml", hang).find("hang.yml: line 2: expected 'key: value'"),
            std::string::npos)
      << ErrorOfText("hang.yml", hang);
}

// Every prefix of a file is a clear error, except those that end at the end of a key of YAML's
// (the whole file, or the file without the distortion coefficients): a truncated file never
// reads as another camera.
TEST(CameraFile, EveryTruncationOfAFileIsAClearErrorOrTheCameraOfItsWholeKeys) {
  const PinholeCamera camera = TestCamera();
  PinholeCamera no_distortion = camera;
  no_distortion.distortion = {0, 0, 0, 0, 0};
  for (const std::string format : {".yml", ".xml", ".json"}) {
    const auto path = TempPath("truncated" + format);
    WriteCameraFile(path, camera);
    const std::string text = ReadText(path);
    int read = 0;
    for (size_t size = 0; size < text.size(); ++size) {
      const std::string prefix = text.substr(0, size);
      std::filesystem::remove(path);  // a new file: rewriting one in place can wait for the disk
      std::ofstream(path, std::ios::binary) << prefix;
      try {
        const PinholeCamera read_camera = ReadCameraFile(path);
        ++read;
        const bool whole = prefix.find("distortion_coefficients") != std::string::npos;
        ExpectSameCamera(read_camera, whole ? camera : no_distortion, prefix);
      } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
      }
    }
    // YAML: the whole file without its last line feed, and without the distortion coefficients
    // (with and without the line feed before them).
    EXPECT_EQ(read, format == ".yml" ? 3 : 1) << format;
    std::filesystem::remove(path);
  }
}

const std::string kSizes = "image_width: 320\nimage_height: 240\n";

// camera_matrix with these rows, cols, dt and data lines.
std::string YamlMatrix(const std::string& name, const std::string& body) {
  return name + ": !!opencv-matrix\n" + body;
}
const std::string kMatrixBody =
    "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]\n";
std::string Yaml(const std::string& body) { return "%YAML:1.0\n---\n" + body; }

struct BadFile {
  std::string what;
  std::string text;
  std::string expected;  // in the message
};

void ExpectErrors(const std::string& file_name, const std::vector<BadFile>& files) {
  for (const BadFile& file : files) {
    const std::string error = ErrorOfText(file_name, file.text);
    EXPECT_NE(error.find(file.expected), std::string::npos)
        << file.what << ": expected '" << file.expected << "' in '" << error << "'";
  }
}

TEST(CameraFile, MalformedYamlFilesAreOneClearErrorWithTheLine) {
  const std::string matrix = YamlMatrix("camera_matrix", kMatrixBody);
  std::string many_values;
  for (int i = 0; i < 999; ++i) many_values += "1., ";
  auto with_data = [&](const std::string& data) {
    return Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   dt: d\n   data: " + data + "\n"));
  };
  ExpectErrors(
      "bad.yml",
      {
          {"truncated matrix",
           Yaml(kSizes + "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                         "   data: [ 300., 0., 160., 0.,\n"),
           "line 9: a '[' that is never closed"},
          {"truncated before the data",
           Yaml(kSizes + "camera_matrix: !!opencv-matrix\n   rows: 3\n"),
           "line 5: camera_matrix must be an OpenCV matrix with rows and cols"},
          {"fewer values", with_data("[ 300., 0., 160., 0., 300., 120., 0., 0. ]"),
           "line 9: camera_matrix has 3x3 = 9 elements but 8 values in its data"},
          {"more values", with_data("[ 300., 0., 160., 0., 300., 120., 0., 0., 1., 1. ]"),
           "camera_matrix has 3x3 = 9 elements but 10 values in its data"},
          {"many more values", with_data("[ " + many_values + "1. ]"),
           "camera_matrix has 3x3 = 9 elements but 1000 values in its data"},
          {"a word", with_data("[ 300., 0., abc, 0., 300., 120., 0., 0., 1. ]"),
           "camera_matrix: value 3 of the data is not a number: 'abc'"},
          {"a quoted number", with_data("[ \"300.\", 0., 160., 0., 300., 120., 0., 0., 1. ]"),
           "value 1 of the data is not a number: '300.'"},
          {"a hexadecimal number", with_data("[ 0x12C, 0., 160., 0., 300., 120., 0., 0., 1. ]"),
           "value 1 of the data is not a number: '0x12C'"},
          {"a list", with_data("[ [ 300. ], 0., 160., 0., 300., 120., 0., 0., 1. ]"),
           "value 1 of the data is not a number: a list"},
          {"data is a map", with_data("{ a:1 }"), "camera_matrix: data must be a list of numbers"},
          {"NaN", with_data("[ 300., .nan, 160., 0., 300., 120., 0., 0., 1. ]"),
           "camera_matrix: value 2 of the data is not a finite number: '.nan'"},
          {"infinity", with_data("[ .Inf, 0., 160., 0., 300., 120., 0., 0., 1. ]"),
           "value 1 of the data is not a finite number: '.Inf'"},
          {"beyond a double", with_data("[ 1e999, 0., 160., 0., 300., 120., 0., 0., 1. ]"),
           "value 1 of the data is out of range: '1e999'"},
          {"negative infinity in the distortion",
           Yaml(kSizes + matrix +
                YamlMatrix(
                    "distortion_coefficients",
                    "   rows: 1\n   cols: 5\n   dt: d\n   data: [ -.Inf, 0., 0., 0., 0. ]\n")),
           "distortion_coefficients: value 1 of the data is not a finite number: '-.Inf'"},
          {"a duplicate camera key", Yaml(kSizes + "image_width: 330\n" + matrix),
           "line 5: the key 'image_width' appears twice"},
          {"a duplicate other key", Yaml("nframes: 3\n" + kSizes + matrix + "nframes: 4\n"),
           "line 11: the key 'nframes' appears twice"},
          {"a duplicate matrix key",
           Yaml(kSizes +
                YamlMatrix("camera_matrix", "   rows: 3\n   rows: 3\n" + kMatrixBody.substr(11))),
           "line 7: the key 'rows' appears twice"},
          {"a duplicate key in a flow map",
           Yaml(kSizes + "camera_matrix: { rows:3, cols:3, rows:3 }\n"),
           "line 5: the key 'rows' appears twice"},
          {"no camera matrix", Yaml(kSizes), "no camera_matrix"},
          {"no image height", Yaml("image_width: 320\n" + matrix), "no image_width/image_height"},
          {"no rows", Yaml(kSizes + YamlMatrix("camera_matrix", kMatrixBody.substr(11))),
           "camera_matrix must be an OpenCV matrix with rows and cols"},
          {"no dt",
           Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   data: [ 1., 0., 0., 0., 1., 0., "
                                    "0., 0., 1. ]\n")),
           "line 5: camera_matrix has no dt (element type)"},
          {"no data",
           Yaml(kSizes + YamlMatrix("camera_matrix", "   rows: 3\n   cols: 3\n   dt: d\n")),
           "line 5: camera_matrix has no data"},
          {"a scalar matrix", Yaml(kSizes + "camera_matrix: 300\n"),
           "camera_matrix must be an OpenCV matrix with rows and cols"},
          {"a fractional width", Yaml("image_width: 320.5\nimage_height: 240\n" + matrix),
           "line 3: image_width and image_height must be whole numbers, not '320.5'"},
          {"a quoted width", Yaml("image_width: \"320\"\nimage_height: 240\n" + matrix),
           "image_width and image_height must be whole numbers, not '320'"},
          {"a huge width", Yaml("image_width: 99999999999\nimage_height: 240\n" + matrix),
           "image_width '99999999999' is out of range"},
          {"two channels",
           Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   dt: \"2d\"\n"
                                    "   data: [ 1., 0., 0., 0., 1., 0., 0., 0., "
                                    "1. ]\n")),
           "line 8: camera_matrix: the element type (dt) '2d' is not supported"},
          {"a fraction in an integer matrix",
           Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   dt: i\n   data: [ 300.5, 0, 160, "
                                    "0, 300, 120, 0, 0, 1 ]\n")),
           "value 1 of the data, '300.5', is not a whole number in the range of dt i"},
          {"beyond 8 bits",
           Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   dt: u\n   data: [ 300, 0, 160, "
                                    "0, 300, 120, 0, 0, 1 ]\n")),
           "'300', is not a whole number in the range of dt u"},
          {"an n-dimensional matrix",
           Yaml(kSizes + "camera_matrix: !!opencv-nd-matrix\n   sizes: [ 3, 3 ]\n   dt: d\n"
                         "   data: [ 300., 0., 160., 0., 300., 120., 0., 0., 1. ]\n"),
           "line 6: camera_matrix must be a 2-dimensional OpenCV matrix"},
          {"another type", Yaml(kSizes + "camera_matrix: !!opencv-sparse-matrix\n" + kMatrixBody),
           "camera_matrix must be an OpenCV matrix (opencv-matrix), not 'opencv-sparse-matrix'"},
          {"an unknown matrix key",
           Yaml(kSizes + YamlMatrix("camera_matrix", "   step: 3\n" + kMatrixBody)),
           "line 6: camera_matrix has the key 'step', which an OpenCV matrix does not have"},
          {"base64 data",
           Yaml(kSizes + YamlMatrix("camera_matrix",
                                    "   rows: 3\n   cols: 3\n   dt: d\n"
                                    "   data: !!binary |\n      MWQgICAg\n")),
           "camera_matrix: binary (base64) data is not supported"},
          {"no header", kSizes + matrix, "not an OpenCV YAML/XML/JSON camera file"},
          {"YAML 2", "%YAML:2.0\n" + kSizes + matrix, "line 1: a YAML camera file must begin"},
          {"indentation",
           Yaml(kSizes + "camera_matrix: !!opencv-matrix\n   rows: 3\n     cols: 3\n"),
           "line 7: unexpected indentation"},
          {"a tab", Yaml(kSizes + "camera_matrix: !!opencv-matrix\n\trows: 3\n"),
           "line 6: a tab in the indentation"},
          {"an alias", Yaml(kSizes + "camera_matrix: *matrix\n"), "line 5: anchors and aliases"},
          {"a second document", Yaml(kSizes + matrix + "---\n" + kSizes),
           "line 10: a second YAML document"},
          {"text after the end", Yaml(kSizes + matrix + "...\nimage_width: 3\n"),
           "line 11: text after the end of the YAML document"},
          {"no colon", Yaml(kSizes + "camera_matrix\n"), "line 5: expected 'key: value'"},
          {"an unclosed string", Yaml("name: \"abc\n" + kSizes + matrix),
           "line 3: a quoted string that does not end on its line"},
          {"a sequence at the top", Yaml("- 1\n- 2\n"), "line 3: a sequence item (- ) where a key"},
          {"nested too deep", Yaml("deep: " + std::string(100000, '[') + "\n"),
           "line 3: values nested more than 64 levels deep"},
          {"a control character", Yaml(kSizes + "name: a\x01z\n"), "line 5: a control character"},
      });
}

TEST(CameraFile, MalformedXmlFilesAreOneClearErrorWithTheLine) {
  const std::string head =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n"
      "<image_width>320</image_width>\n<image_height>240</image_height>\n";
  const std::string matrix =
      "<camera_matrix type_id=\"opencv-matrix\">\n  <rows>3</rows>\n  <cols>3</cols>\n"
      "  <dt>d</dt>\n  <data>\n    300. 0. 160. 0. 300. 120. 0. 0. 1.</data></camera_matrix>\n";
  const std::string tail = "</opencv_storage>\n";
  auto with_data = [&](const std::string& data) {
    return head + "<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols>" +
           "<dt>d</dt>\n<data>" + data + "</data></camera_matrix>\n" + tail;
  };
  EXPECT_EQ(ReadCameraText("good.xml", head + matrix + tail).focal_x_px, 300.0);
  ExpectErrors(
      "bad.xml",
      {
          {"truncated matrix", head + matrix.substr(0, 120), "line 9: <data> is never closed"},
          {"fewer values", with_data("300. 0. 160. 0. 300. 120. 0. 0."),
           "line 6: camera_matrix has 3x3 = 9 elements but 8 values in its data"},
          {"a word", with_data("300. 0. 160. 0. 300. x 0. 0. 1."),
           "camera_matrix: value 6 of the data is not a number: 'x'"},
          {"a string", with_data("\"300.\" 0. 160. 0. 300. 120. 0. 0. 1."),
           "value 1 of the data is not a number: '300.'"},
          {"NaN", with_data("300. 0. 160. 0. 300. 120. 0. 0. .Nan"),
           "value 9 of the data is not a finite number: '.Nan'"},
          {"a duplicate key", head + "<image_width>320</image_width>\n" + matrix + tail,
           "line 5: the key 'image_width' appears twice"},
          {"no image width",
           "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_height>240</image_height>\n" +
               matrix + tail,
           "no image_width/image_height"},
          {"no data",
           head +
               "<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols>"
               "<dt>d</dt></camera_matrix>\n" +
               tail,
           "line 5: camera_matrix has no data"},
          {"an empty width",
           "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width></image_width>"
           "<image_height>240</image_height>\n" +
               matrix + tail,
           "line 3: image_width and image_height must be whole numbers, not an empty value"},
          {"base64 data",
           head +
               "<camera_matrix type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols>"
               "<dt>d</dt><data type_id=\"binary\">MWQgICAg</data></camera_matrix>\n" +
               tail,
           "camera_matrix: binary (base64) data is not supported"},
          {"a closing tag that does not match",
           head + "<camera_matrix type_id=\"opencv-matrix\">\n<rows>3</cols>\n" + tail,
           "line 6: </cols> where </rows> (opened on line 6) was expected"},
          {"an unknown entity", head + "<name>&nbsp;</name>\n" + matrix + tail,
           "line 5: an unknown entity '&nbsp;'"},
          {"a bare ampersand", head + "<name>a & b</name>\n" + matrix + tail,
           "line 5: a '&' that does not begin an entity"},
          {"another root", "<?xml version=\"1.0\"?>\n<storage>\n</storage>\n",
           "line 2: the root element must be <opencv_storage>, not 'storage'"},
          {"no declaration", "<opencv_storage>\n</opencv_storage>\n",
           "not an OpenCV YAML/XML/JSON camera file"},
          {"text after the root", head + matrix + tail + "<more/>\n",
           "line 12: unexpected '<' after </opencv_storage>"},
          {"keys and values mixed",
           head + "<camera_matrix>3 <rows>3</rows></camera_matrix>\n" + tail,
           "line 5: <camera_matrix> mixes keys and values"},
          {"CDATA", head + "<name><![CDATA[x]]></name>\n" + tail, "line 5: CDATA sections"},
          {"an unclosed comment", head + "<!-- a comment\n" + matrix + tail,
           "line 5: a comment (<!--) that is never closed"},
          {"nested too deep",
           head +
               [] {
                 std::string deep;
                 for (int i = 0; i < 100; ++i) deep += "<a>";
                 return deep;
               }(),
           "values nested more than 64 levels deep"},
      });
}

TEST(CameraFile, MalformedJsonFilesAreOneClearErrorWithTheLine) {
  const std::string head = "{\n    \"image_width\": 320,\n    \"image_height\": 240,\n";
  auto with_data = [&](const std::string& data) {
    return head +
           "    \"camera_matrix\": { \"type_id\": \"opencv-matrix\", \"rows\": 3, "
           "\"cols\": 3, \"dt\": \"d\",\n        \"data\": " +
           data + " }\n}\n";
  };
  const std::string good = with_data("[ 300.0, 0.0, 160.0, 0.0, 300.0, 120.0, 0.0, 0.0, 1.0 ]");
  EXPECT_EQ(ReadCameraText("good.json", good).focal_x_px, 300.0);
  ExpectErrors(
      "bad.json",
      {
          {"truncated matrix", good.substr(0, good.size() - 30),
           "line 5: a '[' that is never closed"},
          {"truncated at the end", good.substr(0, good.size() - 2),
           "line 1: a '{' that is never closed"},
          {"more values", with_data("[ 300.0, 0.0, 160.0, 0.0, 300.0, 120.0, 0.0, 0.0, 1.0, 2.0 ]"),
           "line 5: camera_matrix has 3x3 = 9 elements but 10 values in its data"},
          {"a string", with_data("[ \"300\", 0.0, 160.0, 0.0, 300.0, 120.0, 0.0, 0.0, 1.0 ]"),
           "value 1 of the data is not a number: '300'"},
          {"null", with_data("[ null, 0.0, 160.0, 0.0, 300.0, 120.0, 0.0, 0.0, 1.0 ]"),
           "line 5: 'null' is not a number, string, list or map"},
          {"NaN", with_data("[ 300.0, 0.0, 160.0, 0.0, 300.0, 120.0, .Nan, 0.0, 1.0 ]"),
           "value 7 of the data is not a finite number: '.Nan'"},
          {"a word", with_data("[ 300.0, 0.0, 160.0, 0.0, 300.0, 120.0, nan, 0.0, 1.0 ]"),
           "line 5: 'nan' is not a number, string, list or map"},
          {"base64 data", with_data("\"$base64$MWQgICAg\""),
           "camera_matrix: binary (base64) data is not supported"},
          {"a duplicate key", head + "    \"image_height\": 240\n}\n",
           "line 4: the key 'image_height' appears twice"},
          {"a duplicate matrix key",
           head + "    \"camera_matrix\": { \"rows\": 3, \"rows\": 3 }\n}\n",
           "line 4: the key 'rows' appears twice"},
          {"no camera matrix", head + "    \"nframes\": 3\n}\n", "no camera_matrix"},
          {"another type",
           head + "    \"camera_matrix\": { \"type_id\": \"opencv-nd-matrix\", \"sizes\": [3, 3], "
                  "\"dt\": \"d\", \"data\": [] }\n}\n",
           "camera_matrix must be a 2-dimensional OpenCV matrix"},
          {"a trailing comma", head + "    \"nframes\": 3,\n}\n",
           "line 5: expected a key in double quotes, found '}'"},
          {"no comma", head + "    \"nframes\": 3\n    \"flags\": 0\n}\n",
           "line 5: expected ',' or '}', found '\"'"},
          {"text after the object", good + "{}\n", "line 7: unexpected '{' after the end"},
          {"a block comment", head + "/* flags */ \"flags\": 0\n}\n",
           "line 4: expected a key in double quotes, found '/'"},
          {"a bad escape", head + "    \"name\": \"a\\qb\"\n}\n", "line 4: an unknown escape"},
          {"an array", "[ 1, 2 ]\n", "not an OpenCV YAML/XML/JSON camera file"},
          {"nested too deep", head + "    \"deep\": " + std::string(100000, '[') + "\n}\n",
           "line 4: values nested more than 64 levels deep"},
      });
}

// OpenCV writes base64 data with cv::FileStorage::WRITE_BASE64: in other keys it is skipped, in the
// camera's it is refused with a clear message.
TEST(CameraFile, Base64DataIsSkippedInOtherKeysAndRefusedInTheCamera) {
  const PinholeCamera camera = TestCamera();
  for (const std::string format : {".yml", ".xml", ".json"}) {
    cv::FileStorage text_storage(format, cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    text_storage << "image_width" << camera.width_px << "image_height" << camera.height_px;
    text_storage << "camera_matrix" << CameraMatrix(camera);
    const std::string text = text_storage.releaseAndGetString();
    cv::FileStorage base64_storage(format, cv::FileStorage::WRITE_BASE64 | cv::FileStorage::MEMORY);
    base64_storage << "image_points" << cv::Mat(12, 54, CV_32FC2, cv::Scalar(100.5, 200.25));
    base64_storage << "camera_matrix" << CameraMatrix(camera);
    const std::string base64 = base64_storage.releaseAndGetString();
    const size_t points_end =
        base64.find(format == ".json" ? "\"camera_matrix\"" : "camera_matrix");
    ASSERT_NE(points_end, std::string::npos) << base64;
    // The text camera with base64 image points appended.
    std::string both;
    if (format == ".yml") {
      both = text + base64.substr(base64.find("---\n") + 4, points_end - base64.find("---\n") - 4);
    } else if (format == ".xml") {
      const size_t start = base64.find("<opencv_storage>") + 16;
      both = text.substr(0, text.rfind("</opencv_storage>")) +
             base64.substr(start, base64.rfind('<', points_end) - start) + "</opencv_storage>\n";
    } else {
      const size_t start = base64.find('{') + 1;
      const size_t end = base64.rfind(',', points_end);
      both = text.substr(0, text.rfind('}')) + "," + base64.substr(start, end - start) + "\n}\n";
    }
    const auto path = TempPath("base64" + format);
    std::ofstream(path, std::ios::binary) << both;
    cv::FileStorage check(path.string(), cv::FileStorage::READ);  // a file OpenCV reads
    EXPECT_EQ(check["image_points"].mat().size(), cv::Size(54, 12)) << both;
    PinholeCamera expected = camera;
    expected.distortion = {0, 0, 0, 0, 0};
    ExpectSameCamera(ReadCameraFile(path), expected, format);
    std::filesystem::remove(path);
    EXPECT_NE(ErrorOfText("base64" + format, base64)
                  .find("camera_matrix: binary (base64) data is not supported"),
              std::string::npos)
        << format;
  }
}

// The reader's time is linear in the size of the file: a 1 MiB file of long sequences, deep
// indentation, many keys or comments reads (or is refused) in well under a second.
TEST(CameraFile, LargeFilesReadInLinearTime) {
  const std::string matrix = YamlMatrix("camera_matrix", kMatrixBody);
  std::string many_numbers = "points: [ ";
  while (many_numbers.size() < 900000) many_numbers += "1.5, ";
  many_numbers += "2. ]\n";
  std::string many_keys;
  for (int i = 0; many_keys.size() < 900000; ++i) many_keys += "key_" + std::to_string(i) + ": 1\n";
  std::string deep;  // 60 levels, each line indented further
  for (int level = 0; level < 60; ++level) {
    deep += std::string(static_cast<size_t>(level) * 200, ' ') + "k:\n";
  }
  deep += std::string(60 * 200, ' ') + "v: 1\n";
  for (int i = 0; deep.size() < 900000; ++i)
    deep += std::string(60 * 200, ' ') + "w" + std::to_string(i) + ": 1\n";
  std::string comments;
  while (comments.size() < 900000) comments += "# a comment line\n";
  std::string xml_comments = "<?xml version=\"1.0\"?>\n<opencv_storage>\n";
  for (int i = 0; xml_comments.size() < 900000; ++i) {
    xml_comments +=
        "<!-- a comment --><a" + std::to_string(i) + ">1 2 3</a" + std::to_string(i) + ">\n";
  }
  xml_comments += "</opencv_storage>\n";
  std::string json_array = "{ \"a\": [";
  while (json_array.size() < 900000) json_array += "[1, 2], ";
  json_array += "3] }\n";
  const std::vector<std::pair<std::string, std::string>> files = {
      {"numbers.yml", Yaml(many_numbers + kSizes + matrix)},
      {"keys.yml", Yaml(many_keys + kSizes + matrix)},
      {"deep.yml", Yaml(deep + kSizes + matrix)},
      {"comments.yml", Yaml(comments + kSizes + matrix)},
      {"data.yml",
       Yaml(kSizes + YamlMatrix("camera_matrix", "   rows: 3\n   cols: 3\n   dt: d\n   data: " +
                                                     many_numbers.substr(8)))},
      {"comments.xml", xml_comments},
      {"array.json", json_array},
  };
  for (const auto& [name, text] : files) {
    ASSERT_LT(text.size(), 1u << 20) << name;
    const auto path = TempPath(name);
    std::ofstream(path, std::ios::binary) << text;
    const auto start = std::chrono::steady_clock::now();
    const std::string error = ErrorOf(path);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 1.0) << name << ": " << error;
    if (name.ends_with(".yml") && name != "data.yml") {
      EXPECT_EQ(error, "") << name;
    }
    std::filesystem::remove(path);
  }
}

}  // namespace
}  // namespace silpose
