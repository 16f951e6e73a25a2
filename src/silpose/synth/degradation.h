#pragma once
// Controlled degradations of rendered silhouettes, imitating what a real segmentation delivers:
// eroded or dilated borders, pixel noise, occlusion (random in each frame, or an occluder passing
// in front of the object over several frames), background clutter, frames where the object is not
// found at all ("missed") and frames that are badly segmented ("bad"); and the typical flaws of a
// colour threshold's mask: a ragged boundary, small holes, a stick or fingers holding the object,
// a shadow merged into the silhouette, small false-positive specks (MaskQuality::kThreshold
// combines them).
//
// Every random choice comes from std::mt19937_64 engines seeded from (seed, frame, purpose), so a
// frame's degradation does not depend on the other frames, on the order or thread they are
// processed in, or on the options of the other degradations: e.g. which frames are missed depends
// only on the seed and the two frame probabilities.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

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

/// The per-frame effects applied to a mask, as bit flags (a frame's set is a uint32_t of them).
enum MaskEffect : uint32_t {
  kMaskEffectErode = 1u << 0,
  kMaskEffectDilate = 1u << 1,
  kMaskEffectShadow = 1u << 2,
  kMaskEffectStick = 1u << 3,
  kMaskEffectFingers = 1u << 4,
  kMaskEffectRagged = 1u << 5,
  kMaskEffectHoles = 1u << 6,
  kMaskEffectOccluders = 1u << 7,
  kMaskEffectClutter = 1u << 8,
  kMaskEffectSpecks = 1u << 9,
  kMaskEffectNoise = 1u << 10,
  kMaskEffectPassing = 1u << 11,
};

/// Every MaskEffect, in the order DegradeMask applies them.
const std::vector<MaskEffect>& AllMaskEffects();
/// "erode", "dilate", "shadow", "stick", "fingers", "ragged", "holes", "occluders", "passing",
/// "clutter", "specks", "noise".
const char* MaskEffectName(MaskEffect effect);

/// The `degradation` column of groundtruth.csv: "missed" for a missed frame; otherwise "bad" (for a
/// bad frame) and the names of the applied effects, in the order of AllMaskEffects, joined by '+'
/// (e.g. "ragged+holes", "bad+shadow+specks"); "none" if that is empty.
std::string DegradationLabel(FrameDegradation degradation, uint32_t mask_effects);
/// Inverse of DegradationLabel (also reads the plain "none", "missed", "bad" of older files, and
/// any order); false if a part is unknown, repeated, or "missed" is combined with anything.
bool ParseDegradationLabel(std::string_view label, FrameDegradation* degradation,
                           uint32_t* mask_effects);

/// The degradations applied to every frame, in this order: erosion, dilation, shadow, stick,
/// fingers, ragged boundary, holes, occluders, a passing occluder, clutter, specks, (bad frame),
/// salt-and-pepper noise.
/// All off by default. Sizes "relative to the silhouette" are fractions of the width and height of
/// the bounding box of the rendered (undegraded) silhouette; its "size" is the larger of the two.
/// The effects that imitate a colour threshold's mask (shadow ... specks) are those of
/// MaskQuality::kThreshold; the stick, the fingers and the shadow keep their side of the silhouette
/// over the sequence (a direction in the image drawn from the seed alone, jittered per frame), as a
/// hand and a light would.
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
  /// Passing occluders: the share of frames, in [0, 1), in which an occluder passes in front of the
  /// object (a hand, a tool, a person walking by): a filled ellipse that enters the silhouette's
  /// bounding box from one side, crosses it along a straight line and leaves on the other side
  /// over pass_frames consecutive frames, removing object pixels. The frames are cut into windows
  /// of pass_frames / passing_share frames, and each window holds one pass at a random offset;
  /// each pass has its own direction, offset from the centre (up to a quarter of the box across
  /// the direction) and occluder. 0 = off.
  double passing_share = 0.0;
  /// Frames one pass takes, in [2, 1000].
  int pass_frames = 20;
  /// The passing occluder's semi-axes relative to the silhouette's size (the larger side of its
  /// bounding box), in (0, 2]; each pass draws them in [0.5, 1] times that.
  double pass_size = 0.35;
  /// Clutter blobs per frame, in [0, 100]: filled ellipses of object pixels anywhere in the image
  /// (spurious segments of the background).
  int clutter_blobs = 0;
  /// Largest clutter semi-axes relative to the silhouette's bounding box (to the image if the
  /// object is not in view), in (0, 2]; each blob's are drawn in [0.5, 1] times that.
  double clutter_size = 0.1;
  /// Shadow: a copy of the silhouette shifted by this fraction of its size (0 = off), merged into
  /// the mask: a dark region adjoining one side, in [0, 1].
  double shadow = 0.0;
  /// A stick holding the object: a straight bar of stick_width_px pixels from inside the
  /// silhouette's boundary outwards, stick_length times the silhouette's size beyond it.
  bool stick = false;
  /// Width of the stick, pixels, in [1, 100].
  double stick_width_px = 6.0;
  /// Length of the stick beyond the silhouette, relative to its size, in (0, 5].
  double stick_length = 1.0;
  /// Fingers holding the object, in [0, 5]: side by side (half a width apart), each a bar with
  /// round ends of
  /// finger_width times the silhouette's size, reaching finger_length times its size beyond the
  /// boundary (and a quarter of that inside).
  int fingers = 0;
  /// Finger width and length relative to the silhouette's size, in (0, 1].
  double finger_width = 0.07;
  double finger_length = 0.3;
  /// Ragged boundary: the outline moves in and out by a smooth random field of this standard
  /// deviation, pixels, in [0, 20] (0 = off).
  double ragged_px = 0.0;
  /// Correlation length of the ragged boundary (the width of its bumps), pixels, in [1, 100].
  double ragged_scale_px = 6.0;
  /// Holes per frame, in [0, 100]: small filled ellipses of background strictly inside the
  /// silhouette (never touching its outline), of semi-axes in [0.4, 1] x hole_radius_px.
  int holes = 0;
  /// Largest hole semi-axis, pixels, in [1, 50].
  double hole_radius_px = 4.0;
  /// False-positive specks per frame, in [0, 1000]: discs of radius 1..speck_radius_px pixels,
  /// uniformly in the silhouette's bounding box grown by half its size on every side.
  int specks = 0;
  /// Largest speck radius, pixels, in [1, 20].
  double speck_radius_px = 2.0;
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

/// How good the masks are, in one word (synth --mask-quality).
enum class MaskQuality {
  /// The rendered silhouette as it is (no effect).
  kPerfect,
  /// Typical of an HSV colour threshold on a real video: ragged boundary (1 px, bumps of 5 px),
  /// 4 holes of up to 3 px, two fingers on one side (5 % of the silhouette's size wide, 15 % long),
  /// a shadow shifted by 2 % of its size and 10 specks of up to 2 px. Intersection over union with
  /// the true mask about 0.85-0.9 for silhouettes 70-150 px across (the bunny turned by hand at
  /// 4-10
  /// radii in the default camera: 0.87; degradation effects in pixels weigh less on larger ones).
  kThreshold,
};

/// "perfect", "threshold".
const char* MaskQualityName(MaskQuality quality);
/// Inverse of MaskQualityName; false if `name` is none of them.
bool ParseMaskQuality(std::string_view name, MaskQuality* quality);
/// `options` with the effects of `quality` set (the other fields, e.g. seed, missed and bad
/// probabilities, are kept; kPerfect changes nothing).
DegradationOptions WithMaskQuality(DegradationOptions options, MaskQuality quality);

/// Where frame `frame` is in a pass of the passing occluder: the fraction of the pass done at the
/// frame's middle, in (0, 1) ((j + 0.5) / pass_frames in the pass's j-th frame), or a negative
/// value if no pass covers the frame (or passing_share is 0). Depends only on the seed, the frame
/// and the passing options.
double PassPhase(const DegradationOptions& options, int frame);

/// Which kind frame `frame` is (depends only on seed, frame and the two probabilities).
FrameDegradation ChooseFrameDegradation(const DegradationOptions& options, int frame);

/// The effects DegradeMask applies to frame `frame` (MaskEffect flags): those the options switch
/// on (kMaskEffectPassing only in the frames of a pass, PassPhase), none for a missed frame. (An
/// effect may leave a frame unchanged: no stick without an object in view, no hole in a silhouette
/// too thin for one.)
uint32_t AppliedMaskEffects(const DegradationOptions& options, int frame);

/// Degrades the rendered CV_8UC1 mask (255 = object, 0 = not) of frame `frame` in place, as the
/// options say; returns the frame's kind. Deterministic for (options, frame, mask); thread-safe.
/// Throws silpose::Error if the options are invalid or the mask is not CV_8UC1.
FrameDegradation DegradeMask(const DegradationOptions& options, int frame, cv::Mat* mask);

}  // namespace silpose
