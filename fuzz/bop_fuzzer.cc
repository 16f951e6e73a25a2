// The BOP readers (eval/bop_dataset.h): the input is split at NUL bytes into models_info.json,
// scene_camera.json, scene_gt.json and (if there is a fourth part) scene_gt_info.json of a dataset
// folder DIR/models, DIR/test/000001 whose meshes obj_000001..obj_000003.ply and images
// rgb/000000..000002.png exist (empty). The dataset is opened, the scene read and its instances
// listed, as `silpose eval bop` does before tracking.

#include <string>
#include <string_view>
#include <vector>

#include "fuzz/fuzz_common.h"
#include "silpose/eval/bop_dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace fs = std::filesystem;
  using silpose::fuzz::WriteBytes;
  static const fs::path root = [] {
    const fs::path dataset = silpose::fuzz::ScratchFolder() / "bop";
    fs::create_directories(dataset / "models");
    fs::create_directories(dataset / "test" / "000001" / "rgb");
    for (int id = 1; id <= 3; ++id) {
      WriteBytes(dataset / "models" / (silpose::BopModelName(id) + ".ply"), "");
      WriteBytes(dataset / "test" / "000001" / "rgb" / ("00000" + std::to_string(id - 1) + ".png"),
                 "");
    }
    return dataset;
  }();
  const fs::path scene = root / "test" / "000001";

  std::vector<std::string_view> parts;
  std::string_view rest = silpose::fuzz::AsView(data, size);
  while (parts.size() < 3) {
    const size_t end = rest.find('\0');
    if (end == std::string_view::npos) break;
    parts.push_back(rest.substr(0, end));
    rest.remove_prefix(end + 1);
  }
  parts.push_back(rest);
  while (parts.size() < 3) parts.emplace_back("{}");

  WriteBytes(root / "models" / "models_info.json", parts[0]);
  WriteBytes(scene / "scene_camera.json", parts[1]);
  WriteBytes(scene / "scene_gt.json", parts[2]);
  std::error_code ignored;
  if (parts.size() > 3) {
    WriteBytes(scene / "scene_gt_info.json", parts[3]);
  } else {
    fs::remove(scene / "scene_gt_info.json", ignored);
  }

  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    const silpose::BopDataset dataset = silpose::OpenBopDataset(root);
    for (const silpose::BopModel& model : dataset.models) (void)model.name();
  });
  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    const silpose::BopScene bop_scene = silpose::ReadBopScene(scene);
    for (const silpose::BopInstance& instance : silpose::BopSceneInstances(bop_scene)) {
      for (const auto& frame : instance.frames) {
        const silpose::BopImage& image = bop_scene.images.at(static_cast<size_t>(frame.image));
        (void)image.objects.at(static_cast<size_t>(frame.gt_index));
        (void)bop_scene.MaskPath(image.image_id, frame.gt_index, true);
      }
    }
    for (const silpose::BopImage& image : bop_scene.images) {
      (void)silpose::BopCamera(image.camera_matrix, 640, 480);
    }
  });
  return 0;
}
