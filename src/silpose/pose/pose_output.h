#pragma once
// Per-frame results and the files they go to (docs/tracking.md, "Outputs"):
//  - PosesCsvWriter: POSES.csv, one row per frame, header
//      frame,object,score,probability,view_x,view_y,view_z,roll_deg,status,time_ms,particles,
//      effective_particles,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,time_segment_ms,
//      time_describe_ms,time_match_ms,time_pose_ms,time_refine_ms,confidence,state,iou,
//      runner_up_object,runner_up_mass,runner_up_view_x,runner_up_view_y,runner_up_view_z,
//      runner_up_roll_deg
//    with empty cells where a value is unknown (no object, no probability, no pose, ...);
//  - JsonLinesWriter: one JSON object per frame and line, the same information (unknowns null);
//  - BopCsvWriter: the BOP19 results format `scene_id,im_id,obj_id,score,R,t,time`, one row per
//    frame with a pose: R row-major as 9 space-separated numbers, t in millimetres as 3, time in
//    seconds (-1 if unknown).
// Poses are object_to_camera (x_cam = R x_obj + t, OpenCV camera frame, t in model units). Every
// writer flushes each row to the file as it is written (a crash later loses nothing), throws
// silpose::Error naming the file when it cannot be opened or a write fails, and checks the final
// close in Close() (the destructor closes without checking).

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "silpose/geometry/rigid3.h"

namespace silpose {

/// What a frame's result can be trusted for (docs/confidence.md), a fixed set users can act on.
/// POSES.csv / JSON column `state`.
enum class TrackState : uint8_t {
  /// The object and pose are trusted: confidence at or above the threshold, one clear mode.
  kTracking,
  /// Two or more hypotheses explain the silhouette about equally (a mirror twin view, a look-alike
  /// object): the result's runner_up_* fields give the other one.
  kAmbiguous,
  /// The silhouette has fitted no database object for several frames: an object not in the
  /// database is in view.
  kUnknownObject,
  /// Low confidence right after the object was tracked (the outline explains only part of the
  /// silhouette), or the silhouette's area changed abruptly: an occluder, a hand, a segmentation
  /// failure.
  kBadSegmentation,
  /// Low confidence for none of the reasons above (the filter has not found or has lost the
  /// object).
  kLost,
  /// No usable silhouette in this frame (segmentation found nothing, too small, ...): the result
  /// is the filter's prediction.
  kNoSilhouette,
};

/// "tracking", "ambiguous", "unknown-object", "bad-segmentation", "lost", "no-silhouette".
const char* TrackStateName(TrackState state);
/// Inverse of TrackStateName; false if `name` is none of them.
bool ParseTrackState(std::string_view name, TrackState* state);

/// What was found in one frame. NaN / empty / -1 mean "unknown" and give empty cells (CSV) or null
/// (JSON).
struct FrameResult {
  /// Frame number, from 0 in input order (POSES.csv `frame`, BOP `im_id`).
  int frame = 0;
  /// The frame's file name or other label (JSON only); empty = unknown.
  std::string frame_name;
  /// The image's own number when the input names it (an image file "000012.png" -> 12), else -1.
  /// BOP's im_id is this number when known, else `frame`.
  int image_id = -1;
  /// Whether the frame had a usable silhouette and how it was used ("measured",
  /// "predicted-no-silhouette-empty", ...); free text without commas or line breaks.
  std::string status;
  /// Index of the object in the database, -1 = none; its name (the mesh file's stem).
  int object = -1;
  std::string object_name;
  /// Correlation score of the estimate, [-1, 1].
  double score = std::numeric_limits<double>::quiet_NaN();
  /// Probability of the object (particle filter).
  double probability = std::numeric_limits<double>::quiet_NaN();
  /// Unit view direction (object centre -> camera), model frame.
  std::optional<Eigen::Vector3d> view_dir_in_object;
  /// Camera roll, degrees (geometry/view_frame.h).
  double roll_deg = std::numeric_limits<double>::quiet_NaN();
  /// Processing time of the frame, milliseconds.
  double time_ms = std::numeric_limits<double>::quiet_NaN();
  /// Where that time went, milliseconds (NaN = the stage did not run): segmentation of the frame
  /// into a silhouette mask; description (outline, polar signature, on-axis mapping); matching
  /// (the particle filter's step and the view polish, or the brute-force search); the 6-DOF pose
  /// from the matched view; its contour refinement. Decoding the frame is in none of them.
  double time_segment_ms = std::numeric_limits<double>::quiet_NaN();
  double time_describe_ms = std::numeric_limits<double>::quiet_NaN();
  double time_match_ms = std::numeric_limits<double>::quiet_NaN();
  double time_pose_ms = std::numeric_limits<double>::quiet_NaN();
  double time_refine_ms = std::numeric_limits<double>::quiet_NaN();
  /// Particles used and their effective number; 0 / NaN without a particle filter.
  int particles = 0;
  double effective_particles = std::numeric_limits<double>::quiet_NaN();
  /// 6-DOF pose (object_to_camera), if estimated.
  std::optional<Rigid3> camera_from_object;
  /// The probability, in [0, 1], that the object is right and the rotation within 10 degrees
  /// (modulo the object's symmetry) (track/confidence.h); 0 for a frame without a silhouette
  /// that has an estimate (the filter's prediction), NaN without any estimate.
  double confidence = std::numeric_limits<double>::quiet_NaN();
  /// What the result can be trusted for.
  TrackState state = TrackState::kNoSilhouette;
  /// Intersection over union of the model's silhouette at the refined pose with the frame's mask
  /// (NaN when not refined).
  double iou = std::numeric_limits<double>::quiet_NaN();
  /// The strongest other hypothesis: the particle filter's (FilterEstimate::runner_up), or
  /// another pose of the object that explains the outline as well (mass NaN: a mirror twin of the
  /// reported view or a pose farther than 15 degrees; docs/confidence.md): object (-1 = none) and
  /// name, its share of the posterior weight, view direction and roll.
  int runner_up_object = -1;
  std::string runner_up_name;
  double runner_up_mass = std::numeric_limits<double>::quiet_NaN();
  std::optional<Eigen::Vector3d> runner_up_view_dir;
  double runner_up_roll_deg = std::numeric_limits<double>::quiet_NaN();
};

/// The POSES.csv header line (without the newline).
const char* PosesCsvHeader();

/// Writes POSES.csv (see above). Object names are quoted if they contain a comma, a quote or a
/// line break (RFC 4180).
class PosesCsvWriter {
 public:
  /// Creates (truncates) the file and writes the header. Throws silpose::Error naming the file.
  explicit PosesCsvWriter(const std::filesystem::path& path);
  /// Writes and flushes one row. Throws silpose::Error naming the file if the write fails.
  void Write(const FrameResult& result);
  /// Closes the file; throws silpose::Error naming it if closing fails. Writing after it throws.
  void Close();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ofstream stream_;
};

/// Writes JSON Lines: per frame one object {"frame", "frame_name", "status", "object",
/// "object_index", "score", "probability", "view_dir" [x, y, z], "roll_deg", "time_ms",
/// "time_segment_ms", "time_describe_ms", "time_match_ms", "time_pose_ms", "time_refine_ms",
/// "particles", "effective_particles", "pose" {"R": 3 rows of 3, "t": [x, y, z]}, "confidence",
/// "state", "iou", "runner_up" {"object", "object_index", "mass", "view_dir", "roll_deg"}},
/// unknowns null.
class JsonLinesWriter {
 public:
  explicit JsonLinesWriter(const std::filesystem::path& path);
  void Write(const FrameResult& result);
  void Close();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ofstream stream_;
};

struct BopOutputOptions {
  /// BOP scene_id written on every row (>= 0).
  int scene_id = 1;
  /// BOP obj_id of database model i: object_ids[i]; empty = i + 1.
  std::vector<int> object_ids;
  /// Size of one model unit in millimetres (t_mm = t * model_unit_mm), > 0: 1 for meshes in mm,
  /// 1000 for meshes in metres.
  double model_unit_mm = 1.0;

  bool Check(std::string* error = nullptr) const;
};

/// Writes a BOP19 results CSV (see above): header `scene_id,im_id,obj_id,score,R,t,time`, then one
/// row per frame with an object and a pose (others are skipped); im_id = image_id if known, else
/// frame; score = the
/// result's score (0 if unknown), time = time_ms / 1000 (-1 if unknown).
class BopCsvWriter {
 public:
  /// Throws silpose::Error naming the file, or for invalid options.
  BopCsvWriter(const std::filesystem::path& path, const BopOutputOptions& options = {});
  /// Writes and flushes the row of a frame with a pose; returns false (writing nothing) for a
  /// frame without object or pose. Throws silpose::Error naming the file if the write fails, or if
  /// the object index has no entry in options.object_ids.
  bool Write(const FrameResult& result);
  void Close();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  BopOutputOptions options_;
  std::ofstream stream_;
};

}  // namespace silpose
