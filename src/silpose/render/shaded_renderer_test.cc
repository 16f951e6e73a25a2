#include "silpose/render/shaded_renderer.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;

// Square plate of half-size `half` in the object's XY plane, centred at the origin (2 triangles).
TriangleMesh Plate(double half) {
  TriangleMesh mesh;
  mesh.name = "plate";
  const auto h = static_cast<float>(half);
  mesh.vertices = {{-h, -h, 0}, {h, -h, 0}, {h, h, 0}, {-h, h, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

// Pose that puts the object's origin at `translation`, turned by `angle_rad` about camera axis
// `axis`.
Rigid3 Pose(const Eigen::Vector3d& axis, double angle_rad, const Eigen::Vector3d& translation) {
  Rigid3 pose;
  pose.rotation = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  pose.translation = translation;
  return pose;
}

int CountDifferences(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::compare(a, b, difference, cv::CMP_NE);
  if (difference.channels() > 1) difference = difference.reshape(1);
  return cv::countNonZero(difference);
}

std::vector<TriangleMesh> SampleModels() {
  std::vector<TriangleMesh> meshes;
  for (const char* name : {"bunny", "hand", "anchor"}) {
    meshes.push_back(
        LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / (std::string(name) + ".obj")));
  }
  return meshes;
}

TEST(RenderShaded, MaskEqualsTheSilhouetteRenderersMask) {
  const PinholeCamera camera = PinholeCamera::Centered(320, 240, 300.0);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> roll(-180.0, 180.0);
  // Far, framed and very close distances: the last put the camera inside the object, where
  // triangles are clipped by the near plane.
  const double distances_in_radii[] = {8.0, 3.0, 1.2, 0.3};
  int compared = 0;
  for (const TriangleMesh& mesh : SampleModels()) {
    const double radius = mesh.Radius();
    for (int trial = 0; trial < 12; ++trial) {
      Eigen::Vector3d view(unit(random), unit(random), unit(random));
      if (view.norm() < 1e-3) view = Eigen::Vector3d::UnitX();
      const double distance = distances_in_radii[trial % 4] * radius;
      const Rigid3 pose = CameraFromObjectAtView(view, roll(random), distance, mesh.Centre());
      cv::Mat silhouette;
      RenderSilhouette(mesh, camera, pose, &silhouette);
      cv::Mat colour;
      cv::Mat mask;
      RenderShaded(mesh, camera, pose, {}, &colour, &mask);
      ASSERT_EQ(mask.type(), CV_8UC1);
      ASSERT_EQ(colour.type(), CV_8UC3);
      EXPECT_EQ(CountDifferences(mask, silhouette), 0) << mesh.name << " trial " << trial;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 36);
}

TEST(RenderShaded, MaskEqualsTheSilhouetteRenderersMaskForARandomTriangleSoup) {
  // Many small triangles with shared edges and vertices near pixel centres: the span rule must
  // agree pixel for pixel, including on the rows and columns where edges meet pixel centres.
  const PinholeCamera camera = PinholeCamera::Centered(97, 61, 80.0);
  std::mt19937 random(3);
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  TriangleMesh mesh;
  mesh.name = "soup";
  for (int i = 0; i < 300; ++i) {
    mesh.vertices.emplace_back(static_cast<float>(coordinate(random)),
                               static_cast<float>(coordinate(random)),
                               static_cast<float>(0.5 * coordinate(random)));
  }
  std::uniform_int_distribution<uint32_t> vertex(0, 299);
  for (int t = 0; t < 400; ++t)
    mesh.triangles.push_back({vertex(random), vertex(random), vertex(random)});
  for (const double z : {2.5, 1.0, 0.2}) {
    const Rigid3 pose = Pose(Eigen::Vector3d(1, 2, 0), 0.3, Eigen::Vector3d(0.05, -0.02, z));
    cv::Mat silhouette;
    RenderSilhouette(mesh, camera, pose, &silhouette);
    cv::Mat colour;
    cv::Mat mask;
    RenderShaded(mesh, camera, pose, {}, &colour, &mask);
    EXPECT_EQ(CountDifferences(mask, silhouette), 0) << "z " << z;
    EXPECT_GT(cv::countNonZero(mask), 0);
  }
}

TEST(RenderShaded, GroundPlaneUnderTheCameraIsClippedLikeTheSilhouette) {
  // A large floor below the camera, reaching behind it.
  TriangleMesh floor;
  floor.name = "floor";
  floor.vertices = {{-50, 1, -10}, {50, 1, -10}, {50, 1, 60}, {-50, 1, 60}};
  floor.triangles = {{0, 1, 2}, {0, 2, 3}};
  const PinholeCamera camera = PinholeCamera::Centered(160, 120, 100.0);
  cv::Mat silhouette;
  RenderSilhouette(floor, camera, Rigid3{}, &silhouette);
  cv::Mat colour;
  cv::Mat mask;
  cv::Mat depth;
  RenderShaded(floor, camera, Rigid3{}, {}, &colour, &mask, &depth);
  EXPECT_EQ(CountDifferences(mask, silhouette), 0);
  EXPECT_GT(cv::countNonZero(mask), 160 * 50);
  // The floor y = 1 seen at row v lies at depth z = fy / (v - cy).
  for (const int row : {70, 90, 119}) {
    const double expected = 100.0 / (row - camera.principal_y_px);
    EXPECT_NEAR(depth.at<float>(row, 80), expected, 1e-4 * expected) << "row " << row;
  }
  EXPECT_EQ(depth.at<float>(10, 80), 0.0f);  // above the horizon: nothing
}

TEST(RenderShaded, FacesTurnedAwayFromTheLightAreDarker) {
  const PinholeCamera camera = PinholeCamera::Centered(101, 101, 100.0);
  const TriangleMesh plate = Plate(0.5);
  ShadedRenderOptions options;
  options.base_colour_bgr = {200.0, 200.0, 200.0};
  options.light_dir_in_camera = {0.0, 0.0, -1.0};  // a headlight
  options.ambient = 0.2;
  options.diffuse = 0.8;
  double previous = 256.0;
  for (const double angle_deg : {0.0, 20.0, 40.0, 60.0, 80.0}) {
    cv::Mat colour;
    cv::Mat mask;
    RenderShaded(plate, camera, Pose(Eigen::Vector3d::UnitY(), angle_deg * kPi / 180.0, {0, 0, 3}),
                 options, &colour, &mask);
    ASSERT_EQ(mask.at<uint8_t>(50, 50), 255);
    const cv::Vec3b pixel = colour.at<cv::Vec3b>(50, 50);
    // Lambert: 200 * (0.2 + 0.8 cos(angle)); the light is along the optical axis and the face
    // centre is on it, so the angle to the light is the plate's tilt.
    const double expected = 200.0 * (0.2 + 0.8 * std::cos(angle_deg * kPi / 180.0));
    EXPECT_NEAR(pixel[0], expected, 1.0) << angle_deg;
    EXPECT_EQ(pixel[0], pixel[1]);
    EXPECT_EQ(pixel[1], pixel[2]);
    EXPECT_LT(pixel[0], previous) << angle_deg;
    previous = pixel[0];
  }
  // With the default light (above-left of the camera), a plate tilted towards the upper left is
  // brighter than one tilted towards the lower right, whichever side of it the camera sees.
  ShadedRenderOptions default_light;
  const double tilt = 35.0 * kPi / 180.0;
  const Eigen::Vector3d diagonal(1.0, -1.0, 0.0);
  for (const double flip : {0.0, kPi}) {
    cv::Mat towards;
    cv::Mat away;
    cv::Mat mask;
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(flip, Eigen::Vector3d::UnitX()).toRotationMatrix();
    // Turning about (1, -1, 0) by +tilt tips the face normal towards +x, +y (lower right).
    Rigid3 pose_towards = Pose(diagonal, -tilt, {0, 0, 3});
    Rigid3 pose_away = Pose(diagonal, tilt, {0, 0, 3});
    pose_towards.rotation = pose_towards.rotation * turn;
    pose_away.rotation = pose_away.rotation * turn;
    RenderShaded(plate, camera, pose_towards, default_light, &towards, &mask);
    RenderShaded(plate, camera, pose_away, default_light, &away, &mask);
    EXPECT_GT(towards.at<cv::Vec3b>(50, 50)[2], away.at<cv::Vec3b>(50, 50)[2] + 20) << flip;
  }
}

TEST(RenderShaded, SpecularHighlightBrightensFacesMirroringTheLight) {
  const PinholeCamera camera = PinholeCamera::Centered(101, 101, 100.0);
  ShadedRenderOptions options;
  options.base_colour_bgr = {0.0, 0.0, 100.0};
  options.light_dir_in_camera = {0.0, 0.0, -1.0};
  cv::Mat matte;
  cv::Mat shiny;
  cv::Mat mask;
  const Rigid3 facing = Pose(Eigen::Vector3d::UnitY(), 0.0, {0, 0, 3});
  RenderShaded(Plate(0.5), camera, facing, options, &matte, &mask);
  options.specular = 0.5;
  RenderShaded(Plate(0.5), camera, facing, options, &shiny, &mask);
  // Facing the light and (nearly: the face centroid is 4.5 degrees off the optical axis) the
  // camera: almost the full highlight, 0.5 * 255 added to every channel.
  EXPECT_EQ(matte.at<cv::Vec3b>(50, 50), cv::Vec3b(0, 0, 100));
  EXPECT_NEAR(shiny.at<cv::Vec3b>(50, 50)[0], 122.0, 6.0);
  EXPECT_NEAR(shiny.at<cv::Vec3b>(50, 50)[2], 222.0, 6.0);
  // Tilted by 40 degrees, the normal is 40 degrees off the half vector: cos^32 < 0.001.
  RenderShaded(Plate(0.5), camera, Pose(Eigen::Vector3d::UnitY(), 40.0 * kPi / 180.0, {0, 0, 3}),
               options, &shiny, &mask);
  EXPECT_LT(shiny.at<cv::Vec3b>(50, 50)[0], 25);
}

TEST(RenderShaded, BackgroundIsKeptOutsideTheObject) {
  const PinholeCamera camera = PinholeCamera::Centered(120, 90, 100.0);
  cv::Mat background(90, 120, CV_8UC3);
  cv::randu(background, cv::Scalar::all(0), cv::Scalar::all(256));
  ShadedRenderOptions options;
  options.background = background;
  const TriangleMesh mesh = SampleModels().front();
  const Rigid3 pose =
      CameraFromObjectAtView({1, 0.5, 0.2}, 10.0, 3.0 * mesh.Radius(), mesh.Centre());
  cv::Mat colour;
  cv::Mat mask;
  RenderShaded(mesh, camera, pose, options, &colour, &mask);
  const int covered = cv::countNonZero(mask);
  ASSERT_GT(covered, 500);
  int kept = 0;
  int changed_inside = 0;
  for (int v = 0; v < 90; ++v) {
    for (int u = 0; u < 120; ++u) {
      const bool same = colour.at<cv::Vec3b>(v, u) == background.at<cv::Vec3b>(v, u);
      if (mask.at<uint8_t>(v, u) == 0) {
        kept += same;
      } else {
        changed_inside += !same;
      }
    }
  }
  EXPECT_EQ(kept, 120 * 90 - covered);
  EXPECT_GT(changed_inside, covered * 9 / 10);

  // Drawing in place over the background gives the same picture.
  cv::Mat in_place = background.clone();
  options.background = in_place;
  RenderShaded(mesh, camera, pose, options, &in_place, &mask);
  EXPECT_EQ(CountDifferences(in_place, colour), 0);

  // Without a background image: the uniform background colour.
  ShadedRenderOptions plain;
  plain.background_bgr = {10.0, 20.0, 30.0};
  RenderShaded(mesh, camera, pose, plain, &colour, &mask);
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
}

TEST(RenderShaded, NearestSurfaceWinsWhateverTheTriangleOrder) {
  const PinholeCamera camera = PinholeCamera::Centered(64, 64, 64.0);
  // Two overlapping plates facing the camera, at depths 2 and 3, listed in both orders.
  for (const bool near_first : {true, false}) {
    TriangleMesh mesh;
    mesh.name = "plates";
    for (const float z : {near_first ? 2.0f : 3.0f, near_first ? 3.0f : 2.0f}) {
      const auto first = static_cast<uint32_t>(mesh.vertices.size());
      const float h = z == 2.0f ? 0.5f : 1.0f;
      const float shift = z == 2.0f ? 0.3f : 0.0f;
      mesh.vertices.insert(
          mesh.vertices.end(),
          {{-h + shift, -h, z}, {h + shift, -h, z}, {h + shift, h, z}, {-h + shift, h, z}});
      mesh.triangles.push_back({first, first + 1, first + 2});
      mesh.triangles.push_back({first, first + 2, first + 3});
    }
    cv::Mat colour;
    cv::Mat mask;
    cv::Mat depth;
    RenderShaded(mesh, camera, Rigid3{}, {}, &colour, &mask, &depth);
    // Centre pixel: both plates cover it, the near one (z = 2) is seen.
    EXPECT_NEAR(depth.at<float>(32, 32), 2.0f, 1e-5f) << near_first;
    // Left of the near plate (x = -0.35 at z = 3: u = 64 * -0.35 / 3 + 31.5 = 24): the far one.
    EXPECT_NEAR(depth.at<float>(32, 24), 3.0f, 1e-5f) << near_first;
    EXPECT_EQ(depth.at<float>(0, 0), 0.0f);
    EXPECT_EQ(mask.at<uint8_t>(0, 0), 0);
  }
}

TEST(RenderShaded, DepthOfATiltedPlateIsExact) {
  // Perspective-correct depth: the plate z = 3 + 0.5 x is seen at pixel u with
  // z = 3 / (1 - 0.5 (u - cx) / fx).
  const PinholeCamera camera = PinholeCamera::Centered(101, 101, 100.0);
  const Rigid3 pose = Pose(Eigen::Vector3d::UnitY(), -std::atan(0.5), {0, 0, 3});
  cv::Mat colour;
  cv::Mat mask;
  cv::Mat depth;
  RenderShaded(Plate(0.5), camera, pose, {}, &colour, &mask, &depth);
  for (const int u : {38, 50, 60}) {
    const double expected = 3.0 / (1.0 - 0.5 * (u - 50.0) / 100.0);
    EXPECT_NEAR(depth.at<float>(50, u), expected, 1e-5 * expected) << u;
  }
}

TEST(ShadedRenderOptions, CheckNamesTheInvalidField) {
  std::string error;
  EXPECT_TRUE(ShadedRenderOptions{}.Check(&error)) << error;
  ShadedRenderOptions options;
  options.base_colour_bgr = {0, 300, 0};
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("base colour"), std::string::npos) << error;
  options = {};
  options.light_dir_in_camera = Eigen::Vector3d::Zero();
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("light"), std::string::npos) << error;
  options = {};
  options.ambient = 1.5;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("ambient"), std::string::npos) << error;
  options = {};
  options.background = cv::Mat(10, 10, CV_8UC1);
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("background"), std::string::npos) << error;
}

TEST(RenderShaded, WrongBackgroundSizeThrows) {
  const PinholeCamera camera = PinholeCamera::Centered(64, 48, 64.0);
  ShadedRenderOptions options;
  options.background = cv::Mat(48, 63, CV_8UC3, cv::Scalar::all(0));
  cv::Mat colour;
  cv::Mat mask;
  EXPECT_THROW(RenderShaded(Plate(1.0), camera, Rigid3{}, options, &colour, &mask), Error);
}

}  // namespace
}  // namespace silpose
