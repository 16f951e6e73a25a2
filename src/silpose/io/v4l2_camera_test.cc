#include "silpose/io/v4l2_camera.h"

#include <gtest/gtest.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr size_t kPage = 4096;

// A simulated camera at "/dev/fake": offers `formats`, delivers `frames` (as JPEG or YUYV bytes,
// or `raw` bytes as they are), then reports that it was unplugged.
class FakeCamera final : public V4l2Device {
 public:
  std::vector<unsigned int> formats = {V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV};
  unsigned int caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
  int width = 64, height = 48;
  size_t padding = 0;                   // YUYV: bytes after each row
  std::vector<cv::Mat> frames;          // BGR, or CV_8UC2 YUYV for that format
  std::vector<std::vector<uchar>> raw;  // if not empty: delivered instead of frames
  bool never_ready = false;

  // What the source did.
  bool opened = false, closed = false, streaming = false;
  int mapped = 0, unmapped = 0, delivered = 0;
  unsigned int format = 0;

  int Open(const std::string& path) override {
    if (path != "/dev/fake") {
      errno = ENOENT;
      return -1;
    }
    opened = true;
    return 7;
  }
  int Close(int fd) override {
    EXPECT_EQ(fd, 7);
    closed = true;
    return 0;
  }
  int Ioctl(int fd, unsigned long request, void* argument) override {
    EXPECT_EQ(fd, 7);
    switch (request) {
      case VIDIOC_QUERYCAP: {
        auto* capability = static_cast<v4l2_capability*>(argument);
        capability->capabilities = caps | V4L2_CAP_DEVICE_CAPS;
        capability->device_caps = caps;
        return 0;
      }
      case VIDIOC_S_FMT: {
        auto* f = static_cast<v4l2_format*>(argument);
        const unsigned int wanted = f->fmt.pix.pixelformat;
        format = std::find(formats.begin(), formats.end(), wanted) != formats.end() ? wanted
                                                                                    : formats[0];
        f->fmt.pix.pixelformat = format;
        f->fmt.pix.width = static_cast<unsigned int>(width);
        f->fmt.pix.height = static_cast<unsigned int>(height);
        f->fmt.pix.bytesperline =
            format == V4L2_PIX_FMT_YUYV ? static_cast<unsigned int>(2 * width + padding) : 0;
        return 0;
      }
      case VIDIOC_S_PARM:
        return 0;
      case VIDIOC_G_PARM: {
        auto* parameters = static_cast<v4l2_streamparm*>(argument);
        parameters->parm.capture.timeperframe = {1, 25};
        return 0;
      }
      case VIDIOC_REQBUFS: {
        auto* request_buffers = static_cast<v4l2_requestbuffers*>(argument);
        EXPECT_EQ(request_buffers->memory, V4L2_MEMORY_MMAP);
        buffers_.assign(request_buffers->count, std::vector<uchar>(kPage * 8));
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* buffer = static_cast<v4l2_buffer*>(argument);
        buffer->length = static_cast<unsigned int>(buffers_.at(buffer->index).size());
        buffer->m.offset = static_cast<unsigned int>(buffer->index * kPage);
        return 0;
      }
      case VIDIOC_QBUF:
        queued_.push_back(static_cast<v4l2_buffer*>(argument)->index);
        return 0;
      case VIDIOC_DQBUF: {
        const size_t total = raw.empty() ? frames.size() : raw.size();
        if (static_cast<size_t>(delivered) >= total) {
          errno = ENODEV;  // unplugged
          return -1;
        }
        if (queued_.empty()) {
          errno = EAGAIN;
          return -1;
        }
        auto* buffer = static_cast<v4l2_buffer*>(argument);
        buffer->index = queued_.front();
        queued_.pop_front();
        const std::vector<uchar> bytes = Bytes(static_cast<size_t>(delivered));
        std::vector<uchar>& target = buffers_[buffer->index];
        EXPECT_LE(bytes.size(), target.size());
        std::copy(bytes.begin(), bytes.end(), target.begin());
        buffer->bytesused = static_cast<unsigned int>(bytes.size());
        ++delivered;
        return 0;
      }
      case VIDIOC_STREAMON:
        streaming = true;
        return 0;
      case VIDIOC_STREAMOFF:
        streaming = false;
        return 0;
    }
    errno = ENOTTY;
    return -1;
  }
  void* Map(size_t length, int, off_t offset) override {
    const size_t index = static_cast<size_t>(offset) / kPage;
    if (index >= buffers_.size() || length != buffers_[index].size()) {
      errno = EINVAL;
      return MAP_FAILED;
    }
    ++mapped;
    return buffers_[index].data();
  }
  int Unmap(void*, size_t) override {
    ++unmapped;
    return 0;
  }
  int WaitReadable(int, int) override { return never_ready ? 0 : 1; }

 private:
  std::vector<uchar> Bytes(size_t index) const {
    if (!raw.empty()) return raw[index];
    std::vector<uchar> bytes;
    if (format == V4L2_PIX_FMT_MJPEG) {
      cv::imencode(".jpg", frames[index], bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
    } else {
      const cv::Mat& yuyv = frames[index];
      for (int y = 0; y < yuyv.rows; ++y) {
        const uchar* row = yuyv.ptr<uchar>(y);
        bytes.insert(bytes.end(), row, row + 2 * yuyv.cols);
        bytes.insert(bytes.end(), padding, 0xAB);
      }
    }
    return bytes;
  }

  std::vector<std::vector<uchar>> buffers_;
  std::deque<unsigned int> queued_;
};

std::string ErrorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

cv::Mat Gradient(int width, int height, int shift) {
  cv::Mat image(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uchar>(3 * x + shift), static_cast<uchar>(4 * y),
                    static_cast<uchar>(200 - shift));
    }
  }
  return image;
}

TEST(V4l2CameraTest, MjpegFramesAreDecodedInOrderUntilTheCameraStops) {
  auto camera = std::make_shared<FakeCamera>();
  for (int i = 0; i < 3; ++i) camera->frames.push_back(Gradient(64, 48, 20 * i));
  {
    V4l2CameraSource source("/dev/fake", FrameColor::kAsStored, {}, camera);
    EXPECT_EQ(source.pixel_format(), "MJPG");
    EXPECT_EQ(source.size(), cv::Size(64, 48));
    EXPECT_DOUBLE_EQ(source.fps(), 25.0);
    EXPECT_FALSE(source.num_frames().has_value());
    EXPECT_TRUE(camera->streaming);
    EXPECT_EQ(camera->mapped, 4);
    cv::Mat frame;
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(source.Read(&frame)) << i;
      ASSERT_EQ(frame.type(), CV_8UC3);
      EXPECT_LT(cv::norm(frame, camera->frames[static_cast<size_t>(i)], cv::NORM_L1) /
                    static_cast<double>(frame.total()),
                6.0)
          << "frame " << i << " differs from what the camera sent";
      EXPECT_EQ(source.name(), "/dev/fake#" + std::to_string(i));
    }
    // Unplugged: one error naming the device and the frame.
    const std::string error = ErrorOf([&] { source.Read(&frame); });
    EXPECT_NE(error.find("/dev/fake"), std::string::npos) << error;
    EXPECT_NE(error.find("frame 3"), std::string::npos) << error;
    EXPECT_FALSE(source.Read(&frame));
  }
  EXPECT_FALSE(camera->streaming);
  EXPECT_EQ(camera->unmapped, 4);
  EXPECT_TRUE(camera->closed);
}

TEST(V4l2CameraTest, YuyvWithRowPaddingIsConvertedToBgrAndGrey) {
  for (const FrameColor color : {FrameColor::kAsStored, FrameColor::kGray}) {
    auto camera = std::make_shared<FakeCamera>();
    camera->formats = {V4L2_PIX_FMT_YUYV};
    camera->padding = 16;
    // Pure red in BT.601 video range: Y 81, U 90, V 240.
    cv::Mat yuyv(48, 64, CV_8UC2);
    for (int y = 0; y < yuyv.rows; ++y) {
      for (int x = 0; x < yuyv.cols; ++x) {
        yuyv.at<cv::Vec2b>(y, x) = cv::Vec2b(81, x % 2 == 0 ? 90 : 240);
      }
    }
    camera->frames = {yuyv, yuyv};
    V4l2CameraSource source("/dev/fake", color, {}, camera);
    EXPECT_EQ(source.pixel_format(), "YUYV");
    cv::Mat frame;
    ASSERT_TRUE(source.Read(&frame));
    ASSERT_TRUE(source.Read(&frame));
    if (color == FrameColor::kGray) {
      ASSERT_EQ(frame.type(), CV_8UC1);
      EXPECT_EQ(cv::mean(frame)[0], 81.0);  // the luma channel as it is
    } else {
      ASSERT_EQ(frame.type(), CV_8UC3);
      const cv::Scalar mean = cv::mean(frame);
      EXPECT_LT(mean[0], 5.0);
      EXPECT_LT(mean[1], 5.0);
      EXPECT_GT(mean[2], 245.0);
    }
  }
}

TEST(V4l2CameraTest, UnusableDevicesAreRefusedNamingTheDevice) {
  auto missing = std::make_shared<FakeCamera>();
  std::string error =
      ErrorOf([&] { V4l2CameraSource("/dev/missing", FrameColor::kBgr, {}, missing); });
  EXPECT_NE(error.find("/dev/missing: cannot open the camera"), std::string::npos) << error;

  auto output_only = std::make_shared<FakeCamera>();
  output_only->caps = V4L2_CAP_VIDEO_OUTPUT | V4L2_CAP_STREAMING;
  error = ErrorOf([&] { V4l2CameraSource("/dev/fake", FrameColor::kBgr, {}, output_only); });
  EXPECT_NE(error.find("/dev/fake: not a video capture device"), std::string::npos) << error;
  EXPECT_TRUE(output_only->closed);

  auto grey_only = std::make_shared<FakeCamera>();
  grey_only->formats = {V4L2_PIX_FMT_GREY};
  error = ErrorOf([&] { V4l2CameraSource("/dev/fake", FrameColor::kBgr, {}, grey_only); });
  EXPECT_NE(error.find("neither MJPEG nor YUYV"), std::string::npos) << error;
  EXPECT_NE(error.find("GREY"), std::string::npos) << error;
  EXPECT_TRUE(grey_only->closed);

  auto camera = std::make_shared<FakeCamera>();
  V4l2Options options;
  options.buffers = 1;
  error = ErrorOf([&] { V4l2CameraSource("/dev/fake", FrameColor::kBgr, options, camera); });
  EXPECT_NE(error.find("/dev/fake: invalid camera options"), std::string::npos) << error;
}

TEST(V4l2CameraTest, CorruptFrameAndSilentCameraAreErrorsNamingTheFrame) {
  auto camera = std::make_shared<FakeCamera>();
  camera->raw = {std::vector<uchar>(500, 0x42)};  // not a JPEG
  V4l2CameraSource source("/dev/fake", FrameColor::kBgr, {}, camera);
  cv::Mat frame;
  std::string error = ErrorOf([&] { source.Read(&frame); });
  EXPECT_NE(error.find("/dev/fake: frame 0: the camera delivered a corrupt MJPG frame"),
            std::string::npos)
      << error;

  auto silent = std::make_shared<FakeCamera>();
  silent->never_ready = true;
  silent->frames = {Gradient(64, 48, 0)};
  V4l2Options options;
  options.timeout_ms = 50;
  V4l2CameraSource waiting("/dev/fake", FrameColor::kBgr, options, silent);
  error = ErrorOf([&] { waiting.Read(&frame); });
  EXPECT_NE(error.find("no frame from the camera within 50 ms"), std::string::npos) << error;
}

}  // namespace
}  // namespace silpose
