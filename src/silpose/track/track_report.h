#pragma once
// What a tracking run found, summarised and drawn: the estimated (and, with ground truth, the
// true) trajectory on the view sphere (paper Fig. 5) and the pose error over the frames (paper
// Fig. 6), as plot/figure.h figures; and, with ground truth, the accuracy figures of the run.

#include <Eigen/Core>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/plot/figure.h"
#include "silpose/pose/pose_error.h"
#include "silpose/pose/pose_output.h"

namespace silpose {

/// The truth of one frame (e.g. from a synth folder's groundtruth.csv).
struct TruthFrame {
  /// Model name (mesh file stem).
  std::string object;
  /// Unit view direction (object centre -> camera), model frame.
  Eigen::Vector3d view_dir_in_object = Eigen::Vector3d::UnitZ();
  /// object_to_camera.
  Rigid3 camera_from_object;
  /// Object centre in the model frame (for the camera distance).
  Eigen::Vector3d object_centre = Eigen::Vector3d::Zero();
};

/// The truth of a frame showing `object` (a model name), with the object centre taken from the
/// database (zero if the database has no such model).
TruthFrame MakeTruthFrame(const ViewDatabase& database, const std::string& object,
                          const Eigen::Vector3d& view_dir_in_object,
                          const Rigid3& camera_from_object);

/// Accuracy of a run against ground truth. Frames before `skip_frames` are left out (the filter's
/// start-up); every later frame with a truth counts.
struct TrackAccuracy {
  int frames = 0;
  /// Frames whose estimated object is the true one.
  int right_object = 0;
  /// The paper's pose error (view-direction distance, [0, 2]) of every frame with an estimate,
  /// right object or not (the paper counts every frame, all of which had a silhouette; here frames
  /// without an estimate, e.g. before the first silhouette, are left out: see view_error.count).
  ErrorSummary view_error;
  /// Rotation error (degrees) and translation error relative to the true camera distance from the
  /// object centre, of frames with the right object and a 6-DOF pose.
  ErrorSummary rotation_deg;
  ErrorSummary translation_relative;
  /// The values summarised above, in frame order (for pooling several runs).
  std::vector<double> view_values;
  std::vector<double> rotation_values_deg;
  std::vector<double> translation_values_relative;
  /// view_error and rotation_deg modulo the true object's symmetry (geometry/symmetry.h: the
  /// database's symmetries of the model; equal to them for objects without rotations, or when the
  /// report was made without a database). A wrong object's view error is not reduced.
  ErrorSummary view_error_symmetric;
  ErrorSummary rotation_deg_symmetric;
  std::vector<double> view_values_symmetric;
  std::vector<double> rotation_values_deg_symmetric;

  double RightObjectPercent() const { return frames > 0 ? 100.0 * right_object / frames : 0.0; }
};

class TrackReport {
 public:
  /// `object_names`: the database's model names, by index.
  explicit TrackReport(std::vector<std::string> object_names);
  /// The database's model names, and their symmetries for the errors modulo symmetry.
  explicit TrackReport(const ViewDatabase& database);

  /// Adds the next frame's result and, if known, its truth.
  void Add(const FrameResult& result, const std::optional<TruthFrame>& truth = std::nullopt);

  int num_frames() const { return static_cast<int>(frames_.size()); }
  bool has_truth() const { return truth_frames_ > 0; }
  TrackAccuracy Accuracy(int skip_frames = 0) const;

  /// Mean time per stage over the frames where the stage ran (FrameResult::time_segment_ms ...
  /// time_refine_ms), milliseconds; NaN for a stage that never ran.
  struct StageTimes {
    double segment_ms = 0.0;
    double describe_ms = 0.0;
    double match_ms = 0.0;
    double pose_ms = 0.0;
    double refine_ms = 0.0;
  };
  StageTimes MeanStageTimes() const;
  /// Frames per state (FrameResult::state), indexed by the TrackState value.
  std::array<int, 6> StateCounts() const;

  /// Where the true object changes (frames with a truth whose object differs from the previous
  /// truth's): the frame, and how many frames later the estimate names the new object and keeps
  /// naming it for `stable_frames` frames (-1: never, before the end or the next change).
  struct ObjectChange {
    int frame = 0;
    int delay = -1;
  };
  std::vector<ObjectChange> ObjectChanges(int stable_frames = 5) const;

  /// Paper Fig. 5: the view directions on the unit sphere, seen from +z (left panel, z >= 0) and
  /// from -z (right panel, z < 0, mirrored so that both show the sphere as seen from outside):
  /// the estimates as markers, one colour per object, the truth as a grey line.
  Figure TrajectoryFigure(const std::string& title = "") const;
  /// Paper Fig. 6: per frame the view-direction error (left) and, where a 6-DOF pose was
  /// estimated, the rotation error in degrees (right); frames with the wrong object in red.
  /// Requires ground truth (else the figure has no data).
  Figure ErrorFigure(const std::string& title = "") const;

 private:
  struct Entry {
    FrameResult result;
    std::optional<TruthFrame> truth;
  };
  std::vector<std::string> object_names_;
  // Symmetry transforms (SymmetryTransforms) by model name; missing = identity only.
  std::map<std::string, std::vector<Rigid3>> symmetries_;
  std::vector<Entry> frames_;
  int truth_frames_ = 0;
};

}  // namespace silpose
