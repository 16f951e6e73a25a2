#include "silpose/synth/degradation.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "silpose/synth/synth_random.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using synth_internal::FrameSeed;
using synth_internal::StandardNormal;
using synth_internal::Uniform;
using synth_internal::Uniform01;

// One random stream per purpose (see the header).
enum Stream : uint64_t {
  kStreamFrameKind = 1,
  kStreamOccluders = 2,
  kStreamClutter = 3,
  kStreamBad = 4,
  kStreamNoise = 5,
  kStreamShadow = 6,
  kStreamHand = 7,
  kStreamRagged = 8,
  kStreamHoles = 9,
  kStreamSpecks = 10,
  kStreamPassing = 11,
};

// The "frame" of the per-sequence draws (the side of the hand, of the shadow).
constexpr uint64_t kSequenceFrame = ~uint64_t{0};

std::mt19937_64 Engine(const DegradationOptions& options, int frame, Stream stream) {
  return std::mt19937_64(FrameSeed(options.seed, static_cast<uint64_t>(frame), stream));
}

bool Fail(std::string* error, const char* message) {
  if (error != nullptr) *error = message;
  return false;
}

bool InUnitInterval(double value) { return std::isfinite(value) && value >= 0.0 && value <= 1.0; }

void Morphology(int operation, int radius_px, cv::Mat* mask) {
  if (radius_px <= 0) return;
  const cv::Mat kernel =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
  cv::morphologyEx(*mask, *mask, operation, kernel);
}

// A filled ellipse centred at `centre` with semi-axes `semi_axes` (pixels), turned at random.
void FillEllipse(std::mt19937_64& engine, const cv::Point2d& centre, const cv::Point2d& semi_axes,
                 uchar value, cv::Mat* mask) {
  const double angle_deg = Uniform(engine, 0.0, 180.0);
  const cv::Size axes(std::max(1, static_cast<int>(std::lround(semi_axes.x))),
                      std::max(1, static_cast<int>(std::lround(semi_axes.y))));
  const cv::Point point(static_cast<int>(std::lround(centre.x)),
                        static_cast<int>(std::lround(centre.y)));
  cv::ellipse(*mask, point, axes, angle_deg, 0.0, 360.0, cv::Scalar(value), cv::FILLED, cv::LINE_8);
}

// Semi-axes in [0.5, 1] x size x the box's sides.
cv::Point2d RandomSemiAxes(std::mt19937_64& engine, double size, const cv::Rect& box) {
  return {Uniform(engine, 0.5, 1.0) * size * box.width,
          Uniform(engine, 0.5, 1.0) * size * box.height};
}

cv::Point2d RandomPointIn(std::mt19937_64& engine, const cv::Rect& box) {
  return {box.x - 0.5 + box.width * Uniform01(engine),
          box.y - 0.5 + box.height * Uniform01(engine)};
}

bool InRange(double value, double low, double high) {
  return std::isfinite(value) && value >= low && value <= high;
}

// Unit direction in the image (x right, y down) at `angle_deg` from +x towards +y.
Eigen::Vector2d Direction(double angle_deg) {
  const double angle = angle_deg * std::numbers::pi / 180.0;
  return {std::cos(angle), std::sin(angle)};
}

// A per-sequence direction (from the seed and stream alone) within `spread_deg` of `centre_deg`,
// turned per frame by up to +-jitter_deg.
Eigen::Vector2d SideDirection(const DegradationOptions& options, int frame, Stream stream,
                              double centre_deg, double spread_deg, double jitter_deg) {
  std::mt19937_64 sequence_engine(FrameSeed(options.seed, kSequenceFrame, stream));
  const double base = centre_deg + Uniform(sequence_engine, -spread_deg, spread_deg);
  std::mt19937_64 frame_engine = Engine(options, frame, stream);
  return Direction(base + Uniform(frame_engine, -jitter_deg, jitter_deg));
}

cv::Point ToPoint(const Eigen::Vector2d& p) {
  return {static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))};
}

// The object pixel furthest along `direction` (ties: the first in row order), among those whose
// offset from `through` across the direction is within `half_width` of `across` (all if
// half_width is infinite). False if there is none.
bool SupportPoint(const std::vector<cv::Point>& pixels, const Eigen::Vector2d& direction,
                  const Eigen::Vector2d& through, double across, double half_width,
                  Eigen::Vector2d* support) {
  const Eigen::Vector2d normal(-direction.y(), direction.x());
  double best = -1e300;
  bool found = false;
  for (const cv::Point& pixel : pixels) {
    const Eigen::Vector2d p(pixel.x, pixel.y);
    if (std::abs((p - through).dot(normal) - across) > half_width) continue;
    const double along = p.dot(direction);
    if (along > best) {
      best = along;
      *support = p;
      found = true;
    }
  }
  return found;
}

// Shadow: the silhouette shifted by `fraction` of its size along a per-sequence direction, merged.
void Shadow(const DegradationOptions& options, int frame, double size, cv::Mat* mask) {
  const Eigen::Vector2d direction = SideDirection(options, frame, kStreamShadow, 45.0, 180.0, 10.0);
  const Eigen::Vector2d shift = options.shadow * size * direction;
  const cv::Mat translation = (cv::Mat_<double>(2, 3) << 1, 0, shift.x(), 0, 1, shift.y());
  cv::Mat shifted;
  cv::warpAffine(*mask, shifted, translation, mask->size(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                 cv::Scalar(0));
  cv::bitwise_or(*mask, shifted, *mask);
}

// The stick and the fingers: bars from inside the silhouette outwards, on the side of the hand (a
// per-sequence direction pointing down in the image, within 60 degrees).
void Hand(const DegradationOptions& options, int frame, double size, cv::Mat* mask) {
  std::vector<cv::Point> pixels;
  cv::findNonZero(*mask, pixels);
  if (pixels.empty()) return;
  const Eigen::Vector2d direction = SideDirection(options, frame, kStreamHand, 90.0, 60.0, 15.0);
  const Eigen::Vector2d normal(-direction.y(), direction.x());
  Eigen::Vector2d tip = Eigen::Vector2d::Zero();
  const Eigen::Vector2d origin(pixels.front().x, pixels.front().y);
  SupportPoint(pixels, direction, origin, 0.0, 1e300, &tip);
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> bars;  // (from, to), with a width
  std::vector<int> widths;
  if (options.stick) {
    const double width = options.stick_width_px;
    Eigen::Vector2d base;
    if (SupportPoint(pixels, direction, tip, 0.0, std::max(0.5, width / 2.0), &base)) {
      bars.emplace_back(base - 0.15 * size * direction,
                        base + options.stick_length * size * direction);
      widths.push_back(std::max(1, static_cast<int>(std::lround(width))));
    }
  }
  const double finger_width = std::max(2.0, options.finger_width * size);
  const double finger_length = options.finger_length * size;
  for (int i = 0; i < options.fingers; ++i) {
    // Side by side across the direction, centred on the tip (a stick goes through the middle).
    const double across = (i - (options.fingers - 1) / 2.0) * 1.5 * finger_width;
    Eigen::Vector2d base;
    if (!SupportPoint(pixels, direction, tip, across, finger_width / 2.0, &base)) continue;
    const Eigen::Vector2d centre_line = base + (across - (base - tip).dot(normal)) * normal;
    bars.emplace_back(centre_line - 0.25 * finger_length * direction,
                      centre_line + finger_length * direction);
    widths.push_back(std::max(1, static_cast<int>(std::lround(finger_width))));
  }
  for (size_t i = 0; i < bars.size(); ++i) {
    cv::line(*mask, ToPoint(bars[i].first), ToPoint(bars[i].second), cv::Scalar(255), widths[i],
             cv::LINE_8);
  }
}

// A smooth random field over `size` with zero mean and unit standard deviation, correlation
// length about `scale_px`: white noise on a grid of that spacing, interpolated (bicubic).
cv::Mat SmoothNoise(std::mt19937_64& engine, cv::Size size, double scale_px) {
  const int grid_cols = static_cast<int>(std::ceil(size.width / scale_px)) + 2;
  const int grid_rows = static_cast<int>(std::ceil(size.height / scale_px)) + 2;
  cv::Mat grid(grid_rows, grid_cols, CV_32FC1);
  for (int y = 0; y < grid_rows; ++y) {
    for (int x = 0; x < grid_cols; ++x)
      grid.at<float>(y, x) = static_cast<float>(StandardNormal(engine));
  }
  cv::Mat field;
  const int width = static_cast<int>(std::lround(grid_cols * scale_px));
  const int height = static_cast<int>(std::lround(grid_rows * scale_px));
  cv::resize(grid, field, cv::Size(width, height), 0.0, 0.0, cv::INTER_CUBIC);
  field = field(cv::Rect(0, 0, size.width, size.height)).clone();
  cv::Scalar mean;
  cv::Scalar deviation;
  cv::meanStdDev(field, mean, deviation);
  field -= mean[0];
  if (deviation[0] > 0.0) field /= deviation[0];
  return field;
}

// Ragged boundary: the signed distance to the outline (positive inside), plus the smooth noise
// field times the amplitude, thresholded at 0 (without noise: the mask unchanged).
void Ragged(const DegradationOptions& options, int frame, const cv::Rect& silhouette,
            cv::Mat* mask) {
  const int margin = static_cast<int>(std::ceil(4.0 * options.ragged_px)) + 2;
  const cv::Rect roi = cv::Rect(silhouette.x - margin, silhouette.y - margin,
                                silhouette.width + 2 * margin, silhouette.height + 2 * margin) &
                       cv::Rect(0, 0, mask->cols, mask->rows);
  cv::Mat region = (*mask)(roi);
  cv::Mat inside;
  cv::Mat outside;
  cv::distanceTransform(region, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(region == 0, outside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::mt19937_64 engine = Engine(options, frame, kStreamRagged);
  const cv::Mat noise = SmoothNoise(engine, roi.size(), options.ragged_scale_px);
  const cv::Mat level = inside - outside + static_cast<float>(options.ragged_px) * noise;
  cv::Mat ragged = level > 0.0F;
  ragged.copyTo(region);
}

// Holes: small background ellipses centred where the silhouette is thick enough to enclose them.
void Holes(const DegradationOptions& options, int frame, cv::Mat* mask) {
  cv::Mat inside;
  cv::distanceTransform(*mask, inside, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<cv::Point> centres;
  cv::findNonZero(inside > static_cast<float>(options.hole_radius_px + 1.5), centres);
  if (centres.empty()) return;
  std::mt19937_64 engine = Engine(options, frame, kStreamHoles);
  for (int i = 0; i < options.holes; ++i) {
    const size_t pick =
        std::min(centres.size() - 1,
                 static_cast<size_t>(Uniform01(engine) * static_cast<double>(centres.size())));
    const cv::Point2d semi_axes(Uniform(engine, 0.4, 1.0) * options.hole_radius_px,
                                Uniform(engine, 0.4, 1.0) * options.hole_radius_px);
    FillEllipse(engine, centres[pick], semi_axes, 0, mask);
  }
}

// Specks: small discs of object pixels around the silhouette.
void Specks(const DegradationOptions& options, int frame, const cv::Rect& silhouette,
            cv::Mat* mask) {
  const int grow = std::max(silhouette.width, silhouette.height) / 2;
  const cv::Rect area = cv::Rect(silhouette.x - grow, silhouette.y - grow,
                                 silhouette.width + 2 * grow, silhouette.height + 2 * grow) &
                        cv::Rect(0, 0, mask->cols, mask->rows);
  std::mt19937_64 engine = Engine(options, frame, kStreamSpecks);
  for (int i = 0; i < options.specks; ++i) {
    const cv::Point2d centre = RandomPointIn(engine, area);
    const double radius = Uniform(engine, 1.0, options.speck_radius_px);
    cv::circle(
        *mask,
        cv::Point(static_cast<int>(std::lround(centre.x)), static_cast<int>(std::lround(centre.y))),
        std::max(0, static_cast<int>(std::lround(radius)) - 1) + 1, cv::Scalar(255), cv::FILLED,
        cv::LINE_8);
  }
}

// The strong degradation of a "bad" frame.
void BadSegmentation(std::mt19937_64& engine, const cv::Rect& box, cv::Mat* mask) {
  const int kind = static_cast<int>(Uniform(engine, 0.0, 3.0));
  const cv::Rect middle(box.x + box.width / 4, box.y + box.height / 4, std::max(1, box.width / 2),
                        std::max(1, box.height / 2));
  switch (kind) {
    case 0: {  // a large occluder over the middle of the silhouette
      const cv::Point2d centre = RandomPointIn(engine, middle);
      const cv::Point2d axes(Uniform(engine, 0.3, 0.5) * box.width,
                             Uniform(engine, 0.3, 0.5) * box.height);
      FillEllipse(engine, centre, axes, 0, mask);
      break;
    }
    case 1: {  // heavy erosion: thin parts vanish, the outline loses its detail
      const double radius = Uniform(engine, 0.12, 0.2) * std::min(box.width, box.height);
      Morphology(cv::MORPH_ERODE, std::max(2, static_cast<int>(std::lround(radius))), mask);
      break;
    }
    default: {  // a large blob of background merged into the silhouette at its border
      const bool vertical_side = Uniform01(engine) < 0.5;
      const double along = Uniform01(engine);
      const double side = Uniform01(engine) < 0.5 ? 0.0 : 1.0;
      const cv::Point2d centre =
          vertical_side ? cv::Point2d(box.x + side * box.width, box.y + along * box.height)
                        : cv::Point2d(box.x + along * box.width, box.y + side * box.height);
      const cv::Point2d axes(Uniform(engine, 0.25, 0.4) * box.width,
                             Uniform(engine, 0.25, 0.4) * box.height);
      FillEllipse(engine, centre, axes, 255, mask);
      break;
    }
  }
}

void SaltAndPepper(std::mt19937_64& engine, double fraction, cv::Mat* mask) {
  if (fraction <= 0.0) return;
  // Flip where a 64-bit draw falls below fraction * 2^64 (fraction < 1 keeps that below 2^64).
  const bool all = fraction >= 1.0;
  const auto threshold = all ? 0 : static_cast<uint64_t>(std::ldexp(fraction, 64));
  for (int y = 0; y < mask->rows; ++y) {
    uchar* row = mask->ptr<uchar>(y);
    for (int x = 0; x < mask->cols; ++x) {
      if (all || engine() < threshold) row[x] = row[x] != 0 ? 0 : 255;
    }
  }
}

}  // namespace

const char* FrameDegradationName(FrameDegradation degradation) {
  switch (degradation) {
    case FrameDegradation::kNone:
      return "none";
    case FrameDegradation::kMissed:
      return "missed";
    case FrameDegradation::kBad:
      return "bad";
  }
  return "?";
}

bool ParseFrameDegradation(std::string_view name, FrameDegradation* degradation) {
  for (FrameDegradation d :
       {FrameDegradation::kNone, FrameDegradation::kMissed, FrameDegradation::kBad}) {
    if (name == FrameDegradationName(d)) {
      *degradation = d;
      return true;
    }
  }
  return false;
}

namespace {

// The window of passing_share's frames that `frame` falls in: windows of
// round(pass_frames / passing_share) frames (at least pass_frames), each with one pass at a random
// offset, and the random draws of that pass.
struct PassWindow {
  int64_t first_frame = 0;  // of the pass
  std::mt19937_64 engine;   // the pass's geometry, drawn after the offset
};

PassWindow PassWindowOf(const DegradationOptions& options, int frame) {
  const auto length = std::max<int64_t>(options.pass_frames,
                                        std::llround(options.pass_frames / options.passing_share));
  const int64_t window = frame / length;
  PassWindow pass;
  pass.engine = Engine(options, static_cast<int>(window), kStreamPassing);
  const int64_t slack = length - options.pass_frames;
  const auto offset = std::min(
      slack, static_cast<int64_t>(Uniform01(pass.engine) * static_cast<double>(slack + 1)));
  pass.first_frame = window * length + offset;
  return pass;
}

// The passing occluder at `phase` of its pass: an ellipse moving in a straight line across the
// silhouette's bounding box, from just outside one side (phase 0) to just outside the other (1).
void PassingOccluder(const DegradationOptions& options, int frame, double phase,
                     const cv::Rect& silhouette, cv::Mat* mask) {
  PassWindow pass = PassWindowOf(options, frame);
  std::mt19937_64& engine = pass.engine;
  const Eigen::Vector2d direction = Direction(Uniform(engine, 0.0, 360.0));
  const Eigen::Vector2d normal(-direction.y(), direction.x());
  const double across = Uniform(engine, -0.25, 0.25);
  const double size = std::max(silhouette.width, silhouette.height);
  const double a = Uniform(engine, 0.5, 1.0) * options.pass_size * size;
  const double b = Uniform(engine, 0.5, 1.0) * options.pass_size * size;
  const double angle_deg = Uniform(engine, 0.0, 180.0);
  // Half extents of the box along the path and across it.
  const auto half_extent = [&](const Eigen::Vector2d& u) {
    return 0.5 * (std::abs(u.x()) * silhouette.width + std::abs(u.y()) * silhouette.height);
  };
  const Eigen::Vector2d centre(silhouette.x + 0.5 * silhouette.width - 0.5,
                               silhouette.y + 0.5 * silhouette.height - 0.5);
  const double reach = half_extent(direction) + std::max(a, b);
  const Eigen::Vector2d position = centre + normal * (across * 2.0 * half_extent(normal)) +
                                   direction * ((2.0 * phase - 1.0) * reach);
  const cv::Size axes(std::max(1, static_cast<int>(std::lround(a))),
                      std::max(1, static_cast<int>(std::lround(b))));
  cv::ellipse(*mask, ToPoint(position), axes, angle_deg, 0.0, 360.0, cv::Scalar(0), cv::FILLED,
              cv::LINE_8);
}

}  // namespace

const std::vector<MaskEffect>& AllMaskEffects() {
  static const std::vector<MaskEffect> effects = {
      kMaskEffectErode,   kMaskEffectDilate,  kMaskEffectShadow, kMaskEffectStick,
      kMaskEffectFingers, kMaskEffectRagged,  kMaskEffectHoles,  kMaskEffectOccluders,
      kMaskEffectPassing, kMaskEffectClutter, kMaskEffectSpecks, kMaskEffectNoise};
  return effects;
}

const char* MaskEffectName(MaskEffect effect) {
  switch (effect) {
    case kMaskEffectErode:
      return "erode";
    case kMaskEffectDilate:
      return "dilate";
    case kMaskEffectShadow:
      return "shadow";
    case kMaskEffectStick:
      return "stick";
    case kMaskEffectFingers:
      return "fingers";
    case kMaskEffectRagged:
      return "ragged";
    case kMaskEffectHoles:
      return "holes";
    case kMaskEffectOccluders:
      return "occluders";
    case kMaskEffectPassing:
      return "passing";
    case kMaskEffectClutter:
      return "clutter";
    case kMaskEffectSpecks:
      return "specks";
    case kMaskEffectNoise:
      return "noise";
  }
  return "?";
}

std::string DegradationLabel(FrameDegradation degradation, uint32_t mask_effects) {
  if (degradation == FrameDegradation::kMissed) return FrameDegradationName(degradation);
  std::string label = degradation == FrameDegradation::kBad ? "bad" : "";
  for (MaskEffect effect : AllMaskEffects()) {
    if ((mask_effects & effect) == 0) continue;
    if (!label.empty()) label += '+';
    label += MaskEffectName(effect);
  }
  return label.empty() ? std::string(FrameDegradationName(FrameDegradation::kNone)) : label;
}

bool ParseDegradationLabel(std::string_view label, FrameDegradation* degradation,
                           uint32_t* mask_effects) {
  FrameDegradation kind = FrameDegradation::kNone;
  bool kind_given = false;
  uint32_t effects = 0;
  int parts = 0;
  while (true) {
    const size_t plus = label.find('+');
    const std::string_view part = label.substr(0, plus);
    ++parts;
    FrameDegradation named;
    if (ParseFrameDegradation(part, &named)) {
      if (kind_given) return false;
      kind_given = true;
      kind = named;
    } else {
      bool known = false;
      for (MaskEffect effect : AllMaskEffects()) {
        if (part != MaskEffectName(effect)) continue;
        if ((effects & effect) != 0) return false;
        effects |= effect;
        known = true;
      }
      if (!known) return false;
    }
    if (plus == std::string_view::npos) break;
    label.remove_prefix(plus + 1);
  }
  if (kind == FrameDegradation::kMissed && parts > 1) return false;
  *degradation = kind;
  *mask_effects = effects;
  return true;
}

const char* MaskQualityName(MaskQuality quality) {
  switch (quality) {
    case MaskQuality::kPerfect:
      return "perfect";
    case MaskQuality::kThreshold:
      return "threshold";
  }
  return "?";
}

bool ParseMaskQuality(std::string_view name, MaskQuality* quality) {
  for (MaskQuality q : {MaskQuality::kPerfect, MaskQuality::kThreshold}) {
    if (name == MaskQualityName(q)) {
      *quality = q;
      return true;
    }
  }
  return false;
}

DegradationOptions WithMaskQuality(DegradationOptions options, MaskQuality quality) {
  if (quality == MaskQuality::kThreshold) {
    options.ragged_px = 1.0;
    options.ragged_scale_px = 5.0;
    options.holes = 4;
    options.hole_radius_px = 3.0;
    options.fingers = 2;
    options.finger_width = 0.05;
    options.finger_length = 0.15;
    options.shadow = 0.02;
    options.specks = 10;
    options.speck_radius_px = 2.0;
  }
  return options;
}

bool DegradationOptions::Check(std::string* error) const {
  if (!InUnitInterval(noise_fraction)) return Fail(error, "noise fraction must be in [0, 1]");
  if (erode_px < 0 || erode_px > 100 || dilate_px < 0 || dilate_px > 100) {
    return Fail(error, "erosion and dilation must be in [0, 100] pixels");
  }
  if (occluders < 0 || occluders > 100) return Fail(error, "occluders must be in [0, 100]");
  if (!std::isfinite(occluder_size) || occluder_size <= 0.0 || occluder_size > 2.0) {
    return Fail(error, "occluder size must be in (0, 2] (relative to the silhouette)");
  }
  if (!InUnitInterval(passing_share)) {
    return Fail(error,
                "passing share must be in [0, 1] (the share of frames with a passing occluder)");
  }
  if (pass_frames < 2 || pass_frames > 1000) {
    return Fail(error, "pass frames must be in [2, 1000] (frames per pass)");
  }
  if (!std::isfinite(pass_size) || pass_size <= 0.0 || pass_size > 2.0) {
    return Fail(
        error,
        "pass size must be in (0, 2] (the passing occluder's size relative to the silhouette)");
  }
  if (clutter_blobs < 0 || clutter_blobs > 100) {
    return Fail(error, "clutter blobs must be in [0, 100]");
  }
  if (!std::isfinite(clutter_size) || clutter_size <= 0.0 || clutter_size > 2.0) {
    return Fail(error, "clutter size must be in (0, 2] (relative to the silhouette)");
  }
  if (!InUnitInterval(shadow))
    return Fail(error, "shadow must be in [0, 1] (relative to the silhouette)");
  if (!InRange(stick_width_px, 1.0, 100.0))
    return Fail(error, "stick width must be in [1, 100] pixels");
  if (!(std::isfinite(stick_length) && stick_length > 0.0 && stick_length <= 5.0)) {
    return Fail(error, "stick length must be in (0, 5] (relative to the silhouette)");
  }
  if (fingers < 0 || fingers > 5) return Fail(error, "fingers must be in [0, 5]");
  if (!(std::isfinite(finger_width) && finger_width > 0.0 && finger_width <= 1.0) ||
      !(std::isfinite(finger_length) && finger_length > 0.0 && finger_length <= 1.0)) {
    return Fail(error, "finger width and length must be in (0, 1] (relative to the silhouette)");
  }
  if (!InRange(ragged_px, 0.0, 20.0))
    return Fail(error, "ragged boundary must be in [0, 20] pixels");
  if (!InRange(ragged_scale_px, 1.0, 100.0)) {
    return Fail(error, "ragged boundary scale must be in [1, 100] pixels");
  }
  if (holes < 0 || holes > 100) return Fail(error, "holes must be in [0, 100]");
  if (!InRange(hole_radius_px, 1.0, 50.0))
    return Fail(error, "hole radius must be in [1, 50] pixels");
  if (specks < 0 || specks > 1000) return Fail(error, "specks must be in [0, 1000]");
  if (!InRange(speck_radius_px, 1.0, 20.0)) {
    return Fail(error, "speck radius must be in [1, 20] pixels");
  }
  if (!InUnitInterval(missed_probability)) {
    return Fail(error, "missed-frame probability must be in [0, 1]");
  }
  if (!InUnitInterval(bad_probability)) {
    return Fail(error, "bad-frame probability must be in [0, 1]");
  }
  if (missed_probability + bad_probability > 1.0 + 1e-12) {
    return Fail(error, "missed-frame and bad-frame probabilities must sum to at most 1");
  }
  return true;
}

bool DegradationOptions::Any() const {
  return noise_fraction > 0.0 || erode_px > 0 || dilate_px > 0 || occluders > 0 ||
         passing_share > 0.0 || clutter_blobs > 0 || shadow > 0.0 || stick || fingers > 0 ||
         ragged_px > 0.0 || holes > 0 || specks > 0 || missed_probability > 0.0 ||
         bad_probability > 0.0;
}

uint32_t AppliedMaskEffects(const DegradationOptions& options, int frame) {
  if (ChooseFrameDegradation(options, frame) == FrameDegradation::kMissed) return 0;
  uint32_t effects = 0;
  const auto set = [&effects](bool on, MaskEffect effect) {
    if (on) effects |= effect;
  };
  set(options.erode_px > 0, kMaskEffectErode);
  set(options.dilate_px > 0, kMaskEffectDilate);
  set(options.shadow > 0.0, kMaskEffectShadow);
  set(options.stick, kMaskEffectStick);
  set(options.fingers > 0, kMaskEffectFingers);
  set(options.ragged_px > 0.0, kMaskEffectRagged);
  set(options.holes > 0, kMaskEffectHoles);
  set(options.occluders > 0, kMaskEffectOccluders);
  set(PassPhase(options, frame) >= 0.0, kMaskEffectPassing);
  set(options.clutter_blobs > 0, kMaskEffectClutter);
  set(options.specks > 0, kMaskEffectSpecks);
  set(options.noise_fraction > 0.0, kMaskEffectNoise);
  return effects;
}

double PassPhase(const DegradationOptions& options, int frame) {
  if (!(options.passing_share > 0.0) || frame < 0) return -1.0;
  const PassWindow window = PassWindowOf(options, frame);
  const int64_t j = frame - window.first_frame;
  if (j < 0 || j >= options.pass_frames) return -1.0;
  return (static_cast<double>(j) + 0.5) / options.pass_frames;
}

FrameDegradation ChooseFrameDegradation(const DegradationOptions& options, int frame) {
  if (options.missed_probability <= 0.0 && options.bad_probability <= 0.0) {
    return FrameDegradation::kNone;
  }
  std::mt19937_64 engine = Engine(options, frame, kStreamFrameKind);
  const double u = Uniform01(engine);
  if (u < options.missed_probability) return FrameDegradation::kMissed;
  if (u < options.missed_probability + options.bad_probability) return FrameDegradation::kBad;
  return FrameDegradation::kNone;
}

FrameDegradation DegradeMask(const DegradationOptions& options, int frame, cv::Mat* mask) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("invalid degradation options: ", problem);
  if (mask == nullptr || mask->type() != CV_8UC1 || mask->empty()) {
    ThrowError("DegradeMask: the mask must be a non-empty CV_8UC1 image");
  }
  const FrameDegradation kind = ChooseFrameDegradation(options, frame);
  if (kind == FrameDegradation::kMissed) {
    mask->setTo(0);
    return kind;
  }
  const cv::Rect image(0, 0, mask->cols, mask->rows);
  const cv::Rect silhouette = cv::boundingRect(*mask);
  const bool in_view = silhouette.area() > 0;

  Morphology(cv::MORPH_ERODE, options.erode_px, mask);
  Morphology(cv::MORPH_DILATE, options.dilate_px, mask);
  const double size = std::max(silhouette.width, silhouette.height);
  if (in_view && options.shadow > 0.0) Shadow(options, frame, size, mask);
  if (in_view && (options.stick || options.fingers > 0)) Hand(options, frame, size, mask);
  if (in_view && options.ragged_px > 0.0) {
    Ragged(options, frame, cv::boundingRect(*mask), mask);
  }
  if (in_view && options.holes > 0) Holes(options, frame, mask);
  if (in_view && options.occluders > 0) {
    std::mt19937_64 engine = Engine(options, frame, kStreamOccluders);
    for (int i = 0; i < options.occluders; ++i) {
      const cv::Point2d centre = RandomPointIn(engine, silhouette);
      FillEllipse(engine, centre, RandomSemiAxes(engine, options.occluder_size, silhouette), 0,
                  mask);
    }
  }
  if (in_view) {
    const double phase = PassPhase(options, frame);
    if (phase >= 0.0) PassingOccluder(options, frame, phase, silhouette, mask);
  }
  if (options.clutter_blobs > 0) {
    std::mt19937_64 engine = Engine(options, frame, kStreamClutter);
    const cv::Rect reference = in_view ? silhouette : image;
    for (int i = 0; i < options.clutter_blobs; ++i) {
      const cv::Point2d centre = RandomPointIn(engine, image);
      FillEllipse(engine, centre, RandomSemiAxes(engine, options.clutter_size, reference), 255,
                  mask);
    }
  }
  if (in_view && options.specks > 0) Specks(options, frame, silhouette, mask);
  if (kind == FrameDegradation::kBad && in_view) {
    std::mt19937_64 engine = Engine(options, frame, kStreamBad);
    BadSegmentation(engine, silhouette, mask);
  }
  if (options.noise_fraction > 0.0) {
    std::mt19937_64 engine = Engine(options, frame, kStreamNoise);
    SaltAndPepper(engine, options.noise_fraction, mask);
  }
  return kind;
}

}  // namespace silpose
