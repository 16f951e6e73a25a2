#include "silpose/io/frame_source.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "silpose/io/avi_file.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

std::filesystem::path TempDir(const std::string& name) {
  const auto directory = std::filesystem::temp_directory_path() / ("silpose_frames_" + name);
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

// A frame whose pixels all equal `value` (so the reading order is visible in the content).
cv::Mat Flat(int value, cv::Size size = {12, 8}, int type = CV_8UC1) {
  return cv::Mat(size, type, cv::Scalar::all(value));
}

std::string ErrorOf(const std::string& input, const FrameSourceOptions& options = {}) {
  try {
    auto source = OpenFrameSource(input, options);
    cv::Mat frame;
    while (source->Read(&frame)) {
    }
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(FrameSource, ReadsAFolderInNameOrder) {
  const auto directory = TempDir("order");
  cv::imwrite((directory / "000002.png").string(), Flat(2));
  cv::imwrite((directory / "000000.png").string(), Flat(0));
  cv::imwrite((directory / "000001.PNG").string(), Flat(1));
  cv::imwrite((directory / "000003.bmp").string(), Flat(3));
  WriteText(directory / "notes.txt", "not a frame");
  std::filesystem::create_directories(directory / "sub.png");
  auto source = OpenFrameSource(directory.string());
  ASSERT_TRUE(source->num_frames().has_value());
  EXPECT_EQ(*source->num_frames(), 4);
  EXPECT_EQ(source->fps(), 0.0);
  EXPECT_EQ(source->size(), cv::Size(12, 8));
  cv::Mat frame;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(source->Read(&frame));
    EXPECT_EQ(source->frame_index(), i);
    EXPECT_EQ(frame.type(), CV_8UC1);
    EXPECT_EQ(frame.at<std::uint8_t>(0, 0), i);
  }
  EXPECT_EQ(source->name(), "000003.bmp");
  EXPECT_FALSE(source->Read(&frame));
  std::filesystem::remove_all(directory);
}

TEST(FrameSource, NamesTheImageThatDoesNotDecodeAfterTheGoodOnes) {
  const auto directory = TempDir("corrupt");
  cv::imwrite((directory / "a.png").string(), Flat(0));
  WriteText(directory / "b.png", "this is not a PNG file");
  cv::imwrite((directory / "c.png").string(), Flat(2));
  auto source = OpenFrameSource(directory.string());
  cv::Mat frame;
  ASSERT_TRUE(source->Read(&frame));
  try {
    source->Read(&frame);
    ADD_FAILURE() << "no Error for b.png";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("b.png: frame 1"), std::string::npos) << error.what();
  }
  EXPECT_FALSE(source->Read(&frame));  // the source ends after an Error
  std::filesystem::remove_all(directory);
}

TEST(FrameSource, RefusesAFrameSizeChange) {
  const auto directory = TempDir("size");
  cv::imwrite((directory / "a.png").string(), Flat(0));
  cv::imwrite((directory / "b.png").string(), Flat(1, {12, 9}));
  const std::string error = ErrorOf(directory.string());
  EXPECT_NE(error.find("b.png: frame 1 is 12x9 pixels but the first frame is 12x8"),
            std::string::npos)
      << error;
  std::filesystem::remove_all(directory);
}

TEST(FrameSource, ConvertsToTheRequestedColour) {
  const auto directory = TempDir("colour");
  cv::imwrite((directory / "a.png").string(), Flat(100));
  cv::imwrite((directory / "b.png").string(), Flat(50, {12, 8}, CV_8UC3));
  cv::imwrite((directory / "c.png").string(), cv::Mat(8, 12, CV_16UC1, cv::Scalar(257 * 30)));
  cv::imwrite((directory / "d.png").string(), Flat(70, {12, 8}, CV_8UC4));
  const auto read = [&](FrameColor color) {
    FrameSourceOptions options;
    options.color = color;
    auto source = OpenFrameSource(directory.string(), options);
    std::vector<cv::Mat> frames;
    cv::Mat frame;
    while (source->Read(&frame)) frames.push_back(frame);
    return frames;
  };
  const std::vector<int> levels = {100, 50, 30, 70};
  for (FrameColor color : {FrameColor::kAsStored, FrameColor::kGray, FrameColor::kBgr}) {
    const auto frames = read(color);
    ASSERT_EQ(frames.size(), 4u);
    // kAsStored follows the first (grey) frame.
    const int type = color == FrameColor::kBgr ? CV_8UC3 : CV_8UC1;
    for (size_t i = 0; i < 4; ++i) {
      ASSERT_EQ(frames[i].type(), type) << i;
      EXPECT_EQ(frames[i].at<std::uint8_t>(3, 3), levels[i]) << i;
    }
  }
  std::filesystem::remove_all(directory);
}

TEST(FrameSource, PicksTheSubfolderOfASequenceFolder) {
  const auto directory = TempDir("sequence");
  std::filesystem::create_directories(directory / "masks");
  std::filesystem::create_directories(directory / "frames");
  for (int i = 0; i < 3; ++i) {
    cv::imwrite((directory / "masks" / (std::to_string(i) + ".png")).string(), Flat(255));
  }
  for (int i = 0; i < 2; ++i) {
    cv::imwrite((directory / "frames" / (std::to_string(i) + ".png")).string(),
                Flat(90, {12, 8}, CV_8UC3));
  }
  WriteText(directory / "groundtruth.csv", "frame\n");
  FrameSourceOptions options;
  EXPECT_EQ(*OpenFrameSource(directory.string(), options)->num_frames(), 3);
  options.sequence_folder = SequenceFolder::kFrames;
  auto frames = OpenFrameSource(directory.string(), options);
  EXPECT_EQ(*frames->num_frames(), 2);
  cv::Mat frame;
  ASSERT_TRUE(frames->Read(&frame));
  EXPECT_EQ(frame.type(), CV_8UC3);
  // Only masks/: taken even when frames are asked for.
  std::filesystem::remove_all(directory / "frames");
  EXPECT_EQ(*OpenFrameSource(directory.string(), options)->num_frames(), 3);
  std::filesystem::remove_all(directory / "masks");
  EXPECT_NE(ErrorOf(directory.string()).find("no images"), std::string::npos);
  std::filesystem::remove_all(directory);
}

TEST(FrameSource, OpensVideosImagesAndExplainsWhatItCannotOpen) {
  const auto directory = TempDir("kinds");
  {
    VideoWriterOptions options;
    options.avi_codec = AviCodec::kPng;
    AviWriter writer(directory / "Clip.AVI", {12, 8}, 15.0, options);
    for (int i = 0; i < 3; ++i) writer.Write(Flat(10 * i));
  }
  auto video = OpenFrameSource((directory / "Clip.AVI").string());
  EXPECT_EQ(*video->num_frames(), 3);
  EXPECT_DOUBLE_EQ(video->fps(), 15.0);
  cv::Mat frame;
  ASSERT_TRUE(video->Read(&frame));
  ASSERT_TRUE(video->Read(&frame));
  EXPECT_EQ(video->name(), "Clip.AVI#1");
  EXPECT_EQ(frame.at<std::uint8_t>(0, 0), 10);

  cv::imwrite((directory / "one.png").string(), Flat(5));
  auto image = OpenFrameSource((directory / "one.png").string());
  EXPECT_EQ(*image->num_frames(), 1);

  EXPECT_NE(ErrorOf((directory / "missing").string()).find("missing: no such file or folder"),
            std::string::npos);
  EXPECT_NE(ErrorOf("").find("empty"), std::string::npos);
  std::filesystem::create_directories(directory / "empty");
  EXPECT_NE(ErrorOf((directory / "empty").string()).find("no images"), std::string::npos);
  WriteText(directory / "bad.png", "not an image");
  EXPECT_NE(ErrorOf((directory / "bad.png").string()).find("bad.png: frame 0"), std::string::npos);
  WriteText(directory / "garbage.avi", "not an AVI file at all");
  EXPECT_NE(ErrorOf((directory / "garbage.avi").string()).find("not an AVI file"),
            std::string::npos);
  if (!HasOpenCvVideoIo()) {
    WriteText(directory / "clip.mp4", "an mp4 file");
    WriteText(directory / "notes.txt", "text");
    for (const std::string& input : std::vector<std::string>{
             "0", "12", (directory / "clip.mp4").string(), (directory / "notes.txt").string()}) {
      const std::string error = ErrorOf(input);
      EXPECT_NE(error.find("-DSILPOSE_WITH_VIDEOIO=ON"), std::string::npos) << error;
    }
    EXPECT_NE(ErrorOf("0").find("camera"), std::string::npos);
  }
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace silpose
