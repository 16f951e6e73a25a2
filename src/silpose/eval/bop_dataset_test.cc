#include "silpose/eval/bop_dataset.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "silpose/eval/synthetic_bop_dataset_testing.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

std::filesystem::path TempFolder(const std::string& name) {
  const auto folder = std::filesystem::temp_directory_path() /
                      ("silpose_bop_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  return folder;
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream file(path);
  file << text;
}

std::string ReadText(const std::filesystem::path& path) {
  std::ifstream file(path);
  return std::string(std::istreambuf_iterator<char>(file), {});
}

// The message of the silpose::Error that `body` throws ("" if none).
template <typename Body>
std::string ErrorOf(const Body& body) {
  try {
    body();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

class BopDatasetTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::filesystem::path(TempFolder("reader"));
    truth_ = new SyntheticBopDataset(WriteSyntheticBopDataset(*root_, {.num_images = 6}));
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*root_);
    delete truth_;
    delete root_;
  }
  // A copy of the fixture to break.
  static std::filesystem::path Copy(const std::string& name) {
    const std::filesystem::path copy = TempFolder(name);
    std::filesystem::copy(*root_, copy, std::filesystem::copy_options::recursive);
    return copy;
  }

  static std::filesystem::path* root_;
  static SyntheticBopDataset* truth_;
};
std::filesystem::path* BopDatasetTest::root_ = nullptr;
SyntheticBopDataset* BopDatasetTest::truth_ = nullptr;

TEST_F(BopDatasetTest, ReadsModelsExactly) {
  const BopDataset dataset = OpenBopDataset(*root_);
  EXPECT_EQ(dataset.split, "test");
  ASSERT_EQ(dataset.scene_folders.size(), 1u);
  EXPECT_EQ(dataset.scene_folders[0].filename(), "000001");
  EXPECT_EQ(dataset.eval_models_folder, *root_ / "models");  // no models_eval/
  ASSERT_EQ(dataset.models.size(), 2u);
  for (int m = 0; m < 2; ++m) {
    const BopModel& model = dataset.models[static_cast<size_t>(m)];
    EXPECT_EQ(model.obj_id, m + 1);
    EXPECT_EQ(model.name(), truth_->meshes[static_cast<size_t>(m)].name);
    EXPECT_DOUBLE_EQ(model.diameter, truth_->diameters[static_cast<size_t>(m)]);
    // The PLY reads back as written (mm, model frame).
    const TriangleMesh mesh = LoadMesh(model.mesh_path);
    EXPECT_NEAR(mesh.Radius(), truth_->meshes[static_cast<size_t>(m)].Radius(), 1e-4);
    EXPECT_NEAR((mesh.Centre() - truth_->meshes[static_cast<size_t>(m)].Centre()).norm(), 0.0,
                1e-4);
  }
  const BopModel& box = dataset.models[0];
  EXPECT_TRUE(box.HasSymmetries());
  ASSERT_EQ(box.discrete_symmetries.size(), 3u);
  EXPECT_TRUE(box.discrete_symmetries[2].rotation.isApprox(
      Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal().toDenseMatrix()));
  EXPECT_NEAR(box.size.x(), 80.0, 1e-5);
  EXPECT_NEAR(box.min_corner.z(), -15.0, 1e-5);
  EXPECT_FALSE(dataset.models[1].HasSymmetries());
  EXPECT_EQ(dataset.FindModel(2), &dataset.models[1]);
  EXPECT_EQ(dataset.FindModel(7), nullptr);
  EXPECT_EQ(BopModelName(12), "obj_000012");
}

TEST_F(BopDatasetTest, ReadsSceneExactly) {
  const BopScene scene = ReadBopScene(truth_->scene_folder);
  EXPECT_EQ(scene.scene_id, 1);
  ASSERT_EQ(scene.images.size(), truth_->image_ids.size());
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const BopImage& image = scene.images[i];
    EXPECT_EQ(image.image_id, truth_->image_ids[i]);
    EXPECT_EQ(image.camera_matrix, truth_->camera_matrix);
    EXPECT_EQ(image.depth_scale, 1.0);
    ASSERT_TRUE(image.camera_from_world.has_value());
    EXPECT_EQ(image.camera_from_world->rotation, truth_->camera_from_world[i].rotation);
    EXPECT_EQ(image.camera_from_world->translation, truth_->camera_from_world[i].translation);
    EXPECT_TRUE(std::filesystem::is_regular_file(image.image_path)) << image.image_path;
    ASSERT_EQ(image.objects.size(), 2u);
    for (size_t k = 0; k < 2; ++k) {
      EXPECT_EQ(image.objects[k].obj_id, static_cast<int>(k) + 1);
      // JSON keeps doubles to the last bit.
      EXPECT_EQ(image.objects[k].camera_from_object.rotation,
                truth_->camera_from_object[i][k].rotation);
      EXPECT_EQ(image.objects[k].camera_from_object.translation,
                truth_->camera_from_object[i][k].translation);
      EXPECT_DOUBLE_EQ(image.objects[k].visible_fraction, truth_->visible_fraction[i][k]);
      EXPECT_TRUE(std::filesystem::is_regular_file(
          scene.MaskPath(image.image_id, static_cast<int>(k), true)));
      EXPECT_TRUE(std::filesystem::is_regular_file(
          scene.MaskPath(image.image_id, static_cast<int>(k), false)));
    }
  }
  EXPECT_EQ(scene.MaskPath(3, 1, true), truth_->scene_folder / "mask_visib" / "000003_000001.png");
  EXPECT_EQ(scene.MaskPath(3, 1, false), truth_->scene_folder / "mask" / "000003_000001.png");

  const std::vector<BopInstance> instances = BopSceneInstances(scene);
  ASSERT_EQ(instances.size(), 2u);
  EXPECT_EQ(instances[1].obj_id, 2);
  ASSERT_EQ(instances[1].frames.size(), scene.images.size());
  EXPECT_EQ(instances[1].frames[4].image, 4);
  EXPECT_EQ(instances[1].frames[4].gt_index, 1);

  const PinholeCamera camera = BopCamera(scene.images[0].camera_matrix, 640, 480);
  EXPECT_EQ(camera.focal_x_px, 572.4);
  EXPECT_EQ(camera.focal_y_px, 573.6);
  EXPECT_EQ(camera.principal_x_px, 325.3);
  EXPECT_EQ(camera.principal_y_px, 242.0);
}

TEST(BopDataset, InstancesOfRepeatedObjects) {
  // Two copies of object 5 and one of object 3 in two images; the second image lacks one copy.
  BopScene scene;
  scene.images.resize(2);
  scene.images[0].objects = {{.obj_id = 5}, {.obj_id = 3}, {.obj_id = 5}};
  scene.images[1].objects = {{.obj_id = 3}, {.obj_id = 5}};
  const std::vector<BopInstance> instances = BopSceneInstances(scene);
  ASSERT_EQ(instances.size(), 3u);
  EXPECT_EQ(instances[0].obj_id, 3);
  ASSERT_EQ(instances[0].frames.size(), 2u);
  EXPECT_EQ(instances[0].frames[1].gt_index, 0);
  EXPECT_EQ(instances[1].obj_id, 5);
  EXPECT_EQ(instances[1].occurrence, 0);
  EXPECT_EQ(instances[1].frames[1].gt_index, 1);
  EXPECT_EQ(instances[2].occurrence, 1);
  ASSERT_EQ(instances[2].frames.size(), 1u);
  EXPECT_EQ(instances[2].frames[0].gt_index, 2);
}

TEST_F(BopDatasetTest, CorruptOrMissingFilesAreNamed) {
  const std::filesystem::path copy = Copy("broken");
  const std::filesystem::path scene = copy / "test" / "000001";
  const std::string gt_text = ReadText(scene / "scene_gt.json");

  // Cut off half way: not valid JSON.
  WriteText(scene / "scene_gt.json", gt_text.substr(0, gt_text.size() / 2));
  std::string message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find((scene / "scene_gt.json").string()), std::string::npos) << message;
  EXPECT_NE(message.find("not valid JSON"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;

  // A pose with 8 numbers.
  WriteText(scene / "scene_gt.json",
            R"({"0": [{"obj_id": 1, "cam_R_m2c": [1,0,0,0,1,0,0,0], "cam_t_m2c": [0,0,500]}]})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("scene_gt.json"), std::string::npos) << message;
  EXPECT_NE(message.find("cam_R_m2c must be a list of 9 numbers"), std::string::npos) << message;

  // Not a rotation.
  WriteText(scene / "scene_gt.json",
            R"({"0": [{"obj_id": 1, "cam_R_m2c": [2,0,0,0,1,0,0,0,1], "cam_t_m2c": [0,0,500]}]})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("not a rotation matrix"), std::string::npos) << message;

  // Missing translation; a key that is not an id; an image the cameras do not list.
  WriteText(scene / "scene_gt.json", R"({"0": [{"obj_id": 1, "cam_R_m2c": [1,0,0,0,1,0,0,0,1]}]})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("has no 'cam_t_m2c'"), std::string::npos) << message;
  WriteText(scene / "scene_gt.json", R"({"zero": []})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("key 'zero' is not an id"), std::string::npos) << message;
  WriteText(scene / "scene_gt.json", R"({"999": []})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("image 999 is not in scene_camera.json"), std::string::npos) << message;

  // Missing files.
  std::filesystem::remove(scene / "scene_gt.json");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find((scene / "scene_gt.json").string() + ": file not found"),
            std::string::npos)
      << message;
  WriteText(scene / "scene_camera.json", R"({"0": {"cam_K": [1, 2]}})");
  message = ErrorOf([&] { ReadBopScene(scene); });
  EXPECT_NE(message.find("scene_camera.json: image 0 cam_K must be a list of 9 numbers"),
            std::string::npos)
      << message;

  // Models.
  std::filesystem::remove(copy / "models" / "obj_000002.ply");
  message = ErrorOf([&] { OpenBopDataset(copy); });
  EXPECT_NE(message.find("obj_000002.ply: mesh of object 2"), std::string::npos) << message;
  WriteText(copy / "models" / "models_info.json", R"({"1": {"diameter": -3}})");
  message = ErrorOf([&] { OpenBopDataset(copy); });
  EXPECT_NE(message.find("models_info.json: object 1 diameter must be > 0"), std::string::npos)
      << message;
  WriteText(copy / "models" / "models_info.json",
            R"({"1": {"diameter": 3, "symmetries_discrete": [[1, 0, 0]]}})");
  message = ErrorOf([&] { OpenBopDataset(copy); });
  EXPECT_NE(message.find("symmetries_discrete[0] must be a list of 16 numbers"), std::string::npos)
      << message;

  // Folders.
  message = ErrorOf([&] { OpenBopDataset(copy / "nowhere"); });
  EXPECT_NE(message.find("nowhere: dataset folder not found"), std::string::npos) << message;
  message = ErrorOf([&] { OpenBopDataset(*root_, {.split = "val"}); });
  EXPECT_NE(message.find("val: split folder not found"), std::string::npos) << message;
  std::filesystem::remove_all(copy);
}

}  // namespace
}  // namespace silpose
