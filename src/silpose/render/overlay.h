#pragma once
// The picture a user checks tracking results on (paper Fig. 7): a video frame with the outline of
// its segmentation in red, the model drawn at the estimated pose in green (a translucent fill and
// its outline), and a text box with the object's name, the score and the frame number.

#include <opencv2/core.hpp>
#include <string>
#include <string_view>

#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/mesh/triangle_mesh.h"

namespace silpose {

/// A model at a pose, as seen by a camera: `camera_from_object` is the output files'
/// object_to_camera.
struct PosedModel {
  /// The model (not owned; must outlive the call). Required.
  const TriangleMesh* mesh = nullptr;
  /// The frame's camera; its image size must be the frame's.
  PinholeCamera camera;
  Rigid3 camera_from_object;
};

struct OverlayOptions {
  /// Colour of the segmentation outline, B, G, R.
  cv::Scalar segmentation_colour_bgr{0, 0, 255};
  /// Colour of the model's outline and fill, B, G, R.
  cv::Scalar model_colour_bgr{0, 255, 0};
  /// Line width of both outlines in pixels, in [1, 20]. Lines are anti-aliased.
  int line_width_px = 1;
  /// Opacity of the model's fill over the frame, in [0, 1] (0: outline only).
  double model_fill_opacity = 0.3;
  /// Frame number shown in the text box; negative: none.
  int frame_number = -1;
  /// Height of the text relative to OpenCV's Hershey font at scale 1 (about 22 px), in
  /// (0, 10]; 0.5 suits a 640 x 480 frame.
  double text_scale = 0.5;

  bool Check(std::string* error = nullptr) const;
};

/// Draws the overlay for one frame and returns it as a new CV_8UC3 image of the frame's size (the
/// inputs are not changed).
///  - frame: CV_8UC3 (BGR) or CV_8UC1 (grey, shown as grey).
///  - segmentation_mask: CV_8UC1 of the frame's size, non-zero = object; or empty. Every outer and
///    inner boundary of its regions is drawn in the segmentation colour, on the mask's boundary
///    pixels (the outline is drawn last, over the model).
///  - model: the model at the estimated pose, or nullptr when there is no pose (nothing green).
///    Its silhouette is rendered (RenderSilhouette), filled translucently and outlined.
///  - label, score: written in a box in the top-left corner as "label  0.873" (score with three
///    decimals; a NaN score is left out), with "frame N" on a second line when asked. No box if
///    there is nothing to write.
/// Throws silpose::Error if the frame is empty or of another type, the mask or the camera does
/// not match the frame's size, or the options are invalid.
cv::Mat DrawOverlay(const cv::Mat& frame, const cv::Mat& segmentation_mask, const PosedModel* model,
                    std::string_view label, double score, const OverlayOptions& options = {});

}  // namespace silpose
