#include "silpose/io/read_ahead_source.h"

#include <gtest/gtest.h>

#include <any>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

std::filesystem::path TempDir(const std::string& name) {
  const auto directory = std::filesystem::temp_directory_path() / ("silpose_read_ahead_" + name);
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

// Frames 0..count-1 of a folder, each filled with its index (a mask 0/255 pattern beside it, so
// the mask rule has something to keep).
std::filesystem::path WriteFrames(const std::string& name, int count) {
  const auto directory = TempDir(name);
  for (int i = 0; i < count; ++i) {
    cv::Mat frame(24, 32, CV_8UC1, cv::Scalar(i));
    frame(cv::Rect(4, 4, 1 + i % 20, 8)).setTo(255);
    char file[32];
    std::snprintf(file, sizeof(file), "%06d.png", i);
    cv::imwrite((directory / file).string(), frame);
  }
  return directory;
}

struct Delivered {
  std::vector<cv::Mat> frames;
  std::vector<std::string> names;
  std::vector<int> indices;
  std::string error;
};

// Reads `source` to its end (or its Error), cloning nothing: each frame must stay valid.
Delivered ReadAll(FrameSource& source) {
  Delivered out;
  cv::Mat frame;
  try {
    while (source.Read(&frame)) {
      out.frames.push_back(frame);
      out.names.push_back(source.name());
      out.indices.push_back(source.frame_index());
    }
  } catch (const Error& error) {
    out.error = error.what();
  }
  return out;
}

void ExpectSame(const Delivered& read_ahead, const Delivered& plain) {
  ASSERT_EQ(read_ahead.frames.size(), plain.frames.size());
  EXPECT_EQ(read_ahead.names, plain.names);
  EXPECT_EQ(read_ahead.indices, plain.indices);
  EXPECT_EQ(read_ahead.error, plain.error);
  for (size_t i = 0; i < plain.frames.size(); ++i) {
    ASSERT_EQ(read_ahead.frames[i].type(), plain.frames[i].type()) << i;
    ASSERT_EQ(read_ahead.frames[i].size(), plain.frames[i].size()) << i;
    EXPECT_EQ(cv::norm(read_ahead.frames[i], plain.frames[i], cv::NORM_INF), 0.0) << i;
  }
}

TEST(ReadAheadSource, DeliversWhatTheSourceDeliversInOrder) {
  const auto directory = WriteFrames("same", 40);
  for (const FrameColor color : {FrameColor::kAsStored, FrameColor::kMask, FrameColor::kBgr}) {
    FrameSourceOptions options;
    options.color = color;
    auto plain_source = OpenFrameSource(directory.string(), options);
    const Delivered plain = ReadAll(*plain_source);
    ASSERT_EQ(plain.frames.size(), 40u);
    for (const int depth : {1, 3}) {
      ReadAheadSource source(OpenFrameSource(directory.string(), options), depth);
      EXPECT_EQ(source.num_frames(), std::optional<int>(40));
      EXPECT_EQ(source.size(), cv::Size(32, 24));
      EXPECT_EQ(source.fps(), 0.0);
      EXPECT_EQ(source.name(), OpenFrameSource(directory.string(), options)->name());
      ExpectSame(ReadAll(source), plain);
      cv::Mat frame;
      EXPECT_FALSE(source.Read(&frame));  // still the end
    }
  }
  std::filesystem::remove_all(directory);
}

TEST(ReadAheadSource, DeliversTheGoodFramesBeforeTheErrorOfABadOne) {
  const auto directory = WriteFrames("corrupt", 6);
  std::ofstream(directory / "000003.png") << "this is not a PNG file";
  auto plain_source = OpenFrameSource(directory.string());
  const Delivered plain = ReadAll(*plain_source);
  ASSERT_EQ(plain.frames.size(), 3u);
  EXPECT_NE(plain.error.find("000003.png: frame 3"), std::string::npos) << plain.error;
  ReadAheadSource source(OpenFrameSource(directory.string()), 4);
  ExpectSame(ReadAll(source), plain);
  cv::Mat frame;
  EXPECT_FALSE(source.Read(&frame));  // the source ends after an Error
  std::filesystem::remove_all(directory);
}

TEST(ReadAheadSource, StopsWhenDestroyedBeforeTheEnd) {
  const auto directory = WriteFrames("early", 30);
  for (const int read : {0, 1, 5}) {
    ReadAheadSource source(OpenFrameSource(directory.string()), 2);
    cv::Mat frame;
    for (int i = 0; i < read; ++i) {
      ASSERT_TRUE(source.Read(&frame));
      EXPECT_EQ(frame.at<uint8_t>(0, 0), i);
    }
  }  // each destructor joins its thread while the queue is full: the test ends, no hang
  std::filesystem::remove_all(directory);
}

TEST(ReadAheadSource, GivesEachFrameTheResultOfTheWorkDoneOnItAndStopsAtAnErrorOfTheWork) {
  const auto directory = WriteFrames("work", 8);
  // The work sees the frames in order (it counts them) and reads each one's content.
  int seen = 0;
  ReadAheadSource::FrameWork work = [&seen](const cv::Mat& frame) -> std::any {
    const int value = frame.at<uint8_t>(0, 0);
    if (value == 5) ThrowError("work: frame with value 5");
    return std::make_pair(seen++, value);
  };
  ReadAheadSource source(OpenFrameSource(directory.string()), 2, work);
  cv::Mat frame;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(source.Read(&frame)) << i;
    const auto done = std::any_cast<std::pair<int, int>>(source.work_result());
    EXPECT_EQ(done.first, i);
    EXPECT_EQ(done.second, i);
    EXPECT_EQ(frame.at<uint8_t>(0, 0), i);
  }
  try {
    source.Read(&frame);
    ADD_FAILURE() << "no Error from the work on frame 5";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("work: frame with value 5"), std::string::npos);
  }
  EXPECT_FALSE(source.Read(&frame));
  std::filesystem::remove_all(directory);
}

TEST(ReadAheadSource, RefusesADepthBelowOneAndNoSource) {
  const auto directory = WriteFrames("depth", 2);
  EXPECT_THROW(ReadAheadSource(OpenFrameSource(directory.string()), 0), Error);
  EXPECT_THROW(ReadAheadSource(nullptr, 2), Error);
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace silpose
