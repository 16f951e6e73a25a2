#pragma once
// Segmentation front ends: each video frame -> a silhouette mask (CV_8UC1, 255 = object, 0 = not;
// docs/conventions.md "Masks") that shape/polar_signature.h turns into the descriptor (pipeline
// step "frame -> segmentation" of docs/tracking.md).
//
// Three kinds (SegmenterKind), all followed by the same clean-up:
//   mask       the frames already are masks (a synth folder, another program's output): a pixel
//              is object if any channel exceeds `mask_threshold` (0 = DESIGN's "non-zero").
//   bgsub      static camera: OpenCV's BackgroundSubtractorMOG2 or KNN (Zivkovic 2004 / 2006),
//              or one Gaussian per pixel (gaussian_background.h, the cheapest),
//              learned from a background image, or from the frames until an object appears
//              (default; BackgroundLearning), or from the first `learning_frames` frames, then
//              frozen (see `learning_rate`).
//   threshold  controlled lighting: an HSV colour range, or Otsu's threshold on the grey image
//              with the object darker or brighter than the background.
// Clean-up: foreground -> morphological closing then opening (fills the holes of an object whose
// colour is near the background's, then removes specks) -> fraction of the frame that is
// foreground (above `max_foreground_fraction` the frame fails: lighting change, camera moved) ->
// connected components (8-connected) smaller than `min_area_fraction` of the frame dropped -> one
// component kept (largest, or nearest to the last good frame's silhouette centre) -> the mask
// holds that component only.
//
// Input frames: 8-bit (CV_8U), 16-bit (CV_16U, divided by 257) or float (CV_32F, in [0, 1],
// times 255), with 1 channel (grey), 3 (BGR, OpenCV's order) or 4 (BGRA, alpha ignored); the mask
// kind accepts any channel count. Grey frames go into bgsub as one channel (a grey model) and into
// threshold as a colour image with H = S = 0 (so an HSV range selects them by V only).
//
// Failures that video brings (nothing found, the whole frame changed, still learning) are
// statuses (SegmentationStatus) with a message, never exceptions: the caller skips the frame
// (filter Predict only). Exceptions (silpose::Error) are for bad options, an unreadable background
// image, an empty frame or one of an unsupported type or of a size other than the model's.
//
// Threads: OpenCV's own parallelism is left as the caller set it (cv::setNumThreads). A
// Segmenter is stateful (background model, last centre): one per video stream, not shared between
// threads.
//
// Cost per 640 x 480 colour frame, one thread (cv::setNumThreads(1)), median of 160 frames with a
// 17000 px object, best of 3 runs on a shared 2-core machine (under load up to 2x more):
// mask 0.2 ms; threshold otsu 0.65 / hsv 0.9 ms (downscale 2: 0.5 / 0.6); bgsub MOG2 3.9 ms
// (downscale 2: 1.15), KNN 4.2 ms without / 5.6 ms with shadow detection (downscale 2: 1.4 / 1.8);
// shadow detection costs MOG2 little. KNN's cost grows with the foreground's size. gauss: see
// docs/segmentation.md (0.8 ms with the clean-up; MOG2 3.7-3.9 ms, KNN 4.8 ms the same way).

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

namespace silpose {

/// How frames become silhouettes (CLI `--segment KIND`).
enum class SegmenterKind : uint8_t {
  kMask = 0,        ///< "mask": frames are masks
  kBackground = 1,  ///< "bgsub": background subtraction, static camera
  kThreshold = 2,   ///< "threshold": HSV range or Otsu on grey
};
/// "mask", "bgsub", "threshold".
const char* ToString(SegmenterKind kind);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
SegmenterKind ParseSegmenterKind(std::string_view name);

/// Background models: OpenCV's (opencv2/video/background_segm.hpp) and silpose's own.
enum class BackgroundMethod : uint8_t {
  kMog2 = 0,  ///< "mog2": per-pixel Gaussian mixture (Zivkovic 2004); cheaper
  kKnn = 1,   ///< "knn": per-pixel nearest-neighbour sample set (Zivkovic & van der Heijden 2006)
  /// "gauss": one Gaussian per pixel (segment/gaussian_background.h); the cheapest, for a static
  /// scene whose background does not flicker or sway (one colour per pixel).
  kGaussian = 2,
};
/// "mog2", "knn", "gauss".
const char* ToString(BackgroundMethod method);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
BackgroundMethod ParseBackgroundMethod(std::string_view name);

/// How bgsub learns its background from the frames (without a background image).
enum class BackgroundLearning : uint8_t {
  /// "until-object": learns from every frame in which no object is found, after a first
  /// `min_learning_frames`, and stops for good once an object has been found in
  /// `object_confirm_frames` consecutive frames. Needs no knowledge of how long the scene is empty.
  kUntilObject = 0,
  /// "frames": learns from the first `learning_frames` frames, whatever they show.
  kFrames = 1,
};
/// "until-object", "frames".
const char* ToString(BackgroundLearning learning);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
BackgroundLearning ParseBackgroundLearning(std::string_view name);

/// The rule of the threshold kind.
enum class ThresholdMethod : uint8_t {
  kOtsu = 0,      ///< "otsu": Otsu's threshold on the grey image, side chosen by ObjectPolarity
  kHsvRange = 1,  ///< "hsv": pixels inside [hsv_lower, hsv_upper]
};
/// "otsu", "hsv".
const char* ToString(ThresholdMethod method);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
ThresholdMethod ParseThresholdMethod(std::string_view name);

/// Which side of Otsu's threshold is the object.
enum class ObjectPolarity : uint8_t {
  kDarker = 0,    ///< "darker": object darker than the background (dark object on a light table)
  kBrighter = 1,  ///< "brighter"
};
/// "darker", "brighter".
const char* ToString(ObjectPolarity polarity);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
ObjectPolarity ParseObjectPolarity(std::string_view name);

/// Which connected component is the object.
enum class SegmentComponent : uint8_t {
  kLargest = 0,          ///< "largest": largest area
  kNearestPrevious = 1,  ///< "nearest": centre nearest to the last good frame's (largest before)
};
/// "largest", "nearest".
const char* ToString(SegmentComponent component);
/// Inverse of ToString. Throws silpose::Error naming `name` and listing the choices.
SegmentComponent ParseSegmentComponent(std::string_view name);

struct SegmenterOptions {
  SegmenterKind kind = SegmenterKind::kMask;

  // --- mask ---
  /// A mask pixel is object if any channel is > this (8-bit units, 0..254). 0 is the mask rule of
  /// docs/conventions.md "non-zero = object"; for masks stored lossy (JPEG, video codecs), whose
  /// 0/255 come back as e.g. 0..20 / 235..255, use 127.
  int mask_threshold = 0;

  // --- bgsub ---
  BackgroundMethod background_method = BackgroundMethod::kMog2;
  /// How the model is learned from the frames (ignored with a background image). Default
  /// until-object: the object may appear at any frame after the first `min_learning_frames`.
  BackgroundLearning background_learning = BackgroundLearning::kUntilObject;
  /// until-object: frames learned before the model looks for an object (status kLearning), in
  /// [1, 100000]. Measured on synthetic frames with camera noise of 4 levels, false foreground on
  /// empty frames vanishes by 10 frames (MOG2 and KNN); an object in view earlier is learned as
  /// background, as with the frames mode.
  int min_learning_frames = 10;
  /// until-object: learning stops for good once an object (a component of at least
  /// min_area_fraction, foreground below max_foreground_fraction) has been found in this many
  /// consecutive frames, in [1, 1000]. Frames with an object are never learned; an isolated false
  /// detection (a passing shadow) only pauses learning. The frames with an object are segmented
  /// (status kOk) meanwhile.
  int object_confirm_frames = 3;
  /// frames: frames the model learns from before it is used (status kLearning meanwhile), >= 1.
  /// until-object: the window of the running average the model learns with. Also the model's
  /// history. In the frames mode the scene should be empty meanwhile, or the object moving so that
  /// it covers each pixel in well under 10 % of these frames: where it lingers it becomes
  /// background (an object of 80 px moving 5 px per frame, covering pixels half the time, was then
  /// found with IoU 0.37 by MOG2, 0.75 by KNN). 30 = one second at 30 frames/s. Measured on
  /// synthetic frames with camera noise of 4 levels: KNN needs >= 5 frames (with 2 the whole frame
  /// is foreground), false foreground on empty frames vanishes by 10 frames for both; 30 leaves a
  /// margin for what real video adds (auto-exposure settling, codec noise) and costs one second.
  /// Ignored with a background image (the model is ready at the first frame).
  int learning_frames = 30;
  /// Model update rate after learning, in [0, 1); 0 = frozen (default). A static camera watching an
  /// object that may stop moving must not let it fade into the background: with MOG2 a pixel
  /// covered by a still object joins the background once its new mode's weight reaches
  /// 1 - background ratio = 0.1, i.e. after ~0.1 / rate frames (rate 0.001: ~100 frames = 3 s at
  /// 30 frames/s). So only tiny rates (<= 1e-4, ~30 s) make sense, to follow slow light drift.
  /// (KNN cannot take 0; it gets 1e-7, which refreshes a sample every ~10^5 frames. gauss learns
  /// only the pixels it classifies as background: a still object never joins it.)
  double learning_rate = 0.0;
  /// If not empty: the model is initialised from this image of the empty scene (any format
  /// OpenCV reads; same size as the frames) instead of from the first frames.
  std::string background_image_path;
  /// A still image lacks the camera's noise: the model is fed `learning_frames` copies of it with
  /// Gaussian noise of this standard deviation added (grey levels, at full resolution), so that
  /// the model's variance matches a camera's. In [0, 50].
  double background_image_noise = 4.0;
  /// Let the model mark shadows (darker, same chromaticity) and count them as background. Costs
  /// ~10 % of the model's time; a dark grey object on a light grey background may be taken for a
  /// shadow, then switch it off.
  bool detect_shadows = true;
  /// MOG2's squared Mahalanobis distance threshold (OpenCV's default 16 = 4 sigma); > 0. A pixel
  /// must differ from the background by 4 sigma of the camera noise: an object of low contrast
  /// (25 levels in one channel at noise sigma 4) is mostly missed; lower this, or use KNN, whose
  /// threshold is absolute.
  double mog2_variance_threshold = 16.0;
  /// The gauss model's threshold, as MOG2's: squared distance from the pixel's mean colour, summed
  /// over the channels, in units of the channels' summed variance (16 = 4 sigma); > 0.
  double gauss_variance_threshold = 16.0;
  /// KNN's squared distance threshold in grey levels squared, summed over channels (OpenCV's
  /// default 400 = 20 levels); > 0.
  double knn_distance2_threshold = 400.0;
  /// After this many consecutive kTooLarge frames the model is learned anew from the following
  /// frames (a permanent lighting change, the camera moved); 0 = never (default: relearning with
  /// the object in view would make it part of the background).
  int relearn_after_frames = 0;

  // --- threshold ---
  ThresholdMethod threshold_method = ThresholdMethod::kOtsu;
  ObjectPolarity otsu_object = ObjectPolarity::kDarker;
  /// Inclusive HSV bounds, OpenCV's ranges: H in [0, 180) (degrees / 2), S and V in [0, 255]. If
  /// hsv_lower[0] > hsv_upper[0] the hue range wraps through 0 (reds: 170 .. 10).
  cv::Scalar hsv_lower = cv::Scalar(0, 0, 0);
  cv::Scalar hsv_upper = cv::Scalar(179, 255, 255);

  // --- all kinds ---
  /// Radius in full-resolution pixels of the elliptic structuring element (diameter 2 N + 1) of
  /// the opening and closing, in [0, 50]; 0 = no morphology. -1 = the kind's default: 0 for mask
  /// (masks are clean; opening would eat thin parts), 2 for bgsub and threshold (removes specks of
  /// camera noise up to ~4 px wide and closes gaps of the same size).
  int morphology_px = -1;
  SegmentComponent component = SegmentComponent::kLargest;
  /// Components smaller than this fraction of the frame's area are ignored, in [0, 1). 0.0002 is
  /// 61 px at 640 x 480, a 9 px blob: about the smallest silhouette a signature is taken from
  /// (SignatureOptions::min_area_px, 64). An object 30 radii from a 525 px lens casts 150-900 px;
  /// a larger value drops such objects as if the frame were empty.
  double min_area_fraction = 0.0002;
  /// If more than this fraction of the frame is foreground (after morphology), the frame fails
  /// with kTooLarge instead of delivering a wrong mask, in (0, 1]; 1 = never. 0.5: an object that
  /// fills half the frame is cut by its border anyway.
  double max_foreground_fraction = 0.5;
  /// bgsub and threshold run on the frame shrunk by this integer factor (area averaging, which
  /// also averages camera noise) and the mask is scaled back up (bilinear, cut at half), in
  /// [1, 8]: cost / factor^2, outline accurate to ~factor / 2 pixels. Ignored by the mask kind.
  int downscale = 1;

  /// The morphology radius actually used (resolves -1).
  int MorphologyPx() const;
  /// False with a message naming the option if an option is out of range or inconsistent.
  bool Check(std::string* error = nullptr) const;
};

enum class SegmentationStatus : uint8_t {
  kOk = 0,        ///< mask holds the chosen component
  kLearning = 1,  ///< the background model is still learning (and found no object); no mask
  kEmpty = 2,     ///< no foreground, or no component of at least min_area_fraction
  kTooLarge = 3,  ///< more than max_foreground_fraction of the frame is foreground
};
/// "ok", "learning", "empty", "too-large".
const char* ToString(SegmentationStatus status);

struct SegmentationResult {
  SegmentationStatus status = SegmentationStatus::kEmpty;
  /// One line for people: what was found or why not ("foreground covers 93% of the frame > 50%
  /// (max_foreground_fraction): lighting change or camera moved?").
  std::string message;
  /// CV_8UC1 of the frame's size, 255 = the chosen component, 0 elsewhere; all zero unless kOk.
  cv::Mat mask;
  /// Fraction of the frame that was foreground after morphology, before choosing a component.
  double foreground_fraction = 0.0;
  /// Components of at least min_area_fraction.
  int num_components = 0;
  /// The chosen component's area (pixels, full resolution) and centre of gravity (pixels, image
  /// x right, y down; pixel centres at integers). Valid when kOk.
  double area_px = 0.0;
  Eigen::Vector2d centroid_px = Eigen::Vector2d::Zero();

  bool ok() const { return status == SegmentationStatus::kOk; }
};

/// Turns the frames of one video stream into silhouette masks; keeps the background model and the
/// last good silhouette's centre between calls.
class Segmenter {
 public:
  virtual ~Segmenter() = default;
  /// Segments the next frame of the stream (see the file comment for accepted types). Throws
  /// silpose::Error for an empty frame, an unsupported type, or (bgsub) a size or channel count
  /// other than the model's or the background image's.
  virtual SegmentationResult Segment(const cv::Mat& frame) = 0;
  /// Forgets the background model (bgsub learns again, from the image if one was given) and the
  /// last silhouette's centre.
  virtual void Reset() = 0;
  virtual const SegmenterOptions& options() const = 0;
};

/// The segmenter of options.kind. Throws silpose::Error if the options fail Check() (message
/// names the option) or the background image cannot be read (message names the file).
std::unique_ptr<Segmenter> CreateSegmenter(const SegmenterOptions& options);

}  // namespace silpose
