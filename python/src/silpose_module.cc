// The `silpose._silpose` extension module: Python bindings of the silpose library (docs/python.md).
// Arrays cross without copies where the layouts agree: a frame or mask from numpy becomes a cv::Mat
// header over the numpy buffer, and masks, view directions and signatures go back to numpy as
// views of memory the returned array keeps alive.

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "silpose/database/database_builder.h"
#include "silpose/database/database_merge.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/frame_source.h"
#include "silpose/io/mask_file.h"
#include "silpose/io/read_ahead_source.h"
#include "silpose/match/view_matcher.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/pose/pose_output.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/synth/synthetic_sequence.h"
#include "silpose/track/smoother.h"
#include "silpose/track/tracker.h"
#include "silpose/util/error.h"

namespace py = pybind11;

namespace silpose::python {
namespace {

// ---------------------------------------------------------------------------------------------
// numpy <-> cv::Mat

int DepthOf(const py::dtype& dtype) {
  if (dtype.is(py::dtype::of<uint8_t>())) return CV_8U;
  if (dtype.is(py::dtype::of<uint16_t>())) return CV_16U;
  if (dtype.is(py::dtype::of<float>())) return CV_32F;
  return -1;
}

// A cv::Mat header over the buffer of `array` (no copy). `array` must stay alive while the Mat is
// used. Accepts uint8, uint16 and float32 arrays of shape (H, W) or (H, W, C), C in 1..4, whose
// rows are each contiguous (any C-contiguous array, or a row slice of one); others are refused
// with silpose.Error naming `what`.
cv::Mat MatView(const py::array& array, const char* what) {
  const int depth = DepthOf(array.dtype());
  if (depth < 0) {
    ThrowError(what, ": numpy arrays of dtype ", py::str(array.dtype()).cast<std::string>(),
               " are not supported (uint8, uint16 or float32)");
  }
  const py::ssize_t ndim = array.ndim();
  if (ndim != 2 && ndim != 3) {
    ThrowError(what,
               ": expected an array of shape (height, width) or (height, width, channels), "
               "got ",
               ndim, " dimensions");
  }
  const int channels = ndim == 3 ? static_cast<int>(array.shape(2)) : 1;
  if (channels < 1 || channels > 4) {
    ThrowError(what, ": ", channels, " channels (1, 3 or 4 expected)");
  }
  const auto rows = static_cast<int>(array.shape(0));
  const auto cols = static_cast<int>(array.shape(1));
  if (rows == 0 || cols == 0) ThrowError(what, ": the image is empty (", rows, "x", cols, ")");
  const py::ssize_t item = array.itemsize();
  const bool rows_contiguous =
      array.strides(1) == item * channels && (ndim == 2 || array.strides(2) == item);
  if (!rows_contiguous || array.strides(0) < item * channels * cols) {
    ThrowError(what, ": the array's rows are not contiguous (pass numpy.ascontiguousarray(...))");
  }
  return cv::Mat(rows, cols, CV_MAKETYPE(depth, channels), const_cast<void*>(array.data()),
                 static_cast<size_t>(array.strides(0)));
}

// A numpy array over the pixels of `mat` (no copy): the array holds a reference to the Mat's data.
py::array ArrayView(const cv::Mat& mat) {
  if (mat.empty()) return py::array_t<uint8_t>(std::vector<py::ssize_t>{0, 0});
  py::dtype dtype;
  switch (mat.depth()) {
    case CV_8U:
      dtype = py::dtype::of<uint8_t>();
      break;
    case CV_16U:
      dtype = py::dtype::of<uint16_t>();
      break;
    case CV_32F:
      dtype = py::dtype::of<float>();
      break;
    default:
      ThrowError("internal: image depth ", mat.depth(), " has no numpy equivalent");
  }
  auto* holder = new cv::Mat(mat);
  py::capsule owner(holder, [](void* pointer) { delete static_cast<cv::Mat*>(pointer); });
  const auto item = static_cast<py::ssize_t>(mat.elemSize1());
  std::vector<py::ssize_t> shape = {mat.rows, mat.cols};
  std::vector<py::ssize_t> strides = {static_cast<py::ssize_t>(mat.step[0]),
                                      static_cast<py::ssize_t>(mat.elemSize())};
  if (mat.channels() > 1) {
    shape.push_back(mat.channels());
    strides.push_back(item);
  }
  return py::array(dtype, shape, strides, holder->data, owner);
}

// The views below read these element types as packed arrays of their scalars.
static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double));
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
static_assert(sizeof(std::array<uint32_t, 3>) == 3 * sizeof(uint32_t));

// A read-only numpy view of `count` rows of `columns` values at `data`, kept alive by `base`.
template <typename T>
py::array ReadOnlyView(const T* data, py::ssize_t count, py::ssize_t columns, py::handle base) {
  py::array_t<T> array(
      {count, columns},
      {static_cast<py::ssize_t>(sizeof(T)) * columns, static_cast<py::ssize_t>(sizeof(T))}, data,
      base);
  array.attr("flags").attr("writeable") = false;
  return array;
}

Eigen::Matrix4d PoseMatrix(const Rigid3& pose) {
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  matrix.topLeftCorner<3, 3>() = pose.rotation;
  matrix.topRightCorner<3, 1>() = pose.translation;
  return matrix;
}

Rigid3 PoseFromMatrix(const Eigen::Ref<const Eigen::Matrix4d>& matrix, const char* what) {
  if (!matrix.allFinite() || matrix.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    ThrowError(what, ": a 4x4 rigid transform with last row (0, 0, 0, 1) and finite values needed");
  }
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  if (!(rotation.transpose() * rotation).isApprox(Eigen::Matrix3d::Identity(), 1e-6) ||
      rotation.determinant() < 0.0) {
    ThrowError(what, ": the upper-left 3x3 block is not a rotation");
  }
  return {rotation, matrix.topRightCorner<3, 1>()};
}

py::object OptionalFloat(double value) {
  return std::isfinite(value) ? py::object(py::float_(value)) : py::object(py::none());
}

// Sets attributes of `self` from keyword arguments; an unknown name is an error naming it.
void SetFromKeywords(py::handle self, const py::kwargs& keywords, const char* type) {
  for (const auto& [key, value] : keywords) {
    const std::string name = py::str(key);
    if (!py::hasattr(self, name.c_str()) || name.front() == '_') {
      ThrowError(type, ": unknown option '", name, "'");
    }
    py::setattr(self, key, value);
  }
}

// ---------------------------------------------------------------------------------------------
// Python-side value types

struct Candidate {
  int model = -1;
  std::string model_name;
  int view = -1;
  int shell = 0;
  double roll_deg = 0.0;
  double score = 0.0;
  Eigen::Vector3d view_dir = Eigen::Vector3d::Zero();
};

struct TrackResult {
  FrameResult result;
  cv::Mat mask;
  std::string segmentation;
  std::string segmentation_message;
};

TrackResult ToTrackResult(TrackedFrame&& tracked) {
  TrackResult out;
  out.result = std::move(tracked.result);
  out.mask = std::move(tracked.segmentation.mask);
  out.segmentation = ToString(tracked.segmentation.status);
  out.segmentation_message = std::move(tracked.segmentation.message);
  return out;
}

// Calls on one object from several Python threads (the GIL is released while they run) take turns:
// each object below has a mutex `calls`. A working call takes it after releasing the GIL and lets
// go of it before taking the GIL back, so a thread that holds it never waits for the GIL; the
// property getters take it with the GIL held, and wait at most for the call in progress.

// Python's Tracker.
struct PyTracker final : Tracker {
  using Tracker::Tracker;
  std::mutex calls;
};

// A tracker and the smoother fed through it (Python's Smoother owns both).
struct SmoothedTracker {
  SmoothedTracker(const ViewDatabase& database, const PinholeCamera& camera, TrackerOptions options,
                  int lag) {
    options.filter.keep_history = true;
    int64_t& kept = options.filter.max_history_frames;
    if (lag == TrackSmoother::kOffline) {
      kept = 0;
    } else if (kept != 0 && kept <= lag) {
      kept = lag + 1;
    }
    tracker = std::make_unique<Tracker>(database, camera, options);
    smoother = std::make_unique<TrackSmoother>(*tracker, lag);
  }
  std::unique_ptr<Tracker> tracker;
  std::unique_ptr<TrackSmoother> smoother;
  std::mutex calls;
};

std::vector<TrackResult> ToTrackResults(std::vector<TrackedFrame>&& frames) {
  std::vector<TrackResult> results;
  results.reserve(frames.size());
  for (TrackedFrame& frame : frames) results.push_back(ToTrackResult(std::move(frame)));
  return results;
}

// Matching: the spectra and one matcher, bound to a database that outlives them.
class Matcher {
 public:
  explicit Matcher(const ViewDatabase& database)
      : database_(database), spectra_(database), matcher_(spectra_) {}

  std::vector<Candidate> MatchSignature(std::span<const float> radii, const MatchOptions& options) {
    std::vector<Candidate> out;
    for (const MatchCandidate& c : matcher_.Match(radii, options)) {
      Candidate candidate;
      candidate.model = c.model;
      candidate.model_name = database_.models[static_cast<size_t>(c.model)].name;
      candidate.view = c.view;
      candidate.shell = c.shell;
      candidate.roll_deg = c.roll_deg;
      candidate.score = c.score;
      candidate.view_dir = database_.sphere.directions[static_cast<size_t>(c.view)];
      out.push_back(std::move(candidate));
    }
    return out;
  }

  std::vector<Candidate> MatchMask(const cv::Mat& mask, const MatchOptions& options) {
    const SignatureResult silhouette =
        ExtractSignature(DecodeMask(mask), database_.parameters.signature);
    if (!silhouette.ok()) {
      ThrowError(
          "mask: no usable silhouette (", ToString(silhouette.status),
          silhouette.status == SignatureStatus::kTooSmall
              ? ": it must enclose at least " +
                    std::to_string(static_cast<int>(database_.parameters.signature.min_area_px)) +
                    " pixels"
              : std::string(": no non-zero pixel"),
          ")");
    }
    return MatchSignature(silhouette.signature.radii, options);
  }

  const ViewDatabase& database() const { return database_; }
  std::mutex& calls() { return calls_; }

 private:
  const ViewDatabase& database_;
  ViewSpectra spectra_;
  ViewMatcher matcher_;
  std::mutex calls_;
};

// Synthetic sequences: the library's SyntheticSequence with the options `silpose synth` exposes
// most often.
struct SynthOptions {
  std::string trajectory = "orbit";
  int frames = 0;
  uint64_t seed = 1;
  int switch_every = 0;
  bool colour = false;
  double camera_noise = 0.0;
  std::optional<PinholeCamera> camera;
};

SequenceOptions MakeSequenceOptions(const SynthOptions& in, int num_models) {
  SequenceOptions options;
  if (in.camera) options.camera = *in.camera;
  TrajectoryOptions& trajectory = options.trajectory;
  if (in.frames < 0) ThrowError("frames must be >= 1 (or 0 for the default)");
  if (in.trajectory == "orbit") {
    trajectory.kind = TrajectoryKind::kOrbit;
    trajectory.num_frames = in.frames > 0 ? in.frames : trajectory.orbit.FramesPerLoop();
  } else if (in.trajectory == "walk") {
    trajectory.kind = TrajectoryKind::kWalk;
    trajectory.walk.seed = in.seed;
    trajectory.num_frames = in.frames > 0 ? in.frames : 360;
  } else if (in.trajectory == "handheld") {
    trajectory.kind = TrajectoryKind::kHandheld;
    trajectory.handheld.seed = in.seed;
    trajectory.num_frames = in.frames > 0 ? in.frames : 360;
  } else {
    ThrowError("trajectory must be 'orbit', 'walk' or 'handheld', got '", in.trajectory, "'");
  }
  if (in.switch_every < 0) ThrowError("switch_every must be >= 0");
  if (in.switch_every > 0 && num_models < 2) ThrowError("switch_every needs at least two models");
  trajectory.object_switches =
      CyclicObjectSwitches(num_models, trajectory.num_frames, in.switch_every);
  options.degradation.seed = in.seed;
  if (in.colour) {
    options.colour.enabled = true;
    options.colour.seed = in.seed;
    options.colour.background_seed = in.seed;
    options.colour.noise_sigma = in.camera_noise;
  } else if (in.camera_noise != 0.0) {
    ThrowError("camera_noise needs colour=True");
  }
  std::string problem;
  if (!options.Check(&problem)) ThrowError("invalid sequence options: ", problem);
  return options;
}

py::dict TruthDict(const GroundTruthFrame& truth) {
  py::dict out;
  out["frame"] = truth.frame;
  out["object"] = truth.object;
  out["view_dir"] = Eigen::Vector3d(truth.view_dir_in_object);
  out["roll_deg"] = truth.roll_deg;
  out["camera_from_object"] = PoseMatrix(truth.camera_from_object);
  out["distance_in_radii"] = truth.distance_in_radii;
  return out;
}

// Frame reading: any input `silpose track` reads, frame by frame as numpy arrays.
class FrameReader {
 public:
  FrameReader(const std::string& input, const std::string& color, bool masks_folder,
              int read_ahead) {
    if (read_ahead < 0) ThrowError("read_ahead must be >= 0 frames, got ", read_ahead);
    FrameSourceOptions options;
    if (color == "as-stored") {
      options.color = FrameColor::kAsStored;
    } else if (color == "gray" || color == "grey") {
      options.color = FrameColor::kGray;
    } else if (color == "bgr") {
      options.color = FrameColor::kBgr;
    } else if (color == "mask") {
      options.color = FrameColor::kMask;
    } else {
      ThrowError("color must be 'as-stored', 'gray', 'bgr' or 'mask', got '", color, "'");
    }
    options.sequence_folder = masks_folder ? SequenceFolder::kMasks : SequenceFolder::kFrames;
    source_ = OpenFrameSource(input, options);
    if (read_ahead > 0) source_ = std::make_unique<ReadAheadSource>(std::move(source_), read_ahead);
  }
  // With the GIL released.
  std::optional<cv::Mat> Next() {
    const std::lock_guard<std::mutex> one_call(calls_);
    cv::Mat frame;  // a new buffer per frame: the previous array may still be in use
    if (!source_->Read(&frame)) return std::nullopt;
    return frame;
  }
  // What `read` returns of the source, read while no Next() runs.
  template <typename Read>
  auto Ask(const Read& read) {
    const std::lock_guard<std::mutex> one_call(calls_);
    return read(static_cast<const FrameSource&>(*source_));
  }

 private:
  std::unique_ptr<FrameSource> source_;
  std::mutex calls_;
};

// ---------------------------------------------------------------------------------------------

void BindDatabase(py::module_& m) {
  py::class_<DatabaseBuildOptions>(
      m, "DatabaseOptions",
      "Options of build_database, as 'silpose build-db' takes them (docs/database-format.md).\n\n"
      "Keyword arguments set the attributes of the same names: DatabaseOptions(views=200).")
      .def(py::init([](const py::kwargs& keywords) {
             auto options = std::make_unique<DatabaseBuildOptions>();
             SetFromKeywords(py::cast(options.get(), py::return_value_policy::reference), keywords,
                             "DatabaseOptions");
             return options;
           }),
           "Default options (build-db's defaults), changed by keyword arguments.")
      .def_property(
          "views", [](const DatabaseBuildOptions& o) { return o.parameters.view_sphere.num_views; },
          [](DatabaseBuildOptions& o, int v) { o.parameters.view_sphere.num_views = v; },
          "Viewpoints on the sphere (paper: 1000).")
      .def_property(
          "signature_length",
          [](const DatabaseBuildOptions& o) { return o.parameters.signature.length; },
          [](DatabaseBuildOptions& o, int v) { o.parameters.signature.length = v; },
          "Radii per signature, M (even; paper: 1000).")
      .def_property(
          "resolution",
          [](const DatabaseBuildOptions& o) { return o.parameters.render.resolution_px; },
          [](DatabaseBuildOptions& o, int v) { o.parameters.render.resolution_px = v; },
          "Rendered image width and height, pixels.")
      .def_property(
          "distances",
          [](const DatabaseBuildOptions& o) { return o.parameters.distances_in_radii; },
          [](DatabaseBuildOptions& o, std::vector<double> v) {
            o.parameters.distances_in_radii = std::move(v);
          },
          "Camera distances of the distance shells, object radii, increasing.")
      .def_property(
          "fill", [](const DatabaseBuildOptions& o) { return o.parameters.render.fill_fraction; },
          [](DatabaseBuildOptions& o, double v) { o.parameters.render.fill_fraction = v; },
          "Share of the image width the object's bounding sphere fills.")
      .def_property(
          "bins", [](const DatabaseBuildOptions& o) { return o.parameters.view_sphere.num_bins; },
          [](DatabaseBuildOptions& o, int v) { o.parameters.view_sphere.num_bins = v; },
          "K-means bins of the views (paper: 10).")
      .def_property(
          "neighbour_radius",
          [](const DatabaseBuildOptions& o) {
            return o.parameters.view_sphere.neighbour_radius_factor;
          },
          [](DatabaseBuildOptions& o, double v) {
            o.parameters.view_sphere.neighbour_radius_factor = v;
          },
          "Views closer than this many typical spacings are neighbours.")
      .def_readwrite("threads", &DatabaseBuildOptions::num_threads,
                     "Worker threads (0 = all cores); the database does not depend on it.")
      .def_readwrite("full_signatures", &DatabaseBuildOptions::keep_signatures,
                     "Also keep every view's raw signature (build-db --full-signatures); by "
                     "default the database keeps only the spectra and derives the signatures.")
      .def(
          "check",
          [](const DatabaseBuildOptions& o) {
            std::string error;
            if (!o.Check(&error)) ThrowError("invalid database options: ", error);
          },
          "Raises silpose.Error naming the first invalid option.");

  py::class_<ViewDatabase>(
      m, "ViewDatabase",
      "A view database: every model's silhouette signatures from every view of a view sphere "
      "(docs/database-format.md). Read one with ViewDatabase.read(path) or make one with "
      "build_database().")
      .def_static(
          "read",
          [](const std::filesystem::path& path) {
            py::gil_scoped_release release;
            return ViewDatabase::Read(path);
          },
          py::arg("path"),
          "Reads and checks a database file; raises silpose.Error naming the file and the problem "
          "(missing, truncated, corrupt, other format version).")
      .def_static(
          "from_bytes",
          [](const py::bytes& bytes, const std::string& source) {
            return ViewDatabase::Deserialize(std::string_view(bytes), source);
          },
          py::arg("data"), py::arg("source") = "<bytes>",
          "Parses the bytes of a database file; `source` names them in error messages.")
      .def(
          "write",
          [](const ViewDatabase& database, const std::filesystem::path& path) {
            py::gil_scoped_release release;
            database.Write(path);
          },
          py::arg("path"), "Writes the database file (atomically).")
      .def(
          "to_bytes", [](const ViewDatabase& database) { return py::bytes(database.Serialize()); },
          "The bytes write() writes.")
      .def_property_readonly(
          "model_names",
          [](const ViewDatabase& database) {
            std::vector<std::string> names;
            for (const ModelViews& model : database.models) names.push_back(model.name);
            return names;
          },
          "Model names (mesh file stems), in database order.")
      .def_property_readonly(
          "num_models", [](const ViewDatabase& d) { return static_cast<int>(d.models.size()); },
          "Number of models.")
      .def_property_readonly("num_views", &ViewDatabase::num_views, "Views per model and shell.")
      .def_property_readonly("num_shells", &ViewDatabase::num_shells, "Distance shells.")
      .def_property_readonly("signature_length", &ViewDatabase::signature_length,
                             "Radii per signature, M.")
      .def_property_readonly(
          "distances", [](const ViewDatabase& d) { return d.parameters.distances_in_radii; },
          "Camera distances of the shells, object radii.")
      .def_property_readonly(
          "view_directions",
          [](py::object self) {
            const auto& database = self.cast<const ViewDatabase&>();
            return ReadOnlyView<double>(
                reinterpret_cast<const double*>(database.sphere.directions.data()),
                database.num_views(), 3, self);
          },
          "Unit view directions (object centre -> camera, model frame), a read-only (views, 3) "
          "float64 view of the database's memory.")
      .def(
          "signatures",
          [](py::object self, int model) {
            const auto& database = self.cast<const ViewDatabase&>();
            if (model < 0 || model >= static_cast<int>(database.models.size())) {
              ThrowError("model index ", model, " out of range (", database.models.size(),
                         " models)");
            }
            const ModelViews& views = database.models[static_cast<size_t>(model)];
            const auto shape =
                std::vector<py::ssize_t>{static_cast<py::ssize_t>(database.num_shells()),
                                         static_cast<py::ssize_t>(database.num_views()),
                                         static_cast<py::ssize_t>(database.signature_length())};
            if (!views.signatures_stored()) {
              // A compact database: each signature derived from its stored spectrum, copied.
              py::array_t<float> derived(shape);
              float* out = derived.mutable_data();
              const auto length = static_cast<size_t>(database.signature_length());
              for (int s = 0; s < database.num_shells(); ++s) {
                for (int v = 0; v < database.num_views(); ++v) {
                  const std::span<const float> radii = views.Signature(v, s);
                  std::copy(radii.begin(), radii.end(), out);
                  out += length;
                }
              }
              return py::array(derived);
            }
            py::array flat = ReadOnlyView<float>(views.signatures.data(),
                                                 static_cast<py::ssize_t>(views.views.size()),
                                                 database.signature_length(), self);
            return flat.reshape(shape);
          },
          py::arg("model"),
          "Signatures of model `model` (index), a (shells, views, M) float32 array: a read-only "
          "view of the database's memory, or, for a compact database (the default of "
          "build_database), a copy of the signatures derived from the stored spectra (smoothed "
          "as they are); unusable views are all 0.")
      .def("find_model", &ViewDatabase::FindModel, py::arg("name"),
           "Index of the model with this name, or -1.")
      .def(
          "symmetry",
          [](const ViewDatabase& database, int model) {
            if (model < 0 || model >= static_cast<int>(database.models.size())) {
              ThrowError("model index ", model, " out of range (", database.models.size(),
                         " models)");
            }
            const ObjectSymmetry& symmetry = database.models[static_cast<size_t>(model)].symmetry;
            py::list discrete, continuous, mirrors;
            for (const Rigid3& s : symmetry.discrete) {
              Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
              transform.topLeftCorner<3, 3>() = s.rotation;
              transform.topRightCorner<3, 1>() = s.translation;
              discrete.append(transform);
            }
            for (const ContinuousSymmetry& c : symmetry.continuous) {
              py::dict entry;
              entry["axis"] = Eigen::Vector3d(c.axis.normalized());
              entry["offset"] = c.offset;
              continuous.append(entry);
            }
            for (const MirrorSymmetry& m : symmetry.mirrors) {
              py::dict entry;
              entry["normal"] = Eigen::Vector3d(m.normal.normalized());
              entry["offset"] = m.offset;
              mirrors.append(entry);
            }
            py::dict result;
            result["description"] = symmetry.Describe();
            result["discrete"] = discrete;
            result["continuous"] = continuous;
            result["mirrors"] = mirrors;
            return result;
          },
          py::arg("model"),
          "The model's symmetries found by build-db (docs/symmetry.md): {'description': str, "
          "'discrete': [4x4 model_from_model transforms], 'continuous': [{'axis', 'offset'}], "
          "'mirrors': [{'normal', 'offset'}]}.")
      .def("__repr__", [](const ViewDatabase& d) {
        return "<silpose.ViewDatabase: " + std::to_string(d.models.size()) + " models x " +
               std::to_string(d.num_views()) + " views x " + std::to_string(d.num_shells()) +
               " shells>";
      });

  m.def(
      "build_database",
      [](const std::vector<std::filesystem::path>& mesh_paths,
         std::optional<DatabaseBuildOptions> options, std::optional<std::filesystem::path> out) {
        py::gil_scoped_release release;
        const DatabaseBuildOptions build = options.value_or(DatabaseBuildOptions{});
        ViewDatabase database = BuildViewDatabase(mesh_paths, build);
        StoreViewSpectra(&database, CorrelationOptions{}, build.num_threads);
        if (!build.keep_signatures) database.DropSignatures();
        if (out) database.Write(*out);
        return database;
      },
      py::arg("mesh_paths"), py::arg("options") = py::none(), py::arg("out") = py::none(),
      "Builds the database of the meshes (model names: file stems), as 'silpose build-db' does, "
      "and writes it to `out` if given. Raises silpose.Error naming a mesh that cannot be loaded "
      "or an invalid option.");
  m.def(
      "merge_databases",
      [](const std::vector<std::filesystem::path>& paths,
         std::optional<std::filesystem::path> out) {
        py::gil_scoped_release release;
        ViewDatabase database = MergeViewDatabases(paths);
        if (std::any_of(database.models.begin(), database.models.end(), NeedsStoredSpectra)) {
          StoreViewSpectra(&database);
        }
        if (out) database.Write(*out);
        return database;
      },
      py::arg("paths"), py::arg("out") = py::none(),
      "Merges database files built with the same options, in order, as 'silpose merge-db' does "
      "(the result is byte for byte build-db of all their models), and writes it to `out` if "
      "given. Raises silpose.Error naming a file of other parameters or a model found twice.");
}

void BindGeometry(py::module_& m) {
  py::class_<PinholeCamera>(
      m, "Camera",
      "A pinhole camera in OpenCV's convention (x right, y down, z forward; pixel centres at "
      "integer coordinates), with OpenCV distortion coefficients (k1, k2, p1, p2, k3).")
      .def(py::init([](int width, int height, double fx, double fy, double cx, double cy,
                       std::array<double, 5> distortion) {
             PinholeCamera camera{width, height, fx, fy, cx, cy, distortion};
             std::string error;
             if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
             return camera;
           }),
           py::arg("width"), py::arg("height"), py::arg("fx"), py::arg("fy"), py::arg("cx"),
           py::arg("cy"), py::arg("distortion") = std::array<double, 5>{0, 0, 0, 0, 0},
           "A camera of these intrinsics (pixels); raises silpose.Error if they are invalid.")
      .def_static("read", &ReadCameraFile, py::arg("path"),
                  "Reads an OpenCV calibration YAML file (as 'silpose calibrate' writes).")
      .def(
          "write",
          [](const PinholeCamera& c, const std::filesystem::path& p) { WriteCameraFile(p, c); },
          py::arg("path"), "Writes an OpenCV calibration YAML file.")
      .def_static("default", &DefaultCamera, py::arg("width"), py::arg("height"),
                  "The camera 'silpose track' assumes without --camera: focal length 0.8203 * "
                  "width, principal point at the image centre, no distortion.")
      .def_static("synth_default", &DefaultSynthCamera,
                  "The camera of 'silpose synth': 640x480, focal length 525 px.")
      .def_readonly("width", &PinholeCamera::width_px, "Image width, pixels.")
      .def_readonly("height", &PinholeCamera::height_px, "Image height, pixels.")
      .def_readonly("fx", &PinholeCamera::focal_x_px, "Focal length in x, pixels.")
      .def_readonly("fy", &PinholeCamera::focal_y_px, "Focal length in y, pixels.")
      .def_readonly("cx", &PinholeCamera::principal_x_px, "Principal point x, pixels.")
      .def_readonly("cy", &PinholeCamera::principal_y_px, "Principal point y, pixels.")
      .def_readonly("distortion", &PinholeCamera::distortion,
                    "Distortion coefficients (k1, k2, p1, p2, k3).")
      .def_property_readonly(
          "matrix",
          [](const PinholeCamera& c) {
            Eigen::Matrix3d k;
            k << c.focal_x_px, 0, c.principal_x_px, 0, c.focal_y_px, c.principal_y_px, 0, 0, 1;
            return k;
          },
          "The 3x3 camera matrix K.")
      .def("__repr__", [](const PinholeCamera& c) {
        return "<silpose.Camera " + std::to_string(c.width_px) + "x" + std::to_string(c.height_px) +
               " fx=" + std::to_string(c.focal_x_px) + ">";
      });

  py::class_<TriangleMesh>(m, "Mesh", "A triangle mesh (model units); load one with load_mesh().")
      .def_readonly("name", &TriangleMesh::name, "Model name: the file stem.")
      .def_property_readonly(
          "vertices",
          [](py::object self) {
            const auto& mesh = self.cast<const TriangleMesh&>();
            return ReadOnlyView<float>(reinterpret_cast<const float*>(mesh.vertices.data()),
                                       static_cast<py::ssize_t>(mesh.vertices.size()), 3, self);
          },
          "Vertices, a read-only (V, 3) float32 view.")
      .def_property_readonly(
          "triangles",
          [](py::object self) {
            const auto& mesh = self.cast<const TriangleMesh&>();
            return ReadOnlyView<uint32_t>(reinterpret_cast<const uint32_t*>(mesh.triangles.data()),
                                          static_cast<py::ssize_t>(mesh.triangles.size()), 3, self);
          },
          "Vertex indices of each triangle, a read-only (T, 3) uint32 view.")
      .def_property_readonly("centre", &TriangleMesh::Centre,
                             "Object centre: the centre of the vertices' bounding box.")
      .def_property_readonly("radius", &TriangleMesh::Radius,
                             "Object radius: largest distance from the centre to a vertex.");
  m.def("load_mesh", &LoadMesh, py::arg("path"),
        "Loads a mesh (OBJ, PLY, STL, OFF, glTF, ...); raises silpose.Error naming the file.");

  m.def(
      "camera_from_object_at_view",
      [](const Eigen::Vector3d& view_dir, double roll_deg, double distance,
         const Eigen::Vector3d& centre) {
        if (!view_dir.allFinite() || view_dir.norm() == 0.0) {
          ThrowError("view_dir must be a finite non-zero vector");
        }
        return PoseMatrix(
            CameraFromObjectAtView(view_dir.normalized(), roll_deg, distance, centre));
      },
      py::arg("view_dir"), py::arg("roll_deg"), py::arg("distance"),
      py::arg("centre") = Eigen::Vector3d::Zero().eval(),
      "The 4x4 camera_from_object pose of a camera at `distance` (model units) from `centre` "
      "along `view_dir`, looking at it, with roll `roll_deg` (docs/conventions.md).");
}

void BindRender(py::module_& m) {
  m.def(
      "render_view",
      [](const TriangleMesh& mesh, const Eigen::Vector3d& view_dir, double roll_deg, int resolution,
         double distance_in_radii, double fill) {
        if (!view_dir.allFinite() || view_dir.norm() == 0.0) {
          ThrowError("view_dir must be a finite non-zero vector");
        }
        ViewRenderOptions options;
        options.resolution_px = resolution;
        options.distance_in_radii = distance_in_radii;
        options.fill_fraction = fill;
        std::string error;
        if (!options.Check(&error)) ThrowError("invalid rendering options: ", error);
        cv::Mat mask;
        {
          py::gil_scoped_release release;
          RenderView(mesh, view_dir.normalized(), roll_deg, options, &mask);
        }
        return ArrayView(mask);
      },
      py::arg("mesh"), py::arg("view_dir"), py::arg("roll_deg") = 0.0, py::arg("resolution") = 512,
      py::arg("distance_in_radii") = 3.0, py::arg("fill") = 0.9,
      "Renders the silhouette of `mesh` seen from `view_dir` with roll `roll_deg`, framed as the "
      "database frames it (as 'silpose render'): a (resolution, resolution) uint8 mask, 255 = "
      "object.");
  m.def(
      "render_pose",
      [](const TriangleMesh& mesh, const PinholeCamera& camera,
         const Eigen::Ref<const Eigen::Matrix4d>& camera_from_object) {
        const Rigid3 pose = PoseFromMatrix(camera_from_object, "camera_from_object");
        cv::Mat mask;
        {
          py::gil_scoped_release release;
          RenderSilhouette(mesh, camera, pose, &mask);
        }
        return ArrayView(mask);
      },
      py::arg("mesh"), py::arg("camera"), py::arg("camera_from_object"),
      "Renders the silhouette of `mesh` at the 4x4 pose `camera_from_object` (x_cam = R x_obj + "
      "t) seen by `camera` (ideal pinhole): a (height, width) uint8 mask, 255 = object.");
}

void BindMatch(py::module_& m) {
  py::class_<Candidate>(m, "Candidate", "One match of a silhouette against the database.")
      .def_readonly("model", &Candidate::model, "Model index in the database.")
      .def_readonly("model_name", &Candidate::model_name, "Model name.")
      .def_readonly("view", &Candidate::view, "View index (0..num_views-1).")
      .def_readonly("shell", &Candidate::shell, "Distance shell the view was matched in.")
      .def_readonly("roll_deg", &Candidate::roll_deg, "Camera roll, degrees, (-180, 180].")
      .def_readonly("score", &Candidate::score, "Correlation peak in [-1, 1].")
      .def_readonly("view_dir", &Candidate::view_dir,
                    "The view's unit direction (object centre -> camera, model frame).")
      .def("__repr__", [](const Candidate& c) {
        return "<silpose.Candidate " + c.model_name + " view " + std::to_string(c.view) + " roll " +
               std::to_string(c.roll_deg) + " score " + std::to_string(c.score) + ">";
      });

  py::class_<Matcher>(m, "Matcher",
                      "Matches single silhouettes against a whole database (as 'silpose match'); "
                      "keeps the database alive. Calls from several threads take turns: one per "
                      "thread matches in parallel.")
      .def(py::init<const ViewDatabase&>(), py::arg("database"), py::keep_alive<1, 2>(),
           "A matcher over `database`.")
      .def(
          "match",
          [](Matcher& matcher, const py::array& mask, int top_k, bool exhaustive) {
            const cv::Mat view = MatView(mask, "mask");
            MatchOptions options;
            options.top_k = top_k;
            options.exhaustive = exhaustive;
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(matcher.calls());
            return matcher.MatchMask(view, options);
          },
          py::arg("mask"), py::arg("top_k") = 5, py::arg("exhaustive") = false,
          "The best `top_k` candidates (model, view, roll, score) for a mask (non-zero = object, "
          "as "
          "docs/conventions.md says; "
          "uint8, uint16 or float32 array of shape (H, W) or (H, W, C)), best first. Raises "
          "silpose.Error if the mask has no usable silhouette.")
      .def(
          "match_signature",
          [](Matcher& matcher,
             const py::array_t<float, py::array::c_style | py::array::forcecast>& radii, int top_k,
             bool exhaustive) {
            if (radii.ndim() != 1) ThrowError("signature: a 1-D array of radii needed");
            MatchOptions options;
            options.top_k = top_k;
            options.exhaustive = exhaustive;
            const std::span<const float> values(radii.data(), static_cast<size_t>(radii.size()));
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(matcher.calls());
            return matcher.MatchSignature(values, options);
          },
          py::arg("radii"), py::arg("top_k") = 5, py::arg("exhaustive") = false,
          "Like match() for a polar signature of the database's length (e.g. one of "
          "ViewDatabase.signatures()).")
      .def_property_readonly(
          "database",
          [](const Matcher& matcher) -> const ViewDatabase& { return matcher.database(); },
          py::return_value_policy::reference_internal, "The database matched against.");
}

void BindTrack(py::module_& m) {
  py::class_<TrackerOptions>(
      m, "TrackerOptions",
      "Options of the Tracker, as 'silpose track' takes them (docs/tracking.md). Keyword "
      "arguments set the attributes of the same names: TrackerOptions(segment='bgsub', "
      "background='empty.png').")
      .def(py::init([](const py::kwargs& keywords) {
             auto options = std::make_unique<TrackerOptions>();
             SetFromKeywords(py::cast(options.get(), py::return_value_policy::reference), keywords,
                             "TrackerOptions");
             return options;
           }),
           "Default options ('silpose track' defaults), changed by keyword arguments.")
      .def_property(
          "segment", [](const TrackerOptions& o) { return ToString(o.segmentation.kind); },
          [](TrackerOptions& o, const std::string& v) {
            o.segmentation.kind = ParseSegmenterKind(v);
          },
          "How frames become masks: 'mask', 'bgsub' or 'threshold' (--segment).")
      .def_property(
          "mask_threshold", [](const TrackerOptions& o) { return o.segmentation.mask_threshold; },
          [](TrackerOptions& o, int v) { o.segmentation.mask_threshold = v; },
          "mask: a pixel is object above this value (--mask-threshold).")
      .def_property(
          "background",
          [](const TrackerOptions& o) { return o.segmentation.background_image_path; },
          [](TrackerOptions& o, const std::string& v) { o.segmentation.background_image_path = v; },
          "bgsub: image of the empty scene to learn from (--background); '' = the first frames.")
      .def_property(
          "background_method",
          [](const TrackerOptions& o) { return ToString(o.segmentation.background_method); },
          [](TrackerOptions& o, const std::string& v) {
            o.segmentation.background_method = ParseBackgroundMethod(v);
          },
          "bgsub: 'mog2', 'knn' or 'gauss' (--bg-method).")
      .def_property(
          "learning_frames", [](const TrackerOptions& o) { return o.segmentation.learning_frames; },
          [](TrackerOptions& o, int v) { o.segmentation.learning_frames = v; },
          "bgsub: frames learned from without a background image (--learning-frames).")
      .def_property(
          "threshold_method",
          [](const TrackerOptions& o) { return ToString(o.segmentation.threshold_method); },
          [](TrackerOptions& o, const std::string& v) {
            o.segmentation.threshold_method = ParseThresholdMethod(v);
          },
          "threshold: 'otsu' or 'hsv' (--threshold-method).")
      .def_property(
          "object_polarity",
          [](const TrackerOptions& o) { return ToString(o.segmentation.otsu_object); },
          [](TrackerOptions& o, const std::string& v) {
            o.segmentation.otsu_object = ParseObjectPolarity(v);
          },
          "threshold otsu: 'darker' or 'brighter' (--object-polarity).")
      .def_property(
          "component", [](const TrackerOptions& o) { return ToString(o.segmentation.component); },
          [](TrackerOptions& o, const std::string& v) {
            o.segmentation.component = ParseSegmentComponent(v);
          },
          "Which connected component is the object: 'largest' or 'nearest' (--component).")
      .def_readwrite("brute_force", &TrackerOptions::brute_force,
                     "Match every frame against the whole database instead of filtering.")
      .def_readwrite("on_axis_matching", &TrackerOptions::on_axis_matching,
                     "Describe the silhouette in the on-axis virtual camera before matching.")
      .def_readwrite("estimate_pose", &TrackerOptions::estimate_pose,
                     "Estimate the 6-DOF pose of frames with a silhouette.")
      .def_readwrite("refine", &TrackerOptions::refine,
                     "Refine the pose against the frame's outline (--no-refine: False).")
      .def_readwrite("fit_arbitration_ratio", &TrackerOptions::fit_arbitration_ratio,
                     "When the frame's best-scoring hypothesis lies outside the filter's mode, "
                     "report it if its refined outline distance is below this ratio times the "
                     "other's (0.8; 0 = off, --no-fit-arbitration).")
      .def_readwrite("fit_arbitration_margin_px", &TrackerOptions::fit_arbitration_margin_px,
                     "... and lower by more than this many pixels (0.25) ...")
      .def_readwrite("fit_arbitration_iou_gain", &TrackerOptions::fit_arbitration_iou_gain,
                     "... or with an IoU higher by at least this much (0.01; 0 = off).")
      .def_readwrite("fit_arbitration_score_gap", &TrackerOptions::fit_arbitration_score_gap,
                     "... or, for a challenger of the same object that fits at least as well, "
                     "if its score is higher by at least this much (0.3; 0 = off).")
      .def_readwrite("refine_from_motion", &TrackerOptions::refine_from_motion,
                     "Filter mode: also refine from the previous frame's refined pose, turned "
                     "on by the last frame-to-frame rotation, and keep whichever of the two "
                     "refined poses fits the frame's outline better (on by default).")
      .def_readwrite("polish_steps", &TrackerOptions::polish_steps,
                     "Filter mode: the pose starts from the best-scoring view near the filter's "
                     "estimate, found by at most this many steps to a better neighbour (2; 0 = "
                     "the estimate's view as it is).")
      .def_readwrite("mirror_twin_check", &TrackerOptions::mirror_twin_check,
                     "For an object with a mirror plane, also fit the mirror twin of the matched "
                     "pose (the pose casting the same outline from far away) and report it when "
                     "it fits clearly better, by the fit arbitration's rule (--no-twin-check: "
                     "False).")
      .def_readwrite("other_pose_check", &TrackerOptions::other_pose_check,
                     "Also fit the object's best-scoring pose more than 15 degrees from the "
                     "matched one and report it when it fits the outline far closer "
                     "(--no-other-pose-check: False).")
      .def_readwrite("canonical_poses", &TrackerOptions::canonical_poses,
                     "Report the poses of symmetric objects in canonical form "
                     "(--no-canonical-poses: False).")
      .def_property(
          "seed", [](const TrackerOptions& o) { return o.filter.seed; },
          [](TrackerOptions& o, uint64_t v) { o.filter.seed = v; },
          "Seed of the particle filter (--seed).")
      .def_property(
          "keep_history", [](const TrackerOptions& o) { return o.filter.keep_history; },
          [](TrackerOptions& o, bool v) { o.filter.keep_history = v; },
          "Keep the particles' pose histories, which a Smoother reads (True); False tracks "
          "the same poses with a cheaper filter step, as 'silpose track' without --smooth/--lag.")
      .def_property(
          "particles_per_object",
          [](const TrackerOptions& o) { return o.filter.particles_per_object; },
          [](TrackerOptions& o, int v) {
            // As 'silpose track --particles': without adaptive sampling the count is fixed, and
            // the floor and cap follow it.
            o.filter.particles_per_object = v;
            if (!o.filter.adaptive) {
              o.filter.min_particles_per_object = std::min(o.filter.min_particles_per_object, v);
              o.filter.max_particles_per_object = std::max(o.filter.max_particles_per_object, v);
            }
          },
          "Particles per object of the filter (--particles).")
      .def(
          "check",
          [](const TrackerOptions& o) {
            std::string error;
            if (!o.Check(&error)) ThrowError(error);
          },
          "Raises silpose.Error naming the first invalid option.");

  py::class_<TrackResult>(m, "TrackResult",
                          "What the tracker found in one frame (a row of POSES.csv, "
                          "docs/tracking.md); unknown values are None.")
      .def_property_readonly(
          "frame", [](const TrackResult& r) { return r.result.frame; },
          "Frame number, from 0 in processing order.")
      .def_property_readonly(
          "status", [](const TrackResult& r) { return r.result.status; },
          "Whether the frame had a usable silhouette and how it was used ('measured', ...).")
      .def_property_readonly(
          "object",
          [](const TrackResult& r) {
            return r.result.object >= 0 ? py::object(py::int_(r.result.object)) : py::none();
          },
          "Index of the estimated object in the database, or None.")
      .def_property_readonly(
          "object_name",
          [](const TrackResult& r) {
            return r.result.object >= 0 ? py::object(py::str(r.result.object_name)) : py::none();
          },
          "Name of the estimated object, or None.")
      .def_property_readonly(
          "score", [](const TrackResult& r) { return OptionalFloat(r.result.score); },
          "Correlation score of the estimate in [-1, 1], or None.")
      .def_property_readonly(
          "probability", [](const TrackResult& r) { return OptionalFloat(r.result.probability); },
          "Probability of the object (particle filter), or None.")
      .def_property_readonly(
          "view_dir",
          [](const TrackResult& r) -> py::object {
            if (!r.result.view_dir_in_object) return py::none();
            return py::cast(Eigen::Vector3d(*r.result.view_dir_in_object));
          },
          "Unit view direction (object centre -> camera, model frame), or None.")
      .def_property_readonly(
          "roll_deg", [](const TrackResult& r) { return OptionalFloat(r.result.roll_deg); },
          "Camera roll, degrees, or None.")
      .def_property_readonly(
          "camera_from_object",
          [](const TrackResult& r) -> py::object {
            if (!r.result.camera_from_object) return py::none();
            return py::cast(PoseMatrix(*r.result.camera_from_object));
          },
          "The 6-DOF pose as a 4x4 array (x_cam = R x_obj + t, OpenCV camera frame, t in model "
          "units), or None when the frame has no pose.")
      .def_property_readonly(
          "time_ms", [](const TrackResult& r) { return OptionalFloat(r.result.time_ms); },
          "Processing time of the frame in the library, milliseconds.")
      .def_property_readonly(
          "particles", [](const TrackResult& r) { return r.result.particles; },
          "Particles used (0 without a particle filter).")
      .def_property_readonly(
          "effective_particles",
          [](const TrackResult& r) { return OptionalFloat(r.result.effective_particles); },
          "Effective number of particles, or None.")
      .def_property_readonly(
          "confidence", [](const TrackResult& r) { return OptionalFloat(r.result.confidence); },
          "Probability, in [0, 1], that the object is right and the rotation within 10 degrees "
          "(0 for a predicted frame without a silhouette, None without any estimate); see "
          "docs/confidence.md.")
      .def_property_readonly(
          "state", [](const TrackResult& r) { return std::string(TrackStateName(r.result.state)); },
          "What the result can be trusted for: 'tracking', 'ambiguous', 'unknown-object', "
          "'bad-segmentation', 'lost' or 'no-silhouette'.")
      .def_property_readonly(
          "iou", [](const TrackResult& r) { return OptionalFloat(r.result.iou); },
          "IoU of the model's silhouette at the refined pose with the mask, or None.")
      .def_property_readonly(
          "runner_up",
          [](const TrackResult& r) -> py::object {
            if (r.result.runner_up_object < 0) return py::none();
            py::dict d;
            d["object"] = r.result.runner_up_name;
            d["object_index"] = r.result.runner_up_object;
            d["mass"] = OptionalFloat(r.result.runner_up_mass);
            d["view_dir"] = r.result.runner_up_view_dir
                                ? py::cast(std::vector<double>{r.result.runner_up_view_dir->x(),
                                                               r.result.runner_up_view_dir->y(),
                                                               r.result.runner_up_view_dir->z()})
                                : py::none();
            d["roll_deg"] = OptionalFloat(r.result.runner_up_roll_deg);
            return d;
          },
          "The strongest other hypothesis (the particle filter's, or a mirror twin of the view "
          "with mass None) as a dict (object, object_index, mass, view_dir, roll_deg), or None.")
      .def_property_readonly(
          "segmentation", [](const TrackResult& r) { return r.segmentation; },
          "Segmentation status: 'ok', 'learning', 'empty' or 'too-large'.")
      .def_property_readonly(
          "segmentation_message", [](const TrackResult& r) { return r.segmentation_message; },
          "What the segmentation found or why not, for people.")
      .def_property_readonly(
          "mask", [](const TrackResult& r) { return ArrayView(r.mask); },
          "The segmentation mask, a (height, width) uint8 array (255 = object; all zero unless "
          "segmentation == 'ok').")
      .def("__repr__", [](const TrackResult& r) {
        return "<silpose.TrackResult frame " + std::to_string(r.result.frame) + " " +
               (r.result.object >= 0 ? r.result.object_name : std::string("(none)")) + " " +
               r.result.status + ">";
      });

  py::class_<PyTracker>(m, "Tracker",
                        "The per-frame pipeline of 'silpose track' for one video stream: "
                        "segmentation, silhouette, particle filter, 6-DOF pose. Keeps the database "
                        "alive.")
      .def(py::init([](const ViewDatabase& database, const PinholeCamera& camera,
                       std::optional<TrackerOptions> options) {
             return std::make_unique<PyTracker>(database, camera,
                                                options.value_or(TrackerOptions{}));
           }),
           py::arg("database"), py::arg("camera"), py::arg("options") = py::none(),
           py::keep_alive<1, 2>(),
           "A tracker of frames of `camera`'s size against `database`. Raises silpose.Error for "
           "invalid options or camera.")
      .def(
          "process",
          [](PyTracker& tracker, const py::array& frame) {
            const cv::Mat view = MatView(frame, "frame");
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(tracker.calls);
            return ToTrackResult(tracker.Process(view));
          },
          py::arg("frame"),
          "Processes the next frame (mask or grey image (H, W), or BGR (H, W, 3); uint8, uint16 "
          "or float32 in [0, 1]) and returns its TrackResult. Raises silpose.Error for a frame "
          "of another size than the camera's or of an unsupported type.")
      .def(
          "process_many",
          [](PyTracker& tracker, const std::vector<py::array>& frames) {
            std::vector<cv::Mat> views;
            for (const py::array& frame : frames) views.push_back(MatView(frame, "frame"));
            std::vector<TrackResult> results;
            results.reserve(views.size());
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(tracker.calls);
            for (const cv::Mat& view : views)
              results.push_back(ToTrackResult(tracker.Process(view)));
            return results;
          },
          py::arg("frames"),
          "process() of each frame in turn, in one call (the GIL is released throughout).")
      .def_property_readonly(
          "num_frames",
          [](PyTracker& tracker) {
            const std::lock_guard<std::mutex> one_call(tracker.calls);
            return tracker.num_frames();
          },
          "Frames processed so far.")
      .def_property_readonly("camera", &Tracker::camera, "The camera of the frames.")
      .def_property_readonly("database", &Tracker::database,
                             py::return_value_policy::reference_internal,
                             "The database tracked against.");

  py::class_<SmoothedTracker>(
      m, "Smoother",
      "A Tracker whose results come out smoothed by the particle filter's histories "
      "('silpose track --lag N' / '--smooth'; docs/tracking.md): with a lag N, each frame's "
      "result N frames late, corrected by what followed; offline (lag = Smoother.OFFLINE), every "
      "result at finish(). Keeps the database alive.")
      .def(py::init([](const ViewDatabase& database, const PinholeCamera& camera,
                       std::optional<TrackerOptions> options, int lag) {
             return std::make_unique<SmoothedTracker>(database, camera,
                                                      options.value_or(TrackerOptions{}), lag);
           }),
           py::arg("database"), py::arg("camera"), py::arg("options") = py::none(),
           py::arg("lag") = 10, py::keep_alive<1, 2>(),
           "A smoothed tracker of frames of `camera`'s size against `database`; lag in frames "
           "(>= 0) or Smoother.OFFLINE. Raises silpose.Error for invalid options, camera or lag, "
           "or brute-force options.")
      .def_readonly_static("OFFLINE", &TrackSmoother::kOffline,
                           "The lag that means: every result at finish().")
      .def(
          "process",
          [](SmoothedTracker& smoothed, const py::array& frame) {
            const cv::Mat view = MatView(frame, "frame");
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(smoothed.calls);
            return ToTrackResults(smoothed.smoother->Process(view));
          },
          py::arg("frame"),
          "Tracks the next frame (as Tracker.process) and returns the results that are now final, "
          "oldest first: the one `lag` frames back (none during the first `lag` frames; offline "
          "none).")
      .def(
          "finish",
          [](SmoothedTracker& smoothed) {
            py::gil_scoped_release release;
            const std::lock_guard<std::mutex> one_call(smoothed.calls);
            return ToTrackResults(smoothed.smoother->Finish());
          },
          "The results still held, oldest first, smoothed by everything tracked. Call at the "
          "end of the stream.")
      .def_property_readonly(
          "lag", [](const SmoothedTracker& s) { return s.smoother->lag(); },
          "Frames of lag, or Smoother.OFFLINE.")
      .def_property_readonly(
          "num_frames",
          [](SmoothedTracker& s) {
            const std::lock_guard<std::mutex> one_call(s.calls);
            return s.tracker->num_frames();
          },
          "Frames tracked so far.")
      .def_property_readonly(
          "num_pending",
          [](SmoothedTracker& s) {
            const std::lock_guard<std::mutex> one_call(s.calls);
            return s.smoother->num_pending();
          },
          "Frames tracked whose results are not out yet.")
      .def_property_readonly(
          "num_revised",
          [](SmoothedTracker& s) {
            const std::lock_guard<std::mutex> one_call(s.calls);
            return s.smoother->num_revised();
          },
          "Results so far whose object or view the smoothing changed.")
      .def_property_readonly(
          "num_kept_live",
          [](SmoothedTracker& s) {
            const std::lock_guard<std::mutex> one_call(s.calls);
            return s.smoother->num_kept_live();
          },
          "Results so far the smoothing would have re-posed at a pose fitting the silhouette "
          "worse than the live one (a lower IoU, or none measured), returned as tracked.");

  py::class_<PosesCsvWriter>(m, "PosesWriter",
                             "Writes POSES.csv (docs/tracking.md), one row per TrackResult, as "
                             "'silpose track -o' does; a context manager.")
      .def(py::init<const std::filesystem::path&>(), py::arg("path"),
           "Creates (truncates) the file and writes the header.")
      .def(
          "write",
          [](PosesCsvWriter& writer, const TrackResult& result) { writer.Write(result.result); },
          py::arg("result"), "Writes and flushes the row of one frame.")
      .def("close", &PosesCsvWriter::Close, "Closes the file; raises silpose.Error if that fails.")
      .def(
          "__enter__", [](PosesCsvWriter& writer) -> PosesCsvWriter& { return writer; },
          py::return_value_policy::reference_internal, "Returns the writer.")
      .def(
          "__exit__",
          [](PosesCsvWriter& writer, const py::object&, const py::object&, const py::object&) {
            writer.Close();
          },
          "Closes the file.");

  py::class_<FrameReader>(m, "FrameReader",
                          "Reads any input 'silpose track' reads (image folder, sequence folder, "
                          "AVI video) as numpy arrays; an iterator over the frames.")
      .def(py::init<const std::string&, const std::string&, bool, int>(), py::arg("input"),
           py::arg("color") = "as-stored", py::arg("masks") = true, py::arg("read_ahead") = 0,
           "Opens `input`. color: 'as-stored', 'gray', 'bgr' or 'mask'. masks: take a sequence "
           "folder's masks/ (True) or frames/ (False). read_ahead: frames decoded ahead on a "
           "thread of their own while the caller works (as 'silpose track --read-ahead'; 0: "
           "decoded when asked for). Raises silpose.Error naming the input.")
      .def(
          "__iter__", [](FrameReader& reader) -> FrameReader& { return reader; },
          py::return_value_policy::reference_internal, "Returns the reader.")
      .def(
          "__next__",
          [](FrameReader& reader) {
            std::optional<cv::Mat> frame;
            {
              py::gil_scoped_release release;
              frame = reader.Next();
            }
            if (!frame) throw py::stop_iteration();
            return ArrayView(*frame);
          },
          "The next frame: (H, W) or (H, W, 3) uint8 (BGR). Raises silpose.Error for a corrupt "
          "frame.")
      .def_property_readonly(
          "fps",
          [](FrameReader& reader) {
            return reader.Ask([](const FrameSource& s) { return s.fps(); });
          },
          "Frames per second stated by the input; 0 if unknown.")
      .def_property_readonly(
          "num_frames",
          [](FrameReader& reader) -> py::object {
            const auto frames = reader.Ask([](const FrameSource& s) { return s.num_frames(); });
            return frames ? py::object(py::int_(*frames)) : py::none();
          },
          "Number of frames if known, else None.")
      .def_property_readonly(
          "name",
          [](FrameReader& reader) {
            return reader.Ask([](const FrameSource& s) { return s.name(); });
          },
          "Name of the last frame read ('000012.png', 'video.avi#12').");
}

void BindSynth(py::module_& m) {
  py::class_<SyntheticSequence>(
      m, "SyntheticSequence",
      "A synthetic sequence with exact ground truth, as 'silpose synth' makes it: a trajectory "
      "rendered frame by frame, optionally with colour frames over a textured background.")
      .def(py::init([](const std::vector<TriangleMesh>& meshes, const std::string& trajectory,
                       int frames, uint64_t seed, int switch_every, bool colour,
                       double camera_noise, std::optional<PinholeCamera> camera) {
             SynthOptions in{trajectory, frames, seed, switch_every, colour, camera_noise, camera};
             const SequenceOptions options =
                 MakeSequenceOptions(in, static_cast<int>(meshes.size()));
             return std::make_unique<SyntheticSequence>(meshes, options);
           }),
           py::arg("meshes"), py::arg("trajectory") = "orbit", py::arg("frames") = 0,
           py::arg("seed") = 1, py::arg("switch_every") = 0, py::arg("colour") = false,
           py::arg("camera_noise") = 0.0, py::arg("camera") = py::none(),
           "meshes: the objects (load_mesh). trajectory: 'orbit', 'walk' or 'handheld'. frames: "
           "0 = the trajectory's default. switch_every: show the objects in turn, this many "
           "frames each (0: equal parts). colour: also render colour frames, with Gaussian "
           "camera noise `camera_noise`. camera: default Camera.synth_default().")
      .def_property_readonly("num_frames", &SyntheticSequence::num_frames, "Number of frames.")
      .def_property_readonly("camera", &SyntheticSequence::camera, "The camera of every frame.")
      .def_property_readonly(
          "background", [](const SyntheticSequence& s) { return ArrayView(s.background()); },
          "The empty scene of the colour frames, (H, W, 3) uint8 BGR (empty without colour).")
      .def(
          "truth",
          [](const SyntheticSequence& s, int index) {
            if (index < 0 || index >= s.num_frames()) {
              ThrowError("frame ", index, " out of range (", s.num_frames(), " frames)");
            }
            return TruthDict(s.Truth(index));
          },
          py::arg("index"),
          "Ground truth of a frame: dict with frame, object, view_dir, roll_deg, "
          "camera_from_object (4x4) and distance_in_radii.")
      .def(
          "generate",
          [](const SyntheticSequence& s, int index) {
            if (index < 0 || index >= s.num_frames()) {
              ThrowError("frame ", index, " out of range (", s.num_frames(), " frames)");
            }
            SyntheticFrame frame;
            {
              py::gil_scoped_release release;
              s.Generate(index, &frame);
            }
            py::dict out = TruthDict(frame.truth);
            out["mask"] = ArrayView(frame.mask);
            out["colour"] =
                frame.colour.empty() ? py::object(py::none()) : py::object(ArrayView(frame.colour));
            return out;
          },
          py::arg("index"),
          "Renders frame `index`: the truth() dict plus 'mask' ((H, W) uint8) and 'colour' "
          "((H, W, 3) uint8 BGR, or None).")
      .def(
          "write",
          [](const SyntheticSequence& s, const std::filesystem::path& folder, bool overwrite,
             int threads) {
            SequenceWriteOptions options;
            options.overwrite = overwrite;
            options.num_threads = threads;
            SequenceSummary summary;
            {
              py::gil_scoped_release release;
              summary = WriteSequence(s, folder, options);
            }
            return summary.BriefReport();
          },
          py::arg("folder"), py::arg("overwrite") = false, py::arg("threads") = 0,
          "Writes the sequence folder (masks/, frames/, background.png, camera.yml, "
          "groundtruth.csv: docs/conventions.md) and returns a one-line report.");
}

}  // namespace
}  // namespace silpose::python

PYBIND11_MODULE(_silpose, m) {
  using namespace silpose;
  using namespace silpose::python;
  m.doc() =
      "silpose: object identity and 6-DOF pose from silhouettes (compiled part; use the "
      "'silpose' package).";
  static py::exception<Error> error_type(m, "Error", PyExc_ValueError);
  error_type.doc() =
      "Bad input (a file, parameter or array): the message names it and says what is wrong.";
  py::register_exception_translator([](std::exception_ptr pointer) {
    try {
      if (pointer) std::rethrow_exception(pointer);
    } catch (const Error& error) {
      error_type(error.what());
    } catch (const cv::Exception& error) {
      PyErr_SetString(PyExc_RuntimeError, (std::string("OpenCV error: ") + error.what()).c_str());
    }
  });
  BindDatabase(m);
  BindGeometry(m);
  BindRender(m);
  BindMatch(m);
  BindTrack(m);
  BindSynth(m);
}
