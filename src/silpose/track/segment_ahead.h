#pragma once
// Segmentation on the thread that reads the frames: with a ReadAheadSource (io/read_ahead_source.h)
// each frame is segmented while the tracker works on the frame before, and the tracker is given
// the result (Tracker::Process(frame, segmentation, ms)). `silpose track` runs so by default
// (`--read-ahead`, docs/tracking.md, "Input").
//
//   ReadAheadSource source(OpenFrameSource(input), 2, SegmentAhead(options.segmentation));
//   Tracker tracker(database, camera, options);
//   for (cv::Mat frame; source.Read(&frame);) {
//     auto& ahead = std::any_cast<AheadSegmentation&>(source.work_result());
//     Use(tracker.Process(frame, std::move(ahead.result), ahead.ms));
//   }
#include <functional>
#include <opencv2/core.hpp>

#include "silpose/io/read_ahead_source.h"
#include "silpose/segment/segmenter.h"

namespace silpose {

/// A frame's segmentation made ahead of the tracker, and the milliseconds it took.
struct AheadSegmentation {
  SegmentationResult result;
  double ms = 0.0;
};

/// Work for ReadAheadSource that segments every frame it reads, in order, with one Segmenter of
/// `options` (the tracker's TrackerOptions::segmentation), made at the first frame; `at_size`, if
/// given, first adjusts the options to that frame's size (as `silpose track` limits background
/// subtraction on large frames), and must adjust the tracker's options the same way. Each frame's
/// result is an AheadSegmentation. An invalid option or a frame the segmenter refuses ends the
/// frames with its Error.
ReadAheadSource::FrameWork SegmentAhead(
    const SegmenterOptions& options,
    std::function<void(cv::Size frame_size, SegmenterOptions* options)> at_size = {});

}  // namespace silpose
