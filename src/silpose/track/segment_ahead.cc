#include "silpose/track/segment_ahead.h"

#include <any>
#include <chrono>
#include <memory>
#include <utility>

namespace silpose {

ReadAheadSource::FrameWork SegmentAhead(
    const SegmenterOptions& options,
    std::function<void(cv::Size frame_size, SegmenterOptions* options)> at_size) {
  // Shared by the copies std::function may make; used by the one reading thread only.
  auto segmenter = std::make_shared<std::unique_ptr<Segmenter>>();
  return [segmenter, options, at_size = std::move(at_size)](const cv::Mat& frame) -> std::any {
    if (*segmenter == nullptr) {
      SegmenterOptions sized = options;
      if (at_size) at_size(frame.size(), &sized);
      *segmenter = CreateSegmenter(sized);
    }
    const auto start = std::chrono::steady_clock::now();
    AheadSegmentation done{(*segmenter)->Segment(frame), 0.0};
    done.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return done;
  };
}

}  // namespace silpose
