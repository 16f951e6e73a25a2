#include "silpose/track/smoother.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <utility>

#include "silpose/io/image_codec.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr int kMaxLag = 100000;
// The most a flip check allows for the object's turn in one frame, degrees.
constexpr double kMaxFlipMotionDeg = 30.0;

// The state of frame `frame` in `history` (oldest first), or null if the history does not reach
// it.
const PoseState* StateAt(const std::vector<PoseState>& history, int64_t frame) {
  if (history.empty()) return nullptr;
  const int64_t index = frame - history.front().frame;
  if (index < 0 || index >= static_cast<int64_t>(history.size())) return nullptr;
  const PoseState& state = history[static_cast<size_t>(index)];
  return state.frame == frame ? &state : nullptr;
}

}  // namespace

TrackSmoother::TrackSmoother(Tracker& tracker, int lag) : tracker_(tracker), lag_(lag) {
  if (tracker.filter() == nullptr)
    ThrowError("smoothing needs the particle filter's histories (not brute force)");
  if (tracker.num_frames() != 0)
    ThrowError("smoothing must start with the stream (the tracker has processed ",
               tracker.num_frames(), " frames)");
  if (lag < kOffline || lag > kMaxLag)
    ThrowError("the smoothing lag must be in [0, ", kMaxLag, "] frames (or offline), got ", lag);
  for (const ModelViews& model : tracker.database().models)
    equivalence_.emplace_back(model.symmetry);
  if (!tracker.options().filter.keep_history)
    ThrowError("smoothing reads the particle histories: the tracker keeps none (keep_history off)");
  const int64_t kept = tracker.options().filter.max_history_frames;
  if (lag == kOffline && kept != 0) {
    ThrowError("offline smoothing needs the whole history (max_history_frames 0), not ", kept,
               " frames");
  }
  if (lag != kOffline && kept != 0 && kept <= lag) {
    ThrowError("a smoothing lag of ", lag, " frames needs max_history_frames 0 or above ", lag,
               ", not ", kept);
  }
}

bool TrackSmoother::IsMirrorFlip(const ViewDatabase& database, const ViewEquivalence& same,
                                 int object, int before, int after, double radius_deg,
                                 double motion_deg) {
  const int num_views = database.sphere.num_views();
  if (object < 0 || object >= static_cast<int>(database.models.size()) || before < 0 || after < 0 ||
      before >= num_views || after >= num_views)
    return false;
  const ObjectSymmetry& symmetry = database.models[static_cast<size_t>(object)].symmetry;
  const Eigen::Vector3d& d = database.sphere.directions[static_cast<size_t>(after)];
  const Eigen::Vector3d& b = database.sphere.directions[static_cast<size_t>(before)];
  if (same.AngleDeg(d, b) <= radius_deg) return false;
  for (const MirrorSymmetry& mirror : symmetry.mirrors) {
    // The view whose outline is that of `before`, mirrored.
    const Eigen::Vector3d twin = mirror.TwinView(b);
    // A twin within the radius of `before` (seen along the plane's normal) is the same view.
    if (same.AngleDeg(twin, b) <= radius_deg) continue;
    if (same.AngleDeg(d, twin) <= radius_deg + std::max(motion_deg, 0.0)) return true;
  }
  return false;
}

bool TrackSmoother::FlipsBack(const TrackedFrame& tracked) const {
  const auto twin_better = [](const TrackedFrame& frame) {
    return frame.mirror_twin && frame.mirror_twin->view >= 0 &&
           frame.mirror_twin->score > frame.mirror_twin->reported_score;
  };
  if (!twin_better(tracked)) return false;
  for (const Held& later : pending_) {
    if (later.flip) return true;
    if (!twin_better(later.tracked)) return false;
  }
  return false;
}

TrackSmoother::Held TrackSmoother::Hold(TrackedFrame tracked) {
  Held held;
  if (tracked.estimate && tracked.estimate->measured) {
    const int object = tracked.estimate->object;
    held.flip = object >= 0 && object == previous_object_ &&
                IsMirrorFlip(tracker_.database(), equivalence_[static_cast<size_t>(object)], object,
                             previous_view_, tracked.estimate->view,
                             tracker_.options().filter.mode_radius_deg, previous_speed_deg_);
    previous_object_ = tracked.estimate->object;
    previous_view_ = tracked.estimate->view;
    previous_speed_deg_ = std::min(tracked.estimate->speed_deg, kMaxFlipMotionDeg);
  }
  const cv::Mat& mask = tracked.segmentation.mask;
  held.size = mask.size();
  if (!mask.empty() && tracked.segmentation.ok()) {
    held.box = cv::boundingRect(mask);
    if (held.box.area() > 0) {
      if (lag_ == kOffline) {
        if (!EncodeImage(".png", mask(held.box), &held.png, {cv::IMWRITE_PNG_COMPRESSION, 1}))
          ThrowError("frame ", tracked.result.frame, ": could not compress its mask");
      } else {
        held.crop = mask(held.box).clone();
      }
    }
  }
  tracked.segmentation.mask.release();
  if (lag_ == kOffline) {
    // What a revision does not need: the outline points and the radii.
    std::vector<Eigen::Vector2d>().swap(tracked.silhouette.outline_px);
    std::vector<float>().swap(tracked.silhouette.signature.radii);
    if (tracked.on_axis) std::vector<float>().swap(tracked.on_axis->signature.radii);
    if (tracked.estimate) tracked.estimate->object_probability.shrink_to_fit();
  }
  held.tracked = std::move(tracked);
  return held;
}

TrackedFrame TrackSmoother::Release(Held held, const StateLookup& smoothed) {
  TrackedFrame tracked = std::move(held.tracked);
  // The mask as the frame had it (zero outside the object's box).
  if (!held.size.empty()) {
    cv::Mat mask(held.size, CV_8UC1, cv::Scalar(0));
    if (!held.crop.empty()) {
      held.crop.copyTo(mask(held.box));
    } else if (!held.png.empty()) {
      const cv::Mat crop = DecodeImage(held.png, cv::IMREAD_UNCHANGED);
      if (crop.size() != held.box.size() || crop.type() != CV_8UC1)
        ThrowError("frame ", tracked.result.frame, ": could not restore its mask");
      crop.copyTo(mask(held.box));
    }
    tracked.segmentation.mask = mask;
  }
  // Only frames with a filter estimate of an object are smoothed, within that object.
  if (lag_ == 0 || !tracked.estimate || !tracked.estimate->measured || tracked.estimate->object < 0)
    return tracked;
  const std::optional<PoseState> state = smoothed(tracked.result.frame, tracked.estimate->object);
  const auto moved = [&tracked](const TrackedFrame& frame) {
    return frame.result.object != tracked.result.object ||
           frame.result.view_dir_in_object != tracked.result.view_dir_in_object;
  };
  // Smoothing chooses among the poses that explain the frame: a pose whose model covers the
  // frame's silhouette less well than the live pose's did, or not measurably, is not reported. A
  // frame without a fit live (e.g. without a pose) may be re-posed.
  const auto fits_worse = [&tracked](const TrackedFrame& frame) {
    return std::isfinite(tracked.result.iou) &&
           !(std::isfinite(frame.result.iou) && frame.result.iou >= tracked.result.iou);
  };
  bool kept_live = false;
  TrackedFrame revised =
      state && state->object >= 0 && state->view >= 0 ? tracker_.Revise(tracked, *state) : tracked;
  if (moved(revised) && fits_worse(revised)) {
    revised = tracked;
    kept_live = true;
  }
  if (!moved(revised) && FlipsBack(tracked)) {
    // The filter left this view for its mirror twin later, and the twin fitted better here.
    PoseState twin;
    twin.frame = tracked.result.frame;
    twin.object = tracked.estimate->object;
    twin.view = tracked.mirror_twin->view;
    twin.roll_deg = tracked.mirror_twin->roll_deg;
    twin.roll_known = true;
    twin.score = tracked.mirror_twin->score;
    twin.measured = true;
    TrackedFrame flipped = tracker_.Revise(tracked, twin);
    if (moved(flipped) && fits_worse(flipped)) {
      kept_live = true;
    } else {
      revised = std::move(flipped);
    }
  }
  if (moved(revised)) {
    ++num_revised_;
  } else if (kept_live) {
    ++num_kept_live_;
  }
  return revised;
}

std::vector<TrackedFrame> TrackSmoother::Process(const cv::Mat& frame) {
  return Queue(tracker_.Process(frame));
}

std::vector<TrackedFrame> TrackSmoother::Process(const cv::Mat& frame,
                                                 SegmentationResult segmentation,
                                                 double segment_ms) {
  return Queue(tracker_.Process(frame, std::move(segmentation), segment_ms));
}

std::vector<TrackedFrame> TrackSmoother::Queue(TrackedFrame tracked) {
  pending_.push_back(Hold(std::move(tracked)));
  std::vector<TrackedFrame> done;
  if (lag_ == kOffline || static_cast<int>(pending_.size()) <= lag_) return done;
  Held held = std::move(pending_.front());
  pending_.pop_front();
  done.push_back(Release(std::move(held), [this](int64_t f, int object) {
    return tracker_.filter()->SmoothedState(f, object);
  }));
  return done;
}

std::vector<TrackedFrame> TrackSmoother::Finish() {
  std::vector<TrackedFrame> done;
  done.reserve(pending_.size());
  // Offline: per object, the history that explains the whole stream best; with a lag, the last
  // frames each smoothed by what the stream gave after it.
  std::map<int, std::vector<PoseState>> histories;
  const int64_t first = pending_.empty() ? 0 : pending_.front().tracked.result.frame;
  const auto offline = [this, &histories, first](int64_t f,
                                                 int object) -> std::optional<PoseState> {
    auto it = histories.find(object);
    if (it == histories.end()) {
      it = histories.emplace(object, tracker_.filter()->MostLikelyHistory(first, object)).first;
    }
    const PoseState* state = StateAt(it->second, f);
    return state != nullptr ? std::optional<PoseState>(*state) : std::nullopt;
  };
  const auto lagged = [this](int64_t f, int object) {
    return tracker_.filter()->SmoothedState(f, object);
  };
  while (!pending_.empty()) {
    Held held = std::move(pending_.front());
    pending_.pop_front();
    if (lag_ == kOffline) {
      done.push_back(Release(std::move(held), offline));
    } else {
      done.push_back(Release(std::move(held), lagged));
    }
  }
  return done;
}

}  // namespace silpose
