// silpose's OpenCV codecs plugin (image_codec_plugin.h): OpenCV's imread/imdecode/imencode behind
// a C entry point, loaded on demand by image_codec.cc.

#include <exception>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "silpose/io/image_codec_plugin.h"

namespace {

template <typename Body>
bool Guarded(std::string* error, const Body& body) {
  try {
    return body();
  } catch (const cv::Exception& exception) {
    *error = exception.err;
  } catch (const std::exception& exception) {
    *error = exception.what();
  } catch (...) {
    *error = "unknown error in OpenCV's codecs";
  }
  return false;
}

bool Read(const char* path, int flags, cv::Mat* image, std::string* error) {
  return Guarded(error, [&] {
    *image = cv::imread(path, flags);
    return true;
  });
}

bool Decode(const unsigned char* data, size_t size, int flags, cv::Mat* image, std::string* error) {
  if (size > static_cast<size_t>(std::numeric_limits<int>::max())) {
    *error = "image data of more than 2 GiB";
    return false;
  }
  return Guarded(error, [&] {
    const cv::Mat bytes(1, static_cast<int>(size), CV_8UC1, const_cast<unsigned char*>(data));
    *image = cv::imdecode(bytes, flags);
    return true;
  });
}

bool Encode(const char* extension, const cv::Mat* image, const int* params, size_t count,
            std::vector<unsigned char>* bytes, bool* encoded, std::string* error) {
  return Guarded(error, [&] {
    *encoded = cv::imencode(extension, *image, *bytes, std::vector<int>(params, params + count));
    return true;
  });
}

const silpose::OpenCvCodecs kCodecs{silpose::kOpenCvCodecsVersion,
                                    silpose::kOpenCvVersion,
                                    sizeof(silpose::OpenCvCodecs),
                                    Read,
                                    Decode,
                                    Encode};

}  // namespace

extern "C" __attribute__((visibility("default"))) const silpose::OpenCvCodecs*
silpose_opencv_codecs() {
  return &kCodecs;
}
