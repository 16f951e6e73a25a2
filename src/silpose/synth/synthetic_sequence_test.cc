#include "silpose/synth/synthetic_sequence.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/mask_file.h"
#include "silpose/pose/lens_distortion.h"
#include "silpose/pose/pose_from_silhouette.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// A folder in the temporary folder, unique to this process and test, removed afterwards.
class TempFolder {
 public:
  explicit TempFolder(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("silpose_synth_" + std::to_string(::getpid()) + "_" + name)) {
    std::filesystem::remove_all(path_);
  }
  ~TempFolder() {
    std::error_code error;
    std::filesystem::remove_all(path_, error);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

std::string FileBytes(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

const TriangleMesh& Bunny() {
  static const TriangleMesh mesh =
      LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / "bunny.obj");
  return mesh;
}

// An axis-aligned box from `low` to `high` (12 triangles).
TriangleMesh Box(const std::string& name, const Eigen::Vector3f& low, const Eigen::Vector3f& high) {
  TriangleMesh mesh;
  mesh.name = name;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.emplace_back(i & 1 ? high.x() : low.x(), i & 2 ? high.y() : low.y(),
                               i & 4 ? high.z() : low.z());
  }
  mesh.triangles = {{0, 1, 3}, {0, 3, 2}, {4, 6, 7}, {4, 7, 5}, {0, 4, 5}, {0, 5, 1},
                    {2, 3, 7}, {2, 7, 6}, {0, 2, 6}, {0, 6, 4}, {1, 5, 7}, {1, 7, 3}};
  return mesh;
}

// 160 x 120, principal point at the centre; at 3 radii the bounding sphere spans 110 px.
SequenceOptions SmallOrbit(int frames, double step_deg) {
  SequenceOptions options;
  options.camera = PinholeCamera::Centered(160, 120, 155.0);
  options.trajectory.num_frames = frames;
  options.trajectory.orbit.step_deg = step_deg;
  return options;
}

TEST(SyntheticSequence, DefaultCameraIsVgaWithFocal525AtTheCentre) {
  const PinholeCamera camera = DefaultSynthCamera();
  EXPECT_EQ(camera.width_px, 640);
  EXPECT_EQ(camera.height_px, 480);
  EXPECT_EQ(camera.focal_x_px, 525.0);
  EXPECT_EQ(camera.focal_y_px, 525.0);
  EXPECT_EQ(camera.principal_x_px, 319.5);
  EXPECT_EQ(camera.principal_y_px, 239.5);
  EXPECT_TRUE(camera.Check());
}

TEST(SyntheticSequence, GroundTruthPoseIsConsistentWithTheRendering) {
  SequenceOptions options = SmallOrbit(12, 30.0);
  options.trajectory.orbit.roll_deg = 25.0;
  const SyntheticSequence sequence({Bunny()}, options);
  const Eigen::Vector3d centre = Bunny().Centre();
  const double radius = Bunny().Radius();
  for (int k = 0; k < sequence.num_frames(); ++k) {
    const SyntheticFrame frame = sequence.Generate(k);
    const GroundTruthFrame& truth = frame.truth;
    EXPECT_EQ(truth.frame, k);
    EXPECT_EQ(truth.object, "bunny");
    const Rigid3& pose = truth.camera_from_object;
    // The camera looks at the object centre: it projects to the principal point.
    const Eigen::Vector2d centre_px = options.camera.Project(pose * centre);
    EXPECT_NEAR(centre_px.x(), options.camera.principal_x_px, 1e-9);
    EXPECT_NEAR(centre_px.y(), options.camera.principal_y_px, 1e-9);
    // ... from distance_in_radii object radii.
    const Eigen::Vector3d camera_centre = pose.Inverse().translation;
    EXPECT_NEAR((camera_centre - centre).norm(), truth.distance_in_radii * radius, 1e-9);
    // View and roll columns are those of R.
    Eigen::Vector3d view;
    double roll = 0.0;
    ViewAndRollFromRotation(pose.rotation, &view, &roll);
    EXPECT_LT((view - truth.view_dir_in_object).norm(), 1e-9) << "frame " << k;
    EXPECT_NEAR(WrapDegrees(roll - truth.roll_deg), 0.0, 1e-9) << "frame " << k;
    EXPECT_NEAR(truth.roll_deg, 25.0, 1e-12);
    // The rendering is that pose: the object is in view, whole, around the principal point.
    EXPECT_GT(frame.rendered_area_px, 500);
    EXPECT_FALSE(frame.touches_border);
    const cv::Rect box = cv::boundingRect(frame.mask);
    EXPECT_TRUE(box.contains(cv::Point(80, 60))) << "frame " << k;
    EXPECT_EQ(frame.mask.cols, 160);
    EXPECT_EQ(frame.mask.rows, 120);
    // Truth() agrees without rendering.
    EXPECT_EQ(sequence.Truth(k).camera_from_object.rotation, pose.rotation);
  }
}

TEST(SyntheticSequence, ObjectSwitchesChangeTheModelAndItsPose) {
  SequenceOptions options = SmallOrbit(6, 10.0);
  options.trajectory.object_switches = {{3, 1}};
  const TriangleMesh small = Box("small", {0, 0, 0}, {1, 1, 1});
  const TriangleMesh large = Box("large", {10, 10, 10}, {14, 12, 11});
  const SyntheticSequence sequence({small, large}, options);
  for (int k = 0; k < 6; ++k) {
    const SyntheticFrame frame = sequence.Generate(k);
    const TriangleMesh& mesh = k < 3 ? small : large;
    EXPECT_EQ(frame.truth.object, mesh.name);
    const Eigen::Vector3d camera_centre = frame.truth.camera_from_object.Inverse().translation;
    EXPECT_NEAR((camera_centre - mesh.Centre()).norm(), 3.0 * mesh.Radius(), 1e-9);
    EXPECT_GT(frame.rendered_area_px, 500);
  }
  // Frame 3 of the large box, viewed like frame 3 of a sequence of the large box alone.
  const SyntheticSequence alone({large}, SmallOrbit(6, 10.0));
  EXPECT_EQ(cv::countNonZero(sequence.Generate(3).mask != alone.Generate(3).mask), 0);
}

TEST(SyntheticSequence, BadModelListsAreRefused) {
  const TriangleMesh box = Box("box", {0, 0, 0}, {1, 1, 1});
  EXPECT_THROW(SyntheticSequence({}, SmallOrbit(3, 1.0)), Error);
  EXPECT_THROW(SyntheticSequence({box, box}, SmallOrbit(3, 1.0)), Error);  // same name
  SequenceOptions options = SmallOrbit(3, 1.0);
  options.trajectory.object_switches = {{1, 1}};
  try {
    const SyntheticSequence sequence({box}, options);
    ADD_FAILURE() << "a switch to a missing object was accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("object switch"), std::string::npos) << error.what();
  }
  TriangleMesh point = box;
  for (auto& v : point.vertices) v = Eigen::Vector3f(1, 2, 3);
  EXPECT_THROW(SyntheticSequence({point}, SmallOrbit(3, 1.0)), Error);
  options = SmallOrbit(3, 1.0);
  options.camera.focal_x_px = -1.0;
  EXPECT_THROW(SyntheticSequence({box}, options), Error);
}

TEST(SyntheticSequence, WritesTheFolderOfTheDesign) {
  const TempFolder folder("files");
  SequenceOptions options = SmallOrbit(5, 3.0);
  options.degradation.missed_probability = 0.3;
  options.degradation.bad_probability = 0.3;
  options.degradation.seed = 4;
  const SyntheticSequence sequence({Bunny()}, options);
  const SequenceSummary summary = WriteSequence(sequence, folder.path());
  EXPECT_EQ(summary.frames, 5);
  EXPECT_EQ(summary.folder, folder.path());
  EXPECT_NE(summary.BriefReport().find("wrote 5 frames"), std::string::npos);

  for (int k = 0; k < 5; ++k) {
    char name[16];
    std::snprintf(name, sizeof(name), "%06d.png", k);
    EXPECT_EQ(SequenceMaskPath(folder.path(), k), folder.path() / "masks" / name);
    const cv::Mat mask = ReadMask(folder.path() / "masks" / name);
    EXPECT_EQ(mask.cols, 160);
    EXPECT_EQ(mask.rows, 120);
    const SyntheticFrame frame = sequence.Generate(k);
    EXPECT_EQ(cv::countNonZero(mask != frame.mask), 0) << "frame " << k;
    if (frame.truth.degradation == FrameDegradation::kMissed) {
      EXPECT_EQ(cv::countNonZero(mask), 0);
    }
  }
  EXPECT_FALSE(std::filesystem::exists(SequenceMaskPath(folder.path(), 5)));

  const PinholeCamera camera = ReadCameraFile(folder.path() / "camera.yml");
  EXPECT_EQ(camera.width_px, 160);
  EXPECT_EQ(camera.height_px, 120);
  EXPECT_DOUBLE_EQ(camera.focal_x_px, 155.0);
  EXPECT_DOUBLE_EQ(camera.principal_x_px, 79.5);
  EXPECT_DOUBLE_EQ(camera.principal_y_px, 59.5);

  const std::vector<GroundTruthFrame> truth = ReadGroundTruth(folder.path() / "groundtruth.csv");
  ASSERT_EQ(truth.size(), 5u);
  int missed = 0;
  int bad = 0;
  for (int k = 0; k < 5; ++k) {
    const GroundTruthFrame expected = sequence.Truth(k);
    const GroundTruthFrame& read = truth[static_cast<size_t>(k)];
    EXPECT_EQ(read.frame, k);
    EXPECT_EQ(read.object, "bunny");
    EXPECT_EQ(read.view_dir_in_object, expected.view_dir_in_object);
    EXPECT_EQ(read.roll_deg, expected.roll_deg);
    EXPECT_EQ(read.camera_from_object.rotation, expected.camera_from_object.rotation);
    EXPECT_EQ(read.camera_from_object.translation, expected.camera_from_object.translation);
    EXPECT_EQ(read.distance_in_radii, 3.0);
    // Degraded frames are recorded, as the generator chose them.
    EXPECT_EQ(read.degradation, ChooseFrameDegradation(options.degradation, k));
    missed += read.degradation == FrameDegradation::kMissed;
    bad += read.degradation == FrameDegradation::kBad;
  }
  EXPECT_EQ(summary.missed, missed);
  EXPECT_EQ(summary.bad, bad);
  EXPECT_GT(missed + bad, 0);  // with this seed
  EXPECT_LT(missed + bad, 5);
}

TEST(SyntheticSequence, OutputDoesNotDependOnTheThreadCount) {
  SequenceOptions options = SmallOrbit(12, 7.0);
  options.trajectory.kind = TrajectoryKind::kWalk;
  options.trajectory.walk.speed_sigma_deg = 5.0;
  options.degradation.noise_fraction = 0.01;
  options.degradation.occluders = 2;
  options.degradation.clutter_blobs = 1;
  options.degradation.bad_probability = 0.3;
  const SyntheticSequence sequence({Bunny()}, options);
  const TempFolder one("threads1");
  const TempFolder many("threads3");
  WriteSequence(sequence, one.path(), {.num_threads = 1});
  WriteSequence(sequence, many.path(), {.num_threads = 3});
  EXPECT_EQ(FileBytes(one.path() / "groundtruth.csv"), FileBytes(many.path() / "groundtruth.csv"));
  for (int k = 0; k < 12; ++k) {
    EXPECT_EQ(FileBytes(SequenceMaskPath(one.path(), k)),
              FileBytes(SequenceMaskPath(many.path(), k)))
        << "frame " << k;
  }
}

TEST(SyntheticSequence, AnExistingSequenceIsOnlyReplacedWhenAllowed) {
  const TempFolder folder("overwrite");
  const TriangleMesh box = Box("box", {0, 0, 0}, {1, 1, 1});
  WriteSequence(SyntheticSequence({box}, SmallOrbit(6, 5.0)), folder.path());
  std::ofstream(folder.path() / "notes.txt") << "mine";
  try {
    WriteSequence(SyntheticSequence({box}, SmallOrbit(3, 5.0)), folder.path());
    ADD_FAILURE() << "an existing sequence was overwritten";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find(folder.path().string()), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("overwrit"), std::string::npos);
  }
  WriteSequence(SyntheticSequence({box}, SmallOrbit(3, 5.0)), folder.path(), {.overwrite = true});
  EXPECT_EQ(ReadGroundTruth(folder.path() / "groundtruth.csv").size(), 3u);
  EXPECT_TRUE(std::filesystem::exists(SequenceMaskPath(folder.path(), 2)));
  EXPECT_FALSE(std::filesystem::exists(SequenceMaskPath(folder.path(), 3)));  // old masks gone
  EXPECT_TRUE(std::filesystem::exists(folder.path() / "notes.txt"));          // others kept
}

TEST(SyntheticSequence, ReportsObjectsOutOfViewOrCutByTheBorder) {
  const TempFolder folder("border");
  SequenceOptions options = SmallOrbit(2, 5.0);
  options.trajectory.orbit.distance_in_radii = 1.2;  // too close: the object fills the image
  const SequenceSummary summary =
      WriteSequence(SyntheticSequence({Box("box", {0, 0, 0}, {1, 1, 1})}, options), folder.path());
  EXPECT_EQ(summary.touching_border, 2);
  EXPECT_NE(summary.BriefReport().find("cut by the image border"), std::string::npos);
}

// ----- handheld and lens distortion -------------------------------------------------------------

double IoU(const cv::Mat& a, const cv::Mat& b) {
  const int intersection = cv::countNonZero(a & b);
  const int union_area = cv::countNonZero(a | b);
  return union_area > 0 ? static_cast<double>(intersection) / union_area : 1.0;
}

Eigen::Matrix3d Intrinsics(const PinholeCamera& camera) {
  Eigen::Matrix3d k;
  k << camera.focal_x_px, 0, camera.principal_x_px, 0, camera.focal_y_px, camera.principal_y_px, 0,
      0, 1;
  return k;
}

// A sphere of radius 1 around (1, 2, 3), latitude-longitude triangles (96 x 48).
TriangleMesh Sphere() {
  TriangleMesh mesh;
  mesh.name = "sphere";
  constexpr int kRings = 48;
  constexpr int kSectors = 96;
  for (int i = 0; i <= kRings; ++i) {
    const double polar = std::numbers::pi * i / kRings;
    for (int j = 0; j < kSectors; ++j) {
      const double azimuth = 2.0 * std::numbers::pi * j / kSectors;
      mesh.vertices.emplace_back(static_cast<float>(1.0 + std::sin(polar) * std::cos(azimuth)),
                                 static_cast<float>(2.0 + std::sin(polar) * std::sin(azimuth)),
                                 static_cast<float>(3.0 + std::cos(polar)));
    }
  }
  for (int i = 0; i < kRings; ++i) {
    for (int j = 0; j < kSectors; ++j) {
      const auto a =
          static_cast<uint32_t>(i * kSectors + j);  // (unsigned: clang refuses to narrow)
      const auto b = static_cast<uint32_t>(i * kSectors + (j + 1) % kSectors);
      mesh.triangles.push_back({a, a + kSectors, b + kSectors});
      mesh.triangles.push_back({a, b + kSectors, b});
    }
  }
  return mesh;
}

SequenceOptions Handheld(int frames, uint64_t seed) {
  SequenceOptions options;
  options.trajectory.kind = TrajectoryKind::kHandheld;
  options.trajectory.num_frames = frames;
  options.trajectory.handheld.seed = seed;
  options.trajectory.handheld.off_axis_speed_deg = 1.5;  // far off the axis within a few frames
  return options;
}

TEST(SyntheticSequence, HandheldFramesAreRenderedAtTheirOffAxisPose) {
  const SequenceOptions options = Handheld(40, 3);
  const TriangleMesh cube = Box("cube", {0, 0, 0}, {2, 2, 2});
  const SyntheticSequence sequence({cube}, options);
  ASSERT_TRUE(sequence.options().trajectory.handheld.camera.has_value());  // its own camera
  const PinholeCamera& camera = sequence.camera();
  const Eigen::Vector3d centre = cube.Centre();
  double widest_deg = 0.0;
  for (int k = 0; k < sequence.num_frames(); k += 3) {
    const SyntheticFrame frame = sequence.Generate(k);
    const GroundTruthFrame& truth = frame.truth;
    const Rigid3& pose = truth.camera_from_object;
    const Eigen::Vector3d u = truth.centre_ray_in_camera;
    EXPECT_EQ(u, sequence.trajectory()[static_cast<size_t>(k)].centre_ray_in_camera);
    widest_deg = std::max(widest_deg, std::acos(u.z()) * 180.0 / std::numbers::pi);
    // The object centre lies on the ray, at the distance; the virtual camera's axis is the view.
    const Eigen::Vector3d centre_in_camera = pose * centre;
    EXPECT_LT((centre_in_camera - truth.distance_in_radii * cube.Radius() * u).norm(), 1e-9);
    EXPECT_LT((pose.rotation.transpose() * u + truth.view_dir_in_object).norm(), 1e-9);
    ASSERT_GT(frame.rendered_area_px, 0) << "frame " << k;
    EXPECT_FALSE(frame.touches_border) << "frame " << k;
    // The image is the virtual on-axis camera's image turned by Q: warping the on-axis rendering
    // by the homography K Q K^-1 gives the frame's mask.
    cv::Mat on_axis;
    RenderSilhouette(cube, camera,
                     CameraFromObjectAtView(truth.view_dir_in_object, truth.roll_deg,
                                            truth.distance_in_radii * cube.Radius(), centre),
                     &on_axis);
    const Eigen::Matrix3d k_matrix = Intrinsics(camera);
    const Eigen::Matrix3d homography = k_matrix * RotationFromOpticalAxisTo(u) * k_matrix.inverse();
    cv::Mat h(3, 3, CV_64F);
    for (int i = 0; i < 9; ++i) h.at<double>(i / 3, i % 3) = homography(i / 3, i % 3);
    cv::Mat warped;
    cv::warpPerspective(on_axis, warped, h, on_axis.size(), cv::INTER_NEAREST);
    EXPECT_GT(IoU(warped, frame.mask), 0.97) << "frame " << k;
  }
  EXPECT_GT(widest_deg, 8.0);
}

TEST(SyntheticSequence, HandheldSilhouetteOfASphereIsWhereItsTruePoseProjectsIt) {
  // A sphere seen off the axis at angle theta, of angular radius alpha = asin(1 / D): its image is
  // an ellipse centred at f (tan(theta + alpha) + tan(theta - alpha)) / 2 from the principal
  // point, towards the centre's image.
  const TriangleMesh sphere = Sphere();
  const SyntheticSequence sequence({sphere}, Handheld(60, 5));
  const PinholeCamera& camera = sequence.camera();
  int off_axis_frames = 0;
  for (int k = 0; k < sequence.num_frames(); k += 4) {
    const SyntheticFrame frame = sequence.Generate(k);
    const Eigen::Vector3d u = frame.truth.centre_ray_in_camera;
    const double theta = std::acos(u.z());
    const double alpha = std::asin(sphere.Radius() * 0.9995 /  // the facets' mean radius
                                   (frame.truth.distance_in_radii * sphere.Radius()));
    const double radial = (std::tan(theta + alpha) + std::tan(theta - alpha)) / 2.0;
    const Eigen::Vector2d direction =
        theta > 0.0 ? Eigen::Vector2d(u.x(), u.y()).normalized() : Eigen::Vector2d(1, 0);
    const Eigen::Vector2d expected = Eigen::Vector2d(camera.principal_x_px, camera.principal_y_px) +
                                     camera.focal_x_px * radial * direction;
    const cv::Moments moments = cv::moments(frame.mask, true);
    ASSERT_GT(moments.m00, 0.0);
    const Eigen::Vector2d centroid(moments.m10 / moments.m00, moments.m01 / moments.m00);
    EXPECT_LT((centroid - expected).norm(), 1.0) << "frame " << k;
    // ... which is not the centre's own image, the further off the axis the more.
    off_axis_frames += theta > 10.0 * std::numbers::pi / 180.0;
    // The true pose puts the sphere's centre on the ray.
    const Eigen::Vector3d centre = frame.truth.camera_from_object * sphere.Centre();
    EXPECT_LT((centre.normalized() - u).norm(), 1e-9);
  }
  EXPECT_GT(off_axis_frames, 3);
}

TEST(SyntheticSequence, DistortedCamerasGiveDistortedMasksAndColourFrames) {
  SequenceOptions options = Handheld(12, 8);
  options.camera = PinholeCamera::Centered(320, 240, 262.5);
  options.camera.distortion = {-0.25, 0.08, 0.001, -0.001, 0.0};
  options.colour.enabled = true;
  options.trajectory.handheld.distance_min_radii = 3.0;
  options.trajectory.handheld.distance_max_radii = 4.0;
  const SyntheticSequence distorted({Bunny()}, options);
  PinholeCamera ideal_camera = options.camera;
  ideal_camera.distortion = {0, 0, 0, 0, 0};
  double least_ideal_iou = 1.0;
  for (int k = 0; k < distorted.num_frames(); k += 2) {
    const SyntheticFrame frame = distorted.Generate(k);
    ASSERT_GT(frame.rendered_area_px, 500) << "frame " << k;
    cv::Mat ideal;
    RenderSilhouette(Bunny(), ideal_camera, frame.truth.camera_from_object, &ideal);
    // Forward check: each ideal object pixel, moved by the lens model, lands on the mask.
    cv::Mat expected(ideal.size(), CV_8UC1, cv::Scalar(0));
    int inside = 0;
    int total = 0;
    for (int v = 0; v < ideal.rows; ++v) {
      for (int x = 0; x < ideal.cols; ++x) {
        if (ideal.at<uchar>(v, x) == 0) continue;
        const Eigen::Vector3d ray((x - ideal_camera.principal_x_px) / ideal_camera.focal_x_px,
                                  (v - ideal_camera.principal_y_px) / ideal_camera.focal_y_px, 1.0);
        const Eigen::Vector2d pixel = ProjectDistorted(options.camera, ray);
        const int px = static_cast<int>(std::lround(pixel.x()));
        const int py = static_cast<int>(std::lround(pixel.y()));
        if (px < 0 || py < 0 || px >= ideal.cols || py >= ideal.rows) continue;
        ++total;
        // Within a pixel of the mask (nearest-pixel sampling on both sides).
        bool near = false;
        for (int dy = -1; dy <= 1 && !near; ++dy) {
          for (int dx = -1; dx <= 1 && !near; ++dx) {
            const int qx = std::clamp(px + dx, 0, ideal.cols - 1);
            const int qy = std::clamp(py + dy, 0, ideal.rows - 1);
            near = frame.mask.at<uchar>(qy, qx) != 0;
          }
        }
        inside += near;
      }
    }
    ASSERT_GT(total, 0);
    EXPECT_GT(static_cast<double>(inside) / total, 0.995) << "frame " << k;
    // Barrel distortion shrinks the silhouette towards the centre.
    EXPECT_LT(frame.rendered_area_px, cv::countNonZero(ideal)) << "frame " << k;
    least_ideal_iou = std::min(least_ideal_iou, IoU(ideal, frame.mask));
    // The colour frame shows the object exactly on the (distorted) mask, the background elsewhere.
    cv::Mat changed;
    cv::absdiff(frame.colour, distorted.background(), changed);
    cv::cvtColor(changed, changed, cv::COLOR_BGR2GRAY);
    EXPECT_EQ(cv::countNonZero(changed & ~frame.mask), 0) << "frame " << k;
    EXPECT_GT(cv::countNonZero(changed & frame.mask), frame.rendered_area_px * 8 / 10);
  }
  EXPECT_LT(least_ideal_iou, 0.95);  // the distortion matters
}

TEST(SyntheticSequence, ThresholdMaskQualityHasTheDocumentedOverlapWithTheTrueMask) {
  // The bunny turned by hand at 4-10 radii in the default camera (silhouettes 70-100 px across).
  SequenceOptions options = Handheld(24, 6);
  options.degradation = WithMaskQuality(options.degradation, MaskQuality::kThreshold);
  options.degradation.seed = 6;
  const SyntheticSequence sequence({Bunny()}, options);
  double sum = 0.0;
  int frames = 0;
  for (int k = 0; k < sequence.num_frames(); k += 2) {
    const SyntheticFrame frame = sequence.Generate(k);
    cv::Mat truth;
    RenderSilhouette(Bunny(), sequence.camera(), frame.truth.camera_from_object, &truth);
    const double iou = IoU(truth, frame.mask);
    EXPECT_GT(iou, 0.78) << "frame " << k;
    EXPECT_LT(iou, 0.95) << "frame " << k;
    sum += iou;
    ++frames;
    EXPECT_EQ(frame.truth.mask_effects, AppliedMaskEffects(options.degradation, k));
  }
  EXPECT_GT(sum / frames, 0.85);
  EXPECT_LT(sum / frames, 0.9);
}

}  // namespace
}  // namespace silpose
