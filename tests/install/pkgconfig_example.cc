// Built with `c++ pkgconfig_example.cc $(pkg-config --cflags --libs silpose)` and nothing else.
#include <silpose/silpose.h>

#include <cstdio>

int main() try {
  // A few layers: a rectangle's polar signature (shape, OpenCV) and the default camera (track).
  cv::Mat mask = cv::Mat::zeros(240, 320, CV_8UC1);
  mask(cv::Rect(100, 80, 60, 40)).setTo(255);
  const silpose::SignatureResult silhouette = silpose::ExtractSignature(mask);
  const silpose::PinholeCamera camera = silpose::DefaultCamera(mask.cols, mask.rows);
  if (!silhouette.ok()) return 1;
  std::printf("silpose %s: signature of %zu radii, default focal length %.1f px\n", SILPOSE_VERSION,
              silhouette.signature.radii.size(), camera.focal_x_px);
  return 0;
} catch (const silpose::Error& error) {
  std::fprintf(stderr, "error: %s\n", error.what());
  return 1;
}
