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
// Mirror twins. A proposal that moves the filter from a wrong mirror twin to the right one
// continues the history of the particles nearest to it, which lie on the wrong twin: no history
// holds the right view for the frames before. So a second rule: when the filter's estimate jumps
// to the mirror twin of the previous frame's view (a flip), the frames before it in which the twin
// of the reported view explained the outline better than the reported view itself (the tracker
// scores both, TrackedFrame::mirror_twin), back to the first that did not, are reported as that
// twin: within the lag, or back to the start offline.
//
// The frame's own outline has the last word: a frame is re-posed (by either rule) only if the model
// at the new pose covers its silhouette at least as well (IoU of the refined model silhouette with
// the mask) as at the live pose; otherwise, or when the new pose's IoU cannot be measured, it is
// reported as tracked (num_kept_live). When the smoothed state is refused, the mirror-twin rule is
// still tried. A frame without an IoU live (e.g. without a pose) may be re-posed. A particle
// history, or a flip, can say where the object was; it cannot make a worse fit to the frame
// right. (Without this rule smoothing made threshold-like masks' frames worse than live:
// docs/tracking.md.)
//
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
  /// below kOffline or above 100000, or a filter that keeps no history (keep_history) or whose
  /// max_history_frames is too short for the lag.
  TrackSmoother(Tracker& tracker, int lag);

  /// Tracks the next frame (Tracker::Process). Returns the frames that are now final, oldest
  /// first: with lag L the frame L frames back (none for the first L frames); offline none.
  std::vector<TrackedFrame> Process(const cv::Mat& frame);
  /// The same for a frame segmented already (Tracker::Process with a segmentation).
  std::vector<TrackedFrame> Process(const cv::Mat& frame, SegmentationResult segmentation,
                                    double segment_ms);
  /// The frames still held, oldest first, smoothed by everything tracked so far (as above). Call
  /// once the stream has ended; the smoother is then empty (further Process calls go on with the
  /// same stream).
  std::vector<TrackedFrame> Finish();

  /// Whether database view `after` of `object` is a mirror flip of view `before`, one frame
  /// later: farther than `radius_deg` from it, and within `radius_deg` + `motion_deg` (what the
  /// object may have turned in the frame) of one of its mirror twins (-M before for each mirror
  /// plane of the object) that is itself farther than `radius_deg` from `before`; angles modulo
  /// the object's rotational symmetry (`same`).
  static bool IsMirrorFlip(const ViewDatabase& database, const ViewEquivalence& same, int object,
                           int before, int after, double radius_deg, double motion_deg = 0.0);

  int lag() const { return lag_; }
  /// Frames held now (not yet returned).
  int num_pending() const { return static_cast<int>(pending_.size()); }
  /// Frames returned re-posed (their hypothesis changed by the smoothing), so far.
  int num_revised() const { return num_revised_; }
  /// Frames the smoothing would have re-posed at a pose whose model fitted their silhouette worse
  /// than the live pose's (a lower IoU, or none measured), returned as tracked, so far.
  int num_kept_live() const { return num_kept_live_; }

 private:
  struct Held {
    TrackedFrame tracked;
    /// The mask's object box (with a margin), raw (lag) or PNG (offline), and the frame size.
    cv::Rect box;
    cv::Size size;
    cv::Mat crop;
    std::vector<unsigned char> png;
    /// The estimate jumped to the mirror twin of the previous frame's view.
    bool flip = false;
  };
  /// The smoothed state of (frame, object the frame was reported as), if any.
  using StateLookup = std::function<std::optional<PoseState>(int64_t, int)>;
  Held Hold(TrackedFrame tracked);
  /// Holds a frame just tracked; returns the frame that is now final, if one is.
  std::vector<TrackedFrame> Queue(TrackedFrame tracked);
  /// `held` as final, re-posed if `smoothed` says so.
  TrackedFrame Release(Held held, const StateLookup& smoothed);

  /// The frame's mirror twin explained it better than its reported view, and a flip follows in
  /// pending_ after only such frames.
  bool FlipsBack(const TrackedFrame& tracked) const;

  Tracker& tracker_;
  int lag_ = 0;
  std::deque<Held> pending_;
  int num_revised_ = 0;
  int num_kept_live_ = 0;
  std::vector<ViewEquivalence> equivalence_;
  int previous_object_ = -1;
  int previous_view_ = -1;
  double previous_speed_deg_ = 0.0;
};

}  // namespace silpose
