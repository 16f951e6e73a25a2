// Signature extraction and matching on arbitrary masks. The input is a bitmap: byte 0 is the width
// - 1 (1..256 pixels), byte 1 the zoom (1, 2, 4 or 8: each bit a square of pixels), then one bit
// per pixel, row by row. The mask is described (ExtractSignature) and, when it is usable, matched
// against a small database of a sample model built once (2 distance shells, 64 views).

#include <algorithm>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "fuzz/fuzz_common.h"
#include "silpose/database/database_builder.h"
#include "silpose/match/view_matcher.h"
#include "silpose/shape/polar_signature.h"

namespace {

const silpose::ViewDatabase& Database() {
  static const silpose::ViewDatabase database = [] {
    silpose::DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 64;
    options.parameters.render.resolution_px = 128;
    options.parameters.distances_in_radii = {3.0, 7.5};
    options.num_threads = 1;
    return silpose::BuildViewDatabase({SILPOSE_SAMPLE_MODELS_DIR "/anchor.obj"}, options);
  }();
  return database;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const silpose::ViewSpectra spectra(Database());
  static silpose::ViewMatcher matcher(spectra);
  if (size < 3) return 0;
  const int width = 1 + data[0];
  const int zoom = 1 << (data[1] & 3);
  const size_t bits = (size - 2) * 8;
  const int height = static_cast<int>(std::min<size_t>(256, (bits + width - 1) / width));
  cv::Mat mask(height, width, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t bit = static_cast<size_t>(y) * width + x;
      if (bit < bits && (data[2 + bit / 8] >> (bit % 8) & 1)) mask.at<uint8_t>(y, x) = 255;
    }
  }
  if (zoom > 1) cv::resize(mask, mask, {}, zoom, zoom, cv::INTER_NEAREST);

  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    const silpose::SignatureResult result =
        silpose::ExtractSignature(mask, Database().parameters.signature);
    (void)result.Describe();
    if (!result.ok()) return;
    silpose::MatchOptions options;
    options.top_k = 3;
    options.apparent_radius =
        result.signature.mean_radius_px / (0.5 * std::max(mask.cols, mask.rows));
    const auto candidates = matcher.Match(result.signature.radii, options);
    if (candidates.empty()) __builtin_trap();  // a usable signature always has a best view
  });
  return 0;
}
