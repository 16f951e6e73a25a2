#pragma once
// Colour frames for synthetic sequences: what a camera would film of the object moving in front
// of a static background, for testing segmentation by background subtraction or colour
// thresholds. A frame is
//   background (an image, or a generated texture)  ->  the object shaded over it
//   (render/shaded_renderer.h, one colour per object)  ->  global brightness flicker  ->  Gaussian
//   camera noise.
// The background is the same in every frame; flicker and noise are drawn per frame from
// (seed, frame) alone, so any frame can be generated on its own, in any order, on any thread.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "silpose/render/shaded_renderer.h"

namespace silpose {

struct ColourOptions {
  /// Render colour frames at all (SyntheticFrame::colour; DIR/frames/ when written).
  bool enabled = false;
  /// Background image, CV_8UC3 (BGR) of any size: scaled to cover the camera image and cropped
  /// at its centre (FitBackground). Empty: a texture generated from `background_seed`
  /// (GenerateBackgroundTexture).
  cv::Mat background_image;
  uint64_t background_seed = 1;
  /// Surface colour of each object (B, G, R in [0, 255]): empty = DefaultObjectColour(i) for
  /// object i; one entry = that colour for all objects; otherwise one entry per object.
  std::vector<Eigen::Vector3d> object_colours_bgr;
  /// Light and material (render/shaded_renderer.h); its base colour and background are set per
  /// frame from the fields above.
  ShadedRenderOptions shading;
  /// Standard deviation of the camera noise, grey levels, in [0, 100]: independent Gaussian
  /// noise on every channel of every pixel (results rounded and clipped to [0, 255]).
  double noise_sigma = 0.0;
  /// Global brightness flicker, in [0, 0.5]: each frame's intensities are multiplied by
  /// 1 + flicker * u, with u uniform in [-1, 1] per frame.
  double flicker = 0.0;
  /// Seed of the noise and the flicker.
  uint64_t seed = 1;

  bool Check(std::string* error = nullptr) const;
};

/// A distinct, saturated colour for object `index` >= 0 (B, G, R), cycling through eight that
/// stand out from the muted generated background and from each other.
Eigen::Vector3d DefaultObjectColour(int index);

/// A deterministic CV_8UC3 texture of `width_px` x `height_px` for `seed`: a wall of smooth
/// coloured noise in the upper part and, below a horizon at 45% of the height, a table of wooden
/// planks in perspective. Muted colours, intensities within about [20, 230] so that camera noise
/// is rarely clipped. Throws silpose::Error if a size is not in [1, 16384].
cv::Mat GenerateBackgroundTexture(int width_px, int height_px, uint64_t seed);

/// `image` (CV_8UC3) scaled uniformly so that it covers width_px x height_px and cropped at its
/// centre to that size. Throws silpose::Error if the image is empty or not CV_8UC3.
cv::Mat FitBackground(const cv::Mat& image, int width_px, int height_px);

/// Reads a background image (any format OpenCV decodes; grey or with alpha is converted to BGR).
/// Throws silpose::Error naming the file if it is missing or cannot be decoded.
cv::Mat ReadBackgroundImage(const std::filesystem::path& path);

/// Applies frame `frame`'s flicker and camera noise (as `options` say) to a CV_8UC3 image in
/// place. Deterministic for (options.seed, frame, image); thread-safe.
void ApplyCameraEffects(const ColourOptions& options, int frame, cv::Mat* image);

}  // namespace silpose
