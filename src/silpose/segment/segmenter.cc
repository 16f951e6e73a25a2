#include "silpose/segment/segmenter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/background_segm.hpp>
#include <sstream>
#include <utility>
#include <vector>

#include "silpose/io/image_codec.h"
#include "silpose/segment/gaussian_background.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

template <typename Enum, size_t N>
Enum ParseName(std::string_view name, const char* what, const Enum (&choices)[N]) {
  for (const Enum choice : choices) {
    if (name == ToString(choice)) return choice;
  }
  std::ostringstream list;
  for (size_t i = 0; i < N; ++i) list << (i == 0 ? "" : ", ") << ToString(choices[i]);
  ThrowError("unknown ", what, " '", name, "'; choose one of: ", list.str());
}

bool Finite(double value) { return std::isfinite(value); }

std::string Percent(double fraction) {
  std::ostringstream text;
  text.precision(fraction < 0.01 ? 2 : 3);
  text << 100.0 * fraction << "%";
  return text.str();
}

// Any supported depth -> 8 bits, same channels.
cv::Mat ToEightBit(const cv::Mat& frame) {
  switch (frame.depth()) {
    case CV_8U:
      return frame;
    case CV_16U: {
      cv::Mat converted;
      frame.convertTo(converted, CV_8U, 1.0 / 257.0);
      return converted;
    }
    case CV_32F: {
      cv::Mat converted;
      frame.convertTo(converted, CV_8U, 255.0);
      return converted;
    }
    default:
      ThrowError("segmentation: frame depth must be 8-bit, 16-bit unsigned or 32-bit float, got ",
                 "OpenCV depth ", frame.depth());
  }
}

// 8-bit frame of 1, 3 or 4 channels -> grey or BGR.
cv::Mat ToGreyOrBgr(const cv::Mat& frame) {
  if (frame.channels() == 1 || frame.channels() == 3) return frame;
  if (frame.channels() == 4) {
    cv::Mat bgr;
    cv::cvtColor(frame, bgr, cv::COLOR_BGRA2BGR);
    return bgr;
  }
  ThrowError("segmentation: frames must have 1 (grey), 3 (BGR) or 4 (BGRA) channels, got ",
             frame.channels());
}

// The frame shrunk by `factor` (area averaging over whole factor x factor blocks; a remainder of
// less than `factor` rows or columns is dropped), in `buffer`; the frame itself if factor is 1.
cv::Mat Shrink(const cv::Mat& frame, int factor, cv::Mat* buffer) {
  if (factor == 1) return frame;
  const cv::Size small(std::max(1, frame.cols / factor), std::max(1, frame.rows / factor));
  const cv::Rect covered(0, 0, std::min(frame.cols, small.width * factor),
                         std::min(frame.rows, small.height * factor));
  cv::resize(frame(covered), *buffer, small, 0, 0, cv::INTER_AREA);
  return *buffer;
}

// Area, bounding box and centre of gravity of each label of a CV_32S label image (0 = none), in one
// pass over runs of equal labels. What cv::connectedComponentsWithStats reports, and the same
// numbers (integer sums, one division); that function took 10-20 times as long as the labelling
// alone in OpenCV 4.6 (0.45-0.9 ms against 0.04 ms for a 240 x 240 box around a disc).
struct ComponentStats {
  int64_t area = 0;
  int64_t sum_x = 0;
  int64_t sum_y = 0;
  int left = std::numeric_limits<int>::max();
  int top = std::numeric_limits<int>::max();
  int right = -1;
  int bottom = -1;
  double CentreX() const { return static_cast<double>(sum_x) / static_cast<double>(area); }
  double CentreY() const { return static_cast<double>(sum_y) / static_cast<double>(area); }
};

void MeasureComponents(const cv::Mat& labels, int count, std::vector<ComponentStats>* stats) {
  stats->assign(static_cast<size_t>(std::max(count, 1)), ComponentStats{});
  for (int y = 0; y < labels.rows; ++y) {
    const int* row = labels.ptr<int>(y);
    for (int x = 0; x < labels.cols;) {
      const int label = row[x];
      int end = x + 1;
      while (end < labels.cols && row[end] == label) ++end;
      if (label > 0) {
        ComponentStats& s = (*stats)[static_cast<size_t>(label)];
        const int64_t run = end - x;
        s.area += run;
        s.sum_x += (int64_t{x} + end - 1) * run / 2;
        s.sum_y += int64_t{y} * run;
        s.left = std::min(s.left, x);
        s.right = std::max(s.right, end - 1);
        s.top = std::min(s.top, y);
        s.bottom = std::max(s.bottom, y);
      }
      x = end;
    }
  }
}

// The kind-specific step: working frame -> raw foreground (CV_8UC1, 255 = object; other non-zero
// values such as shadows are dropped by the caller's cut at 128), or a status explaining why not.
class ForegroundModel {
 public:
  virtual ~ForegroundModel() = default;
  // Returns kOk with `foreground` set, or kLearning with `message` set.
  // `full` is the frame's size before downscaling.
  virtual SegmentationStatus Foreground(const cv::Mat& working, const cv::Size& full,
                                        cv::Mat* foreground, std::string* message) = 0;
  virtual void Reset() {}
};

class MaskModel final : public ForegroundModel {
 public:
  explicit MaskModel(int threshold) : threshold_(threshold) {}
  SegmentationStatus Foreground(const cv::Mat& working, const cv::Size&, cv::Mat* foreground,
                                std::string*) override {
    cv::Mat single = working;
    if (working.channels() > 1) {
      // Largest colour channel value per pixel (alpha ignored): one row per pixel, reduced
      // across its channels. reshape needs continuous data (an ROI is copied).
      cv::Mat colour = working;
      if (working.channels() == 4) {
        cv::cvtColor(working, colour, cv::COLOR_BGRA2BGR);
      } else if (!working.isContinuous()) {
        colour = working.clone();
      }
      const cv::Mat rows = colour.reshape(1, static_cast<int>(colour.total()));
      cv::reduce(rows, single, 1, cv::REDUCE_MAX);
      single = single.reshape(1, colour.rows);
    }
    // Pixels above the threshold lie inside the box of the non-zero ones: only that box is
    // thresholded (a mask frame is mostly background).
    foreground->create(single.size(), CV_8UC1);
    foreground->setTo(0);
    const cv::Rect box = NonZeroBoundingBox(single);
    if (!box.empty()) {
      cv::Mat inside = (*foreground)(box);
      cv::threshold(single(box), inside, threshold_, 255, cv::THRESH_BINARY);
    }
    return SegmentationStatus::kOk;
  }

 private:
  int threshold_;
};

class ThresholdModel final : public ForegroundModel {
 public:
  explicit ThresholdModel(const SegmenterOptions& options) : options_(options) {}
  SegmentationStatus Foreground(const cv::Mat& working, const cv::Size&, cv::Mat* foreground,
                                std::string*) override {
    if (options_.threshold_method == ThresholdMethod::kOtsu) {
      cv::Mat grey = working;
      if (working.channels() == 3) cv::cvtColor(working, grey, cv::COLOR_BGR2GRAY);
      const int type = options_.otsu_object == ObjectPolarity::kDarker ? cv::THRESH_BINARY_INV
                                                                       : cv::THRESH_BINARY;
      cv::threshold(grey, *foreground, 0, 255, type | cv::THRESH_OTSU);
      return SegmentationStatus::kOk;
    }
    cv::Mat bgr = working;
    if (working.channels() == 1) cv::cvtColor(working, bgr, cv::COLOR_GRAY2BGR);
    cv::cvtColor(bgr, hsv_, cv::COLOR_BGR2HSV);
    const cv::Scalar& lower = options_.hsv_lower;
    const cv::Scalar& upper = options_.hsv_upper;
    if (lower[0] <= upper[0]) {
      cv::inRange(hsv_, lower, upper, *foreground);
    } else {  // the hue range wraps through 0
      cv::inRange(hsv_, lower, cv::Scalar(180, upper[1], upper[2]), *foreground);
      cv::inRange(hsv_, cv::Scalar(0, lower[1], lower[2]), upper, second_);
      cv::bitwise_or(*foreground, second_, *foreground);
    }
    return SegmentationStatus::kOk;
  }

 private:
  SegmenterOptions options_;
  cv::Mat hsv_;
  cv::Mat second_;
};

class BackgroundModel final : public ForegroundModel {
 public:
  explicit BackgroundModel(const SegmenterOptions& options) : options_(options) {
    if (!options.background_image_path.empty()) {
      const std::filesystem::path path(options.background_image_path);
      std::error_code error;
      if (!std::filesystem::is_regular_file(path, error)) {
        ThrowError(options.background_image_path, ": background image not found");
      }
      background_image_ = ReadImage(options.background_image_path, cv::IMREAD_UNCHANGED);
      if (background_image_.empty()) {
        ThrowError(options.background_image_path,
                   ": not an image OpenCV can read (background_image_path)");
      }
      background_image_ = ToGreyOrBgr(ToEightBit(background_image_));
    }
    Reset();
  }

  void Reset() override {
    Forget();
    use_image_ = !background_image_.empty();
  }

  // Relearning after a permanent change uses the live frames: the image no longer shows the scene.
  void Relearn() {
    Forget();
    use_image_ = false;
  }

  // True if the last Foreground() looked for an object while still learning (until-object): the
  // caller then reports with AfterProbe whether it found one.
  bool probing() const { return probing_; }
  int frames_learned() const { return frames_learned_; }
  bool frozen() const { return frozen_; }

  // until-object: a frame without an object is learned; `object_confirm_frames` consecutive frames
  // with one end the learning.
  void AfterProbe(const cv::Mat& working, bool found_object) {
    probing_ = false;
    if (found_object) {
      if (++found_run_ >= options_.object_confirm_frames) frozen_ = true;
      return;
    }
    found_run_ = 0;
    ++frames_learned_;
    // OpenCV's automatic rate 1 / min(2 n, history), given explicitly: the probing calls count
    // as frames in OpenCV's own counter.
    const double rate = 1.0 / std::min(2 * frames_learned_, options_.learning_frames);
    model_->apply(working, ignored_, rate);
  }

  SegmentationStatus Foreground(const cv::Mat& working, const cv::Size& full, cv::Mat* foreground,
                                std::string* message) override {
    if (model_.empty()) {
      Create();
      if (use_image_) LearnFromImage(working, full);
    } else if (working.size() != size_ || working.type() != type_) {
      ThrowError("segmentation (bgsub): frame of ", working.cols, " x ", working.rows, " with ",
                 working.channels(), " channel(s) after frames of ", size_.width, " x ",
                 size_.height, " with ", CV_MAT_CN(type_), " (after downscale ", options_.downscale,
                 ")");
    }
    size_ = working.size();
    type_ = working.type();
    probing_ = false;
    const bool until_object = options_.background_learning == BackgroundLearning::kUntilObject;
    const int first_frames = until_object ? options_.min_learning_frames : options_.learning_frames;
    if (!frozen_ && frames_learned_ < first_frames) {
      // OpenCV's automatic rate 1 / min(2 n, history): a running average over the frames so far.
      model_->apply(working, *foreground, -1.0);
      ++frames_learned_;
      std::ostringstream text;
      text << "learning the background (frame " << frames_learned_ << " of "
           << (until_object ? "at least " : "") << first_frames << ")";
      *message = text.str();
      return SegmentationStatus::kLearning;
    }
    if (!frozen_ && !until_object) frozen_ = true;
    if (!frozen_) {
      // Look for an object without learning the frame; AfterProbe learns it if there is none.
      model_->apply(working, *foreground, DetectionRate());
      probing_ = true;
      return SegmentationStatus::kOk;
    }
    model_->apply(working, *foreground, Rate());
    return SegmentationStatus::kOk;
  }

 private:
  void Create() {
    const int history = options_.learning_frames;
    if (options_.background_method == BackgroundMethod::kMog2) {
      model_ = cv::createBackgroundSubtractorMOG2(history, options_.mog2_variance_threshold,
                                                  options_.detect_shadows);
    } else if (options_.background_method == BackgroundMethod::kKnn) {
      model_ = cv::createBackgroundSubtractorKNN(history, options_.knn_distance2_threshold,
                                                 options_.detect_shadows);
    } else {
      GaussianBackgroundOptions gauss;
      gauss.history = history;
      gauss.threshold = options_.gauss_variance_threshold;
      gauss.detect_shadows = options_.detect_shadows;
      model_ = cv::makePtr<GaussianBackground>(gauss);
    }
  }

  double Rate() const {
    // KNN derives its sample refresh periods from log(1 - rate): 0 would divide by zero.
    if (options_.background_method == BackgroundMethod::kKnn) {
      return std::max(options_.learning_rate, 1e-7);
    }
    return options_.learning_rate;
  }

  double DetectionRate() const {
    return options_.background_method == BackgroundMethod::kKnn ? 1e-7 : 0.0;
  }

  void Forget() {
    model_.release();
    frames_learned_ = 0;
    found_run_ = 0;
    frozen_ = false;
    probing_ = false;
  }

  void LearnFromImage(const cv::Mat& working, const cv::Size& full) {
    if (background_image_.channels() != working.channels()) {
      cv::Mat converted;
      cv::cvtColor(background_image_, converted,
                   working.channels() == 1 ? cv::COLOR_BGR2GRAY : cv::COLOR_GRAY2BGR);
      background_image_ = converted;
    }
    if (background_image_.size() != full) {
      ThrowError(options_.background_image_path, ": background image is ", background_image_.cols,
                 " x ", background_image_.rows, " pixels but the frames are ", full.width, " x ",
                 full.height);
    }
    const int factor = options_.downscale;
    const cv::Mat image = Shrink(background_image_, factor, &shrunk_image_);
    // Area averaging over factor^2 pixels divides independent noise by the factor.
    const double sigma = options_.background_image_noise / factor;
    cv::RNG random(0x5e9e47);
    cv::Mat noise(image.size(), CV_MAKETYPE(CV_16S, image.channels()));
    cv::Mat noisy;
    cv::Mat ignored;
    for (int i = 0; i < options_.learning_frames; ++i) {
      random.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
      cv::add(image, noise, noisy, cv::noArray(), image.depth());
      model_->apply(noisy, ignored, -1.0);
    }
    frames_learned_ = options_.learning_frames;
    frozen_ = true;
  }

  SegmenterOptions options_;
  cv::Mat background_image_;
  cv::Mat shrunk_image_;
  cv::Ptr<cv::BackgroundSubtractor> model_;
  bool use_image_ = false;
  int frames_learned_ = 0;
  int found_run_ = 0;     // until-object: consecutive frames with an object
  bool frozen_ = false;   // learning is over
  bool probing_ = false;  // see probing()
  cv::Mat ignored_;
  cv::Size size_;
  int type_ = 0;
};

class PipelineSegmenter final : public Segmenter {
 public:
  explicit PipelineSegmenter(const SegmenterOptions& options) : options_(options) {
    switch (options.kind) {
      case SegmenterKind::kMask:
        model_ = std::make_unique<MaskModel>(options.mask_threshold);
        break;
      case SegmenterKind::kBackground: {
        auto background = std::make_unique<BackgroundModel>(options);
        background_ = background.get();
        model_ = std::move(background);
        break;
      }
      case SegmenterKind::kThreshold:
        model_ = std::make_unique<ThresholdModel>(options);
        break;
    }
    SILPOSE_ASSERT(model_ != nullptr);
    factor_ = options.kind == SegmenterKind::kMask ? 1 : options.downscale;
    const int radius = static_cast<int>(std::lround(options.MorphologyPx() / double(factor_)));
    if (options.MorphologyPx() > 0) {
      const int r = std::max(1, radius);
      kernel_ = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1));
    }
  }

  const SegmenterOptions& options() const override { return options_; }

  void Reset() override {
    model_->Reset();
    has_previous_ = false;
    too_large_run_ = 0;
  }

  SegmentationResult Segment(const cv::Mat& frame) override {
    if (frame.empty()) ThrowError("segmentation: frame is empty (0 x 0 pixels)");
    cv::Mat eight = ToEightBit(frame);
    if (options_.kind != SegmenterKind::kMask) eight = ToGreyOrBgr(eight);
    const cv::Size full = frame.size();
    const cv::Mat working = Shrink(eight, factor_, &working_);
    SegmentationResult result = SegmentWorking(working, full);
    if (background_ != nullptr && background_->probing()) {
      const bool found = result.ok();
      background_->AfterProbe(working, found);
      std::ostringstream text;
      if (result.status == SegmentationStatus::kTooLarge) {
        // A lighting change while the scene is empty: learned too, and reported as it is.
        text << result.message << " (still learning the background)";
        result.message = text.str();
      } else if (!found) {
        text << "learning the background until an object appears (" << background_->frames_learned()
             << " frames learned; " << result.message << ")";
        result.status = SegmentationStatus::kLearning;
        result.message = text.str();
      } else if (background_->frozen()) {
        text << result.message << "; background learned from " << background_->frames_learned()
             << " frames";
        result.message = text.str();
      }
    }
    return result;
  }

 private:
  SegmentationResult SegmentWorking(const cv::Mat& working, const cv::Size& full) {
    SegmentationResult result;
    // Not Mat::zeros: see shape/polar_signature.cc (trackers run on several threads at once).
    result.mask = cv::Mat(full, CV_8UC1, cv::Scalar(0));
    result.status = model_->Foreground(working, full, &raw_, &result.message);
    if (result.status != SegmentationStatus::kOk) return result;

    if (background_ != nullptr) {
      // Shadows (127) and anything else below half are background.
      cv::threshold(raw_, foreground_, 127, 255, cv::THRESH_BINARY);
    } else {
      foreground_ = raw_;  // already 0 / 255
    }
    if (!kernel_.empty()) {
      // Closing first: an object whose colour is near the background's comes out riddled with
      // holes, and opening first breaks it apart (low-contrast test: IoU 0.04-0.2 open-close vs
      // 0.93-0.97 close-open at downscale 1); camera noise specks are sparse, so closing rarely
      // joins them into blobs the opening cannot remove (a median filter first did worse on both).
      cv::morphologyEx(foreground_, foreground_, cv::MORPH_CLOSE, kernel_);
      cv::morphologyEx(foreground_, foreground_, cv::MORPH_OPEN, kernel_);
    }
    const double working_area = static_cast<double>(foreground_.total());
    result.foreground_fraction = cv::countNonZero(foreground_) / working_area;
    if (result.foreground_fraction > options_.max_foreground_fraction) {
      result.status = SegmentationStatus::kTooLarge;
      std::ostringstream text;
      text << "foreground covers " << Percent(result.foreground_fraction) << " of the frame > "
           << Percent(options_.max_foreground_fraction)
           << " (max_foreground_fraction): lighting change or camera moved?";
      ++too_large_run_;
      if (background_ != nullptr && !background_->probing() && options_.relearn_after_frames > 0 &&
          too_large_run_ >= options_.relearn_after_frames) {
        background_->Relearn();
        too_large_run_ = 0;
        text << "; " << options_.relearn_after_frames
             << " such frames in a row: learning the background anew";
      }
      result.message = text.str();
      return result;
    }
    too_large_run_ = 0;
    if (result.foreground_fraction == 0.0) {
      result.status = SegmentationStatus::kEmpty;
      result.message = "no foreground";
      return result;
    }
    ChooseComponent(full, &result);
    return result;
  }

  void ChooseComponent(const cv::Size& full, SegmentationResult* result) {
    // Labelling only the box around all foreground pixels: usually a small part of the frame.
    const cv::Rect region = NonZeroBoundingBox(foreground_);
    const int count = cv::connectedComponents(foreground_(region), labels_, 8, CV_32S);
    MeasureComponents(labels_, count, &components_);
    const double scale = factor_;
    const double min_area_working = options_.min_area_fraction * double(foreground_.total());
    int chosen = -1;
    int largest_area = 0;
    double best = 0.0;
    for (int label = 1; label < count; ++label) {
      const ComponentStats& component = components_[static_cast<size_t>(label)];
      const int area = static_cast<int>(component.area);
      largest_area = std::max(largest_area, area);
      if (area < min_area_working || area == 0) continue;
      ++result->num_components;
      // Component centre in full-resolution pixels: working pixel centre (x + 0.5) * scale - 0.5.
      const Eigen::Vector2d centre((component.CentreX() + region.x + 0.5) * scale - 0.5,
                                   (component.CentreY() + region.y + 0.5) * scale - 0.5);
      double score = area;
      if (options_.component == SegmentComponent::kNearestPrevious && has_previous_) {
        score = -(centre - previous_centre_px_).squaredNorm();
      }
      if (chosen < 0 || score > best) {
        chosen = label;
        best = score;
      }
    }
    if (chosen < 0) {
      result->status = SegmentationStatus::kEmpty;
      std::ostringstream text;
      text << "largest component " << std::lround(largest_area * scale * scale) << " px < minimum "
           << std::lround(options_.min_area_fraction * double(full.area()))
           << " px (min_area_fraction " << options_.min_area_fraction << ")";
      result->message = text.str();
      return;
    }
    const ComponentStats& component = components_[static_cast<size_t>(chosen)];
    const cv::Rect box(component.left + region.x, component.top + region.y,
                       component.right - component.left + 1, component.bottom - component.top + 1);
    cv::Rect box_full;
    if (factor_ == 1) {
      cv::Mat target = result->mask(region);
      cv::compare(labels_, chosen, target, cv::CMP_EQ);
      box_full = box;
    } else {
      // Bilinear upscaling cut at half gives a smooth outline, not factor-sized steps.
      chosen_.create(foreground_.size(), CV_8UC1);
      chosen_.setTo(cv::Scalar(0));
      cv::Mat target = chosen_(region);
      cv::compare(labels_, chosen, target, cv::CMP_EQ);
      const cv::Size covered(std::min(full.width, chosen_.cols * factor_),
                             std::min(full.height, chosen_.rows * factor_));
      cv::Mat up;
      cv::resize(chosen_, up, cv::Size(chosen_.cols * factor_, chosen_.rows * factor_), 0, 0,
                 cv::INTER_LINEAR);
      cv::threshold(up, up, 127, 255, cv::THRESH_BINARY);
      up(cv::Rect(0, 0, covered.width, covered.height))
          .copyTo(result->mask(cv::Rect(0, 0, covered.width, covered.height)));
      box_full = cv::Rect(box.x * factor_ - factor_, box.y * factor_ - factor_,
                          (box.width + 2) * factor_, (box.height + 2) * factor_) &
                 cv::Rect(0, 0, full.width, full.height);
    }
    // Moments of the component's box only: the rest of the mask is zero.
    Eigen::Vector2d centroid;
    result->area_px = PixelAreaCentroid(result->mask(box_full), &centroid);
    if (result->area_px > 0.0) {
      result->centroid_px = Eigen::Vector2d(box_full.x, box_full.y) + centroid;
    }
    result->status = SegmentationStatus::kOk;
    std::ostringstream text;
    text << "silhouette of " << std::lround(result->area_px) << " px, " << result->num_components
         << " component(s), foreground " << Percent(result->foreground_fraction);
    result->message = text.str();
    previous_centre_px_ = result->centroid_px;
    has_previous_ = true;
  }

  SegmenterOptions options_;
  std::unique_ptr<ForegroundModel> model_;
  BackgroundModel* background_ = nullptr;  // model_ when kind is bgsub
  int factor_ = 1;
  cv::Mat kernel_;
  bool has_previous_ = false;
  Eigen::Vector2d previous_centre_px_ = Eigen::Vector2d::Zero();
  int too_large_run_ = 0;
  // Buffers kept between frames to avoid reallocations.
  cv::Mat working_, raw_, foreground_, labels_, chosen_;
  std::vector<ComponentStats> components_;
};

}  // namespace

const char* ToString(SegmenterKind kind) {
  switch (kind) {
    case SegmenterKind::kMask:
      return "mask";
    case SegmenterKind::kBackground:
      return "bgsub";
    case SegmenterKind::kThreshold:
      return "threshold";
  }
  return "?";
}

SegmenterKind ParseSegmenterKind(std::string_view name) {
  static constexpr SegmenterKind kChoices[] = {SegmenterKind::kMask, SegmenterKind::kBackground,
                                               SegmenterKind::kThreshold};
  return ParseName(name, "segmentation kind", kChoices);
}

const char* ToString(BackgroundMethod method) {
  switch (method) {
    case BackgroundMethod::kMog2:
      return "mog2";
    case BackgroundMethod::kKnn:
      return "knn";
    case BackgroundMethod::kGaussian:
      return "gauss";
  }
  return "?";
}

BackgroundMethod ParseBackgroundMethod(std::string_view name) {
  static constexpr BackgroundMethod kChoices[] = {BackgroundMethod::kMog2, BackgroundMethod::kKnn,
                                                  BackgroundMethod::kGaussian};
  return ParseName(name, "background subtraction method", kChoices);
}

const char* ToString(BackgroundLearning learning) {
  switch (learning) {
    case BackgroundLearning::kUntilObject:
      return "until-object";
    case BackgroundLearning::kFrames:
      return "frames";
  }
  return "?";
}

BackgroundLearning ParseBackgroundLearning(std::string_view name) {
  static constexpr BackgroundLearning kChoices[] = {BackgroundLearning::kUntilObject,
                                                    BackgroundLearning::kFrames};
  return ParseName(name, "background learning", kChoices);
}

const char* ToString(ThresholdMethod method) {
  switch (method) {
    case ThresholdMethod::kOtsu:
      return "otsu";
    case ThresholdMethod::kHsvRange:
      return "hsv";
  }
  return "?";
}

ThresholdMethod ParseThresholdMethod(std::string_view name) {
  static constexpr ThresholdMethod kChoices[] = {ThresholdMethod::kOtsu,
                                                 ThresholdMethod::kHsvRange};
  return ParseName(name, "threshold method", kChoices);
}

const char* ToString(ObjectPolarity polarity) {
  switch (polarity) {
    case ObjectPolarity::kDarker:
      return "darker";
    case ObjectPolarity::kBrighter:
      return "brighter";
  }
  return "?";
}

ObjectPolarity ParseObjectPolarity(std::string_view name) {
  static constexpr ObjectPolarity kChoices[] = {ObjectPolarity::kDarker, ObjectPolarity::kBrighter};
  return ParseName(name, "object polarity", kChoices);
}

const char* ToString(SegmentComponent component) {
  switch (component) {
    case SegmentComponent::kLargest:
      return "largest";
    case SegmentComponent::kNearestPrevious:
      return "nearest";
  }
  return "?";
}

SegmentComponent ParseSegmentComponent(std::string_view name) {
  static constexpr SegmentComponent kChoices[] = {SegmentComponent::kLargest,
                                                  SegmentComponent::kNearestPrevious};
  return ParseName(name, "component choice", kChoices);
}

const char* ToString(SegmentationStatus status) {
  switch (status) {
    case SegmentationStatus::kOk:
      return "ok";
    case SegmentationStatus::kLearning:
      return "learning";
    case SegmentationStatus::kEmpty:
      return "empty";
    case SegmentationStatus::kTooLarge:
      return "too-large";
  }
  return "?";
}

int SegmenterOptions::MorphologyPx() const {
  if (morphology_px >= 0) return morphology_px;
  return kind == SegmenterKind::kMask ? 0 : 2;
}

bool SegmenterOptions::Check(std::string* error) const {
  std::ostringstream message;
  const auto hsv_ok = [](const cv::Scalar& value) {
    return value[0] >= 0 && value[0] < 180 && value[1] >= 0 && value[1] <= 255 && value[2] >= 0 &&
           value[2] <= 255;
  };
  if (kind != SegmenterKind::kMask && kind != SegmenterKind::kBackground &&
      kind != SegmenterKind::kThreshold) {
    message << "kind: unknown value " << int(kind);
  } else if (mask_threshold < 0 || mask_threshold > 254) {
    message << "mask_threshold must be in [0, 254], got " << mask_threshold;
  } else if (learning_frames < 1 || learning_frames > 100000) {
    message << "learning_frames must be in [1, 100000], got " << learning_frames;
  } else if (background_learning != BackgroundLearning::kUntilObject &&
             background_learning != BackgroundLearning::kFrames) {
    message << "background_learning: unknown value " << int(background_learning);
  } else if (min_learning_frames < 1 || min_learning_frames > 100000) {
    message << "min_learning_frames must be in [1, 100000], got " << min_learning_frames;
  } else if (object_confirm_frames < 1 || object_confirm_frames > 1000) {
    message << "object_confirm_frames must be in [1, 1000], got " << object_confirm_frames;
  } else if (!(learning_rate >= 0.0 && learning_rate < 1.0)) {
    message << "learning_rate must be in [0, 1), got " << learning_rate;
  } else if (!(background_image_noise >= 0.0 && background_image_noise <= 50.0)) {
    message << "background_image_noise must be in [0, 50] grey levels, got "
            << background_image_noise;
  } else if (!(mog2_variance_threshold > 0.0) || !Finite(mog2_variance_threshold)) {
    message << "mog2_variance_threshold must be > 0, got " << mog2_variance_threshold;
  } else if (!(gauss_variance_threshold > 0.0) || !Finite(gauss_variance_threshold)) {
    message << "gauss_variance_threshold must be > 0, got " << gauss_variance_threshold;
  } else if (!(knn_distance2_threshold > 0.0) || !Finite(knn_distance2_threshold)) {
    message << "knn_distance2_threshold must be > 0, got " << knn_distance2_threshold;
  } else if (relearn_after_frames < 0) {
    message << "relearn_after_frames must be >= 0 (0 = never), got " << relearn_after_frames;
  } else if (!hsv_ok(hsv_lower) || !hsv_ok(hsv_upper)) {
    message << "hsv_lower and hsv_upper must have H in [0, 180), S and V in [0, 255], got ("
            << hsv_lower[0] << ", " << hsv_lower[1] << ", " << hsv_lower[2] << ") and ("
            << hsv_upper[0] << ", " << hsv_upper[1] << ", " << hsv_upper[2] << ")";
  } else if (hsv_lower[1] > hsv_upper[1] || hsv_lower[2] > hsv_upper[2]) {
    message << "hsv_lower must not exceed hsv_upper in S and V (only H may wrap)";
  } else if (kind == SegmenterKind::kThreshold && threshold_method == ThresholdMethod::kHsvRange &&
             hsv_lower[0] == 0 && hsv_upper[0] >= 179 && hsv_lower[1] == 0 && hsv_upper[1] >= 255 &&
             hsv_lower[2] == 0 && hsv_upper[2] >= 255) {
    message << "hsv_lower / hsv_upper select every colour: set the object's range";
  } else if (morphology_px < -1 || morphology_px > 50) {
    message << "morphology_px must be in [0, 50] or -1 (kind's default), got " << morphology_px;
  } else if (!(min_area_fraction >= 0.0 && min_area_fraction < 1.0)) {
    message << "min_area_fraction must be in [0, 1), got " << min_area_fraction;
  } else if (!(max_foreground_fraction > 0.0 && max_foreground_fraction <= 1.0)) {
    message << "max_foreground_fraction must be in (0, 1], got " << max_foreground_fraction;
  } else if (downscale < 1 || downscale > 8) {
    message << "downscale must be an integer in [1, 8], got " << downscale;
  } else if (!background_image_path.empty() && kind != SegmenterKind::kBackground) {
    message << "background_image_path is only used by the bgsub kind, not " << ToString(kind);
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

std::unique_ptr<Segmenter> CreateSegmenter(const SegmenterOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid segmentation options: ", error);
  return std::make_unique<PipelineSegmenter>(options);
}

}  // namespace silpose
