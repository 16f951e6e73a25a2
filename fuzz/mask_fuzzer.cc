// Mask and image decoding into a silhouette: the input is an image file (the first byte picks the
// extension: PNG, JPEG, BMP, PGM, TIFF, WebP; OpenCV decodes by content). It is read as a mask
// (ReadMask, then the mask segmenter and the signature) and as a video frame (a one-image frame
// source, then the threshold segmenter and the signature), as `silpose track` does.

#include <array>
#include <opencv2/core.hpp>
#include <string>

#include "fuzz/fuzz_common.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/mask_file.h"
#include "silpose/segment/segmenter.h"
#include "silpose/shape/polar_signature.h"

namespace {

void Describe(const silpose::SegmentationResult& result) {
  if (result.ok()) (void)silpose::ExtractSignature(result.mask);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const std::array<std::string, 6> kExtensions = {".png", ".jpg", ".bmp",
                                                         ".pgm", ".tif", ".webp"};
  const std::string& extension = kExtensions[data[0] % kExtensions.size()];
  const auto path = silpose::fuzz::WriteInput(silpose::fuzz::AsView(data + 1, size - 1), extension);

  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    const cv::Mat mask = silpose::ReadMask(path);
    silpose::SegmenterOptions options;
    options.kind = silpose::SegmenterKind::kMask;
    Describe(silpose::CreateSegmenter(options)->Segment(mask));
  });
  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    auto source = silpose::OpenFrameSource(path.string());
    cv::Mat frame;
    if (!source->Read(&frame)) return;
    silpose::SegmenterOptions options;
    options.kind = silpose::SegmenterKind::kThreshold;
    Describe(silpose::CreateSegmenter(options)->Segment(frame));
  });
  return 0;
}
