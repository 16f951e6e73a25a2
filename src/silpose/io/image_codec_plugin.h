#pragma once
// The interface of silpose's OpenCV codecs plugin (libsilpose_opencv_codecs.so), the one place
// that links OpenCV's image codecs. image_codec.cc loads it with dlopen the first time an image in
// a format other than PNG or JPEG is read or written, so that programs start without OpenCV's
// codec library and the libraries it pulls in. Both sides are built from the same sources with the
// same compiler and OpenCV, so C++ types cross the boundary; exceptions do not (each function
// catches them and returns false with the reason in `error`).

#include <cstddef>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace silpose {

struct OpenCvCodecs {
  int version;         // kOpenCvCodecsVersion of the plugin's build
  int opencv_version;  // kOpenCvVersion of the plugin's build: one OpenCV in the process
  size_t size;         // sizeof(OpenCvCodecs) in the plugin's build
  bool (*read)(const char* path, int flags, cv::Mat* image, std::string* error);
  bool (*decode)(const unsigned char* data, size_t size, int flags, cv::Mat* image,
                 std::string* error);
  bool (*encode)(const char* extension, const cv::Mat* image, const int* params, size_t count,
                 std::vector<unsigned char>* bytes, bool* encoded, std::string* error);
};

inline constexpr int kOpenCvCodecsVersion = 2;
inline constexpr int kOpenCvVersion =
    CV_VERSION_MAJOR * 10000 + CV_VERSION_MINOR * 100 + CV_VERSION_REVISION;

}  // namespace silpose

/// The plugin's one exported symbol.
extern "C" const silpose::OpenCvCodecs* silpose_opencv_codecs();
