#include "silpose/io/mask_file.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "silpose/util/error.h"

namespace silpose {

cv::Mat ReadMask(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code error;
  if (!std::filesystem::exists(path, error)) ThrowError(name, ": no such file");
  if (std::filesystem::is_directory(path, error))
    ThrowError(name, ": is a directory, not an image");
  cv::Mat image;
  try {
    image = cv::imread(name, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& exception) {
    ThrowError(name, ": cannot decode image (", exception.err, ")");
  }
  if (image.empty()) ThrowError(name, ": not an image OpenCV can read (or a corrupt one)");
  cv::Mat mask;
  if (image.channels() > 1) {
    std::vector<cv::Mat> channels;
    cv::split(image, channels);
    mask = channels[0] != 0;
    for (size_t c = 1; c < channels.size(); ++c) mask |= channels[c] != 0;
  } else {
    mask = image != 0;
  }
  return mask;
}

void WriteMask(const std::filesystem::path& path, const cv::Mat& mask) {
  bool written = false;
  try {
    written = cv::imwrite(path.string(), mask);
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot write image (", exception.err, ")");
  }
  if (!written)
    ThrowError(path.string(), ": cannot write image (unknown extension or no permission)");
}

}  // namespace silpose
