#include "silpose/io/video_writer.h"

#include <algorithm>
#include <cctype>
#include <utility>

#include "silpose/io/avi_file.h"
#include "silpose/util/error.h"

#if SILPOSE_WITH_VIDEOIO
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#endif

namespace silpose {
namespace {

#if SILPOSE_WITH_VIDEOIO
// Containers other than AVI through OpenCV videoio (FFmpeg).
class OpenCvVideoWriter final : public VideoWriter {
 public:
  OpenCvVideoWriter(const std::filesystem::path& path, cv::Size size, double fps,
                    const VideoWriterOptions& options)
      : VideoWriter(path, size, fps) {
    const std::string& code = options.opencv_fourcc;
    const int fourcc = cv::VideoWriter::fourcc(code[0], code[1], code[2], code[3]);
    try {
      writer_.open(path.string(), cv::CAP_ANY, fourcc, fps, size, true);
    } catch (const cv::Exception& exception) {
      ThrowError(path.string(), ": cannot open for writing (", exception.msg, ")");
    }
    if (!writer_.isOpened()) {
      ThrowError(path.string(), ": OpenCV videoio cannot write this file with codec '", code,
                 "' (unknown container or codec, or no permission); .avi always works");
    }
  }
  ~OpenCvVideoWriter() override {
    try {
      Close();
    } catch (...) {
      // A destructor must not throw; Close() explicitly to see the error.
    }
  }

  void Write(const cv::Mat& frame) override {
    const std::string label = path().string() + ": frame " + std::to_string(frames_) + ": ";
    if (closed_) ThrowError(label, "write after Close()");
    if (frame.type() != CV_8UC1 && frame.type() != CV_8UC3) {
      ThrowError(label, "type must be CV_8UC1 or CV_8UC3");
    }
    if (frame.size() != size()) {
      ThrowError(label, "is ", frame.cols, "x", frame.rows, " pixels, but the video's frames are ",
                 size().width, "x", size().height);
    }
    try {
      if (frame.channels() == 1) {
        cv::cvtColor(frame, colour_, cv::COLOR_GRAY2BGR);
        writer_.write(colour_);
      } else {
        writer_.write(frame);
      }
    } catch (const cv::Exception& exception) {
      ThrowError(label, "cannot write (", exception.msg, ")");
    }
    ++frames_;
  }

  void Close() override {
    if (closed_) return;
    closed_ = true;
    try {
      writer_.release();
    } catch (const cv::Exception& exception) {
      ThrowError(path().string(), ": cannot finish writing (", exception.msg, ")");
    }
  }

  int num_frames() const override { return frames_; }

 private:
  cv::VideoWriter writer_;
  cv::Mat colour_;
  int frames_ = 0;
  bool closed_ = false;
};
#endif

}  // namespace

void VideoWriterOptions::Check() const {
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    ThrowError("video writer: jpeg_quality must be in 1..100, got ", jpeg_quality);
  }
  if (png_compression < 0 || png_compression > 9) {
    ThrowError("video writer: png_compression must be in 0..9, got ", png_compression);
  }
  if (avi_max_file_bytes > kAviMaxFileBytes) {
    ThrowError("video writer: avi_max_file_bytes must be at most ", kAviMaxFileBytes, ", got ",
               avi_max_file_bytes);
  }
  if (opencv_fourcc.size() != 4) {
    ThrowError("video writer: opencv_fourcc must have 4 characters, got '", opencv_fourcc, "'");
  }
}

VideoWriter::VideoWriter(std::filesystem::path path, cv::Size size, double fps)
    : path_(std::move(path)), size_(size), fps_(fps) {}

VideoWriter::~VideoWriter() = default;

std::unique_ptr<VideoWriter> OpenVideoWriter(const std::filesystem::path& path, cv::Size size,
                                             double fps, const VideoWriterOptions& options) {
  options.Check();
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".avi") return std::make_unique<AviWriter>(path, size, fps, options);
#if SILPOSE_WITH_VIDEOIO
  if (size.width < 1 || size.height < 1) {
    ThrowError(path.string(), ": invalid frame size ", size.width, "x", size.height);
  }
  if (!(fps > 0)) ThrowError(path.string(), ": invalid frame rate ", fps, " (frames per second)");
  return std::make_unique<OpenCvVideoWriter>(path, size, fps, options);
#else
  ThrowError(path.string(), ": writing '", extension.empty() ? "(no extension)" : extension,
             "' videos needs a build with -DSILPOSE_WITH_VIDEOIO=ON (OpenCV videoio; Debian's "
             "FFmpeg is GPL); use .avi (MJPEG, or lossless PNG frames) instead");
#endif
}

}  // namespace silpose
