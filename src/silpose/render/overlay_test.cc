#include "silpose/render/overlay.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kNoScore = std::numeric_limits<double>::quiet_NaN();
const cv::Vec3b kGrey(110, 110, 110);

cv::Mat GreyFrame() { return cv::Mat(150, 200, CV_8UC3, cv::Scalar(110, 110, 110)); }

cv::Mat DiscMask(cv::Point centre, int radius) {
  cv::Mat mask(150, 200, CV_8UC1, cv::Scalar(0));
  cv::circle(mask, centre, radius, cv::Scalar(255), cv::FILLED);
  return mask;
}

// Pixels within `distance` (chessboard metric) of a non-zero pixel of `mask`.
cv::Mat Near(const cv::Mat& mask, int distance) {
  cv::Mat grown;
  cv::dilate(mask, grown, cv::Mat::ones(2 * distance + 1, 2 * distance + 1, CV_8UC1));
  return grown;
}

// Object pixels with a background pixel among their 4 neighbours: the pixels an 8-connected
// border following visits.
cv::Mat Boundary(const cv::Mat& mask) {
  cv::Mat eroded;
  cv::erode(mask, eroded, cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(3, 3)));
  return mask - eroded;
}

// A square plate facing the camera, 1 unit wide, 4 units in front of it.
TriangleMesh Plate() {
  TriangleMesh mesh;
  mesh.name = "plate";
  mesh.vertices = {{-0.5f, -0.5f, 0}, {0.5f, -0.5f, 0}, {0.5f, 0.5f, 0}, {-0.5f, 0.5f, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

PosedModel PlateAt(const TriangleMesh& mesh, double x) {
  PosedModel model;
  model.mesh = &mesh;
  model.camera = PinholeCamera::Centered(200, 150, 200.0);
  model.camera_from_object.translation = {x, 0.0, 4.0};
  return model;
}

TEST(DrawOverlay, SegmentationOutlineIsRedAndTheRestIsUnchanged) {
  const cv::Mat frame = GreyFrame();
  const cv::Mat mask = DiscMask({120, 90}, 30);
  const cv::Mat overlay = DrawOverlay(frame, mask, nullptr, "", kNoScore);
  ASSERT_EQ(overlay.type(), CV_8UC3);
  ASSERT_EQ(overlay.size(), frame.size());
  const cv::Mat boundary = Boundary(mask);
  const cv::Mat near_boundary = Near(boundary, 2);
  int boundary_pixels = 0;
  for (int v = 0; v < frame.rows; ++v) {
    for (int u = 0; u < frame.cols; ++u) {
      const cv::Vec3b pixel = overlay.at<cv::Vec3b>(v, u);
      if (boundary.at<uint8_t>(v, u) != 0) {
        ++boundary_pixels;
        EXPECT_GE(pixel[2], 200) << u << "," << v;
        EXPECT_LE(pixel[1], 60) << u << "," << v;
        EXPECT_LE(pixel[0], 60) << u << "," << v;
      } else if (near_boundary.at<uint8_t>(v, u) == 0) {
        EXPECT_EQ(pixel, kGrey) << u << "," << v;
      }
    }
  }
  EXPECT_GT(boundary_pixels, 100);
}

TEST(DrawOverlay, PosedModelIsFilledAndOutlinedInGreen) {
  const cv::Mat frame = GreyFrame();
  const TriangleMesh plate = Plate();
  const PosedModel model = PlateAt(plate, 0.3);
  cv::Mat silhouette;
  RenderSilhouette(plate, model.camera, model.camera_from_object, &silhouette);
  ASSERT_GT(cv::countNonZero(silhouette), 1000);
  const cv::Mat overlay = DrawOverlay(frame, cv::Mat(), &model, "", kNoScore);
  cv::Mat inside;
  cv::erode(silhouette, inside, cv::Mat::ones(7, 7, CV_8UC1));
  const cv::Mat boundary = Boundary(silhouette);
  const cv::Mat near_model = Near(silhouette, 2);
  for (int v = 0; v < frame.rows; ++v) {
    for (int u = 0; u < frame.cols; ++u) {
      const cv::Vec3b pixel = overlay.at<cv::Vec3b>(v, u);
      if (inside.at<uint8_t>(v, u) != 0) {
        // 30% green over grey 110: 0.7 * 110 + 0.3 * 255 = 153.5 in G, 77 in B and R.
        EXPECT_NEAR(pixel[1], 153.5, 1.0) << u << "," << v;
        EXPECT_NEAR(pixel[0], 77.0, 1.0) << u << "," << v;
        EXPECT_NEAR(pixel[2], 77.0, 1.0) << u << "," << v;
      } else if (boundary.at<uint8_t>(v, u) != 0) {
        EXPECT_GE(pixel[1], 200) << u << "," << v;
        EXPECT_LE(pixel[2], 60) << u << "," << v;
      } else if (near_model.at<uint8_t>(v, u) == 0) {
        EXPECT_EQ(pixel, kGrey) << u << "," << v;
      }
    }
  }
}

TEST(DrawOverlay, SegmentationOutlineIsDrawnOverTheModel) {
  const cv::Mat frame = GreyFrame();
  const TriangleMesh plate = Plate();
  const PosedModel model = PlateAt(plate, 0.0);
  const cv::Mat mask = DiscMask({100, 75}, 20);  // inside the plate's square
  const cv::Mat overlay = DrawOverlay(frame, mask, &model, "plate", 0.5);
  const cv::Mat boundary = Boundary(mask);
  for (int v = 0; v < frame.rows; ++v) {
    for (int u = 0; u < frame.cols; ++u) {
      if (boundary.at<uint8_t>(v, u) == 0) continue;
      const cv::Vec3b pixel = overlay.at<cv::Vec3b>(v, u);
      EXPECT_GE(pixel[2], 200) << u << "," << v;
      EXPECT_LE(pixel[1], 100) << u << "," << v;
    }
  }
}

TEST(DrawOverlay, WithoutPoseMaskOrTextTheFrameIsUnchanged) {
  const cv::Mat frame = GreyFrame();
  cv::Mat overlay = DrawOverlay(frame, cv::Mat(), nullptr, "", kNoScore);
  EXPECT_EQ(cv::norm(overlay, frame, cv::NORM_INF), 0.0);
  overlay = DrawOverlay(frame, cv::Mat::zeros(frame.size(), CV_8UC1), nullptr, "", kNoScore);
  EXPECT_EQ(cv::norm(overlay, frame, cv::NORM_INF), 0.0);
}

TEST(DrawOverlay, TextBoxIsInTheTopLeftCorner) {
  const cv::Mat frame = GreyFrame();
  OverlayOptions options;
  options.frame_number = 12;
  const cv::Mat overlay = DrawOverlay(frame, cv::Mat(), nullptr, "bunny", 0.873, options);
  // Changed pixels exist and all lie in the upper-left part of the frame.
  cv::Mat changed_pixels;
  cv::absdiff(overlay, frame, changed_pixels);
  cv::cvtColor(changed_pixels, changed_pixels, cv::COLOR_BGR2GRAY);
  const cv::Rect bounds = cv::boundingRect(changed_pixels);
  EXPECT_GT(bounds.area(), 0);
  EXPECT_LT(bounds.x, 20);
  EXPECT_LT(bounds.y, 20);
  EXPECT_LT(bounds.br().x, frame.cols);
  EXPECT_LT(bounds.br().y, frame.rows / 2);
  // Two lines of text: the box is taller than for one.
  const cv::Mat one_line = DrawOverlay(frame, cv::Mat(), nullptr, "bunny", 0.873);
  cv::absdiff(one_line, frame, changed_pixels);
  cv::cvtColor(changed_pixels, changed_pixels, cv::COLOR_BGR2GRAY);
  EXPECT_LT(cv::boundingRect(changed_pixels).height, bounds.height);
}

TEST(DrawOverlay, AcceptsGreyFrames) {
  const cv::Mat grey(150, 200, CV_8UC1, cv::Scalar(110));
  const cv::Mat overlay = DrawOverlay(grey, DiscMask({50, 50}, 10), nullptr, "", kNoScore);
  ASSERT_EQ(overlay.type(), CV_8UC3);
  EXPECT_EQ(overlay.at<cv::Vec3b>(140, 190), kGrey);
  EXPECT_GE(overlay.at<cv::Vec3b>(50, 40)[2], 200);  // on the disc's left edge
}

TEST(DrawOverlay, RejectsMismatchedInputs) {
  const cv::Mat frame = GreyFrame();
  EXPECT_THROW(DrawOverlay(cv::Mat(), cv::Mat(), nullptr, "", kNoScore), Error);
  EXPECT_THROW(DrawOverlay(frame, cv::Mat(10, 10, CV_8UC1, cv::Scalar(0)), nullptr, "", 0.0),
               Error);
  EXPECT_THROW(DrawOverlay(cv::Mat(150, 200, CV_32FC1, cv::Scalar(0)), cv::Mat(), nullptr, "", 0.0),
               Error);
  const TriangleMesh plate = Plate();
  PosedModel model = PlateAt(plate, 0.0);
  model.camera = PinholeCamera::Centered(640, 480, 500.0);
  EXPECT_THROW(DrawOverlay(frame, cv::Mat(), &model, "", 0.0), Error);
  OverlayOptions options;
  options.model_fill_opacity = 2.0;
  EXPECT_THROW(DrawOverlay(frame, cv::Mat(), nullptr, "", 0.0, options), Error);
}

}  // namespace
}  // namespace silpose
