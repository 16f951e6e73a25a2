#include "silpose/io/v4l2_camera.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "silpose/io/image_codec.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

class SystemDevice final : public V4l2Device {
 public:
  int Open(const std::string& path) override { return ::open(path.c_str(), O_RDWR | O_NONBLOCK); }
  int Close(int fd) override { return ::close(fd); }
  int Ioctl(int fd, unsigned long request, void* argument) override {
    int result;
    do {
      result = ::ioctl(fd, request, argument);
    } while (result == -1 && errno == EINTR);
    return result;
  }
  void* Map(size_t length, int fd, off_t offset) override {
    return ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
  }
  int Unmap(void* address, size_t length) override { return ::munmap(address, length); }
  int WaitReadable(int fd, int timeout_ms) override {
    pollfd entry{fd, POLLIN, 0};
    int result;
    do {
      result = ::poll(&entry, 1, timeout_ms);
    } while (result == -1 && errno == EINTR);
    return result;
  }
};

std::string FourCc(unsigned int code) {
  std::string text(4, ' ');
  for (int i = 0; i < 4; ++i)
    text[static_cast<size_t>(i)] = static_cast<char>((code >> (8 * i)) & 0xff);
  return text;
}

}  // namespace

V4l2Device::~V4l2Device() = default;

std::shared_ptr<V4l2Device> SystemV4l2Device() { return std::make_shared<SystemDevice>(); }

V4l2CameraSource::V4l2CameraSource(std::string path, FrameColor color, const V4l2Options& options,
                                   std::shared_ptr<V4l2Device> device)
    : FrameSource(color), path_(std::move(path)), device_(std::move(device)) {
  SILPOSE_ASSERT(device_ != nullptr);
  if (options.width < 1 || options.height < 1 || options.buffers < 2 || options.buffers > 32 ||
      !(options.fps >= 0.0) || options.timeout_ms < 1) {
    ThrowError(path_, ": invalid camera options (size ", options.width, "x", options.height, ", ",
               options.buffers, " buffers, ", options.fps, " frames/s, timeout ",
               options.timeout_ms, " ms)");
  }
  timeout_ms_ = options.timeout_ms;
  fd_ = device_->Open(path_);
  if (fd_ < 0) Fail("cannot open the camera", errno);
  try {
    Start(options);
  } catch (...) {
    Stop();
    throw;
  }
}

V4l2CameraSource::~V4l2CameraSource() { Stop(); }

std::string V4l2CameraSource::name() const { return path_ + "#" + std::to_string(frame_index()); }

void V4l2CameraSource::Fail(const std::string& what, int error_number) const {
  ThrowError(
      path_, ": ", what,
      error_number != 0 ? " (" + std::string(std::strerror(error_number)) + ")" : std::string());
}

void V4l2CameraSource::Start(const V4l2Options& options) {
  v4l2_capability capability{};
  if (device_->Ioctl(fd_, VIDIOC_QUERYCAP, &capability) != 0) {
    Fail("not a Video4Linux2 device", errno);
  }
  const unsigned int caps = (capability.capabilities & V4L2_CAP_DEVICE_CAPS) != 0
                                ? capability.device_caps
                                : capability.capabilities;
  if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0) Fail("not a video capture device", 0);
  if ((caps & V4L2_CAP_STREAMING) == 0) Fail("the camera does not support streaming I/O", 0);

  // MJPEG first (less bandwidth, larger sizes at full rate), else YUYV.
  std::string offered;
  for (const unsigned int wanted : {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV}) {
    v4l2_format format{};
    format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    format.fmt.pix.width = static_cast<unsigned int>(options.width);
    format.fmt.pix.height = static_cast<unsigned int>(options.height);
    format.fmt.pix.pixelformat = wanted;
    format.fmt.pix.field = V4L2_FIELD_ANY;
    if (device_->Ioctl(fd_, VIDIOC_S_FMT, &format) != 0) {
      if (errno == EBUSY) Fail("the camera is in use by another program", errno);
      continue;
    }
    offered += (offered.empty() ? "" : ", ") + FourCc(format.fmt.pix.pixelformat);
    if (format.fmt.pix.pixelformat != wanted) continue;
    pixel_format_ = wanted;
    format_name_ = FourCc(wanted);
    size_ =
        cv::Size(static_cast<int>(format.fmt.pix.width), static_cast<int>(format.fmt.pix.height));
    bytes_per_line_ = format.fmt.pix.bytesperline != 0 ? format.fmt.pix.bytesperline
                                                       : static_cast<size_t>(2 * size_.width);
    break;
  }
  if (pixel_format_ == 0) {
    Fail("the camera offers neither MJPEG nor YUYV frames (it answered " +
             (offered.empty() ? std::string("nothing") : offered) + ")",
         0);
  }
  if (size_.width < 1 || size_.height < 1 ||
      (pixel_format_ == V4L2_PIX_FMT_YUYV &&
       bytes_per_line_ < static_cast<size_t>(2 * size_.width))) {
    Fail("the camera reports an invalid frame size", 0);
  }

  v4l2_streamparm parameters{};
  parameters.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (options.fps > 0.0) {
    parameters.parm.capture.timeperframe.numerator = 1000;
    parameters.parm.capture.timeperframe.denominator =
        static_cast<unsigned int>(std::lround(options.fps * 1000.0));
    device_->Ioctl(fd_, VIDIOC_S_PARM, &parameters);  // a camera may keep its own rate
  }
  parameters = {};
  parameters.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (device_->Ioctl(fd_, VIDIOC_G_PARM, &parameters) == 0 &&
      parameters.parm.capture.timeperframe.numerator != 0) {
    fps_ = double(parameters.parm.capture.timeperframe.denominator) /
           parameters.parm.capture.timeperframe.numerator;
  }

  v4l2_requestbuffers request{};
  request.count = static_cast<unsigned int>(options.buffers);
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (device_->Ioctl(fd_, VIDIOC_REQBUFS, &request) != 0) {
    Fail("the camera refuses memory-mapped buffers", errno);
  }
  if (request.count < 2) Fail("the camera grants fewer than 2 buffers", 0);
  for (unsigned int i = 0; i < request.count; ++i) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = i;
    if (device_->Ioctl(fd_, VIDIOC_QUERYBUF, &buffer) != 0) Fail("cannot query a buffer", errno);
    void* start = device_->Map(buffer.length, fd_, static_cast<off_t>(buffer.m.offset));
    if (start == MAP_FAILED) Fail("cannot map a buffer", errno);
    buffers_.push_back({start, buffer.length});
    if (device_->Ioctl(fd_, VIDIOC_QBUF, &buffer) != 0) Fail("cannot queue a buffer", errno);
  }
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (device_->Ioctl(fd_, VIDIOC_STREAMON, &type) != 0) Fail("cannot start streaming", errno);
  streaming_ = true;
}

void V4l2CameraSource::Stop() {
  if (fd_ < 0) return;
  if (streaming_) {
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    device_->Ioctl(fd_, VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  for (const Buffer& buffer : buffers_) device_->Unmap(buffer.start, buffer.length);
  buffers_.clear();
  device_->Close(fd_);
  fd_ = -1;
}

bool V4l2CameraSource::ReadNext(cv::Mat* frame) {
  const int index = frame_index() + 1;
  const std::string at = "frame " + std::to_string(index) + ": ";
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  while (true) {
    const int ready = device_->WaitReadable(fd_, timeout_ms_);
    if (ready < 0) Fail(at + "waiting for the camera failed", errno);
    if (ready == 0) {
      Fail(at + "no frame from the camera within " + std::to_string(timeout_ms_) + " ms", 0);
    }
    if (device_->Ioctl(fd_, VIDIOC_DQBUF, &buffer) == 0) break;
    if (errno != EAGAIN) Fail(at + "cannot take a frame from the camera", errno);
  }
  if (buffer.index >= buffers_.size() || buffer.bytesused > buffers_[buffer.index].length) {
    Fail(at + "the camera returned an invalid buffer", 0);
  }
  const Buffer& mapped = buffers_[buffer.index];
  cv::Mat decoded;
  bool corrupt = (buffer.flags & V4L2_BUF_FLAG_ERROR) != 0 || buffer.bytesused == 0;
  if (!corrupt && pixel_format_ == V4L2_PIX_FMT_MJPEG) {
    const std::span<const uint8_t> bytes(static_cast<const uint8_t*>(mapped.start),
                                         buffer.bytesused);
    try {
      decoded = DecodeImage(bytes,
                            color() == FrameColor::kGray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
    } catch (const cv::Exception&) {
      decoded.release();  // a damaged frame: counted below like an empty one
    }
    corrupt = decoded.empty() || decoded.size() != size_;
  } else if (!corrupt) {
    const size_t needed = bytes_per_line_ * static_cast<size_t>(size_.height);
    corrupt = buffer.bytesused < needed || mapped.length < needed;
    if (!corrupt) {
      const cv::Mat yuyv(size_, CV_8UC2, mapped.start, bytes_per_line_);
      cv::cvtColor(yuyv, decoded,
                   color() == FrameColor::kGray ? cv::COLOR_YUV2GRAY_YUYV : cv::COLOR_YUV2BGR_YUYV);
    }
  }
  // The buffer goes back to the camera before any error: a bad frame does not stall it.
  const int requeued = device_->Ioctl(fd_, VIDIOC_QBUF, &buffer);
  const int requeue_error = errno;
  if (corrupt) Fail(at + "the camera delivered a corrupt " + format_name_ + " frame", 0);
  if (requeued != 0) Fail(at + "cannot give a buffer back to the camera", requeue_error);
  *frame = decoded;
  ++frames_read_;
  return true;
}

}  // namespace silpose
