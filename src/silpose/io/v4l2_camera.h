#pragma once
// Live cameras on Linux through Video4Linux2 (the kernel's camera interface), in every build: no
// OpenCV videoio, no FFmpeg. The camera is asked for MJPEG (decoded with OpenCV imgcodecs) or, if
// it does not offer MJPEG, YUYV 4:2:2 (converted with OpenCV imgproc), streamed through
// memory-mapped buffers. `silpose track -d parts.db /dev/video0` (or `0` in a build without
// OpenCV videoio) reads one.
//
// The system calls (open, ioctl, mmap, poll, ...) go through V4l2Device, so that a test can drive
// V4l2CameraSource with a simulated camera; SystemV4l2Device() is the real one.

#include <sys/types.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "silpose/io/frame_source.h"

namespace silpose {

/// The system calls a V4L2 capture makes. Return values and errno follow the POSIX calls.
class V4l2Device {
 public:
  virtual ~V4l2Device();
  /// open(path, O_RDWR | O_NONBLOCK): a file descriptor, or -1 with errno set.
  virtual int Open(const std::string& path) = 0;
  virtual int Close(int fd) = 0;
  /// ioctl(fd, request, argument): 0 or -1 with errno set.
  virtual int Ioctl(int fd, unsigned long request, void* argument) = 0;
  /// mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset): the mapping or
  /// MAP_FAILED with errno set.
  virtual void* Map(size_t length, int fd, off_t offset) = 0;
  virtual int Unmap(void* address, size_t length) = 0;
  /// poll() for input on fd: > 0 ready, 0 timed out, -1 with errno set.
  virtual int WaitReadable(int fd, int timeout_ms) = 0;
};

/// The real system calls.
std::shared_ptr<V4l2Device> SystemV4l2Device();

struct V4l2Options {
  /// Frame size asked for; the camera may choose the nearest it supports (size() says which).
  int width = 640;
  int height = 480;
  /// Frame rate asked for (0 = the camera's current one).
  double fps = 30.0;
  /// Memory-mapped buffers, in [2, 32].
  int buffers = 4;
  /// A frame not delivered within this many milliseconds is an error.
  int timeout_ms = 5000;
};

/// Frames of a V4L2 capture device ("/dev/video0"), BGR (or grey, by FrameColor), until the
/// camera stops delivering (an error naming the device). num_frames() is unknown.
class V4l2CameraSource final : public FrameSource {
 public:
  /// Opens and starts the camera. Throws silpose::Error naming `path` if it cannot be opened, is
  /// not a video capture device with streaming I/O, offers neither MJPEG nor YUYV, or refuses the
  /// buffers.
  V4l2CameraSource(std::string path, FrameColor color = FrameColor::kAsStored,
                   const V4l2Options& options = {},
                   std::shared_ptr<V4l2Device> device = SystemV4l2Device());
  ~V4l2CameraSource() override;

  std::optional<int> num_frames() const override { return std::nullopt; }
  double fps() const override { return fps_; }
  cv::Size size() const override { return size_; }
  std::string name() const override;
  /// "MJPG" or "YUYV": the pixel format the camera delivers.
  const std::string& pixel_format() const { return format_name_; }

 protected:
  bool ReadNext(cv::Mat* frame) override;

 private:
  struct Buffer {
    void* start = nullptr;
    size_t length = 0;
  };
  void Start(const V4l2Options& options);
  void Stop();
  [[noreturn]] void Fail(const std::string& what, int error_number) const;

  std::string path_;
  std::shared_ptr<V4l2Device> device_;
  int fd_ = -1;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  unsigned int pixel_format_ = 0;
  std::string format_name_;
  size_t bytes_per_line_ = 0;
  cv::Size size_;
  double fps_ = 0.0;
  int timeout_ms_ = 5000;
  int frames_read_ = 0;
};

}  // namespace silpose
