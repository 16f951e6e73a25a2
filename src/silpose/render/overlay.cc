#include "silpose/render/overlay.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// Outlines of the regions of a CV_8UC1 mask (outer borders and the borders of holes), on the
// mask's own boundary pixels.
std::vector<std::vector<cv::Point>> Outlines(const cv::Mat& mask) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  return contours;
}

void DrawOutlines(const cv::Mat& mask, const cv::Scalar& colour, int width_px, cv::Mat* image) {
  const std::vector<std::vector<cv::Point>> contours = Outlines(mask);
  // A closed polyline through the boundary pixels' centres; a one-pixel region is a dot.
  for (const std::vector<cv::Point>& contour : contours) {
    if (contour.size() == 1) {
      cv::circle(*image, contour.front(), std::max(0, (width_px - 1) / 2), colour, cv::FILLED,
                 cv::LINE_AA);
    }
  }
  cv::polylines(*image, contours, true, colour, width_px, cv::LINE_AA);
}

// Blends `colour` over the pixels of `mask` with the given opacity.
void Fill(const cv::Mat& mask, const cv::Scalar& colour, double opacity, cv::Mat* image) {
  if (opacity <= 0.0) return;
  for (int row = 0; row < image->rows; ++row) {
    const uint8_t* inside = mask.ptr<uint8_t>(row);
    uint8_t* pixel = image->ptr<uint8_t>(row);
    for (int u = 0; u < image->cols; ++u, pixel += 3) {
      if (inside[u] == 0) continue;
      for (int k = 0; k < 3; ++k) {
        pixel[k] = cv::saturate_cast<uint8_t>((1.0 - opacity) * pixel[k] + opacity * colour[k]);
      }
    }
  }
}

void DrawTextBox(const std::vector<std::string>& lines, double scale, cv::Mat* image) {
  if (lines.empty()) return;
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 2.0)));
  const int margin = std::max(2, static_cast<int>(std::lround(8.0 * scale)));
  int box_width = 0;
  int line_height = 0;
  int baseline = 0;
  for (const std::string& line : lines) {
    const cv::Size size = cv::getTextSize(line, kFont, scale, thickness, &baseline);
    box_width = std::max(box_width, size.width);
    line_height = std::max(line_height, size.height + baseline);
  }
  const int line_step = line_height + margin / 2;
  const cv::Rect box(margin, margin, box_width + 2 * margin,
                     static_cast<int>(lines.size()) * line_step + margin);
  const cv::Rect clipped = box & cv::Rect(0, 0, image->cols, image->rows);
  if (clipped.area() > 0) {
    cv::Mat region = (*image)(clipped);
    region.convertTo(region, -1, 0.35);  // darken, so white text reads on any frame
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const cv::Point origin(box.x + margin,
                           box.y + margin / 2 + static_cast<int>(i + 1) * line_step - baseline);
    cv::putText(*image, lines[i], origin, kFont, scale, cv::Scalar(255, 255, 255), thickness,
                cv::LINE_AA);
  }
}

}  // namespace

bool OverlayOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (line_width_px < 1 || line_width_px > 20) {
    message << "line width must be in [1, 20] pixels, got " << line_width_px;
  } else if (!(model_fill_opacity >= 0.0 && model_fill_opacity <= 1.0)) {
    message << "model fill opacity must be in [0, 1], got " << model_fill_opacity;
  } else if (!(text_scale > 0.0 && text_scale <= 10.0)) {
    message << "text scale must be in (0, 10], got " << text_scale;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

cv::Mat DrawOverlay(const cv::Mat& frame, const cv::Mat& segmentation_mask, const PosedModel* model,
                    std::string_view label, double score, const OverlayOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid overlay options: ", error);
  if (frame.empty()) ThrowError("overlay: the frame is empty");
  cv::Mat image;
  if (frame.type() == CV_8UC3) {
    image = frame.clone();
  } else if (frame.type() == CV_8UC1) {
    cv::cvtColor(frame, image, cv::COLOR_GRAY2BGR);
  } else {
    ThrowError("overlay: the frame must be 8-bit BGR or grey, got OpenCV type ", frame.type());
  }
  if (!segmentation_mask.empty() &&
      (segmentation_mask.type() != CV_8UC1 || segmentation_mask.size() != frame.size())) {
    ThrowError("overlay: the segmentation mask must be 8-bit single-channel ", frame.cols, "x",
               frame.rows, " like the frame, got ", segmentation_mask.cols, "x",
               segmentation_mask.rows, " of OpenCV type ", segmentation_mask.type());
  }

  if (model != nullptr) {
    if (model->mesh == nullptr) ThrowError("overlay: the posed model has no mesh");
    if (model->camera.width_px != frame.cols || model->camera.height_px != frame.rows) {
      ThrowError("overlay: the camera is ", model->camera.width_px, "x", model->camera.height_px,
                 " but the frame is ", frame.cols, "x", frame.rows);
    }
    cv::Mat model_mask;
    RenderSilhouette(*model->mesh, model->camera, model->camera_from_object, &model_mask);
    Fill(model_mask, options.model_colour_bgr, options.model_fill_opacity, &image);
    DrawOutlines(model_mask, options.model_colour_bgr, options.line_width_px, &image);
  }
  if (!segmentation_mask.empty()) {
    DrawOutlines(segmentation_mask, options.segmentation_colour_bgr, options.line_width_px, &image);
  }

  std::vector<std::string> lines;
  std::string first(label);
  if (std::isfinite(score)) {
    char text[64];
    std::snprintf(text, sizeof(text), "%s%.3f", first.empty() ? "" : "  ", score);
    first += text;
  }
  if (!first.empty()) lines.push_back(first);
  if (options.frame_number >= 0) lines.push_back("frame " + std::to_string(options.frame_number));
  DrawTextBox(lines, options.text_scale, &image);
  return image;
}

}  // namespace silpose
