#include "silpose/io/frame_source.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>
#include <utility>

#include "silpose/io/avi_file.h"
#include "silpose/io/image_codec.h"
#include "silpose/io/image_limits.h"
#include "silpose/io/mask_file.h"
#include "silpose/io/v4l2_camera.h"
#include "silpose/util/error.h"

#if SILPOSE_WITH_VIDEOIO
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/videoio.hpp>
#endif

namespace silpose {
namespace {

constexpr std::array<std::string_view, 10> kImageExtensions = {
    ".png", ".pgm", ".pbm", ".ppm", ".bmp", ".tif", ".tiff", ".jpg", ".jpeg", ".webp"};
// Containers that only OpenCV videoio (FFmpeg) reads; named in the default build's error.
constexpr std::array<std::string_view, 14> kOtherVideoExtensions = {
    ".mp4", ".m4v", ".mkv", ".mov", ".webm", ".mpg", ".mpeg",
    ".wmv", ".flv", ".ogv", ".3gp", ".ts",   ".mts", ".m2ts"};
constexpr const char* kVideoIoHint =
    "needs a build with -DSILPOSE_WITH_VIDEOIO=ON (OpenCV videoio; Debian's FFmpeg is GPL)";

std::string LowerExtension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

template <size_t N>
bool Contains(const std::array<std::string_view, N>& list, const std::string& value) {
  return std::find(list.begin(), list.end(), value) != list.end();
}

bool AllDigits(const std::string& text) {
  return !text.empty() && text.size() <= 4 &&
         std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

cv::Mat DecodeImageFile(const std::filesystem::path& path, FrameColor color, int frame) {
  cv::Mat image;
  const int flags = color == FrameColor::kGray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_UNCHANGED;
  CheckImageFileSize(path);
  try {
    image = ReadImage(path.string(), flags);
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": frame ", frame, ": cannot decode image (", exception.err, ")");
  }
  if (image.empty()) {
    ThrowError(path.string(), ": frame ", frame,
               ": not an image OpenCV can decode (or a corrupt or unreadable one)");
  }
  return image;
}

#if SILPOSE_WITH_VIDEOIO
// OpenCV's videoio backends log every failed attempt (GStreamer, V4L2, ...) to stderr; silpose
// reports the failure itself in one line, so keep OpenCV's log to errors.
void QuietOpenCvLog() {
  static const bool once = [] {
    if (cv::utils::logging::getLogLevel() > cv::utils::logging::LOG_LEVEL_ERROR)
      cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
    return true;
  }();
  (void)once;
}

// Videos (other than the AVI files AviReader reads) and cameras through OpenCV videoio.
class OpenCvVideoSource final : public FrameSource {
 public:
  OpenCvVideoSource(const std::filesystem::path& path, FrameColor color)
      : FrameSource(color), label_(path.filename().string()) {
    QuietOpenCvLog();
    try {
      capture_.open(path.string(), cv::CAP_ANY);
    } catch (const cv::Exception& exception) {
      ThrowError(path.string(), ": cannot open video (", exception.err, ")");
    }
    if (!capture_.isOpened()) ThrowError(path.string(), ": not a video OpenCV videoio can read");
    const double count = capture_.get(cv::CAP_PROP_FRAME_COUNT);
    if (count > 0 && count < 1e9) num_frames_ = static_cast<int>(count);
    Init(path.string());
  }

  OpenCvVideoSource(int camera, FrameColor color)
      : FrameSource(color), label_("camera" + std::to_string(camera)) {
    QuietOpenCvLog();
    try {
      capture_.open(camera, cv::CAP_ANY);
    } catch (const cv::Exception& exception) {
      ThrowError("camera ", camera, ": cannot open (", exception.err, ")");
    }
    if (!capture_.isOpened()) ThrowError("camera ", camera, ": cannot open (no such camera?)");
    Init(label_);
  }

  std::optional<int> num_frames() const override { return num_frames_; }
  double fps() const override { return fps_; }
  cv::Size size() const override { return size_; }
  std::string name() const override { return label_ + "#" + std::to_string(frame_index()); }

 protected:
  bool ReadNext(cv::Mat* frame) override {
    cv::Mat image;
    try {
      if (!capture_.read(image) || image.empty()) return false;
    } catch (const cv::Exception& exception) {
      ThrowError(label_, ": frame ", frame_index() + 1, ": cannot decode (", exception.err, ")");
    }
    *frame = image;
    return true;
  }

 private:
  void Init(const std::string& where) {
    fps_ = std::max(0.0, capture_.get(cv::CAP_PROP_FPS));
    size_ = cv::Size(static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH)),
                     static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT)));
    if (size_.width < 0 || size_.height < 0) ThrowError(where, ": invalid frame size");
  }

  cv::VideoCapture capture_;
  std::string label_;
  std::optional<int> num_frames_;
  double fps_ = 0.0;
  cv::Size size_;
};
#endif

std::unique_ptr<FrameSource> OpenVideoFile(const std::filesystem::path& path, FrameColor color) {
#if SILPOSE_WITH_VIDEOIO
  return std::make_unique<OpenCvVideoSource>(path, color);
#else
  (void)color;
  const std::string extension = LowerExtension(path);
  if (Contains(kOtherVideoExtensions, extension)) {
    ThrowError(path.string(), ": reading ", extension, " videos ", kVideoIoHint,
               "; this build reads AVI files with MJPEG, PNG or uncompressed frames, and folders "
               "of images");
  }
  ThrowError(path.string(),
             ": not a folder, an image or a video this build reads (AVI with MJPEG, PNG or "
             "uncompressed frames; other video formats ",
             kVideoIoHint, ")");
#endif
}

}  // namespace

bool HasOpenCvVideoIo() {
#if SILPOSE_WITH_VIDEOIO
  return true;
#else
  return false;
#endif
}

std::vector<std::filesystem::path> ImageFilesIn(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> files;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    std::error_code type_error;
    if (entry.is_regular_file(type_error) &&
        Contains(kImageExtensions, LowerExtension(entry.path()))) {
      files.push_back(entry.path());
    }
  }
  if (error) ThrowError(folder.string(), ": cannot list folder: ", error.message());
  std::sort(files.begin(), files.end());
  return files;
}

// ---------------------------------------------------------------------------------------------
// FrameSource

FrameSource::FrameSource(FrameColor color) : color_(color) {}

FrameSource::~FrameSource() = default;

bool FrameSource::Read(cv::Mat* frame) {
  SILPOSE_ASSERT(frame != nullptr);
  if (finished_) return false;
  try {
    if (!ReadNext(&raw_)) {
      finished_ = true;
      return false;
    }
    ++frame_index_;
    CheckImageSize(name(), raw_.cols, raw_.rows);
    cv::Mat image = raw_;
    if (color_ == FrameColor::kMask) {
      image = DecodeMask(raw_, mask_threshold_, name());
    } else if (image.depth() == CV_16U) {
      image.convertTo(image, CV_8U, 1.0 / 257.0);
    } else if (image.depth() != CV_8U) {
      ThrowError(name(), ": frame ", frame_index_, ": unsupported pixel depth (not 8 or 16 bits)");
    }
    if (color_ == FrameColor::kMask) {
      // already one channel
    } else if (image.channels() == 4) {
      cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
    } else if (image.channels() == 2) {
      cv::extractChannel(image, image, 0);
    }
    if (frame_index_ == 0) {
      first_size_ = image.size();
      first_channels_ = color_ == FrameColor::kGray || color_ == FrameColor::kMask ? 1
                        : color_ == FrameColor::kBgr                               ? 3
                                                     : image.channels();
    } else if (image.size() != first_size_) {
      ThrowError(name(), ": frame ", frame_index_, " is ", image.cols, "x", image.rows,
                 " pixels but the first frame is ", first_size_.width, "x", first_size_.height,
                 " (the frame size must not change)");
    }
    if (image.channels() != first_channels_) {
      cv::cvtColor(image, image, first_channels_ == 1 ? cv::COLOR_BGR2GRAY : cv::COLOR_GRAY2BGR);
    }
    *frame = image;
  } catch (...) {
    finished_ = true;
    throw;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// ImageFolderSource

ImageFolderSource::ImageFolderSource(std::vector<std::filesystem::path> files, FrameColor color)
    : FrameSource(color), files_(std::move(files)) {
  if (files_.empty()) ThrowError("ImageFolderSource: no image files given");
  first_ = DecodeImageFile(files_.front(), color, 0);
  size_ = first_.size();
}

std::string ImageFolderSource::name() const {
  if (frame_index() < 0) return files_.front().parent_path().string();
  return files_[static_cast<size_t>(frame_index())].filename().string();
}

bool ImageFolderSource::ReadNext(cv::Mat* frame) {
  if (next_ >= files_.size()) return false;
  const int index = static_cast<int>(next_);
  if (next_ == 0) {
    *frame = first_;
    first_.release();
  } else {
    *frame = DecodeImageFile(files_[next_], color(), index);
  }
  ++next_;
  return true;
}

// ---------------------------------------------------------------------------------------------

namespace {

std::unique_ptr<FrameSource> OpenSource(const std::string& input,
                                        const FrameSourceOptions& options) {
  if (input.empty()) ThrowError("input: empty name (give a folder, a video file or a camera)");
  const std::filesystem::path path(input);
  std::error_code error;
#if defined(__linux__)
  // Video4Linux2 devices, in every build.
  if (input.rfind("/dev/video", 0) == 0 || input.rfind("/dev/v4l/", 0) == 0) {
    return std::make_unique<V4l2CameraSource>(input, options.color);
  }
#endif
  if (!std::filesystem::exists(path, error)) {
    if (AllDigits(input)) {
#if SILPOSE_WITH_VIDEOIO
      return std::make_unique<OpenCvVideoSource>(std::stoi(input), options.color);
#elif defined(__linux__)
      // Camera number N is /dev/videoN, read through Video4Linux2.
      try {
        return std::make_unique<V4l2CameraSource>("/dev/video" + input, options.color);
      } catch (const Error& fault) {
        ThrowError(input, ": no such file or folder, nor a camera: ", fault.what(),
                   " (cameras that Video4Linux2 cannot read: ", kVideoIoHint, ")");
      }
#else
      ThrowError(input, ": no such file or folder; reading it as camera number ", input, " ",
                 kVideoIoHint);
#endif
    }
    ThrowError(input, ": no such file or folder");
  }

  if (std::filesystem::is_directory(path, error)) {
    // A sequence folder (masks/ or frames/ with images) is read from the subfolder even if it
    // holds images of its own (a synth folder's background.png).
    std::vector<std::filesystem::path> images;
    std::array<const char*, 2> order = {"masks", "frames"};
    if (options.sequence_folder == SequenceFolder::kFrames) std::swap(order[0], order[1]);
    for (const char* subfolder : order) {
      if (std::filesystem::is_directory(path / subfolder, error)) {
        images = ImageFilesIn(path / subfolder);
        if (!images.empty()) break;
      }
    }
    if (images.empty()) images = ImageFilesIn(path);
    if (images.empty()) {
      ThrowError(input,
                 ": no images (.png .pgm .pbm .ppm .bmp .tif .jpg .webp) in this folder nor in "
                 "a masks/ or frames/ subfolder");
    }
    return std::make_unique<ImageFolderSource>(std::move(images), options.color);
  }

  const std::string extension = LowerExtension(path);
  if (extension == ".avi") {
#if SILPOSE_WITH_VIDEOIO
    if (!ReadAviHeader(path).supported) return OpenVideoFile(path, options.color);
#endif
    return std::make_unique<AviReader>(path, options.color);
  }
  if (Contains(kImageExtensions, extension)) {
    return std::make_unique<ImageFolderSource>(std::vector<std::filesystem::path>{path},
                                               options.color);
  }
  return OpenVideoFile(path, options.color);
}

}  // namespace

std::unique_ptr<FrameSource> OpenFrameSource(const std::string& input,
                                             const FrameSourceOptions& options) {
  if (options.mask_threshold < 0 || options.mask_threshold > 254) {
    ThrowError("mask threshold must be in [0, 254], got ", options.mask_threshold);
  }
  std::unique_ptr<FrameSource> source = OpenSource(input, options);
  source->set_mask_threshold(options.mask_threshold);
  return source;
}

}  // namespace silpose
