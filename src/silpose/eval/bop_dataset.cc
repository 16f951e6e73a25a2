#include "silpose/eval/bop_dataset.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {
namespace {

using Json = nlohmann::json;

Json ReadJson(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) ThrowError(path.string(), ": file not found");
  std::ifstream file(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open");
  std::stringstream text;
  text << file.rdbuf();
  try {
    return Json::parse(text.str());
  } catch (const Json::exception& exception) {
    // nlohmann's message is one line: "[json.exception.parse_error.101] parse error at line ...".
    std::string message = exception.what();
    const size_t bracket = message.find("] ");
    if (bracket != std::string::npos) message = message.substr(bracket + 2);
    ThrowError(path.string(), ": not valid JSON: ", message);
  }
}

// An image / object id key of a BOP JSON object ("12" -> 12).
int IdKey(const std::string& key, const std::filesystem::path& path) {
  if (key.empty() || key.size() > 9 ||
      !std::all_of(key.begin(), key.end(), [](unsigned char c) { return std::isdigit(c); })) {
    ThrowError(path.string(), ": key '", key, "' is not an id (a whole number)");
  }
  return std::stoi(key);
}

double Number(const Json& value, const std::filesystem::path& path, const std::string& where) {
  if (!value.is_number()) ThrowError(path.string(), ": ", where, " must be a number");
  const double number = value.get<double>();
  if (!std::isfinite(number)) ThrowError(path.string(), ": ", where, " is not finite");
  return number;
}

std::vector<double> Numbers(const Json& value, size_t count, const std::filesystem::path& path,
                            const std::string& where) {
  if (!value.is_array() || value.size() != count)
    ThrowError(path.string(), ": ", where, " must be a list of ", count, " numbers");
  std::vector<double> numbers;
  for (size_t i = 0; i < count; ++i) numbers.push_back(Number(value[i], path, where));
  return numbers;
}

const Json& Member(const Json& object, const char* name, const std::filesystem::path& path,
                   const std::string& where) {
  if (!object.is_object()) ThrowError(path.string(), ": ", where, " must be a JSON object");
  const auto found = object.find(name);
  if (found == object.end()) ThrowError(path.string(), ": ", where, " has no '", name, "'");
  return *found;
}

Eigen::Matrix3d Matrix3(const std::vector<double>& v) {
  Eigen::Matrix3d m;
  m << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  return m;
}

// A rotation given by a file: orthonormal with determinant +1 within a tolerance that lets the
// rounding of stored matrices pass (BOP stores about 8 significant digits).
Eigen::Matrix3d Rotation(const std::vector<double>& v, const std::filesystem::path& path,
                         const std::string& where) {
  const Eigen::Matrix3d r = Matrix3(v);
  const double orthogonality =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthogonality < 1e-3) || !(r.determinant() > 0.0))
    ThrowError(path.string(), ": ", where, " is not a rotation matrix");
  return r;
}

Rigid3 Pose(const Json& entry, const char* rotation_key, const char* translation_key,
            const std::filesystem::path& path, const std::string& where) {
  Rigid3 pose;
  pose.rotation = Rotation(
      Numbers(Member(entry, rotation_key, path, where), 9, path, where + " " + rotation_key), path,
      where + " " + rotation_key);
  const std::vector<double> t =
      Numbers(Member(entry, translation_key, path, where), 3, path, where + " " + translation_key);
  pose.translation = Eigen::Vector3d(t[0], t[1], t[2]);
  return pose;
}

std::string SixDigits(int id) {
  char text[32];
  std::snprintf(text, sizeof(text), "%06d", id);
  return text;
}

bool IsSceneFolder(const std::filesystem::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  return entry.is_directory() && name.size() == 6 &&
         std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::vector<std::filesystem::path> SceneFolders(const std::filesystem::path& split_folder) {
  std::vector<std::filesystem::path> scenes;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(split_folder, error)) {
    if (IsSceneFolder(entry)) scenes.push_back(entry.path());
  }
  if (error) ThrowError(split_folder.string(), ": cannot list folder: ", error.message());
  std::sort(scenes.begin(), scenes.end());
  return scenes;
}

}  // namespace

std::string BopModelName(int obj_id) { return "obj_" + SixDigits(obj_id); }

std::string BopModel::name() const { return mesh_path.stem().string(); }

std::vector<BopModel> ReadBopModels(const std::filesystem::path& models_folder) {
  std::error_code error;
  if (!std::filesystem::is_directory(models_folder, error))
    ThrowError(models_folder.string(), ": models folder not found");
  const std::filesystem::path path = models_folder / "models_info.json";
  const Json info = ReadJson(path);
  if (!info.is_object() || info.empty())
    ThrowError(path.string(), ": must be a non-empty JSON object (obj_id -> model info)");
  std::vector<BopModel> models;
  for (const auto& [key, entry] : info.items()) {
    BopModel model;
    model.obj_id = IdKey(key, path);
    const std::string where = "object " + key;
    model.mesh_path = models_folder / (BopModelName(model.obj_id) + ".ply");
    model.diameter = Number(Member(entry, "diameter", path, where), path, where + " diameter");
    if (!(model.diameter > 0.0)) ThrowError(path.string(), ": ", where, " diameter must be > 0");
    if (entry.contains("min_x") && entry.contains("size_x")) {
      const char* axes[3] = {"x", "y", "z"};
      for (int k = 0; k < 3; ++k) {
        const std::string min_key = std::string("min_") + axes[k];
        const std::string size_key = std::string("size_") + axes[k];
        model.min_corner[k] =
            Number(Member(entry, min_key.c_str(), path, where), path, where + " " + min_key);
        model.size[k] =
            Number(Member(entry, size_key.c_str(), path, where), path, where + " " + size_key);
      }
    }
    if (const auto found = entry.find("symmetries_discrete"); found != entry.end()) {
      if (!found->is_array())
        ThrowError(path.string(), ": ", where, " symmetries_discrete must be a list");
      for (size_t s = 0; s < found->size(); ++s) {
        const std::string label = where + " symmetries_discrete[" + std::to_string(s) + "]";
        const std::vector<double> m = Numbers((*found)[s], 16, path, label);
        Rigid3 symmetry;
        symmetry.rotation =
            Rotation({m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]}, path, label);
        symmetry.translation = Eigen::Vector3d(m[3], m[7], m[11]);
        model.discrete_symmetries.push_back(symmetry);
      }
    }
    if (const auto found = entry.find("symmetries_continuous"); found != entry.end()) {
      if (!found->is_array())
        ThrowError(path.string(), ": ", where, " symmetries_continuous must be a list");
      for (size_t s = 0; s < found->size(); ++s) {
        const std::string label = where + " symmetries_continuous[" + std::to_string(s) + "]";
        const std::vector<double> axis =
            Numbers(Member((*found)[s], "axis", path, label), 3, path, label + " axis");
        const std::vector<double> offset =
            Numbers(Member((*found)[s], "offset", path, label), 3, path, label + " offset");
        ContinuousSymmetry symmetry{.axis = Eigen::Vector3d(axis[0], axis[1], axis[2]),
                                    .offset = Eigen::Vector3d(offset[0], offset[1], offset[2])};
        if (!(symmetry.axis.norm() > 0.0))
          ThrowError(path.string(), ": ", label, " axis must not be zero");
        model.continuous_symmetries.push_back(symmetry);
      }
    }
    if (!std::filesystem::is_regular_file(model.mesh_path, error))
      ThrowError(model.mesh_path.string(), ": mesh of object ", model.obj_id, " (listed in ",
                 path.string(), ") not found");
    models.push_back(std::move(model));
  }
  std::sort(models.begin(), models.end(),
            [](const BopModel& a, const BopModel& b) { return a.obj_id < b.obj_id; });
  return models;
}

std::filesystem::path BopScene::MaskPath(int image_id, int gt_index, bool visible_part) const {
  return folder / (visible_part ? "mask_visib" : "mask") /
         (SixDigits(image_id) + "_" + SixDigits(gt_index) + ".png");
}

BopScene ReadBopScene(const std::filesystem::path& scene_folder) {
  BopScene scene;
  scene.folder = scene_folder;
  const std::string name = scene_folder.filename().string();
  if (name.empty() || name.size() > 9 ||
      !std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isdigit(c); }))
    ThrowError(scene_folder.string(), ": a scene folder is named by its id (6 digits)");
  scene.scene_id = std::stoi(name);
  std::error_code error;
  if (!std::filesystem::is_directory(scene_folder, error))
    ThrowError(scene_folder.string(), ": scene folder not found");

  // Cameras: the list of images.
  const std::filesystem::path camera_path = scene_folder / "scene_camera.json";
  const Json cameras = ReadJson(camera_path);
  if (!cameras.is_object())
    ThrowError(camera_path.string(), ": must be a JSON object (image id -> camera)");
  std::map<int, BopImage> images;
  for (const auto& [key, entry] : cameras.items()) {
    BopImage image;
    image.image_id = IdKey(key, camera_path);
    const std::string where = "image " + key;
    image.camera_matrix = Matrix3(
        Numbers(Member(entry, "cam_K", camera_path, where), 9, camera_path, where + " cam_K"));
    if (const auto found = entry.find("depth_scale"); found != entry.end())
      image.depth_scale = Number(*found, camera_path, where + " depth_scale");
    if (entry.contains("cam_R_w2c") && entry.contains("cam_t_w2c"))
      image.camera_from_world = Pose(entry, "cam_R_w2c", "cam_t_w2c", camera_path, where);
    images[image.image_id] = std::move(image);
  }
  if (images.empty()) ThrowError(camera_path.string(), ": lists no image");

  // Ground truth.
  const std::filesystem::path gt_path = scene_folder / "scene_gt.json";
  const Json gt = ReadJson(gt_path);
  if (!gt.is_object()) ThrowError(gt_path.string(), ": must be a JSON object (image id -> list)");
  for (const auto& [key, list] : gt.items()) {
    const int image_id = IdKey(key, gt_path);
    const auto image = images.find(image_id);
    if (image == images.end())
      ThrowError(gt_path.string(), ": image ", image_id, " is not in scene_camera.json");
    if (!list.is_array())
      ThrowError(gt_path.string(), ": image ", key, " must have a list of objects");
    for (size_t k = 0; k < list.size(); ++k) {
      const std::string where = "image " + key + " entry " + std::to_string(k);
      BopGroundTruth object;
      const double obj_id =
          Number(Member(list[k], "obj_id", gt_path, where), gt_path, where + " obj_id");
      if (obj_id != std::floor(obj_id) || obj_id < 0 || obj_id > 1e9)
        ThrowError(gt_path.string(), ": ", where, " obj_id must be a whole number >= 0");
      object.obj_id = static_cast<int>(obj_id);
      object.camera_from_object = Pose(list[k], "cam_R_m2c", "cam_t_m2c", gt_path, where);
      image->second.objects.push_back(object);
    }
  }

  // Visible fractions, when given.
  const std::filesystem::path info_path = scene_folder / "scene_gt_info.json";
  if (std::filesystem::exists(info_path, error)) {
    const Json info = ReadJson(info_path);
    if (!info.is_object()) ThrowError(info_path.string(), ": must be a JSON object");
    for (const auto& [key, list] : info.items()) {
      const int image_id = IdKey(key, info_path);
      const auto image = images.find(image_id);
      if (image == images.end() || !list.is_array()) continue;
      for (size_t k = 0; k < list.size() && k < image->second.objects.size(); ++k) {
        if (list[k].is_object() && list[k].contains("visib_fract")) {
          image->second.objects[k].visible_fraction =
              Number(list[k]["visib_fract"], info_path,
                     "image " + key + " entry " + std::to_string(k) + " visib_fract");
        }
      }
    }
  }

  // Image files.
  for (const char* folder : {"rgb", "gray"}) {
    if (!std::filesystem::is_directory(scene_folder / folder, error)) continue;
    for (auto& [id, image] : images) {
      for (const char* extension : {".png", ".jpg", ".jpeg", ".tif", ".tiff"}) {
        const std::filesystem::path candidate = scene_folder / folder / (SixDigits(id) + extension);
        if (std::filesystem::is_regular_file(candidate, error)) {
          image.image_path = candidate;
          break;
        }
      }
    }
    break;
  }
  for (auto& [id, image] : images) scene.images.push_back(std::move(image));
  return scene;
}

std::vector<BopInstance> BopSceneInstances(const BopScene& scene) {
  std::map<std::pair<int, int>, BopInstance> instances;
  for (size_t i = 0; i < scene.images.size(); ++i) {
    std::map<int, int> seen;  // obj_id -> occurrences so far in this image
    const auto& objects = scene.images[i].objects;
    for (size_t k = 0; k < objects.size(); ++k) {
      const int obj_id = objects[k].obj_id;
      const int occurrence = seen[obj_id]++;
      BopInstance& instance = instances[{obj_id, occurrence}];
      instance.obj_id = obj_id;
      instance.occurrence = occurrence;
      instance.frames.push_back({.image = static_cast<int>(i), .gt_index = static_cast<int>(k)});
    }
  }
  std::vector<BopInstance> result;
  for (auto& [key, instance] : instances) result.push_back(std::move(instance));
  return result;
}

PinholeCamera BopCamera(const Eigen::Matrix3d& k, int width_px, int height_px) {
  PinholeCamera camera;
  camera.width_px = width_px;
  camera.height_px = height_px;
  camera.focal_x_px = k(0, 0);
  camera.focal_y_px = k(1, 1);
  camera.principal_x_px = k(0, 2);
  camera.principal_y_px = k(1, 2);
  std::string problem;
  if (std::abs(k(1, 0)) > 1e-9 || std::abs(k(2, 0)) > 1e-9 || std::abs(k(2, 1)) > 1e-9 ||
      std::abs(k(2, 2) - 1.0) > 1e-9) {
    ThrowError("camera matrix is not of the pinhole form [fx s cx; 0 fy cy; 0 0 1]");
  }
  if (!camera.Check(&problem)) ThrowError("camera matrix: ", problem);
  return camera;
}

const BopModel* BopDataset::FindModel(int obj_id) const {
  for (const BopModel& model : models) {
    if (model.obj_id == obj_id) return &model;
  }
  return nullptr;
}

std::filesystem::path BopDataset::EvalMeshPath(int obj_id) const {
  return eval_models_folder / (BopModelName(obj_id) + ".ply");
}

BopDataset OpenBopDataset(const std::filesystem::path& root, const BopDatasetOptions& options) {
  std::error_code error;
  if (!std::filesystem::is_directory(root, error))
    ThrowError(root.string(), ": dataset folder not found");
  BopDataset dataset;
  dataset.root = root;
  dataset.models_folder = root / options.models_folder;
  dataset.models = ReadBopModels(dataset.models_folder);
  if (!options.eval_models_folder.empty()) {
    dataset.eval_models_folder = root / options.eval_models_folder;
    if (!std::filesystem::is_directory(dataset.eval_models_folder, error))
      ThrowError(dataset.eval_models_folder.string(), ": models folder not found");
  } else if (std::filesystem::is_directory(root / "models_eval", error)) {
    dataset.eval_models_folder = root / "models_eval";
  } else {
    dataset.eval_models_folder = dataset.models_folder;
  }

  if (!options.split.empty()) {
    dataset.split = options.split;
    const std::filesystem::path folder = root / options.split;
    if (!std::filesystem::is_directory(folder, error))
      ThrowError(folder.string(), ": split folder not found");
    dataset.scene_folders = SceneFolders(folder);
    if (dataset.scene_folders.empty())
      ThrowError(folder.string(), ": no scene folder (6-digit name) in the split");
  } else {
    std::vector<std::string> candidates;
    for (const auto& entry : std::filesystem::directory_iterator(root, error)) {
      if (entry.is_directory()) candidates.push_back(entry.path().filename().string());
    }
    if (error) ThrowError(root.string(), ": cannot list folder: ", error.message());
    std::sort(candidates.begin(), candidates.end());
    const auto test = std::find(candidates.begin(), candidates.end(), "test");
    if (test != candidates.end()) std::rotate(candidates.begin(), test, test + 1);
    for (const std::string& name : candidates) {
      if (name.rfind("models", 0) == 0) continue;
      std::vector<std::filesystem::path> scenes = SceneFolders(root / name);
      if (!scenes.empty()) {
        dataset.split = name;
        dataset.scene_folders = std::move(scenes);
        break;
      }
    }
    if (dataset.split.empty())
      ThrowError(root.string(), ": no split folder with scenes (e.g. test/000001/)");
  }
  return dataset;
}

}  // namespace silpose
