// README.md "As a library": tracking a video from your own code (kept identical to the README).
#include <silpose/silpose.h>

#include <cstdio>

int main() try {
  const silpose::ViewDatabase database = silpose::ViewDatabase::Read("parts.db");
  silpose::TrackerOptions options;
  options.segmentation.kind = silpose::SegmenterKind::kBackground;
  options.segmentation.background_image_path = "empty.png";
  silpose::Tracker tracker(database, silpose::ReadCameraFile("camera.yml"), options);
  auto source = silpose::OpenFrameSource("recording.avi");
  for (cv::Mat frame; source->Read(&frame);) {
    const silpose::TrackedFrame tracked = tracker.Process(frame);
    // tracked.result: object_name, score, probability, view_dir_in_object, roll_deg and, when the
    // frame had a silhouette, camera_from_object (x_cam = R x_obj + t, OpenCV camera frame)
    const silpose::FrameResult& result = tracked.result;
    std::printf("frame %d: %s score %.3f%s\n", tracker.num_frames() - 1,
                result.object_name.empty() ? "-" : result.object_name.c_str(), result.score,
                result.camera_from_object ? " with pose" : "");
  }
  return 0;
} catch (const silpose::Error& error) {
  std::fprintf(stderr, "error: %s\n", error.what());
  return 1;
}
