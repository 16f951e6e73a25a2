#include "silpose/io/mask_file.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "silpose/io/image_codec.h"
#include "silpose/io/image_limits.h"
#include "silpose/util/error.h"

namespace silpose {

cv::Mat DecodeMask(const cv::Mat& image, int threshold, const std::string& name) {
  if (image.empty()) ThrowError(name, ": empty image");
  if (threshold < 0 || threshold > 254) {
    ThrowError(name, ": mask threshold must be in [0, 254], got ", threshold);
  }
  double cut = threshold;  // object: value > cut, on the image's own scale
  switch (image.depth()) {
    case CV_8U:
      break;
    case CV_16U:
      cut = threshold * 257.0;
      break;
    case CV_32F:
    case CV_64F:
      cut = threshold / 255.0;
      break;
    default:
      ThrowError(name, ": mask images must be 8-bit, 16-bit or floating point (OpenCV depth ",
                 image.depth(), ")");
  }
  const int channels = image.channels();
  if (channels < 1 || channels > 4) {
    ThrowError(name, ": mask images must have 1 to 4 channels, got ", channels);
  }
  if (channels == 1) {  // the usual mask: no copy of its one plane
    cv::Mat mask;
    cv::compare(image, cut, mask, cv::CMP_GT);
    return mask;
  }
  std::vector<cv::Mat> planes;
  cv::split(image, planes);
  const bool has_alpha = channels == 2 || channels == 4;
  if (has_alpha) {
    double low = 0.0, high = 0.0;
    cv::minMaxLoc(planes.back(), &low, &high);
    if (low != high) {
      cv::Mat mask;
      cv::compare(planes.back(), cut, mask, cv::CMP_GT);
      return mask;
    }
    planes.pop_back();  // uniform alpha: the colours decide
  }
  cv::Mat mask;
  cv::compare(planes[0], cut, mask, cv::CMP_GT);
  for (size_t c = 1; c < planes.size(); ++c) {
    cv::Mat more;
    cv::compare(planes[c], cut, more, cv::CMP_GT);
    mask |= more;
  }
  return mask;
}

cv::Mat ReadMask(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code error;
  if (!std::filesystem::exists(path, error)) ThrowError(name, ": no such file");
  if (std::filesystem::is_directory(path, error))
    ThrowError(name, ": is a directory, not an image");
  CheckImageFileSize(path);
  cv::Mat image;
  try {
    image = ReadImage(name, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& exception) {
    ThrowError(name, ": cannot decode image (", exception.err, ")");
  }
  if (image.empty()) ThrowError(name, ": not an image OpenCV can read (or a corrupt one)");
  CheckImageSize(name, image.cols, image.rows);
  return DecodeMask(image, 0, name);
}

void WriteMask(const std::filesystem::path& path, const cv::Mat& mask) {
  bool written = false;
  try {
    written = WriteImage(path.string(), mask);
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot write image (", exception.err, ")");
  }
  if (!written)
    ThrowError(path.string(), ": cannot write image (unknown extension or no permission)");
}

}  // namespace silpose
