#pragma once
// Mask images (docs/conventions.md: 8-bit, non-zero = object).

#include <filesystem>
#include <opencv2/core.hpp>

namespace silpose {

/// Reads an image as a mask: any depth and channel count, a pixel is object if any channel is
/// non-zero; returns CV_8UC1 with 255 = object. Throws silpose::Error naming the file if it is
/// missing or not an image OpenCV can decode.
cv::Mat ReadMask(const std::filesystem::path& path);

/// Writes a CV_8UC1 mask as an image (format from the extension; PNG recommended).
/// Throws silpose::Error naming the file on failure.
void WriteMask(const std::filesystem::path& path, const cv::Mat& mask);

}  // namespace silpose
