#include "silpose/segment/gaussian_background.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/hal/intrin.hpp>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr uchar kForeground = 255;
constexpr uchar kShadow = 127;

struct ShadowRule {
  bool enabled = false;
  float ratio = 0.5f;  // lowest brightness ratio
  float scale = 0.0f;  // threshold * C
};

// True if the pixel x (C channels) is a darker copy of the background mean mu with variance v.
template <int C>
bool IsShadow(const uchar* x, const float* mu, float variance, const ShadowRule& rule) {
  float dot = 0.0f;
  float norm2 = 0.0f;
  for (int c = 0; c < C; ++c) {
    dot += static_cast<float>(x[c]) * mu[c];
    norm2 += mu[c] * mu[c];
  }
  if (!(norm2 > 0.0f)) return false;
  const float a = dot / norm2;
  if (a < rule.ratio || a > 1.0f) return false;
  float distance2 = 0.0f;
  for (int c = 0; c < C; ++c) {
    const float d = a * mu[c] - static_cast<float>(x[c]);
    distance2 += d * d;
  }
  return distance2 <= rule.scale * variance * a * a;
}

// One row: mask[x] = 255 where sum_c (pixel_c - mean_c)^2 > scale * variance, then shadows.
template <int C>
void ClassifyRow(const uchar* pixels, const float* const* mean, const float* variance, int width,
                 float scale, const ShadowRule& shadows, uchar* mask) {
  int x = 0;
#if CV_SIMD128
  const cv::v_float32x4 vscale = cv::v_setall_f32(scale);
  for (; x + 16 <= width; x += 16) {
    cv::v_uint8x16 channel[C];
    if constexpr (C == 3) {
      cv::v_load_deinterleave(pixels + 3 * x, channel[0], channel[1], channel[2]);
    } else {
      channel[0] = cv::v_load(pixels + x);
    }
    cv::v_float32x4 distance2[4] = {cv::v_setzero_f32(), cv::v_setzero_f32(), cv::v_setzero_f32(),
                                    cv::v_setzero_f32()};
    for (int c = 0; c < C; ++c) {
      cv::v_uint16x8 low16, high16;
      cv::v_expand(channel[c], low16, high16);
      cv::v_uint32x4 words[4];
      cv::v_expand(low16, words[0], words[1]);
      cv::v_expand(high16, words[2], words[3]);
      for (int k = 0; k < 4; ++k) {
        const cv::v_float32x4 d =
            cv::v_cvt_f32(cv::v_reinterpret_as_s32(words[k])) - cv::v_load(mean[c] + x + 4 * k);
        distance2[k] = cv::v_fma(d, d, distance2[k]);
      }
    }
    cv::v_uint32x4 outside[4];
    for (int k = 0; k < 4; ++k) {
      outside[k] =
          cv::v_reinterpret_as_u32(distance2[k] > vscale * cv::v_load(variance + x + 4 * k));
    }
    const cv::v_uint8x16 out =
        cv::v_pack(cv::v_pack(outside[0], outside[1]), cv::v_pack(outside[2], outside[3]));
    cv::v_store(mask + x, out);
    if (shadows.enabled && cv::v_check_any(out)) {
      for (int i = x; i < x + 16; ++i) {
        if (mask[i] == 0) continue;
        float mu[C];
        for (int c = 0; c < C; ++c) mu[c] = mean[c][i];
        if (IsShadow<C>(pixels + C * i, mu, variance[i], shadows)) mask[i] = kShadow;
      }
    }
  }
#endif
  for (; x < width; ++x) {
    float mu[C];
    float distance2 = 0.0f;
    for (int c = 0; c < C; ++c) {
      mu[c] = mean[c][x];
      const float d = static_cast<float>(pixels[C * x + c]) - mu[c];
      distance2 += d * d;
    }
    uchar value = 0;
    if (distance2 > scale * variance[x]) {
      value = shadows.enabled && IsShadow<C>(pixels + C * x, mu, variance[x], shadows)
                  ? kShadow
                  : kForeground;
    }
    mask[x] = value;
  }
}

// One row of learning at `rate`; only where mask is 0 unless every_pixel.
template <int C>
void LearnRow(const uchar* pixels, float* const* mean, float* variance, int width, float rate,
              float min_variance, float max_variance, const uchar* mask, bool every_pixel) {
  for (int x = 0; x < width; ++x) {
    if (!every_pixel && mask[x] != 0) continue;
    float distance2 = 0.0f;
    for (int c = 0; c < C; ++c) {
      const float d = static_cast<float>(pixels[C * x + c]) - mean[c][x];
      mean[c][x] += rate * d;
      distance2 += d * d;
    }
    const float v = variance[x] + rate * (distance2 / C - variance[x]);
    variance[x] = std::clamp(v, min_variance, max_variance);
  }
}

}  // namespace

GaussianBackground::GaussianBackground(const GaussianBackgroundOptions& options)
    : options_(options) {
  const auto& o = options;
  if (o.history < 1) ThrowError("gaussian background: history must be >= 1, got ", o.history);
  if (!(o.threshold > 0.0) || !std::isfinite(o.threshold)) {
    ThrowError("gaussian background: threshold must be > 0, got ", o.threshold);
  }
  if (!(o.shadow_ratio > 0.0 && o.shadow_ratio < 1.0)) {
    ThrowError("gaussian background: shadow_ratio must be in (0, 1), got ", o.shadow_ratio);
  }
  if (!(o.min_variance > 0.0) || !(o.max_variance >= o.min_variance) ||
      !std::isfinite(o.max_variance) || !(o.initial_variance >= o.min_variance) ||
      !(o.initial_variance <= o.max_variance)) {
    ThrowError("gaussian background: variances must satisfy 0 < min (", o.min_variance,
               ") <= initial (", o.initial_variance, ") <= max (", o.max_variance, ")");
  }
}

void GaussianBackground::clear() {
  frames_ = 0;
  for (cv::Mat& plane : mean_) plane.release();
  variance_.release();
}

void GaussianBackground::apply(cv::InputArray image_array, cv::OutputArray mask_array,
                               double rate) {
  const cv::Mat image = image_array.getMat();
  if (image.empty()) ThrowError("gaussian background: empty frame");
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    ThrowError("gaussian background: frames must be 8-bit with 1 or 3 channels, got OpenCV type ",
               image.type());
  }
  if (!std::isfinite(rate) || rate > 1.0) {
    ThrowError("gaussian background: learning rate must be < 0 (automatic) or in [0, 1], got ",
               rate);
  }
  if (frames_ > 0 && (image.size() != variance_.size() || image.type() != type_)) {
    ThrowError("gaussian background: frame of ", image.cols, " x ", image.rows, " with ",
               image.channels(), " channel(s) after frames of ", variance_.cols, " x ",
               variance_.rows, " with ", Channels());
  }
  mask_array.create(image.size(), CV_8UC1);
  cv::Mat mask = mask_array.getMat();
  if (frames_ == 0) {
    type_ = image.type();
    variance_.create(image.size(), CV_32FC1);
    // The first frame is the background: mean = frame, variance = the initial one.
    cv::Mat planes[3];
    cv::split(image, planes);
    for (int c = 0; c < Channels(); ++c) planes[c].convertTo(mean_[c], CV_32F);
    variance_.setTo(options_.initial_variance);
    mask.setTo(0);
    frames_ = 1;
    return;
  }
  Classify(image, mask);
  ++frames_;
  if (rate < 0.0) {
    const double automatic = 1.0 / std::min(2 * frames_, options_.history);
    Learn(image, mask, automatic, true);
  } else if (rate > 0.0) {
    Learn(image, mask, rate, false);
  }
}

void GaussianBackground::Classify(const cv::Mat& image, cv::Mat& mask) const {
  const float scale = static_cast<float>(options_.threshold * Channels());
  ShadowRule shadows;
  shadows.enabled = options_.detect_shadows;
  shadows.ratio = static_cast<float>(options_.shadow_ratio);
  shadows.scale = scale;
  for (int y = 0; y < image.rows; ++y) {
    const float* mean[3] = {nullptr, nullptr, nullptr};
    for (int c = 0; c < Channels(); ++c) mean[c] = mean_[c].ptr<float>(y);
    const float* variance = variance_.ptr<float>(y);
    if (Channels() == 3) {
      ClassifyRow<3>(image.ptr<uchar>(y), mean, variance, image.cols, scale, shadows,
                     mask.ptr<uchar>(y));
    } else {
      ClassifyRow<1>(image.ptr<uchar>(y), mean, variance, image.cols, scale, shadows,
                     mask.ptr<uchar>(y));
    }
  }
}

void GaussianBackground::Learn(const cv::Mat& image, const cv::Mat& mask, double rate,
                               bool every_pixel) {
  const float r = static_cast<float>(rate);
  const float low = static_cast<float>(options_.min_variance);
  const float high = static_cast<float>(options_.max_variance);
  for (int y = 0; y < image.rows; ++y) {
    float* mean[3] = {nullptr, nullptr, nullptr};
    for (int c = 0; c < Channels(); ++c) mean[c] = mean_[c].ptr<float>(y);
    float* variance = variance_.ptr<float>(y);
    if (Channels() == 3) {
      LearnRow<3>(image.ptr<uchar>(y), mean, variance, image.cols, r, low, high, mask.ptr<uchar>(y),
                  every_pixel);
    } else {
      LearnRow<1>(image.ptr<uchar>(y), mean, variance, image.cols, r, low, high, mask.ptr<uchar>(y),
                  every_pixel);
    }
  }
}

void GaussianBackground::getBackgroundImage(cv::OutputArray image) const {
  if (frames_ == 0) {
    image.release();
    return;
  }
  cv::Mat planes[3];
  for (int c = 0; c < Channels(); ++c) mean_[c].convertTo(planes[c], CV_8U);
  cv::merge(planes, static_cast<size_t>(Channels()), image);
}

}  // namespace silpose
