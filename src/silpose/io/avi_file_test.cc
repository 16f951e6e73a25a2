#include "silpose/io/avi_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "silpose/util/error.h"

namespace silpose {
namespace {

using Bytes = std::vector<std::uint8_t>;

std::filesystem::path TempDir(const std::string& name) {
  const auto directory = std::filesystem::temp_directory_path() / ("silpose_avi_" + name);
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

// A smooth image with some edges that changes with `index` (JPEG-friendly, all frames distinct).
cv::Mat TestFrame(int index, cv::Size size, int type) {
  cv::Mat image(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y) {
    for (int x = 0; x < size.width; ++x) {
      image.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<std::uint8_t>((x * 255) / size.width),
                                            static_cast<std::uint8_t>((y * 255) / size.height),
                                            static_cast<std::uint8_t>((index * 37) % 256));
    }
  }
  cv::circle(image, {size.width / 4 + index * 3, size.height / 2}, size.height / 4,
             cv::Scalar(255, 255, 255), cv::FILLED);
  if (type == CV_8UC1) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
  return image;
}

Bytes ReadBytes(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::filesystem::path& path, const Bytes& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
}

std::filesystem::path WriteVideo(const std::filesystem::path& path,
                                 const std::vector<cv::Mat>& frames, double fps, AviCodec codec) {
  VideoWriterOptions options;
  options.avi_codec = codec;
  AviWriter writer(path, frames.front().size(), fps, options);
  for (const cv::Mat& frame : frames) writer.Write(frame);
  writer.Close();
  return path;
}

std::vector<cv::Mat> TestFrames(int count, cv::Size size, int type) {
  std::vector<cv::Mat> frames;
  for (int i = 0; i < count; ++i) frames.push_back(TestFrame(i, size, type));
  return frames;
}

// Reads every frame; returns the frames and the Error message ("" if the file ended cleanly).
// Stops after `limit` frames so that a reader that never ends fails the test instead of hanging.
struct ReadResult {
  std::vector<cv::Mat> frames;
  std::string error;
  bool opened = false;
};

ReadResult ReadAll(const std::filesystem::path& path, FrameColor color = FrameColor::kAsStored,
                   int limit = 1000) {
  ReadResult result;
  try {
    AviReader reader(path, color);
    result.opened = true;
    cv::Mat frame;
    while (static_cast<int>(result.frames.size()) < limit && reader.Read(&frame)) {
      result.frames.push_back(frame);
    }
    EXPECT_LT(static_cast<int>(result.frames.size()), limit) << "reader did not stop";
  } catch (const Error& error) {
    result.error = error.what();
  }
  return result;
}

double Psnr(const cv::Mat& a, const cv::Mat& b) {
  const double mse = cv::norm(a, b, cv::NORM_L2SQR) / static_cast<double>(a.total() * a.channels());
  return mse == 0 ? 1e9 : 10.0 * std::log10(255.0 * 255.0 / mse);
}

// Byte offsets of the frame chunks (chunk header start) in a file silpose wrote.
std::vector<size_t> ChunkOffsets(const Bytes& bytes) {
  std::vector<size_t> offsets;
  size_t position = 224;  // AviWriter's header size
  while (position + 8 <= bytes.size() && std::memcmp(&bytes[position], "00dc", 4) == 0) {
    offsets.push_back(position);
    std::uint32_t size = 0;
    std::memcpy(&size, &bytes[position + 4], 4);
    position += 8 + size + (size & 1);
  }
  offsets.push_back(position);  // the idx1 chunk
  return offsets;
}

TEST(AviFile, PngFramesRoundTripPixelIdentical) {
  const auto directory = TempDir("png");
  for (int type : {CV_8UC3, CV_8UC1}) {
    const auto frames = TestFrames(7, {64, 48}, type);
    const auto path = WriteVideo(directory / "clip.avi", frames, 25.0, AviCodec::kPng);
    AviReader reader(path);
    EXPECT_EQ(reader.header().fourcc, "MPNG");
    ASSERT_TRUE(reader.num_frames().has_value());
    EXPECT_EQ(*reader.num_frames(), 7);
    EXPECT_DOUBLE_EQ(reader.fps(), 25.0);
    EXPECT_EQ(reader.size(), cv::Size(64, 48));
    EXPECT_EQ(reader.frame_index(), -1);
    cv::Mat frame;
    for (int i = 0; i < 7; ++i) {
      ASSERT_TRUE(reader.Read(&frame)) << i;
      EXPECT_EQ(reader.frame_index(), i);
      EXPECT_EQ(reader.name(), "clip.avi#" + std::to_string(i));
      ASSERT_EQ(frame.type(), type);
      EXPECT_EQ(cv::norm(frame, frames[static_cast<size_t>(i)], cv::NORM_INF), 0.0) << i;
    }
    EXPECT_FALSE(reader.Read(&frame));
    EXPECT_FALSE(reader.Read(&frame));
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, JpegFramesRoundTripWithinPsnrBound) {
  const auto directory = TempDir("jpeg");
  const auto frames = TestFrames(5, {160, 120}, CV_8UC3);
  const auto path = WriteVideo(directory / "clip.avi", frames, 30.0, AviCodec::kMjpeg);
  const ReadResult result = ReadAll(path);
  EXPECT_EQ(result.error, "");
  ASSERT_EQ(result.frames.size(), 5u);
  for (size_t i = 0; i < 5; ++i) {
    ASSERT_EQ(result.frames[i].type(), CV_8UC3);
    EXPECT_GT(Psnr(result.frames[i], frames[i]), 30.0) << i;
  }
  EXPECT_EQ(ReadAviHeader(path).fourcc, "MJPG");
  // Grey output decodes the luminance straight from the JPEG.
  const ReadResult gray = ReadAll(path, FrameColor::kGray);
  ASSERT_EQ(gray.frames.size(), 5u);
  cv::Mat expected;
  cv::cvtColor(frames[2], expected, cv::COLOR_BGR2GRAY);
  ASSERT_EQ(gray.frames[2].type(), CV_8UC1);
  EXPECT_GT(Psnr(gray.frames[2], expected), 30.0);
  std::filesystem::remove_all(directory);
}

TEST(AviFile, FrameRateIsStoredExactly) {
  const auto directory = TempDir("fps");
  for (double fps : {30000.0 / 1001.0, 12.5, 60.0, 7.0}) {
    const auto path =
        WriteVideo(directory / "clip.avi", TestFrames(1, {8, 8}, CV_8UC1), fps, AviCodec::kPng);
    EXPECT_NEAR(ReadAviHeader(path).fps, fps, 1e-9 * fps);
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, TruncatedFileGivesCompleteFramesThenError) {
  const auto directory = TempDir("truncated");
  const auto frames = TestFrames(5, {40, 30}, CV_8UC3);
  for (AviCodec codec : {AviCodec::kPng, AviCodec::kMjpeg}) {
    const auto path = WriteVideo(directory / "full.avi", frames, 10.0, codec);
    const Bytes bytes = ReadBytes(path);
    const std::vector<size_t> chunks = ChunkOffsets(bytes);
    ASSERT_EQ(chunks.size(), 6u);
    const size_t movi_end = chunks.back();
    std::vector<size_t> cuts = {0, 3, 11, 12, 30, 100, 200, 223, 224, 228};
    for (size_t i = 0; i < 5; ++i) {
      cuts.push_back(chunks[i] + 4);                                    // inside a chunk header
      cuts.push_back(chunks[i] + 8 + (chunks[i + 1] - chunks[i]) / 2);  // inside its data
      cuts.push_back(chunks[i + 1] - 1);                                // one byte short
      cuts.push_back(chunks[i + 1]);                                    // on a chunk boundary
    }
    cuts.push_back(movi_end + 10);  // inside the index
    for (size_t cut : cuts) {
      const auto cut_path = directory / "cut.avi";
      WriteBytes(cut_path, Bytes(bytes.begin(), bytes.begin() + static_cast<long>(cut)));
      const ReadResult result = ReadAll(cut_path);
      SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(bytes.size()));
      if (cut < 224) {
        EXPECT_FALSE(result.opened);
        EXPECT_NE(result.error.find("cut.avi"), std::string::npos) << result.error;
        continue;
      }
      size_t complete = 0;
      while (complete < 5 && chunks[complete + 1] <= cut) ++complete;
      // A chunk whose data is complete but whose padding byte is cut still decodes.
      ASSERT_GE(result.frames.size(), complete);
      ASSERT_LE(result.frames.size(), complete + 1);
      for (size_t i = 0; i < result.frames.size() && codec == AviCodec::kPng; ++i) {
        EXPECT_EQ(cv::norm(result.frames[i], frames[i], cv::NORM_INF), 0.0);
      }
      if (cut >= movi_end) {
        EXPECT_EQ(result.error, "");
        EXPECT_EQ(result.frames.size(), 5u);
      } else {
        EXPECT_NE(result.error.find("cut.avi: frame "), std::string::npos) << result.error;
        EXPECT_NE(result.error.find("truncated"), std::string::npos) << result.error;
      }
    }
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, CorruptJpegDataNamesTheFrame) {
  const auto directory = TempDir("corrupt");
  const auto path =
      WriteVideo(directory / "clip.avi", TestFrames(4, {40, 30}, CV_8UC3), 10.0, AviCodec::kMjpeg);
  const Bytes bytes = ReadBytes(path);
  const std::vector<size_t> chunks = ChunkOffsets(bytes);
  std::uint32_t size = 0;
  std::memcpy(&size, &bytes[chunks[2] + 4], 4);
  const size_t begin = chunks[2] + 8;
  const size_t end = begin + size;
  // Frame 2 without its start marker, without its end marker, and with only the two markers.
  const std::vector<std::pair<size_t, size_t>> zeroed = {
      {begin, begin + 2}, {end - 2, end}, {begin + 2, end - 2}};
  for (const auto& [first, last] : zeroed) {
    Bytes corrupt = bytes;
    std::fill(corrupt.begin() + static_cast<long>(first), corrupt.begin() + static_cast<long>(last),
              0);
    WriteBytes(directory / "corrupt.avi", corrupt);
    const ReadResult result = ReadAll(directory / "corrupt.avi");
    EXPECT_EQ(result.frames.size(), 2u);
    EXPECT_NE(result.error.find("corrupt.avi: frame 2: "), std::string::npos) << result.error;
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, GarbageIsNotAnAviFile) {
  const auto directory = TempDir("garbage");
  std::mt19937 random(7);
  Bytes garbage(5000);
  for (auto& byte : garbage) byte = static_cast<std::uint8_t>(random());
  for (const Bytes& content : {garbage, Bytes{}, Bytes{'R', 'I', 'F', 'F'}}) {
    WriteBytes(directory / "garbage.avi", content);
    const ReadResult result = ReadAll(directory / "garbage.avi");
    EXPECT_FALSE(result.opened);
    EXPECT_NE(result.error.find("garbage.avi: not an AVI file"), std::string::npos) << result.error;
  }
  const ReadResult missing = ReadAll(directory / "missing.avi");
  EXPECT_NE(missing.error.find("missing.avi: no such file"), std::string::npos);
  std::filesystem::remove_all(directory);
}

// Flips random bytes of small files: every read must end in frames or an Error.
TEST(AviFile, RandomlyCorruptedFilesGiveFramesOrAnError) {
  const auto directory = TempDir("fuzz");
  std::mt19937 random(20240601);
  int errors = 0;
  int clean = 0;
  for (AviCodec codec : {AviCodec::kPng, AviCodec::kMjpeg}) {
    const auto path =
        WriteVideo(directory / "clip.avi", TestFrames(4, {24, 16}, CV_8UC3), 10.0, codec);
    const Bytes bytes = ReadBytes(path);
    for (int variant = 0; variant < 200; ++variant) {
      Bytes corrupt = bytes;
      const int flips = 1 + static_cast<int>(random() % 4);
      for (int f = 0; f < flips; ++f) {
        // Half of the flips hit the headers, where sizes and counts live.
        const size_t range = random() % 2 ? 240 : corrupt.size();
        corrupt[random() % range] ^= static_cast<std::uint8_t>(1 + random() % 255);
      }
      if (variant % 10 == 0) corrupt.resize(random() % corrupt.size());
      WriteBytes(directory / "fuzz.avi", corrupt);
      const ReadResult result = ReadAll(directory / "fuzz.avi", FrameColor::kAsStored, 100);
      (result.error.empty() ? clean : errors)++;
      for (const cv::Mat& frame : result.frames) {
        EXPECT_FALSE(frame.empty());
        EXPECT_TRUE(frame.type() == CV_8UC1 || frame.type() == CV_8UC3);
      }
    }
  }
  EXPECT_GT(errors, 0);
  EXPECT_GT(clean, 0);
  std::filesystem::remove_all(directory);
}

TEST(AviFile, WriterDestructorFinishesTheFile) {
  const auto directory = TempDir("destructor");
  const auto frames = TestFrames(3, {20, 10}, CV_8UC3);
  {
    VideoWriterOptions options;
    options.avi_codec = AviCodec::kPng;
    AviWriter writer(directory / "clip.avi", {20, 10}, 5.0, options);
    for (const auto& frame : frames) writer.Write(frame);
    EXPECT_EQ(writer.num_frames(), 3);
  }
  const AviHeader header = ReadAviHeader(directory / "clip.avi");
  ASSERT_TRUE(header.num_frames.has_value());
  EXPECT_EQ(*header.num_frames, 3);
  EXPECT_EQ(ReadAll(directory / "clip.avi").frames.size(), 3u);
  std::filesystem::remove_all(directory);
}

TEST(AviFile, UnfinishedFileReadsToItsEnd) {
  // What a writer that crashed leaves: sizes 0 (never patched) and no index.
  const auto directory = TempDir("unfinished");
  const auto frames = TestFrames(3, {20, 10}, CV_8UC3);
  const auto path = WriteVideo(directory / "clip.avi", frames, 5.0, AviCodec::kPng);
  Bytes bytes = ReadBytes(path);
  bytes.resize(ChunkOffsets(bytes).back());
  std::memset(&bytes[4], 0, 4);
  std::memset(&bytes[216], 0, 4);
  WriteBytes(path, bytes);
  EXPECT_FALSE(ReadAviHeader(path).num_frames.has_value());
  const ReadResult result = ReadAll(path);
  EXPECT_EQ(result.error, "");
  EXPECT_EQ(result.frames.size(), 3u);
  std::filesystem::remove_all(directory);
}

TEST(AviFile, WriterRefusesBadFramesAndStopsBeforeTheSizeLimit) {
  const auto directory = TempDir("limits");
  VideoWriterOptions options;
  options.avi_codec = AviCodec::kPng;
  options.png_compression = 0;
  options.avi_max_file_bytes = 6000;  // a 4 GiB file in miniature
  AviWriter writer(directory / "clip.avi", {32, 16}, 5.0, options);
  EXPECT_THROW(writer.Write(cv::Mat(16, 31, CV_8UC3, cv::Scalar::all(0))), Error);
  EXPECT_THROW(writer.Write(cv::Mat(16, 32, CV_32FC1, cv::Scalar::all(0))), Error);
  int written = 0;
  std::string message;
  try {
    for (int i = 0; i < 100; ++i) {
      writer.Write(TestFrame(i, {32, 16}, CV_8UC3));
      ++written;
    }
  } catch (const Error& error) {
    message = error.what();
  }
  EXPECT_GT(written, 0);
  EXPECT_LT(written, 100);
  EXPECT_NE(message.find("limit of an AVI 1.0 file"), std::string::npos) << message;
  writer.Close();
  EXPECT_THROW(writer.Write(TestFrame(0, {32, 16}, CV_8UC3)), Error);
  EXPECT_LE(std::filesystem::file_size(directory / "clip.avi"), 6000u);
  const ReadResult result = ReadAll(directory / "clip.avi");
  EXPECT_EQ(result.error, "");
  EXPECT_EQ(static_cast<int>(result.frames.size()), written);
  EXPECT_THROW(AviWriter(directory / "bad.avi", {0, 10}, 5.0), Error);
  EXPECT_THROW(AviWriter(directory / "bad.avi", {10, 10}, 0.0), Error);
  EXPECT_THROW(AviWriter(directory / "no_such_folder" / "x.avi", {10, 10}, 5.0), Error);
  std::filesystem::remove_all(directory);
}

// --- Files from other writers, built chunk by chunk ----------------------------------------

void Append(Bytes* bytes, const Bytes& more) {
  bytes->insert(bytes->end(), more.begin(), more.end());
}

void Put32(Bytes* bytes, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) bytes->push_back(static_cast<std::uint8_t>(value >> (8 * i)));
}

void PutText(Bytes* bytes, const char* text) { bytes->insert(bytes->end(), text, text + 4); }

Bytes Chunk(const char* id, const Bytes& data) {
  Bytes bytes;
  PutText(&bytes, id);
  Put32(&bytes, static_cast<std::uint32_t>(data.size()));
  Append(&bytes, data);
  if (data.size() & 1) bytes.push_back(0);
  return bytes;
}

Bytes List(const char* kind, const char* type, const std::vector<Bytes>& children) {
  Bytes data;
  PutText(&data, type);
  for (const Bytes& child : children) Append(&data, child);
  Bytes bytes;
  PutText(&bytes, kind);
  Put32(&bytes, static_cast<std::uint32_t>(data.size()));
  Append(&bytes, data);
  return bytes;
}

Bytes StreamHeader(const char* type, const char* handler, std::uint32_t scale, std::uint32_t rate) {
  Bytes data;
  PutText(&data, type);
  PutText(&data, handler);
  for (int i = 0; i < 3; ++i) Put32(&data, 0);  // flags, priority+language, initial frames
  Put32(&data, scale);
  Put32(&data, rate);
  for (int i = 0; i < 5; ++i) Put32(&data, 0);  // start, length, buffer, quality, sample size
  for (int i = 0; i < 2; ++i) Put32(&data, 0);  // rcFrame
  return Chunk("strh", data);
}

Bytes BitmapInfo(int width, int height, int bits, const char* compression, const Bytes& palette) {
  Bytes data;
  Put32(&data, 40);
  Put32(&data, static_cast<std::uint32_t>(width));
  Put32(&data, static_cast<std::uint32_t>(height));
  data.push_back(1);
  data.push_back(0);
  data.push_back(static_cast<std::uint8_t>(bits));
  data.push_back(0);
  if (compression == nullptr) {
    Put32(&data, 0);
  } else {
    PutText(&data, compression);
  }
  for (int i = 0; i < 3; ++i) Put32(&data, 0);  // biSizeImage, biXPelsPerMeter, biYPelsPerMeter
  Put32(&data, static_cast<std::uint32_t>(palette.size() / 4));
  Put32(&data, 0);
  Append(&data, palette);
  return Chunk("strf", data);
}

// hdrl with an audio stream first and the video stream second (chunk ids "01dc"/"01db").
Bytes HeaderList(const Bytes& video_format, const char* handler, std::uint32_t total_frames) {
  Bytes avih;
  Put32(&avih, 40000);  // 25 fps, overridden by strh
  for (int i = 0; i < 13; ++i) Put32(&avih, 0);
  Bytes wave;
  for (int i = 0; i < 4; ++i) Put32(&wave, 1);
  std::vector<Bytes> children = {
      Chunk("avih", avih),
      List("LIST", "strl", {StreamHeader("auds", "\0\0\0\0", 1, 8000), Chunk("strf", wave)}),
      List("LIST", "strl",
           {StreamHeader("vids", handler, 2, 25), video_format, Chunk("JUNK", Bytes(31, 0))})};
  if (total_frames > 0) {
    Bytes dmlh;
    Put32(&dmlh, total_frames);
    children.push_back(List("LIST", "odml", {Chunk("dmlh", dmlh)}));
  }
  return List("LIST", "hdrl", children);
}

Bytes Riff(const char* type, const std::vector<Bytes>& children) {
  return List("RIFF", type, children);
}

// 24-bit bottom-up rows padded to 4 bytes.
Bytes Dib24(const cv::Mat& image) {
  const int row_bytes = (image.cols * 3 + 3) / 4 * 4;
  Bytes bytes(static_cast<size_t>(row_bytes * image.rows), 0xEE);
  for (int y = 0; y < image.rows; ++y) {
    std::memcpy(&bytes[static_cast<size_t>((image.rows - 1 - y) * row_bytes)], image.ptr(y),
                static_cast<size_t>(image.cols * 3));
  }
  return bytes;
}

Bytes Dib8TopDown(const cv::Mat& indices) {
  const int row_bytes = (indices.cols + 3) / 4 * 4;
  Bytes bytes(static_cast<size_t>(row_bytes * indices.rows), 0);
  for (int y = 0; y < indices.rows; ++y) {
    std::memcpy(&bytes[static_cast<size_t>(y * row_bytes)], indices.ptr(y),
                static_cast<size_t>(indices.cols));
  }
  return bytes;
}

TEST(AviFile, ReadsUnindexedUncompressedFramesInRecListsBesideAudio) {
  const auto directory = TempDir("dib");
  const cv::Size size(13, 7);  // odd width: padded rows
  const auto frames = TestFrames(3, size, CV_8UC3);
  const Bytes audio(101, 0x55);
  const Bytes movi = List(
      "LIST", "movi",
      {Chunk("01db", Dib24(frames[0])), Chunk("00wb", audio),
       List("LIST", "rec ", {Chunk("00wb", audio), Chunk("01db", Dib24(frames[1]))}),
       Chunk("JUNK", Bytes(9, 0)), Chunk("ix01", Bytes(24, 0)), Chunk("01db", Dib24(frames[2]))});
  const Bytes file = Riff("AVI ", {HeaderList(BitmapInfo(13, 7, 24, nullptr, {}), "DIB ", 0),
                                   Chunk("JUNK", Bytes(17, 0)), movi});
  WriteBytes(directory / "dib.avi", file);
  const AviHeader header = ReadAviHeader(directory / "dib.avi");
  EXPECT_EQ(header.stream_number, 1);
  EXPECT_EQ(header.fourcc, "DIB ");
  EXPECT_TRUE(header.supported);
  EXPECT_FALSE(header.num_frames.has_value());
  EXPECT_DOUBLE_EQ(header.fps, 12.5);
  const ReadResult result = ReadAll(directory / "dib.avi");
  EXPECT_EQ(result.error, "");
  ASSERT_EQ(result.frames.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(cv::norm(result.frames[i], frames[i], cv::NORM_INF), 0.0) << i;
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, ReadsPalettedFramesAndRepeatsDroppedFrames) {
  const auto directory = TempDir("palette");
  cv::Mat indices(5, 6, CV_8UC1);
  cv::randu(indices, 0, 256);
  Bytes gray_palette;
  Bytes colour_palette;
  for (int i = 0; i < 256; ++i) {
    const auto level = static_cast<std::uint8_t>(255 - i);
    gray_palette.insert(gray_palette.end(), {level, level, level, 0});
    colour_palette.insert(colour_palette.end(), {static_cast<std::uint8_t>(i), 7, level, 0});
  }
  for (bool gray : {true, false}) {
    const Bytes movi = List("LIST", "movi",
                            {Chunk("01dc", Dib8TopDown(indices)), Chunk("01dc", {}),
                             Chunk("01dc", Dib8TopDown(255 - indices))});
    const Bytes format = BitmapInfo(6, -5, 8, nullptr, gray ? gray_palette : colour_palette);
    WriteBytes(directory / "palette.avi", Riff("AVI ", {HeaderList(format, "\0\0\0\0", 3), movi}));
    const ReadResult result = ReadAll(directory / "palette.avi");
    EXPECT_EQ(result.error, "");
    ASSERT_EQ(result.frames.size(), 3u);
    cv::Mat expected;
    if (gray) {
      expected = 255 - indices;
    } else {
      std::vector<cv::Mat> channels = {indices, cv::Mat(indices.size(), CV_8UC1, cv::Scalar(7)),
                                       255 - indices};
      cv::merge(channels, expected);
    }
    ASSERT_EQ(result.frames[0].type(), expected.type());
    EXPECT_EQ(cv::norm(result.frames[0], expected, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(result.frames[1], expected, cv::NORM_INF), 0.0);  // dropped: repeated
    EXPECT_GT(cv::norm(result.frames[2], expected, cv::NORM_INF), 0.0);
  }
  std::filesystem::remove_all(directory);
}

TEST(AviFile, ReadsOpenDmlContinuationsAndOtherJpegFourccs) {
  const auto directory = TempDir("opendml");
  const auto frames = TestFrames(4, {32, 24}, CV_8UC3);
  std::vector<Bytes> jpegs;
  for (const cv::Mat& frame : frames) {
    std::vector<std::uint8_t> jpeg;
    cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
    jpegs.push_back(jpeg);
  }
  Bytes file =
      Riff("AVI ", {HeaderList(BitmapInfo(32, 24, 24, "mjpg", {}), "mjpg", 4),
                    List("LIST", "movi", {Chunk("01dc", jpegs[0]), Chunk("01dc", jpegs[1])}),
                    Chunk("idx1", Bytes(32, 0))});
  Append(&file,
         Riff("AVIX", {Chunk("JUNK", Bytes(6, 0)),
                       List("LIST", "movi", {Chunk("01dc", jpegs[2]), Chunk("01dc", jpegs[3])})}));
  WriteBytes(directory / "opendml.avi", file);
  const AviHeader header = ReadAviHeader(directory / "opendml.avi");
  EXPECT_EQ(header.fourcc, "mjpg");
  ASSERT_TRUE(header.num_frames.has_value());
  EXPECT_EQ(*header.num_frames, 4);
  const ReadResult result = ReadAll(directory / "opendml.avi");
  EXPECT_EQ(result.error, "");
  ASSERT_EQ(result.frames.size(), 4u);
  for (size_t i = 0; i < 4; ++i) EXPECT_GT(Psnr(result.frames[i], frames[i]), 30.0) << i;
  std::filesystem::remove_all(directory);
}

TEST(AviFile, UnsupportedCodecNamesItAndTheBuildOption) {
  const auto directory = TempDir("h264");
  const Bytes file = Riff("AVI ", {HeaderList(BitmapInfo(32, 24, 24, "H264", {}), "H264", 0),
                                   List("LIST", "movi", {Chunk("01dc", Bytes(100, 1))})});
  WriteBytes(directory / "h264.avi", file);
  const AviHeader header = ReadAviHeader(directory / "h264.avi");
  EXPECT_FALSE(header.supported);
  EXPECT_EQ(header.fourcc, "H264");
  const ReadResult result = ReadAll(directory / "h264.avi");
  EXPECT_FALSE(result.opened);
  EXPECT_NE(result.error.find("'H264'"), std::string::npos) << result.error;
  if (!HasOpenCvVideoIo()) {
    EXPECT_NE(result.error.find("SILPOSE_WITH_VIDEOIO"), std::string::npos) << result.error;
  }
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace silpose

namespace silpose {
namespace {

TEST(AviFile, CorruptHeadersGiveErrors) {
  const auto directory = TempDir("headers");
  const Bytes movi = List("LIST", "movi", {Chunk("00dc", Bytes(10, 0))});
  Bytes tiny_header;
  PutText(&tiny_header, "LIST");
  Put32(&tiny_header, 2);
  PutText(&tiny_header, "hdrl");
  Bytes audio_only_format;
  for (int i = 0; i < 4; ++i) Put32(&audio_only_format, 1);
  const std::vector<std::pair<Bytes, std::string>> cases = {
      {Riff("AVI ", {tiny_header, movi}), "implausible size"},
      {Riff("AVI ", {List("LIST", "hdrl",
                          {List("LIST", "strl",
                                {StreamHeader("auds", "\0\0\0\0", 1, 8000),
                                 Chunk("strf", audio_only_format)})}),
                     movi}),
       "no video stream"},
      {Riff("AVI ",
            {List("LIST", "hdrl",
                  {List("LIST", "strl",
                        {StreamHeader("vids", "MJPG", 1, 25), Chunk("strf", Bytes(20, 0))})}),
             movi}),
       "'strf' too short"},
      {Riff("AVI ", {HeaderList(BitmapInfo(0, 10, 24, "MJPG", {}), "MJPG", 0), movi}),
       "frame size 0x10"},
      {Riff("AVI ", {HeaderList(BitmapInfo(8, 8, 24, "MJPG", {}), "MJPG", 0)}), "no 'movi' list"},
      {Riff("AVI ", {movi}), "no 'hdrl' header"},
  };
  for (const auto& [bytes, expected] : cases) {
    WriteBytes(directory / "bad.avi", bytes);
    const ReadResult result = ReadAll(directory / "bad.avi");
    EXPECT_FALSE(result.opened);
    EXPECT_NE(result.error.find("bad.avi: "), std::string::npos) << result.error;
    EXPECT_NE(result.error.find(expected), std::string::npos) << result.error;
  }
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace silpose
