#pragma once
// A small dataset in the BOP format (eval/bop_dataset.h), rendered by silpose with known truth,
// the fixture of the `eval bop` tests (not installed: *_testing.h headers are left out of the
// install). Header-only (render, mesh, OpenCV imgcodecs and nlohmann-json), so that tests that do
// not link the eval library can write it too.
//
//   ROOT/models/obj_000001.ply   a box 80 x 50 x 30 mm centred at its origin (three 180-degree
//                                symmetries, listed in models_info.json)
//   ROOT/models/obj_000002.ply   an asymmetric block: an L of two arms with a tab on one end, mm
//   ROOT/models/models_info.json
//   ROOT/<split>/<scene>/        scene_camera.json (cam_K, depth_scale, cam_R_w2c, cam_t_w2c),
//                                scene_gt.json, scene_gt_info.json (visib_fract), rgb/ (the two
//                                objects shaded in two colours on a grey background), mask/ and
//                                mask_visib/ (the visible part, from the rendered depths)
// The two objects stand on a table (world z up, mm) 180 mm apart; the camera looks at the table
// from `elevation_deg` above it at `camera_distance_mm` and moves along an arc of azimuths, so the
// objects are seen off the optical axis from a slowly changing direction (like a hand-held
// recording). All objects are in every image.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "silpose/eval/bop_dataset.h"
#include "silpose/geometry/pinhole_camera.h"
#include "silpose/geometry/rigid3.h"
#include "silpose/io/image_codec.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/render/shaded_renderer.h"
#include "silpose/util/error.h"

namespace silpose {

struct SyntheticBopOptions {
  std::string split = "test";
  int scene_id = 1;
  /// Images, ids 0 .. num_images - 1.
  int num_images = 18;
  int width_px = 640;
  int height_px = 480;
  /// cam_K: focal lengths and principal point, pixels.
  double fx = 572.4, fy = 573.6, cx = 325.3, cy = 242.0;
  /// The camera looks at the middle of the table from this distance (mm) and elevation, along
  /// azimuths from first to last (degrees; 0 = from the -y side of the table).
  double camera_distance_mm = 520.0;
  double elevation_deg = 40.0;
  double first_azimuth_deg = -40.0;
  double last_azimuth_deg = 45.0;
  /// Write the image ids of scene_gt.json and scene_camera.json (and the masks) starting here.
  int first_image_id = 0;
};

/// The truth written, for checks.
struct SyntheticBopDataset {
  std::filesystem::path root;
  std::filesystem::path scene_folder;
  Eigen::Matrix3d camera_matrix = Eigen::Matrix3d::Identity();
  /// Per object (obj_id 1, 2): the mesh as written (mm) and its diameter.
  std::vector<TriangleMesh> meshes;
  std::vector<double> diameters;
  /// Per image: id, camera_from_world, and per gt index (obj_id = index + 1) camera_from_object.
  std::vector<int> image_ids;
  std::vector<Rigid3> camera_from_world;
  std::vector<std::vector<Rigid3>> camera_from_object;
  std::vector<std::vector<double>> visible_fraction;
};

namespace synthetic_bop_internal {

// Adds an axis-aligned box [lo, hi] whose faces are split into n x n squares (two triangles each).
inline void AddBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int n,
                   TriangleMesh* mesh) {
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const uint32_t base = static_cast<uint32_t>(mesh->vertices.size());
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3f p;
          p[axis] = side == 0 ? lo[axis] : hi[axis];
          p[u] = lo[u] + (hi[u] - lo[u]) * static_cast<float>(i) / static_cast<float>(n);
          p[v] = lo[v] + (hi[v] - lo[v]) * static_cast<float>(j) / static_cast<float>(n);
          mesh->vertices.push_back(p);
        }
      }
      const auto at = [&](int i, int j) { return base + static_cast<uint32_t>(i * (n + 1) + j); };
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          mesh->triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
          mesh->triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
      }
    }
  }
}

inline void WritePly(const std::filesystem::path& path, const TriangleMesh& mesh) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file << "ply\nformat ascii 1.0\nelement vertex " << mesh.vertices.size()
       << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
       << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& p : mesh.vertices) file << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  for (const auto& t : mesh.triangles) file << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

inline double Diameter(const TriangleMesh& mesh) {
  double best = 0.0;
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (size_t j = i + 1; j < mesh.vertices.size(); ++j)
      best = std::max(best, static_cast<double>((mesh.vertices[i] - mesh.vertices[j]).norm()));
  }
  return best;
}

inline std::vector<double> Flat(const Eigen::Matrix3d& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}

inline std::vector<double> Flat(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

inline void WriteJson(const std::filesystem::path& path, const nlohmann::json& json) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file << json.dump(1) << '\n';
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

inline void WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (!WriteImage(path.string(), image)) ThrowError(path.string(), ": cannot write");
}

inline std::string Id6(int id) {
  char text[16];
  std::snprintf(text, sizeof(text), "%06d", id);
  return text;
}

// Camera at `eye` looking at `target`, world z up appearing up in the image.
inline Rigid3 LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Rigid3 camera_from_world;
  camera_from_world.rotation.row(0) = x.transpose();
  camera_from_world.rotation.row(1) = y.transpose();
  camera_from_world.rotation.row(2) = z.transpose();
  camera_from_world.translation = -(camera_from_world.rotation * eye);
  return camera_from_world;
}

}  // namespace synthetic_bop_internal

/// The box of obj_000001 (80 x 50 x 30 mm, centred) and the L block of obj_000002 (mm, its
/// bounding box centred at the origin).
inline std::vector<TriangleMesh> SyntheticBopMeshes() {
  using synthetic_bop_internal::AddBox;
  TriangleMesh box;
  box.name = "obj_000001";
  AddBox({-40.f, -25.f, -15.f}, {40.f, 25.f, 15.f}, 4, &box);
  TriangleMesh block;
  block.name = "obj_000002";
  AddBox({0.f, 0.f, 0.f}, {70.f, 18.f, 22.f}, 4, &block);    // long arm along x
  AddBox({0.f, 18.f, 0.f}, {18.f, 45.f, 22.f}, 4, &block);   // short arm along y
  AddBox({52.f, 0.f, 22.f}, {70.f, 18.f, 40.f}, 3, &block);  // tab on the long arm's end
  const Eigen::Vector3f centre(35.f, 22.5f, 20.f);
  for (auto& p : block.vertices) p -= centre;
  return {box, block};
}

/// Writes the dataset to `root` (created; existing files replaced). Throws silpose::Error naming
/// the file if a write fails.
inline SyntheticBopDataset WriteSyntheticBopDataset(const std::filesystem::path& root,
                                                    const SyntheticBopOptions& options = {}) {
  using namespace synthetic_bop_internal;
  SyntheticBopDataset dataset;
  dataset.root = root;
  dataset.meshes = SyntheticBopMeshes();
  const std::filesystem::path models = root / "models";
  dataset.scene_folder = root / options.split / Id6(options.scene_id);
  for (const char* sub : {"rgb", "mask", "mask_visib"})
    std::filesystem::create_directories(dataset.scene_folder / sub);
  std::filesystem::create_directories(models);

  // Models.
  nlohmann::json info = nlohmann::json::object();
  for (size_t m = 0; m < dataset.meshes.size(); ++m) {
    const TriangleMesh& mesh = dataset.meshes[m];
    WritePly(models / (mesh.name + ".ply"), mesh);
    Eigen::Vector3f lo = mesh.vertices[0], hi = mesh.vertices[0];
    for (const auto& p : mesh.vertices) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    dataset.diameters.push_back(Diameter(mesh));
    nlohmann::json entry = {{"diameter", dataset.diameters.back()},
                            {"min_x", lo.x()},
                            {"min_y", lo.y()},
                            {"min_z", lo.z()},
                            {"size_x", hi.x() - lo.x()},
                            {"size_y", hi.y() - lo.y()},
                            {"size_z", hi.z() - lo.z()}};
    if (m == 0) {
      // The box: half turns about x, y and z (4x4 row-major, translation 0).
      nlohmann::json symmetries = nlohmann::json::array();
      for (int axis = 0; axis < 3; ++axis) {
        const Eigen::Matrix3d r =
            Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
        std::vector<double> flat;
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) flat.push_back(std::round(r(i, j)));
          flat.push_back(0.0);
        }
        flat.insert(flat.end(), {0.0, 0.0, 0.0, 1.0});
        symmetries.push_back(flat);
      }
      entry["symmetries_discrete"] = symmetries;
    }
    info[std::to_string(m + 1)] = entry;
  }
  WriteJson(models / "models_info.json", info);

  // The objects on the table (world frame, mm, z up).
  std::vector<Rigid3> world_from_object(2);
  world_from_object[0].rotation =
      Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  world_from_object[0].translation = Eigen::Vector3d(-90.0, 0.0, 15.0);
  world_from_object[1].rotation =
      Eigen::AngleAxisd(-0.9, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  world_from_object[1].translation = Eigen::Vector3d(90.0, 10.0, 20.0);
  dataset.camera_matrix << options.fx, 0.0, options.cx, 0.0, options.fy, options.cy, 0.0, 0.0, 1.0;
  PinholeCamera camera;
  camera.width_px = options.width_px;
  camera.height_px = options.height_px;
  camera.focal_x_px = options.fx;
  camera.focal_y_px = options.fy;
  camera.principal_x_px = options.cx;
  camera.principal_y_px = options.cy;

  const std::array<Eigen::Vector3d, 2> colours = {Eigen::Vector3d(200.0, 120.0, 40.0),
                                                  Eigen::Vector3d(40.0, 110.0, 220.0)};
  nlohmann::json scene_camera = nlohmann::json::object();
  nlohmann::json scene_gt = nlohmann::json::object();
  nlohmann::json scene_gt_info = nlohmann::json::object();
  const Eigen::Vector3d target(0.0, 5.0, 15.0);
  for (int k = 0; k < options.num_images; ++k) {
    const int image_id = options.first_image_id + k;
    const double t = options.num_images > 1 ? static_cast<double>(k) / (options.num_images - 1) : 0;
    const double azimuth =
        (options.first_azimuth_deg + t * (options.last_azimuth_deg - options.first_azimuth_deg)) *
        std::numbers::pi / 180.0;
    const double elevation = options.elevation_deg * std::numbers::pi / 180.0;
    const Eigen::Vector3d eye =
        target + options.camera_distance_mm *
                     Eigen::Vector3d(std::cos(elevation) * std::sin(azimuth),
                                     -std::cos(elevation) * std::cos(azimuth), std::sin(elevation));
    const Rigid3 camera_from_world = LookAt(eye, target);
    dataset.image_ids.push_back(image_id);
    dataset.camera_from_world.push_back(camera_from_world);

    std::vector<cv::Mat> colour(2), mask(2), depth(2);
    std::vector<Rigid3> poses;
    for (size_t m = 0; m < 2; ++m) {
      poses.push_back(camera_from_world * world_from_object[m]);
      ShadedRenderOptions render;
      render.base_colour_bgr = colours[m];
      RenderShaded(dataset.meshes[m], camera, poses.back(), render, &colour[m], &mask[m],
                   &depth[m]);
    }
    cv::Mat image(options.height_px, options.width_px, CV_8UC3, cv::Scalar(150, 150, 150));
    std::vector<cv::Mat> visible = {cv::Mat(mask[0].size(), CV_8UC1, cv::Scalar(0)),
                                    cv::Mat(mask[0].size(), CV_8UC1, cv::Scalar(0))};
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        int nearest = -1;
        float nearest_depth = 0.f;
        for (int m = 0; m < 2; ++m) {
          if (mask[static_cast<size_t>(m)].at<uint8_t>(y, x) == 0) continue;
          const float d = depth[static_cast<size_t>(m)].at<float>(y, x);
          if (nearest < 0 || d < nearest_depth) {
            nearest = m;
            nearest_depth = d;
          }
        }
        if (nearest < 0) continue;
        visible[static_cast<size_t>(nearest)].at<uint8_t>(y, x) = 255;
        image.at<cv::Vec3b>(y, x) = colour[static_cast<size_t>(nearest)].at<cv::Vec3b>(y, x);
      }
    }
    WritePng(dataset.scene_folder / "rgb" / (Id6(image_id) + ".png"), image);
    nlohmann::json gt = nlohmann::json::array(), gt_info = nlohmann::json::array();
    std::vector<double> fractions;
    for (size_t m = 0; m < 2; ++m) {
      const std::string name = Id6(image_id) + "_" + Id6(static_cast<int>(m)) + ".png";
      WritePng(dataset.scene_folder / "mask" / name, mask[m]);
      WritePng(dataset.scene_folder / "mask_visib" / name, visible[m]);
      const int all = cv::countNonZero(mask[m]);
      fractions.push_back(all > 0 ? static_cast<double>(cv::countNonZero(visible[m])) / all : 0.0);
      gt.push_back({{"obj_id", static_cast<int>(m) + 1},
                    {"cam_R_m2c", Flat(poses[m].rotation)},
                    {"cam_t_m2c", Flat(poses[m].translation)}});
      gt_info.push_back({{"visib_fract", fractions.back()}, {"px_count_all", all}});
    }
    dataset.camera_from_object.push_back(poses);
    dataset.visible_fraction.push_back(fractions);
    scene_camera[std::to_string(image_id)] = {{"cam_K", Flat(dataset.camera_matrix)},
                                              {"depth_scale", 1.0},
                                              {"cam_R_w2c", Flat(camera_from_world.rotation)},
                                              {"cam_t_w2c", Flat(camera_from_world.translation)}};
    scene_gt[std::to_string(image_id)] = gt;
    scene_gt_info[std::to_string(image_id)] = gt_info;
  }
  WriteJson(dataset.scene_folder / "scene_camera.json", scene_camera);
  WriteJson(dataset.scene_folder / "scene_gt.json", scene_gt);
  WriteJson(dataset.scene_folder / "scene_gt_info.json", scene_gt_info);
  return dataset;
}

}  // namespace silpose
