#pragma once
// Smoothed trajectories from the particle filter's histories (docs/tracking.md, "Smoothing").
//
// Every particle of the filter carries the chain of states it came from (filter/particle_filter.h,
// "Pose history"). When a frame is ambiguous (a bilaterally symmetric object seen from a view and
// its mirror twin give the same outline; a poor mask), the filter may follow the wrong hypothesis
// for a while and then switch: the particles on the right hypothesis survive, and their histories
// say where the object was in the frames before. A smoother reports each frame from those
// histories instead of the estimate made at the time:
//  - fixed lag L (live): frame t is reported after frame t + L has been tracked, from the
//    ancestors in frame t of the particles at frame t + L, weighted by their weights then (the
//    smoothed posterior of frame t; ParticleFilter::SmoothedState): the state at the centre of
//    its heaviest mode. Costs L frames of latency; lag 0 reports every frame as tracked;
//  - offline: every frame is reported at the end of the stream, from the particle history that
//    explains the whole stream best (ParticleFilter::MostLikelyHistory: the highest sum of the
//    filter's log-likelihoods over every frame). The ancestors' vote would hang on the last
//    frame's posterior, which a few bad masks at the end can move; the sum over the whole stream
//    does not.
// Smoothing corrects the view and roll, never the object: a particle's history never leaves its
// object, so histories cannot tell when the object in front of the camera changed; each frame is
// smoothed among the histories of the object it was reported as. A frame whose smoothed state is
// its own hypothesis (a view within the filter's mode radius modulo symmetry) is reported
// exactly as tracked; only the others are re-posed (Tracker::Revise: pose, refinement, fit and
// confidence at the new view, the former view as the runner-up).
//
//   Tracker tracker(database, camera, options);  // options.filter.max_history_frames: see below
//   TrackSmoother smoother(tracker, 10);         // or TrackSmoother::kOffline
//   for (cv::Mat frame; source->Read(&frame);)
//     for (const TrackedFrame& done : smoother.Process(frame)) Use(done);
//   for (const TrackedFrame& done : smoother.Finish()) Use(done);
//
// Memory. The smoother holds the frames not yet reported: with a lag, L + 1 frames with their
// masks cropped to the object; offline, every frame, its mask cropped and PNG-compressed (about
// 1-3 KB per frame for a 640 x 480 video) and without the silhouette's outline and radii. The
// filter must keep the histories that long: max_history_frames must be 0 (all) offline, and 0 or
// more than L with a lag.

#include <deque>
#include <functional>
#include <optional>
#include <vector>

#include "silpose/track/tracker.h"

namespace silpose {

class TrackSmoother {
 public:
  /// The lag value that means "offline" (report everything at Finish).
  static constexpr int kOffline = -1;

  /// `tracker` must track with the particle filter (not brute force), be fed only through this
  /// smoother from its first frame on, and outlive it. `lag` >= 0 frames, or kOffline. Throws
  /// silpose::Error for a brute-force tracker, a tracker that has processed frames already, a lag
  /// below kOffline or above 100000, or a filter whose max_history_frames is too short for the lag.
  TrackSmoother(Tracker& tracker, int lag);

  /// Tracks the next frame (Tracker::Process). Returns the frames that are now final, oldest
  /// first: with lag L the frame L frames back (none for the first L frames); offline none.
  std::vector<TrackedFrame> Process(const cv::Mat& frame);
  /// The frames still held, oldest first, smoothed by everything tracked so far (as above). Call
  /// once the stream has ended; the smoother is then empty (further Process calls go on with the
  /// same stream).
  std::vector<TrackedFrame> Finish();

  int lag() const { return lag_; }
  /// Frames held now (not yet returned).
  int num_pending() const { return static_cast<int>(pending_.size()); }
  /// Frames returned re-posed (their hypothesis changed by the smoothing), so far.
  int num_revised() const { return num_revised_; }

 private:
  struct Held {
    TrackedFrame tracked;
    /// The mask's object box (with a margin), raw (lag) or PNG (offline), and the frame size.
    cv::Rect box;
    cv::Size size;
    cv::Mat crop;
    std::vector<unsigned char> png;
  };
  /// The smoothed state of (frame, object the frame was reported as), if any.
  using StateLookup = std::function<std::optional<PoseState>(int64_t, int)>;
  Held Hold(TrackedFrame tracked) const;
  /// `held` as final, re-posed if `smoothed` says so.
  TrackedFrame Release(Held held, const StateLookup& smoothed);

  Tracker& tracker_;
  int lag_ = 0;
  std::deque<Held> pending_;
  int num_revised_ = 0;
};

}  // namespace silpose
