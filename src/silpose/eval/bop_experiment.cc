#include "silpose/eval/bop_experiment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "silpose/io/image_codec.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"

namespace silpose {

bool BopExperimentOptions::Check(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (max_frames < 0) return fail("max_frames must be >= 0");
  if (max_instances < 0) return fail("max_instances must be >= 0");
  if (particles_per_object < 0) return fail("particles_per_object must be >= 0");
  if (!(min_visible_fraction >= 0.0 && min_visible_fraction <= 1.0))
    return fail("min_visible_fraction must be in [0, 1]");
  if (!(symmetry_step_fraction > 0.0 && symmetry_step_fraction <= 1.0))
    return fail("symmetry_step_fraction must be in (0, 1]");
  if (masks == BopMaskSource::kImage) {
    if (segmentation.kind == SegmenterKind::kMask)
      return fail("segmenting the images needs a segmentation kind other than mask");
    std::string problem;
    if (!segmentation.Check(&problem)) return fail("segmentation: " + problem);
  }
  return true;
}

namespace {

template <typename T>
bool Selected(const std::vector<T>& chosen, T value) {
  return chosen.empty() || std::find(chosen.begin(), chosen.end(), value) != chosen.end();
}

// The instances of a scene the options select, each cut to max_frames.
std::vector<BopInstance> SelectedInstances(const BopScene& scene,
                                           const BopExperimentOptions& options) {
  std::vector<BopInstance> selected;
  for (BopInstance& instance : BopSceneInstances(scene)) {
    if (!Selected(options.object_ids, instance.obj_id)) continue;
    if (options.max_frames > 0 && static_cast<int>(instance.frames.size()) > options.max_frames)
      instance.frames.resize(static_cast<size_t>(options.max_frames));
    selected.push_back(std::move(instance));
  }
  return selected;
}

std::vector<std::filesystem::path> SelectedScenes(const BopDataset& dataset,
                                                  const BopExperimentOptions& options) {
  std::vector<std::filesystem::path> folders;
  for (const auto& folder : dataset.scene_folders) {
    if (Selected(options.scene_ids, std::stoi(folder.filename().string())))
      folders.push_back(folder);
  }
  if (folders.empty())
    ThrowError(dataset.root.string(), ": none of the chosen scenes is in split ", dataset.split);
  return folders;
}

cv::Mat ReadImage(const std::filesystem::path& path, const char* what) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    ThrowError(path.string(), ": ", what, " not found");
  cv::Mat image;
  try {
    image = silpose::ReadImage(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& exception) {
    ThrowError(path.string(), ": cannot read ", what, " (", exception.err, ")");
  }
  if (image.empty()) ThrowError(path.string(), ": cannot read ", what, " (not an image?)");
  return image;
}

// What the errors of one model need, computed once.
struct EvalModel {
  const BopModel* info = nullptr;
  Eigen::Matrix3Xd points;
  std::unique_ptr<NearestPointIndex> index;
  std::vector<Rigid3> symmetries;
};

int ObjIdOfName(const std::string& name) {
  if (name.size() != 10 || name.rfind("obj_", 0) != 0) return -1;
  for (size_t i = 4; i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
  }
  return std::stoi(name.substr(4));
}

BopSummary Summarise(int obj_id, const std::string& name, int instances,
                     const std::vector<const BopFrameResult*>& frames) {
  BopSummary summary;
  summary.obj_id = obj_id;
  summary.name = name;
  summary.instances = instances;
  std::vector<double> rotation, translation, translation_percent;
  double ms = 0.0;
  for (const BopFrameResult* frame : frames) {
    ++summary.frames;
    summary.with_pose += frame->estimate.has_value();
    summary.right_object += frame->right_object;
    ms += frame->time_ms;
    if (std::isfinite(frame->rotation_deg)) {
      rotation.push_back(frame->rotation_deg);
      translation.push_back(frame->translation_mm);
      translation_percent.push_back(frame->translation_percent);
    }
  }
  summary.rotation_deg = Summarize(rotation);
  summary.translation_mm = Summarize(translation);
  summary.translation_percent = Summarize(translation_percent);
  summary.ms_per_frame = summary.frames > 0 ? ms / summary.frames : 0.0;
  return summary;
}

}  // namespace

int BopFrameCount(const BopDataset& dataset, const BopExperimentOptions& options) {
  int frames = 0, instances = 0;
  for (const auto& folder : SelectedScenes(dataset, options)) {
    const BopScene scene = ReadBopScene(folder);
    for (const BopInstance& instance : SelectedInstances(scene, options)) {
      if (options.max_instances > 0 && instances >= options.max_instances) return frames;
      ++instances;
      frames += static_cast<int>(instance.frames.size());
    }
  }
  return frames;
}

BopExperimentResult RunBopExperiment(const BopDataset& dataset, const ViewDatabase& database,
                                     const BopExperimentOptions& options,
                                     const std::function<void()>& on_frame) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("eval bop: ", problem);
  const auto start = std::chrono::steady_clock::now();
  BopExperimentResult result;
  result.split = dataset.split;

  std::map<int, EvalModel> eval_models;
  auto eval_model = [&](int obj_id) -> const EvalModel& {
    auto found = eval_models.find(obj_id);
    if (found != eval_models.end()) return found->second;
    EvalModel model;
    model.info = dataset.FindModel(obj_id);
    if (model.info == nullptr)
      ThrowError(dataset.models_folder.string(), "/models_info.json: has no object ", obj_id,
                 " (annotated in the split ", dataset.split, ")");
    const TriangleMesh mesh = LoadMesh(dataset.EvalMeshPath(obj_id));
    model.points.resize(3, static_cast<Eigen::Index>(mesh.vertices.size()));
    for (size_t i = 0; i < mesh.vertices.size(); ++i)
      model.points.col(static_cast<Eigen::Index>(i)) = mesh.vertices[i].cast<double>();
    model.index = std::make_unique<NearestPointIndex>(model.points);
    model.symmetries =
        SymmetryTransforms(model.info->discrete_symmetries, model.info->continuous_symmetries,
                           options.symmetry_step_fraction);
    return eval_models.emplace(obj_id, std::move(model)).first->second;
  };

  std::map<int, int> instances_per_object;
  std::map<int, int> width_per_object;
  int instance_count = 0;
  bool done = false;
  for (const auto& folder : SelectedScenes(dataset, options)) {
    if (done) break;
    const BopScene scene = ReadBopScene(folder);
    const std::vector<BopInstance> instances = SelectedInstances(scene, options);
    if (instances.empty()) continue;
    // The image size: the scene's first image, else the first instance's first mask.
    cv::Size size;
    for (const BopImage& image : scene.images) {
      if (!image.image_path.empty()) {
        size = ReadImage(image.image_path, "image").size();
        break;
      }
    }
    if (options.masks == BopMaskSource::kImage && size.empty())
      ThrowError(folder.string(), ": no images in rgb/ or gray/ to segment");

    for (const BopInstance& instance : instances) {
      if (options.max_instances > 0 && instance_count >= options.max_instances) {
        done = true;
        break;
      }
      const EvalModel& model = eval_model(instance.obj_id);
      const int database_model = database.FindModel(BopModelName(instance.obj_id));
      if (database_model < 0)
        ThrowError("eval bop: the database has no model ", BopModelName(instance.obj_id),
                   " (object ", instance.obj_id, " of scene ", scene.scene_id, ")");
      const bool visible = options.masks != BopMaskSource::kFull;
      const BopImage& first = scene.images[static_cast<size_t>(instance.frames.front().image)];
      if (size.empty()) {
        size = ReadImage(scene.MaskPath(first.image_id, instance.frames.front().gt_index, visible),
                         "mask")
                   .size();
      }
      PinholeCamera camera;
      try {
        camera = BopCamera(first.camera_matrix, size.width, size.height);
      } catch (const Error& error) {
        ThrowError((folder / "scene_camera.json").string(), ": image ", first.image_id, ": ",
                   error.what());
      }
      for (const BopInstance::Frame& frame : instance.frames) {
        const Eigen::Matrix3d& k = scene.images[static_cast<size_t>(frame.image)].camera_matrix;
        if ((k - first.camera_matrix).cwiseAbs().maxCoeff() > 1e-6 * first.camera_matrix.norm()) {
          result.warnings.push_back("scene " + std::to_string(scene.scene_id) +
                                    ": cam_K varies between images; the "
                                    "camera of image " +
                                    std::to_string(first.image_id) + " was used for object " +
                                    std::to_string(instance.obj_id));
          break;
        }
      }

      TrackerOptions tracker_options;
      if (options.masks == BopMaskSource::kImage)
        tracker_options.segmentation = options.segmentation;
      tracker_options.brute_force = options.brute_force;
      if (options.particles_per_object > 0) {
        // A fixed count: the adaptive floor and cap follow it (any count works).
        ParticleFilterOptions& filter = tracker_options.filter;
        filter.particles_per_object = options.particles_per_object;
        filter.min_particles_per_object =
            std::min(filter.min_particles_per_object, filter.particles_per_object);
        filter.max_particles_per_object =
            std::max(filter.max_particles_per_object, filter.particles_per_object);
      }
      tracker_options.filter.seed = options.seed + static_cast<uint64_t>(instance_count);
      tracker_options.filter.keep_history = false;  // as `track` without smoothing
      Tracker tracker(database, camera, tracker_options);
      ++instance_count;
      ++instances_per_object[instance.obj_id];
      width_per_object[instance.obj_id] = size.width;

      for (const BopInstance::Frame& frame : instance.frames) {
        const BopImage& image = scene.images[static_cast<size_t>(frame.image)];
        const BopGroundTruth& truth = image.objects[static_cast<size_t>(frame.gt_index)];
        std::filesystem::path path;
        if (options.masks == BopMaskSource::kImage) {
          path = image.image_path;
          if (path.empty()) ThrowError((folder / "rgb").string(), ": no image ", image.image_id);
        } else {
          path = scene.MaskPath(image.image_id, frame.gt_index, visible);
        }
        const cv::Mat input =
            ReadImage(path, options.masks == BopMaskSource::kImage ? "image" : "mask");
        TrackedFrame tracked;
        try {
          tracked = tracker.Process(input);
        } catch (const Error& error) {
          ThrowError(path.string(), ": ", error.what());
        }

        BopFrameResult row;
        row.scene_id = scene.scene_id;
        row.image_id = image.image_id;
        row.obj_id = instance.obj_id;
        row.occurrence = instance.occurrence;
        row.gt_index = frame.gt_index;
        row.visible_fraction = truth.visible_fraction;
        row.counted = !(truth.visible_fraction < options.min_visible_fraction);
        row.status = tracked.result.status;
        row.score = tracked.result.score;
        row.time_ms = tracked.result.time_ms;
        if (tracked.result.object >= 0)
          row.estimated_obj_id = ObjIdOfName(tracked.result.object_name);
        row.right_object = tracked.result.object == database_model;
        row.estimate = tracked.result.camera_from_object;
        if (row.right_object && row.estimate) {
          const Rigid3& estimate = *row.estimate;
          const Rigid3& true_pose = truth.camera_from_object;
          row.rotation_deg = RotationErrorDeg(estimate.rotation, true_pose.rotation);
          row.translation_mm = (estimate.translation - true_pose.translation).norm();
          const double distance = true_pose.translation.norm();
          row.translation_percent = distance > 0.0 ? 100.0 * row.translation_mm / distance
                                                   : std::numeric_limits<double>::quiet_NaN();
          row.add = AddError(model.points, estimate, true_pose);
          row.adds = AddSError(model.points, *model.index, estimate, true_pose);
          row.add_or_adds = model.info->HasSymmetries() ? row.adds : row.add;
          row.mssd = MssdError(model.points, estimate, true_pose, model.symmetries);
          row.mspd = MspdError(model.points, estimate, true_pose, model.symmetries, camera);
        }
        result.frames.push_back(std::move(row));
        if (on_frame) on_frame();
      }
    }
  }
  if (result.frames.empty()) ThrowError("eval bop: no annotated object instance was selected");

  // Summaries: per object, then pooled.
  std::vector<const BopFrameResult*> all_frames;
  double all_add = 0.0, all_mssd = 0.0, all_mspd = 0.0;
  for (const auto& [obj_id, count] : instances_per_object) {
    const EvalModel& model = eval_model(obj_id);
    std::vector<const BopFrameResult*> frames;
    std::vector<double> add, mssd, mspd;
    for (const BopFrameResult& frame : result.frames) {
      if (frame.obj_id != obj_id || !frame.counted) continue;
      frames.push_back(&frame);
      add.push_back(frame.add_or_adds);
      mssd.push_back(frame.mssd);
      mspd.push_back(frame.mspd);
    }
    BopSummary summary = Summarise(obj_id, BopModelName(obj_id), count, frames);
    summary.recall_add = Recall(add, 0.1 * model.info->diameter);
    summary.ar_mssd =
        frames.empty() ? 0.0 : AverageRecall(mssd, MssdThresholds(model.info->diameter));
    summary.ar_mspd =
        frames.empty() ? 0.0 : AverageRecall(mspd, MspdThresholds(width_per_object[obj_id]));
    summary.ar = 0.5 * (summary.ar_mssd + summary.ar_mspd);
    // Pooled recalls: every counted frame weighs the same, whatever its object.
    const double n = static_cast<double>(frames.size());
    all_add += summary.recall_add * n;
    all_mssd += summary.ar_mssd * n;
    all_mspd += summary.ar_mspd * n;
    all_frames.insert(all_frames.end(), frames.begin(), frames.end());
    result.objects.push_back(std::move(summary));
  }
  result.total = Summarise(0, "all", instance_count, all_frames);
  if (!all_frames.empty()) {
    const double n = static_cast<double>(all_frames.size());
    result.total.recall_add = all_add / n;
    result.total.ar_mssd = all_mssd / n;
    result.total.ar_mspd = all_mspd / n;
    result.total.ar = 0.5 * (result.total.ar_mssd + result.total.ar_mspd);
  }
  std::sort(result.warnings.begin(), result.warnings.end());
  result.warnings.erase(std::unique(result.warnings.begin(), result.warnings.end()),
                        result.warnings.end());
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

namespace {

std::string Cell(double value, int precision = 6) {
  if (std::isnan(value)) return "";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream stream;
  stream.precision(precision);
  stream << value;
  return stream.str();
}

std::ofstream OpenCsv(const std::filesystem::path& path, const char* header) {
  std::ofstream file(path);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  file << header << '\n';
  return file;
}

void CloseCsv(std::ofstream& file, const std::filesystem::path& path) {
  file.close();
  if (!file) ThrowError(path.string(), ": write failed");
}

}  // namespace

const char* BopFramesHeader() {
  return "scene_id,im_id,obj_id,occurrence,gt_index,visib_fract,counted,status,estimated_obj_id,"
         "score,right_object,rotation_error_deg,translation_error_mm,translation_error_percent,"
         "add_mm,adds_mm,add_s_mm,mssd_mm,mspd_px,time_ms";
}

void WriteBopFrames(const std::filesystem::path& path, const BopExperimentResult& result) {
  std::ofstream file = OpenCsv(path, BopFramesHeader());
  for (const BopFrameResult& f : result.frames) {
    file << f.scene_id << ',' << f.image_id << ',' << f.obj_id << ',' << f.occurrence << ','
         << f.gt_index << ',' << Cell(f.visible_fraction) << ',' << (f.counted ? 1 : 0) << ','
         << f.status << ',' << (f.estimated_obj_id >= 0 ? std::to_string(f.estimated_obj_id) : "")
         << ',' << Cell(f.score) << ',' << (f.right_object ? 1 : 0) << ',' << Cell(f.rotation_deg)
         << ',' << Cell(f.translation_mm) << ',' << Cell(f.translation_percent) << ','
         << Cell(f.add) << ',' << Cell(f.adds) << ',' << Cell(f.add_or_adds) << ',' << Cell(f.mssd)
         << ',' << Cell(f.mspd) << ',' << Cell(f.time_ms) << '\n';
  }
  CloseCsv(file, path);
}

const char* BopSummaryHeader() {
  return "object,obj_id,instances,frames,with_pose,right_object_percent,"
         "rotation_error_median_deg,translation_error_median_mm,"
         "translation_error_median_percent,recall_add_s,ar_mssd,ar_mspd,ar,ms_per_frame";
}

void WriteBopSummary(const std::filesystem::path& path, const BopExperimentResult& result) {
  std::ofstream file = OpenCsv(path, BopSummaryHeader());
  auto row = [&file](const BopSummary& s) {
    const bool errors = s.rotation_deg.count > 0;
    file << s.name << ',' << s.obj_id << ',' << s.instances << ',' << s.frames << ',' << s.with_pose
         << ',' << Cell(s.RightObjectPercent()) << ','
         << (errors ? Cell(s.rotation_deg.median) : "") << ','
         << (errors ? Cell(s.translation_mm.median) : "") << ','
         << (errors ? Cell(s.translation_percent.median) : "") << ',' << Cell(s.recall_add) << ','
         << Cell(s.ar_mssd) << ',' << Cell(s.ar_mspd) << ',' << Cell(s.ar) << ','
         << Cell(s.ms_per_frame) << '\n';
  };
  for (const BopSummary& s : result.objects) row(s);
  row(result.total);
  CloseCsv(file, path);
}

void WriteBopResults(const std::filesystem::path& path, const BopExperimentResult& result) {
  std::ofstream file = OpenCsv(path, "scene_id,im_id,obj_id,score,R,t,time");
  for (const BopFrameResult& f : result.frames) {
    if (!f.estimate || f.estimated_obj_id < 0) continue;
    file << f.scene_id << ',' << f.image_id << ',' << f.estimated_obj_id << ','
         << (std::isfinite(f.score) ? Cell(f.score) : "0") << ',';
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c)
        file << (r + c > 0 ? " " : "") << Cell(f.estimate->rotation(r, c), 9);
    }
    file << ',';
    for (int i = 0; i < 3; ++i) file << (i > 0 ? " " : "") << Cell(f.estimate->translation[i], 9);
    file << ',' << Cell(f.time_ms / 1000.0) << '\n';
  }
  CloseCsv(file, path);
}

}  // namespace silpose
