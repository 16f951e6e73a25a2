#pragma once
// Reading datasets in the BOP format (the layout of the BOP benchmark's datasets: LM, LM-O,
// T-LESS, YCB-V, ...):
//
//   DIR/models/models_info.json      per obj_id: diameter, min_x/y/z, size_x/y/z (mm), optional
//                                    symmetries_discrete (4x4 matrices, row-major, flattened,
//                                    translation in mm) and symmetries_continuous ({axis, offset})
//   DIR/models/obj_000001.ply        the meshes, in mm
//   DIR/models_eval/                 optional: the same models resampled evenly (for the errors)
//   DIR/<split>/<scene_id, 6 digits>/
//       scene_camera.json            per image id: cam_K (9 numbers, row-major), depth_scale,
//                                    optional cam_R_w2c (9 numbers) and cam_t_w2c (mm)
//       scene_gt.json                per image id: a list of {obj_id, cam_R_m2c (9 numbers,
//                                    row-major), cam_t_m2c (mm)}; "gt index" = position in it
//       scene_gt_info.json           optional: per image id and gt index, visib_fract
//       rgb/ or gray/                the images, <image id, 6 digits>.png (or .jpg, .tif)
//       mask/ and mask_visib/        <image id, 6 digits>_<gt index, 6 digits>.png: the whole
//                                    silhouette of the object, and its visible part
//
// Poses are camera_from_object (x_cam = R x_obj + t, OpenCV camera frame, millimetres), which is
// BOP's m2c. Every missing or malformed file is a silpose::Error naming the file and the problem.

#include <Eigen/Core>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "silpose/eval/bop_pose_error.h"
#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"

namespace silpose {

/// One object model of the dataset (models_info.json).
struct BopModel {
  int obj_id = 0;
  /// models/obj_<obj_id, 6 digits>.ply.
  std::filesystem::path mesh_path;
  /// Diameter: the largest distance between two vertices, mm.
  double diameter = 0.0;
  /// Bounding box: lowest corner and size, mm (zero when models_info.json does not give them).
  Eigen::Vector3d min_corner = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  /// Discrete symmetries (model_from_model, mm), the identity not included.
  std::vector<Rigid3> discrete_symmetries;
  std::vector<ContinuousSymmetry> continuous_symmetries;

  /// The mesh's name: its file stem ("obj_000001"), as silpose names database models.
  std::string name() const;
  bool HasSymmetries() const {
    return !discrete_symmetries.empty() || !continuous_symmetries.empty();
  }
};

/// "obj_000012" for 12.
std::string BopModelName(int obj_id);

/// Reads DIR/models_info.json of a models folder; models by increasing obj_id. Throws
/// silpose::Error naming the file for a missing or malformed file, or a model whose mesh
/// (obj_XXXXXX.ply) is missing.
std::vector<BopModel> ReadBopModels(const std::filesystem::path& models_folder);

/// One annotated object instance in one image (scene_gt.json, scene_gt_info.json).
struct BopGroundTruth {
  int obj_id = 0;
  Rigid3 camera_from_object;
  /// Visible fraction of the object's silhouette, [0, 1]; NaN without scene_gt_info.json.
  double visible_fraction = std::numeric_limits<double>::quiet_NaN();
};

/// One image of a scene.
struct BopImage {
  int image_id = 0;
  /// Intrinsics (pixels, OpenCV convention).
  Eigen::Matrix3d camera_matrix = Eigen::Matrix3d::Identity();
  /// Depth unit of the depth images, mm (1 if not given).
  double depth_scale = 1.0;
  /// Pose of the world in the camera (cam_R_w2c, cam_t_w2c), when given.
  std::optional<Rigid3> camera_from_world;
  /// The annotated objects, in gt index order (empty if the image has no entry in scene_gt.json).
  std::vector<BopGroundTruth> objects;
  /// The image file in rgb/ or gray/, empty when there is none.
  std::filesystem::path image_path;
};

/// One scene: the images in increasing image id.
struct BopScene {
  int scene_id = 0;
  std::filesystem::path folder;
  std::vector<BopImage> images;

  /// folder/mask_visib/<image id>_<gt index>.png (visible part), or folder/mask/... (whole).
  std::filesystem::path MaskPath(int image_id, int gt_index, bool visible_part) const;
};

/// Reads scene_camera.json, scene_gt.json and, if present, scene_gt_info.json of a scene folder
/// (named by its 6-digit id) and finds the images. Images are those of scene_camera.json. Throws
/// silpose::Error naming the file and the problem.
BopScene ReadBopScene(const std::filesystem::path& scene_folder);

/// One object instance followed through a scene: the `occurrence`-th annotation (from 0) with
/// obj_id in each image that has one, in image order. (BOP lists the instances of a scene in the
/// same order in every image.)
struct BopInstance {
  int obj_id = 0;
  int occurrence = 0;
  struct Frame {
    /// Index into BopScene::images, and the gt index within that image.
    int image = 0;
    int gt_index = 0;
  };
  std::vector<Frame> frames;
};

/// The instances of a scene, by obj_id then occurrence.
std::vector<BopInstance> BopSceneInstances(const BopScene& scene);

/// The pinhole camera of a BOP camera matrix for images of the given size (no distortion; the
/// skew is ignored). Throws silpose::Error if the matrix is not a valid pinhole matrix.
PinholeCamera BopCamera(const Eigen::Matrix3d& camera_matrix, int width_px, int height_px);

struct BopDatasetOptions {
  /// The split folder (test, val, test_primesense, ...); empty: "test" if it exists, else the
  /// first folder by name that holds scene folders.
  std::string split;
  /// The models folder (meshes for the database and models_info.json).
  std::string models_folder = "models";
  /// The models whose vertices the errors are computed on; empty: models_eval if it exists,
  /// else models_folder.
  std::string eval_models_folder;
};

/// A dataset: its models and the scene folders of one split.
struct BopDataset {
  std::filesystem::path root;
  std::string split;
  std::filesystem::path models_folder;
  std::filesystem::path eval_models_folder;
  std::vector<BopModel> models;
  /// Scene folders of the split (6-digit names), by increasing scene id.
  std::vector<std::filesystem::path> scene_folders;

  /// The model with this obj_id, or null.
  const BopModel* FindModel(int obj_id) const;
  /// The eval mesh of a model: eval_models_folder/obj_XXXXXX.ply.
  std::filesystem::path EvalMeshPath(int obj_id) const;
};

/// Opens a dataset (reads models_info.json, lists the split's scenes; scenes are read later by
/// ReadBopScene). Throws silpose::Error naming the folder or file when the root, the models or
/// the split is missing, or the split holds no scene.
BopDataset OpenBopDataset(const std::filesystem::path& root, const BopDatasetOptions& options = {});

}  // namespace silpose
