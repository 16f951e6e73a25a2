#pragma once
// Writing frame sequences as video files, e.g. `silpose track --overlay OUT.avi`. The default build
// writes AVI files itself (MJPEG or lossless PNG frames, see AviWriter in avi_file.h); other
// containers (.mp4, .mkv, ...) need a build with -DSILPOSE_WITH_VIDEOIO=ON (OpenCV videoio, whose
// FFmpeg is GPL in Debian).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

namespace silpose {

/// How an AVI file stores its frames.
enum class AviCodec {
  kMjpeg,  ///< JPEG per frame (fourcc 'MJPG'): small, lossy; what most players read.
  kPng,    ///< PNG per frame (fourcc 'MPNG'): lossless, e.g. for mask sequences.
};

/// The largest AVI 1.0 file: its RIFF sizes are 32-bit.
inline constexpr std::uint64_t kAviMaxFileBytes = 0xFFFFFFFFull;

struct VideoWriterOptions {
  /// Frame coding in .avi files.
  AviCodec avi_codec = AviCodec::kMjpeg;
  /// JPEG quality for kMjpeg, 1..100.
  int jpeg_quality = 90;
  /// zlib level for kPng, 0 (fastest) .. 9 (smallest).
  int png_compression = 1;
  /// Size limit of .avi files in bytes, at most kAviMaxFileBytes (a smaller one is for tests).
  std::uint64_t avi_max_file_bytes = kAviMaxFileBytes;
  /// Four-character code for OpenCV videoio writers (.mp4, .mkv, ...): "mp4v" is MPEG-4 part 2.
  std::string opencv_fourcc = "mp4v";

  /// Throws silpose::Error naming the first invalid field.
  void Check() const;
};

/// Writes frames of one size to a video file. Frames are CV_8UC1 (grey) or CV_8UC3 (BGR); both may
/// be mixed. Not thread-safe.
class VideoWriter {
 public:
  virtual ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// Appends one frame of size() pixels. Throws silpose::Error (naming the file) for a frame of
  /// another size or type, a write failure, or a file that would exceed its format's size limit;
  /// the frames written before stay readable after Close().
  virtual void Write(const cv::Mat& frame) = 0;
  /// Finishes the file (index, sizes) and closes it; throws silpose::Error if that fails. Called by
  /// the destructor if not before (which then ignores errors). Write() after Close() is an error.
  virtual void Close() = 0;
  /// Frames written so far.
  virtual int num_frames() const = 0;

  const std::filesystem::path& path() const { return path_; }
  cv::Size size() const { return size_; }
  double fps() const { return fps_; }

 protected:
  VideoWriter(std::filesystem::path path, cv::Size size, double fps);

 private:
  std::filesystem::path path_;
  cv::Size size_;
  double fps_;
};

/// Opens a video file for writing, by extension (any case): .avi is written by silpose's AviWriter
/// (options.avi_codec); .mp4, .mkv, .mov and others go to OpenCV videoio in a build with
/// SILPOSE_WITH_VIDEOIO, and are an Error suggesting .avi otherwise. `size` in pixels (both > 0),
/// `fps` > 0. Overwrites an existing file. Throws silpose::Error naming the file.
std::unique_ptr<VideoWriter> OpenVideoWriter(const std::filesystem::path& path, cv::Size size,
                                             double fps, const VideoWriterOptions& options = {});

}  // namespace silpose
