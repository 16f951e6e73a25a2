#include "silpose/io/video_writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "silpose/io/avi_file.h"
#include "silpose/io/frame_source.h"
#include "silpose/util/error.h"

#if SILPOSE_WITH_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

namespace silpose {
namespace {

std::filesystem::path TempDir(const std::string& name) {
  const auto directory = std::filesystem::temp_directory_path() / ("silpose_writer_" + name);
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

cv::Mat Frame(int index, cv::Size size) {
  cv::Mat image(size, CV_8UC3, cv::Scalar(40, 80, 120));
  cv::rectangle(image, {4 + 2 * index, 4}, {size.width / 2 + 2 * index, size.height - 4},
                cv::Scalar(250, 250, 250), cv::FILLED);
  return image;
}

double Psnr(const cv::Mat& a, const cv::Mat& b) {
  const double mse = cv::norm(a, b, cv::NORM_L2SQR) / static_cast<double>(a.total() * a.channels());
  return mse == 0 ? 1e9 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

std::vector<cv::Mat> ReadAll(const std::filesystem::path& path) {
  auto source = OpenFrameSource(path.string());
  std::vector<cv::Mat> frames;
  cv::Mat frame;
  while (source->Read(&frame)) frames.push_back(frame);
  return frames;
}

TEST(VideoWriter, AviMixesGreyAndColourFramesLosslessly) {
  const auto directory = TempDir("avi");
  VideoWriterOptions options;
  options.avi_codec = AviCodec::kPng;
  const cv::Size size(48, 32);
  std::vector<cv::Mat> written;
  {
    auto writer = OpenVideoWriter(directory / "overlay.AVI", size, 24.0, options);
    EXPECT_EQ(writer->size(), size);
    EXPECT_DOUBLE_EQ(writer->fps(), 24.0);
    for (int i = 0; i < 4; ++i) {
      cv::Mat frame = Frame(i, size);
      if (i == 1) cv::cvtColor(frame, frame, cv::COLOR_BGR2GRAY);
      writer->Write(frame);
      if (i == 1) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
      written.push_back(frame);
    }
    EXPECT_EQ(writer->num_frames(), 4);
    writer->Close();
  }
  const auto frames = ReadAll(directory / "overlay.AVI");
  ASSERT_EQ(frames.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    ASSERT_EQ(frames[i].type(), CV_8UC3);
    EXPECT_EQ(cv::norm(frames[i], written[i], cv::NORM_INF), 0.0) << i;
  }
  std::filesystem::remove_all(directory);
}

TEST(VideoWriter, EveryWrittenFrameIsOnDiskBeforeClose) {
  // What a killed process leaves: the file as it is after the last Write(), without Close().
  const auto directory = TempDir("killed");
  VideoWriterOptions options;
  options.avi_codec = AviCodec::kPng;
  const cv::Size size(48, 32);
  auto writer = OpenVideoWriter(directory / "overlay.avi", size, 24.0, options);
  for (int i = 0; i < 5; ++i) writer->Write(Frame(i, size));
  std::filesystem::copy_file(directory / "overlay.avi", directory / "snapshot.avi");
  auto source = OpenFrameSource((directory / "snapshot.avi").string());
  int frames = 0;
  cv::Mat frame;
  try {
    while (source->Read(&frame)) ++frames;
  } catch (const Error&) {
    // An unfinished file may end with an error after its last whole frame.
  }
  EXPECT_EQ(frames, 5);
  writer->Close();
  std::filesystem::remove_all(directory);
}

TEST(VideoWriter, ChecksItsOptions) {
  VideoWriterOptions options;
  EXPECT_NO_THROW(options.Check());
  options.jpeg_quality = 0;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.png_compression = 10;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.avi_max_file_bytes = kAviMaxFileBytes + 1;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.opencv_fourcc = "mp4";
  EXPECT_THROW(options.Check(), Error);
}

TEST(VideoWriter, OtherContainersNeedVideoIo) {
  const auto directory = TempDir("mp4");
  const cv::Size size(64, 48);
  if (!HasOpenCvVideoIo()) {
    for (const char* name : {"out.mp4", "out.mkv", "out"}) {
      try {
        OpenVideoWriter(directory / name, size, 25.0);
        ADD_FAILURE() << name;
      } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_NE(message.find("SILPOSE_WITH_VIDEOIO"), std::string::npos) << message;
        EXPECT_NE(message.find(".avi"), std::string::npos) << message;
      }
    }
    EXPECT_FALSE(std::filesystem::exists(directory / "out.mp4"));
  } else {
    // A round trip through OpenCV videoio (FFmpeg's MPEG-4 part 2 encoder).
    {
      auto writer = OpenVideoWriter(directory / "out.mp4", size, 25.0);
      for (int i = 0; i < 10; ++i) writer->Write(Frame(i, size));
      writer->Close();
    }
    auto source = OpenFrameSource((directory / "out.mp4").string());
    EXPECT_EQ(source->size(), size);
    EXPECT_NEAR(source->fps(), 25.0, 1e-6);
    EXPECT_EQ(source->num_frames().value_or(-1), 10);
    const auto frames = ReadAll(directory / "out.mp4");
    ASSERT_EQ(frames.size(), 10u);
    for (size_t i = 0; i < frames.size(); ++i) {
      EXPECT_GT(Psnr(frames[i], Frame(static_cast<int>(i), size)), 25.0) << i;
    }
  }
#if SILPOSE_WITH_VIDEOIO
  // An AVI whose codec silpose's reader does not decode (MPEG-4 part 2) is read by OpenCV.
  {
    cv::VideoWriter writer((directory / "mpeg4.avi").string(), cv::CAP_FFMPEG,
                           cv::VideoWriter::fourcc('F', 'M', 'P', '4'), 25.0, size, true);
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 6; ++i) writer.write(Frame(i, size));
  }
  const auto frames = ReadAll(directory / "mpeg4.avi");
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_GT(Psnr(frames[3], Frame(3, size)), 25.0);

  // FFmpeg's MJPEG AVI files are read by silpose's reader, and silpose's by FFmpeg.
  {
    cv::VideoWriter writer((directory / "ffmpeg_mjpeg.avi").string(), cv::CAP_FFMPEG,
                           cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, size, true);
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 6; ++i) writer.write(Frame(i, size));
  }
  AviReader reader(directory / "ffmpeg_mjpeg.avi");
  EXPECT_EQ(reader.num_frames().value_or(-1), 6);
  EXPECT_NEAR(reader.fps(), 25.0, 1e-9);
  cv::Mat frame;
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(reader.Read(&frame)) << i;
    EXPECT_GT(Psnr(frame, Frame(i, size)), 25.0) << i;
  }
  EXPECT_FALSE(reader.Read(&frame));
  for (AviCodec codec : {AviCodec::kMjpeg, AviCodec::kPng}) {
    VideoWriterOptions options;
    options.avi_codec = codec;
    {
      auto writer = OpenVideoWriter(directory / "silpose.avi", size, 25.0, options);
      for (int i = 0; i < 7; ++i) writer->Write(Frame(i, size));
    }
    cv::VideoCapture capture((directory / "silpose.avi").string(), cv::CAP_FFMPEG);
    ASSERT_TRUE(capture.isOpened());
    EXPECT_EQ(capture.get(cv::CAP_PROP_FRAME_COUNT), 7.0);
    EXPECT_NEAR(capture.get(cv::CAP_PROP_FPS), 25.0, 1e-6);
    int count = 0;
    while (capture.read(frame)) {
      EXPECT_GT(Psnr(frame, Frame(count, size)), codec == AviCodec::kPng ? 1e8 : 30.0) << count;
      ++count;
    }
    EXPECT_EQ(count, 7);
  }
#endif
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace silpose
