#pragma once
// Mask images (docs/limits.md, "Masks"). One rule decodes a mask, for `silpose match` and for
// `silpose track --segment mask` alike (DecodeMask):
//  - values are compared on the image's own scale: 8-bit as stored; 16-bit against
//    threshold x 257 (so a 16-bit 1 is object); float against threshold / 255;
//  - grey: a pixel is object if its value is above the threshold (0: any non-zero value);
//  - colour (BGR): if any channel is above the threshold;
//  - with an alpha channel (grey + alpha, BGRA): if the alpha channel varies over the image, it is
//    the mask (alpha above the threshold = object); if it is the same everywhere (an opaque image)
//    it says nothing and the grey or colour channels decide as above.

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

namespace silpose {

/// Decodes an image (any depth, 1 to 4 channels) into a mask by the rule above: CV_8UC1 with
/// 255 = object, 0 = background. `threshold` is on the 8-bit scale, in [0, 254]. Throws
/// silpose::Error naming `name` for an unsupported depth or channel count.
cv::Mat DecodeMask(const cv::Mat& image, int threshold = 0, const std::string& name = "mask");

/// Reads an image file as a mask (DecodeMask with threshold 0); returns CV_8UC1 with 255 = object.
/// Throws silpose::Error naming the file if it is missing, not an image OpenCV can decode, or
/// beyond the image size limit (image_limits.h).
cv::Mat ReadMask(const std::filesystem::path& path);

/// Writes a CV_8UC1 mask as an image (format from the extension; PNG recommended).
/// Throws silpose::Error naming the file on failure.
void WriteMask(const std::filesystem::path& path, const cv::Mat& mask);

}  // namespace silpose
