#include "silpose/synth/degradation.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "silpose/synth/synth_random.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using synth_internal::FrameSeed;
using synth_internal::Uniform;
using synth_internal::Uniform01;

// One random stream per purpose (see the header).
enum Stream : uint64_t {
  kStreamFrameKind = 1,
  kStreamOccluders = 2,
  kStreamClutter = 3,
  kStreamBad = 4,
  kStreamNoise = 5,
};

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

bool DegradationOptions::Check(std::string* error) const {
  if (!InUnitInterval(noise_fraction)) return Fail(error, "noise fraction must be in [0, 1]");
  if (erode_px < 0 || erode_px > 100 || dilate_px < 0 || dilate_px > 100) {
    return Fail(error, "erosion and dilation must be in [0, 100] pixels");
  }
  if (occluders < 0 || occluders > 100) return Fail(error, "occluders must be in [0, 100]");
  if (!std::isfinite(occluder_size) || occluder_size <= 0.0 || occluder_size > 2.0) {
    return Fail(error, "occluder size must be in (0, 2] (relative to the silhouette)");
  }
  if (clutter_blobs < 0 || clutter_blobs > 100) {
    return Fail(error, "clutter blobs must be in [0, 100]");
  }
  if (!std::isfinite(clutter_size) || clutter_size <= 0.0 || clutter_size > 2.0) {
    return Fail(error, "clutter size must be in (0, 2] (relative to the silhouette)");
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
         clutter_blobs > 0 || missed_probability > 0.0 || bad_probability > 0.0;
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
  if (in_view && options.occluders > 0) {
    std::mt19937_64 engine = Engine(options, frame, kStreamOccluders);
    for (int i = 0; i < options.occluders; ++i) {
      const cv::Point2d centre = RandomPointIn(engine, silhouette);
      FillEllipse(engine, centre, RandomSemiAxes(engine, options.occluder_size, silhouette), 0,
                  mask);
    }
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
