#pragma once
// Reading and writing image files and in-memory images: PNG and JPEG are decoded and encoded
// directly with libpng and libjpeg; every other format (BMP, TIFF, PNM, WebP, ...) goes through
// OpenCV's image codecs, which are loaded only when such an image is met. OpenCV's codec library
// pulls in well over a hundred other libraries (GDAL among them) and takes a fifth of a second
// to load, so a program that reads only PNG and JPEG starts without it (docs/PERFORMANCE.md).
//
// The functions follow cv::imread / cv::imdecode / cv::imwrite / cv::imencode: the same `flags`
// (cv::IMREAD_UNCHANGED, cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR), the same channel order (BGR,
// BGRA), the same depths (8-bit, 16-bit with IMREAD_UNCHANGED), the same orientation rule (the
// EXIF orientation of a JPEG's APP1 block or a PNG's eXIf chunk is applied unless
// IMREAD_UNCHANGED) and the same parameters (cv::IMWRITE_PNG_COMPRESSION and
// cv::IMWRITE_JPEG_QUALITY are applied here; any other setting sends the image to OpenCV's
// encoder). Where they differ: a corrupt or truncated PNG or JPEG throws cv::Exception with the
// decoder's reason (OpenCV returns an empty image, or for a truncated JPEG one whose missing rows
// are grey), as does a progressive JPEG of more than 500 scans or an image file of more than
// 2 GiB; and nothing is printed to stderr. Writing never leaves a partial file: on a write error
// the file is removed.
//
// OpenCV's codecs are loaded from libsilpose_opencv_codecs.so: the file named by the environment
// variable SILPOSE_OPENCV_CODECS if it is set, else the one installed beside the program or
// library (lib/silpose/ under the installation prefix), never from a path relative to the working
// folder.

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <span>
#include <string>
#include <vector>

namespace silpose {

/// Decodes the image file at `path`. Returns an empty image if the file cannot be opened, is
/// empty, or is in no format known; throws cv::Exception if it is a PNG or JPEG that cannot be
/// decoded (the reason in `err`), or if decoding another format fails in OpenCV.
cv::Mat ReadImage(const std::filesystem::path& path, int flags);

/// Decodes an image held in memory; the format is found from the content. As ReadImage.
cv::Mat DecodeImage(std::span<const uint8_t> bytes, int flags);

/// Encodes `image` in the format named by `extension` (".png", ".jpg", ".bmp", ...) into
/// `bytes`. Returns false if the format cannot hold the image; throws cv::Exception on an
/// unknown extension or an encoder error.
bool EncodeImage(const std::string& extension, const cv::Mat& image, std::vector<uint8_t>* bytes,
                 const std::vector<int>& params = {});

/// Writes `image` to `path` in the format named by its extension. Returns false if the file
/// cannot be written; throws cv::Exception as EncodeImage.
bool WriteImage(const std::filesystem::path& path, const cv::Mat& image,
                const std::vector<int>& params = {});

/// The plugin is looked for beside the running program or library (../lib/silpose/ from an
/// installed program), then where it was installed and where it was built; the environment
/// variable SILPOSE_OPENCV_CODECS, if set, names the one file to load instead. If it cannot be
/// loaded, images in other formats throw cv::Exception saying so.
///
/// Whether OpenCV's image codecs have been loaded into this process (by a format other than PNG
/// or JPEG, or by another part of the program linking them).
bool OpenCvImageCodecsLoaded();

}  // namespace silpose
