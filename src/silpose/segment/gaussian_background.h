#pragma once
// A background model with one Gaussian per pixel, for a static camera (the `gauss` method of
// bgsub, segment/segmenter.h). Cheaper than OpenCV's MOG2 and KNN: a frozen model (what silpose's
// segmenter uses after learning) tests a frame in one pass with vector instructions; with the
// clean-up, a 640 x 480 colour frame is segmented in about a fifth of MOG2's time
// (docs/PERFORMANCE.md). It cannot learn a background of more than one colour per pixel.
//
// Per pixel: the background's mean colour mu (one value per channel) and one variance v per
// channel, shared by the channels (isotropic, as MOG2's components). A pixel x is
//   foreground  if  d2 = sum_c (x_c - mu_c)^2  >  threshold * C * v   (C channels),
// background otherwise; threshold is the squared distance in standard deviations of the channels'
// sum, as MOG2's varThreshold (16 = 4 sigma). With shadow detection a foreground pixel is a shadow
// (value 127 in the mask) when it is a darker copy of the background: with a = x.mu / mu.mu, the
// brightness ratio, in [shadow_ratio, 1] and |x - a mu|^2 <= threshold * C * v * a^2 (the shadow
// rule of Prati et al. 2003 that MOG2 applies).
//
// Learning, as OpenCV's subtractors do it: the first frame, whatever the rate, sets mu = x and
// v = initial_variance (and its mask is empty); then apply(frame, mask, rate) with
//   rate < 0   automatic: 1 / min(2 n, history) for the n-th frame, a running average of the
//              frames so far; every pixel is learned;
//   rate = 0   the model is frozen: the frame is only classified;
//   rate > 0   mu += rate (x - mu), v += rate (d2 / C - v) at the pixels classified background
//              only, so that an object that stops is not learned into the background.
// v is kept within [min_variance, max_variance].
//
// Frames: 8-bit, 1 or 3 channels; every frame of the size and type of the first (else throws
// silpose::Error). The mask is CV_8UC1: 255 foreground, 127 shadow, 0 background.

#include <opencv2/core.hpp>
#include <opencv2/video/background_segm.hpp>

namespace silpose {

struct GaussianBackgroundOptions {
  /// Frames of the automatic learning rate's window (OpenCV's `history`), >= 1.
  int history = 30;
  /// Squared distance, in variances of the channels' sum, above which a pixel is foreground; > 0.
  double threshold = 16.0;
  bool detect_shadows = true;
  /// Lowest brightness ratio of a shadow to the background, in (0, 1) (MOG2's tau).
  double shadow_ratio = 0.5;
  /// Per-channel variance in grey levels squared: set at a pixel's first frame, and the bounds
  /// kept while learning. They are MOG2's for the sum of three channels (15, 4 and 75) divided by
  /// three: a noiseless still image does not make every rounding difference foreground (min:
  /// sigma 1.15), and flicker does not hide objects (max: sigma 5).
  double initial_variance = 5.0;
  double min_variance = 4.0 / 3.0;
  double max_variance = 25.0;
};

class GaussianBackground final : public cv::BackgroundSubtractor {
 public:
  /// Throws silpose::Error if an option is out of range.
  explicit GaussianBackground(const GaussianBackgroundOptions& options = {});

  /// Classifies `image` into `mask` (255 / 127 / 0, see the file comment), then learns it at
  /// `rate` (see the file comment).
  void apply(cv::InputArray image, cv::OutputArray mask, double rate = -1) override;
  /// The mean colour, 8-bit, of the frames' type; empty before the first frame.
  void getBackgroundImage(cv::OutputArray image) const override;

  /// Forgets everything learned: the next frame is a first frame.
  void clear() override;
  bool empty() const override { return frames_ == 0; }

  /// The per-pixel variance (CV_32FC1, grey levels squared, per channel); empty before the first
  /// frame.
  const cv::Mat& variance() const { return variance_; }
  const GaussianBackgroundOptions& options() const { return options_; }

 private:
  void Classify(const cv::Mat& image, cv::Mat& mask) const;
  void Learn(const cv::Mat& image, const cv::Mat& mask, double rate, bool every_pixel);

  GaussianBackgroundOptions options_;
  // The frames' channels (1 or 3), from their type.
  int Channels() const { return CV_MAT_CN(type_); }

  int frames_ = 0;
  int type_ = 0;      // of the first frame; the size is the variance's
  cv::Mat mean_[3];   // CV_32FC1 per channel, the frames' channel order
  cv::Mat variance_;  // CV_32FC1
};

}  // namespace silpose
