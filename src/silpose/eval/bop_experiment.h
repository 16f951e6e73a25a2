#pragma once
// silpose on a dataset in the BOP format (eval/bop_dataset.h): every object instance of every
// scene of a split is one sequence. Its images, in increasing image id, are fed to a Tracker
// (track/tracker.h) with the scene's camera (cam_K of the instance's first image, image size from
// the scene's first image): the dataset's masks (mask_visib/ or mask/) as silhouettes, or the
// images themselves through a segmenter. Each frame's estimate is compared with scene_gt.json:
//  - right object: the estimated model is the instance's obj_id;
//  - rotation error (degrees), translation error (mm and % of the true distance |t|);
//  - BOP's ADD, ADD-S, ADD(-S) (ADD-S for objects with symmetries), MSSD and MSPD
//    (eval/bop_pose_error.h) on the vertices of the eval models, with the symmetries of
//    models_info.json (continuous ones sampled).
// A frame without a pose or with the wrong object has infinite ADD/ADD-S/MSSD/MSPD (a miss) and no
// rotation or translation error. Recalls: ADD(-S) < 0.1 diameter, and BOP's average recalls of
// MSSD and MSPD over their threshold ranges; AR = (AR_MSSD + AR_MSPD) / 2 (BOP's AR also averages
// VSD, which needs depth and is not computed here). Frames whose visible fraction
// (scene_gt_info.json) is below min_visible_fraction are tracked but not counted.
//
// The database's models must be the dataset's, named obj_XXXXXX (mesh file stems); model units are
// the dataset's millimetres.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/eval/bop_dataset.h"
#include "silpose/pose/pose_error.h"
#include "silpose/segment/segmenter.h"

namespace silpose {

/// Where the silhouettes come from.
enum class BopMaskSource : uint8_t {
  kVisible = 0,  ///< "visib": mask_visib/ (the visible part; occlusions cut it)
  kFull = 1,     ///< "full": mask/ (the whole silhouette, as if nothing occluded it)
  kImage = 2,    ///< the rgb/ (or gray/) images through BopExperimentOptions::segmentation
};

struct BopExperimentOptions {
  /// Scenes (ids) and objects (obj_ids) to evaluate; empty = all.
  std::vector<int> scene_ids;
  std::vector<int> object_ids;
  BopMaskSource masks = BopMaskSource::kVisible;
  /// With kImage: how the images become silhouettes (kind bgsub or threshold).
  SegmenterOptions segmentation;
  /// Match every frame on its own (no particle filter).
  bool brute_force = false;
  /// Particles per object of the filter; 0 = the tracker's default.
  int particles_per_object = 0;
  /// Filter seed (instance i of the run uses seed + i).
  uint64_t seed = 1;
  /// At most this many frames per instance (the first ones); 0 = all.
  int max_frames = 0;
  /// At most this many instances in all (in scene, obj_id order); 0 = all.
  int max_instances = 0;
  /// Frames whose visible fraction is below this are not counted (they are still tracked); BOP
  /// counts targets with at least 0.1. Frames without a known fraction are counted.
  double min_visible_fraction = 0.0;
  /// Sampling of continuous symmetries (SymmetryTransforms).
  double symmetry_step_fraction = 0.01;

  bool Check(std::string* error = nullptr) const;
};

/// One frame of one instance.
struct BopFrameResult {
  int scene_id = 0;
  int image_id = 0;
  int obj_id = 0;
  /// Occurrence of the object in the scene (BopInstance::occurrence) and its gt index here.
  int occurrence = 0;
  int gt_index = 0;
  double visible_fraction = std::numeric_limits<double>::quiet_NaN();
  /// Counted in the summaries (visible enough).
  bool counted = true;
  /// The tracker's status (FrameResult::status).
  std::string status;
  /// Estimated object (obj_id), -1 = none; its score.
  int estimated_obj_id = -1;
  double score = std::numeric_limits<double>::quiet_NaN();
  bool right_object = false;
  /// The estimate (camera_from_object, mm), when there is one.
  std::optional<Rigid3> estimate;
  /// Right object with a pose: the errors; else NaN.
  double rotation_deg = std::numeric_limits<double>::quiet_NaN();
  double translation_mm = std::numeric_limits<double>::quiet_NaN();
  /// translation_mm / |t_true| * 100.
  double translation_percent = std::numeric_limits<double>::quiet_NaN();
  /// BOP errors (mm, MSPD px); infinite for a miss.
  double add = std::numeric_limits<double>::infinity();
  double adds = std::numeric_limits<double>::infinity();
  double mssd = std::numeric_limits<double>::infinity();
  double mspd = std::numeric_limits<double>::infinity();
  /// ADD-S if the object has a symmetry, else ADD.
  double add_or_adds = std::numeric_limits<double>::infinity();
  double time_ms = 0.0;
};

/// Summary of the counted frames of one object (or all objects).
struct BopSummary {
  /// obj_id, or 0 for all objects together.
  int obj_id = 0;
  std::string name;
  int instances = 0;
  int frames = 0;
  int with_pose = 0;
  int right_object = 0;
  /// Of the frames with the right object and a pose.
  ErrorSummary rotation_deg;
  ErrorSummary translation_mm;
  ErrorSummary translation_percent;
  /// ADD(-S) < 0.1 diameter, fraction in [0, 1].
  double recall_add = 0.0;
  double ar_mssd = 0.0;
  double ar_mspd = 0.0;
  /// (ar_mssd + ar_mspd) / 2.
  double ar = 0.0;
  double ms_per_frame = 0.0;

  double RightObjectPercent() const { return frames > 0 ? 100.0 * right_object / frames : 0.0; }
};

struct BopExperimentResult {
  std::string split;
  std::vector<BopFrameResult> frames;
  /// Per evaluated object, by obj_id, then all together.
  std::vector<BopSummary> objects;
  BopSummary total;
  /// Things the user should know (a scene whose camera matrix varies, ...), one line each.
  std::vector<std::string> warnings;
  double seconds = 0.0;
};

/// Frames the experiment will process (for a progress bar). Reads the scenes.
int BopFrameCount(const BopDataset& dataset, const BopExperimentOptions& options);

/// Runs the experiment. `database` holds the dataset's models (names obj_XXXXXX; others are
/// allowed, an estimate naming one is a wrong object). `on_frame()` is called after every frame.
/// Throws silpose::Error for invalid options, an object with no database model, or a missing or
/// unreadable file (named).
BopExperimentResult RunBopExperiment(const BopDataset& dataset, const ViewDatabase& database,
                                     const BopExperimentOptions& options,
                                     const std::function<void()>& on_frame = {});

/// Header of the per-frame CSV.
const char* BopFramesHeader();
/// Writes one row per frame (BopFramesHeader): unknowns empty, misses "inf". Throws
/// silpose::Error naming the file.
void WriteBopFrames(const std::filesystem::path& path, const BopExperimentResult& result);
/// Header of the summary CSV.
const char* BopSummaryHeader();
/// Writes one row per object and one for all ("all", obj_id 0).
void WriteBopSummary(const std::filesystem::path& path, const BopExperimentResult& result);
/// Writes the estimates in the BOP19 results format (scene_id,im_id,obj_id,score,R,t,time; t in
/// mm, time in s), one row per frame with a pose, for BOP's own evaluation tools.
void WriteBopResults(const std::filesystem::path& path, const BopExperimentResult& result);

}  // namespace silpose
