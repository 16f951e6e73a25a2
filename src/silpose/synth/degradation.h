#pragma once
// Controlled degradations of rendered silhouettes, imitating what a real segmentation delivers:
// ragged borders (erosion, dilation), pixel noise, occlusion, background clutter, frames where the
// object is not found at all ("missed") and frames that are badly segmented ("bad").
//
// Every random choice comes from std::mt19937_64 engines seeded from (seed, frame, purpose), so a
// frame's degradation does not depend on the other frames, on the order or thread they are
// processed in, or on the options of the other degradations: e.g. which frames are missed depends
// only on the seed and the two frame probabilities.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>

namespace silpose {

/// What happened to a frame, as recorded in groundtruth.csv (column `degradation`).
enum class FrameDegradation {
  /// Only the per-frame degradations (noise, erosion, ...), if any, were applied.
  kNone,
  /// The mask is all zero: the segmentation found nothing.
  kMissed,
  /// A strong degradation on top of the others: a large occluder, a heavy erosion or a large blob
  /// merged into the silhouette (chosen at random).
  kBad,
};

/// "none", "missed", "bad".
const char* FrameDegradationName(FrameDegradation degradation);
/// Inverse of FrameDegradationName; false if `name` is none of them.
bool ParseFrameDegradation(std::string_view name, FrameDegradation* degradation);

/// The degradations applied to every frame, in this order: erosion, dilation, occluders, clutter,
/// (bad frame), salt-and-pepper noise. All off by default. Sizes "relative to the silhouette" are
/// fractions of the width and height of the bounding box of the rendered (undegraded) silhouette.
struct DegradationOptions {
  /// Seed of all random choices.
  uint64_t seed = 1;
  /// Salt-and-pepper noise: each pixel of the image is flipped (object <-> background)
  /// independently with this probability, in [0, 1].
  double noise_fraction = 0.0;
  /// Erosion, then dilation, of the silhouette by this many pixels (elliptic structuring element
  /// of diameter 2N+1), in [0, 100].
  int erode_px = 0;
  int dilate_px = 0;
  /// Occluders per frame, in [0, 100]: filled ellipses that remove object pixels (never add any),
  /// centred uniformly in the silhouette's bounding box, turned at random.
  int occluders = 0;
  /// Largest occluder semi-axes relative to the silhouette's bounding box, in (0, 2]; each
  /// occluder's are drawn in [0.5, 1] times that.
  double occluder_size = 0.25;
  /// Clutter blobs per frame, in [0, 100]: filled ellipses of object pixels anywhere in the image
  /// (spurious segments of the background).
  int clutter_blobs = 0;
  /// Largest clutter semi-axes relative to the silhouette's bounding box (to the image if the
  /// object is not in view), in (0, 2]; each blob's are drawn in [0.5, 1] times that.
  double clutter_size = 0.1;
  /// Probability that a frame is missed (all-zero mask), in [0, 1].
  double missed_probability = 0.0;
  /// Probability that a frame is badly segmented, in [0, 1]. One uniform draw per frame decides:
  /// missed if u < missed_probability, else bad if u < missed_probability + bad_probability, so
  /// the two must sum to at most 1.
  double bad_probability = 0.0;

  bool Check(std::string* error = nullptr) const;
  /// True if any degradation is switched on.
  bool Any() const;
};

/// Which kind frame `frame` is (depends only on seed, frame and the two probabilities).
FrameDegradation ChooseFrameDegradation(const DegradationOptions& options, int frame);

/// Degrades the rendered CV_8UC1 mask (255 = object, 0 = not) of frame `frame` in place, as the
/// options say; returns the frame's kind. Deterministic for (options, frame, mask); thread-safe.
/// Throws silpose::Error if the options are invalid or the mask is not CV_8UC1.
FrameDegradation DegradeMask(const DegradationOptions& options, int frame, cv::Mat* mask);

}  // namespace silpose
