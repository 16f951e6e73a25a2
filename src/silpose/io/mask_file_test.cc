#include "silpose/io/mask_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "silpose/util/error.h"

namespace silpose {
namespace {

TEST(MaskFile, AnyNonZeroPixelOfAnyChannelOrDepthIsObject) {
  const auto path = std::filesystem::temp_directory_path() / "silpose_mask16.png";
  cv::Mat wide = cv::Mat::zeros(20, 30, CV_16UC1);
  wide.at<uint16_t>(3, 4) = 1;  // would vanish if scaled down to 8 bits
  cv::imwrite(path.string(), wide);
  cv::Mat mask = ReadMask(path);
  EXPECT_EQ(mask.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(mask), 1);
  EXPECT_EQ(mask.at<uint8_t>(3, 4), 255);
  cv::Mat colour = cv::Mat::zeros(20, 30, CV_8UC3);
  colour.at<cv::Vec3b>(5, 6) = {0, 0, 9};
  cv::imwrite(path.string(), colour);
  mask = ReadMask(path);
  EXPECT_EQ(cv::countNonZero(mask), 1);
  EXPECT_EQ(mask.at<uint8_t>(5, 6), 255);
  WriteMask(path, mask);
  EXPECT_EQ(cv::countNonZero(ReadMask(path) != mask), 0);
  std::filesystem::remove(path);
}

TEST(MaskFile, MissingCorruptAndUnwritableFilesNameTheFile) {
  const auto missing = std::filesystem::temp_directory_path() / "silpose_no_mask.png";
  try {
    ReadMask(missing);
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("silpose_no_mask.png: no such file"),
              std::string::npos);
  }
  const auto corrupt = std::filesystem::temp_directory_path() / "silpose_corrupt_mask.png";
  std::ofstream(corrupt) << "\x89PNG\r\n\x1a\n truncated";
  EXPECT_THROW(ReadMask(corrupt), Error);
  std::filesystem::remove(corrupt);
  EXPECT_THROW(WriteMask("/nonexistent/dir/out.png", cv::Mat::zeros(4, 4, CV_8UC1)), Error);
}

}  // namespace
}  // namespace silpose
