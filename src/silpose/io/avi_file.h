#pragma once
// AVI files read and written by silpose itself, so that the default build needs no video library
// (OpenCV videoio links Debian's GPL FFmpeg). JPEG and PNG coding is OpenCV imgcodecs
// (libjpeg-turbo, libpng).
//
// Reading: an AVI 1.0 RIFF file and its OpenDML 'AVIX' continuations, from any writer (ffmpeg
// `-c:v mjpeg` or `-c:v png`, OpenCV, cameras), whose first video stream holds
//  - JPEG frames: fourcc MJPG, JPEG, AVRn or dmb1 (any case); Huffman tables may be omitted;
//  - PNG frames: fourcc MPNG, PNG1 or "PNG ";
//  - uncompressed frames (BI_RGB, fourcc "DIB "): 24-bit BGR, 32-bit BGRx, or 8-bit with a palette
//    (grey palettes give CV_8UC1).
// The frames are found by walking the 'movi' lists (including 'rec ' lists); the 'idx1' index is
// used only to count the frames, so unindexed and truncated files read up to their last complete
// frame. Zero-length frame chunks (dropped frames) repeat the previous frame. Interlaced
// (two-field) MJPEG is not supported.
//
// Writing: AVI 1.0 with avih/strh/strf headers, one video stream, a 'movi' list and an 'idx1'
// index; at most 4 GiB (VideoWriterOptions::avi_max_file_bytes).

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "silpose/io/frame_source.h"
#include "silpose/io/video_writer.h"

namespace silpose {

/// What the headers of an AVI file say about its first video stream.
struct AviHeader {
  /// Frame size in pixels (strf biWidth x |biHeight|).
  cv::Size frame_size;
  /// Frames per second (strh dwRate / dwScale, else avih), 0 if neither is set.
  double fps = 0.0;
  /// The stream's four-character code: strf biCompression, "DIB " for uncompressed (BI_RGB).
  std::string fourcc;
  /// strf biBitCount.
  int bits_per_pixel = 0;
  /// Frame count from the OpenDML header, else from the idx1 index; std::nullopt if the file has
  /// neither (e.g. it was not finished).
  std::optional<int> num_frames;
  /// Number of the stream among the file's streams (chunk ids "NNdc"/"NNdb").
  int stream_number = 0;
  /// True if AviReader decodes this stream's frames (codecs listed at the top of avi_file.h).
  bool supported = false;
};

/// Reads the headers of an AVI file. Throws silpose::Error naming the file if it is missing, not
/// an AVI file, has no video stream, or its headers are truncated or inconsistent.
AviHeader ReadAviHeader(const std::filesystem::path& path);

/// Reads the frames of an AVI file (see the top of this file for what it reads).
class AviReader final : public FrameSource {
 public:
  /// Opens the file and reads its headers. Throws silpose::Error naming the file as
  /// ReadAviHeader does, and for a codec it does not decode (naming the fourcc and the
  /// SILPOSE_WITH_VIDEOIO option that reads it through OpenCV).
  explicit AviReader(const std::filesystem::path& path, FrameColor color = FrameColor::kAsStored);
  ~AviReader() override;

  const AviHeader& header() const { return header_; }
  std::optional<int> num_frames() const override { return header_.num_frames; }
  double fps() const override { return header_.fps; }
  cv::Size size() const override { return header_.frame_size; }
  /// "<file name>#<frame_index>".
  std::string name() const override;

 protected:
  bool ReadNext(cv::Mat* frame) override;

 private:
  [[noreturn]] void Fail(const std::string& problem) const;
  bool NextFrameChunk(std::uint32_t* size);
  void DecodeDib(cv::Mat* frame) const;

  std::filesystem::path path_;
  std::ifstream file_;
  std::uint64_t file_size_ = 0;
  AviHeader header_;
  std::vector<cv::Vec3b> palette_;  // BGR palette of 8-bit uncompressed frames
  bool gray_palette_ = false;
  int dib_row_bytes_ = 0;
  bool dib_bottom_up_ = true;
  // Movi walk: the current position and the ends of the enclosing lists (innermost last).
  std::uint64_t position_ = 0;
  std::vector<std::uint64_t> list_ends_;
  std::uint64_t riff_end_ = 0;  // end of the current RIFF chunk, where an 'AVIX' may follow
  std::vector<std::uint8_t> payload_;
  cv::Mat previous_;
};

/// Writes an AVI 1.0 file with one video stream of MJPEG or PNG frames. The file is written as
/// frames come; Close() (or the destructor) appends the index and fixes the header sizes, so a file
/// cut short by a crash still reads up to its last complete frame.
class AviWriter final : public VideoWriter {
 public:
  /// Creates (or overwrites) `path`. `size` in pixels (both in 1..65535), `fps` > 0. Throws
  /// silpose::Error naming the file for invalid arguments or if it cannot be created.
  AviWriter(const std::filesystem::path& path, cv::Size size, double fps,
            const VideoWriterOptions& options = {});
  ~AviWriter() override;

  void Write(const cv::Mat& frame) override;
  void Close() override;
  int num_frames() const override { return static_cast<int>(chunk_sizes_.size()); }

 private:
  [[noreturn]] void Fail(const std::string& problem) const;

  VideoWriterOptions options_;
  std::ofstream file_;
  bool closed_ = false;
  std::uint64_t position_ = 0;            // bytes written
  std::uint64_t movi_fourcc_offset_ = 0;  // idx1 offsets count from the 'movi' fourcc
  std::vector<std::uint32_t> chunk_sizes_;
  std::vector<std::uint32_t> chunk_offsets_;
  std::uint32_t largest_chunk_ = 0;
  std::vector<std::uint8_t> encoded_;
};

}  // namespace silpose
