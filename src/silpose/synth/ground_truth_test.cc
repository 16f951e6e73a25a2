#include "silpose/synth/ground_truth.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/pose/pose_from_silhouette.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// A file in the temporary folder, unique to this process and test, removed afterwards.
class TempFile {
 public:
  explicit TempFile(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("silpose_gt_" + std::to_string(::getpid()) + "_" + name)) {}
  ~TempFile() {
    std::error_code error;
    std::filesystem::remove(path_, error);
  }
  const std::filesystem::path& path() const { return path_; }
  void Write(const std::string& text) const { std::ofstream(path_, std::ios::binary) << text; }

 private:
  std::filesystem::path path_;
};

std::vector<GroundTruthFrame> RandomFrames(int count) {
  std::mt19937_64 engine(5);
  std::normal_distribution<double> normal;
  std::vector<GroundTruthFrame> frames;
  for (int k = 0; k < count; ++k) {
    GroundTruthFrame frame;
    frame.frame = 3 * k;
    frame.object = k % 2 == 0 ? "bunny" : "cow";
    const Eigen::Vector3d view(normal(engine), normal(engine), normal(engine));
    frame.roll_deg = WrapDegrees(100.0 * normal(engine));
    frame.distance_in_radii = 3.0 + std::abs(normal(engine));
    frame.camera_from_object = CameraFromObjectAtView(
        view, frame.roll_deg, frame.distance_in_radii * 0.37, Eigen::Vector3d(0.1, -0.2, 0.3));
    frame.view_dir_in_object = view.normalized();
    if (k % 4 != 0) {  // off the optical axis: R = Q R_on
      frame.centre_ray_in_camera =
          Eigen::Vector3d(0.2 * normal(engine), 0.2 * normal(engine), 1.0).normalized();
      frame.camera_from_object.rotation =
          RotationFromOpticalAxisTo(frame.centre_ray_in_camera) * frame.camera_from_object.rotation;
    }
    frame.degradation = static_cast<FrameDegradation>(k % 3);
    if (frame.degradation != FrameDegradation::kMissed) {  // effects of a missed frame: none
      frame.mask_effects = static_cast<uint32_t>(k * 37) & ((1u << AllMaskEffects().size()) - 1);
    }
    frames.push_back(frame);
  }
  return frames;
}

void ExpectSame(const GroundTruthFrame& a, const GroundTruthFrame& b) {
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(a.object, b.object);
  EXPECT_EQ(a.view_dir_in_object, b.view_dir_in_object);
  EXPECT_EQ(a.roll_deg, b.roll_deg);
  EXPECT_EQ(a.camera_from_object.rotation, b.camera_from_object.rotation);
  EXPECT_EQ(a.camera_from_object.translation, b.camera_from_object.translation);
  EXPECT_EQ(a.distance_in_radii, b.distance_in_radii);
  EXPECT_EQ(a.degradation, b.degradation);
  EXPECT_EQ(a.centre_ray_in_camera, b.centre_ray_in_camera);
  EXPECT_EQ(a.mask_effects, b.mask_effects);
}

TEST(GroundTruth, WriteThenReadGivesExactlyTheSameFrames) {
  const TempFile file("roundtrip.csv");
  const std::vector<GroundTruthFrame> frames = RandomFrames(50);
  WriteGroundTruth(file.path(), frames);
  std::ifstream text(file.path());
  std::string header;
  std::getline(text, header);
  EXPECT_EQ(header,
            "frame,object,view_x,view_y,view_z,roll_deg,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,"
            "tz,distance,degradation,centre_ray_x,centre_ray_y,centre_ray_z,off_axis_deg");
  const std::vector<GroundTruthFrame> read = ReadGroundTruth(file.path());
  ASSERT_EQ(read.size(), frames.size());
  for (size_t k = 0; k < frames.size(); ++k) ExpectSame(read[k], frames[k]);
}

TEST(GroundTruth, ReadsTheDesignColumnsInAnyOrderWithExtras) {
  const TempFile file("design.csv");
  // The required columns only (docs/conventions.md), shuffled, with an extra one, CRLF line ends, 6
  // decimals.
  file.Write(
      "object,frame,note,roll_deg,view_x,view_y,view_z,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,"
      "tz\r\n"
      "cow,0,hello,10.5,1,0,0,0,1,0,0,0,-1,-1,0,0,0,0,3\r\n"
      "cow,4,,-90,0,0.707107,0.707107,1,0,0,0,-0.707107,0.707107,0,-0.707107,-0.707107,0,0,"
      "3\r\n\r\n");
  const std::vector<GroundTruthFrame> frames = ReadGroundTruth(file.path());
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].object, "cow");
  EXPECT_EQ(frames[1].frame, 4);
  EXPECT_EQ(frames[0].roll_deg, 10.5);
  EXPECT_EQ(frames[0].view_dir_in_object, Eigen::Vector3d::UnitX());
  EXPECT_EQ(frames[0].camera_from_object.translation, Eigen::Vector3d(0, 0, 3));
  EXPECT_TRUE(std::isnan(frames[0].distance_in_radii));
  EXPECT_EQ(frames[1].degradation, FrameDegradation::kNone);
  EXPECT_EQ(frames[1].centre_ray_in_camera, Eigen::Vector3d::UnitZ());  // on the axis
}

// The error message when reading `body` after a valid header.
std::string ReadError(const std::string& name, const std::string& text) {
  const TempFile file(name);
  file.Write(text);
  try {
    ReadGroundTruth(file.path());
  } catch (const Error& error) {
    std::string message = error.what();
    EXPECT_NE(message.find(file.path().string()), std::string::npos) << message;
    return message;
  }
  ADD_FAILURE() << name << ": no error";
  return "";
}

TEST(GroundTruth, CorruptFilesGiveAnErrorNamingFileAndLine) {
  // Files without the centre ray columns (written before they existed) are checked alike.
  const std::string header =
      "frame,object,view_x,view_y,view_z,roll_deg,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,"
      "distance,degradation\n";
  const std::string good = "0,bunny,1,0,0,0,0,1,0,0,0,-1,-1,0,0,0,0,3,3,none\n";
  const auto row_with = [](const std::string& view_x, const std::string& degradation) {
    return "1,bunny," + view_x + ",0,0,0,0,1,0,0,0,-1,-1,0,0,0,0,3,3," + degradation + "\n";
  };

  std::string message = ReadError("number.csv", header + good + row_with("abc", "none"));
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("view_x"), std::string::npos) << message;

  message = ReadError("fields.csv", header + good + "1,bunny,1,0\n");
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("fields"), std::string::npos) << message;

  message = ReadError("kind.csv", header + good + row_with("1", "blurred"));
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("blurred"), std::string::npos) << message;

  message = ReadError("order.csv", header + good + good);
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;
  EXPECT_NE(message.find("increase"), std::string::npos) << message;

  message = ReadError("unit.csv", header + row_with("2", "none"));
  EXPECT_NE(message.find(":2:"), std::string::npos) << message;
  EXPECT_NE(message.find("unit"), std::string::npos) << message;

  message =
      ReadError("rotation.csv", header + "0,bunny,1,0,0,0,0,2,0,0,0,-1,-1,0,0,0,0,3,3,none\n");
  EXPECT_NE(message.find("rotation"), std::string::npos) << message;

  message = ReadError("axis.csv", header + "0,bunny,0,1,0,0,0,1,0,0,0,-1,-1,0,0,0,0,3,3,none\n");
  EXPECT_NE(message.find("optical axis"), std::string::npos) << message;

  message = ReadError("infinite.csv", header + row_with("inf", "none"));
  EXPECT_NE(message.find("finite"), std::string::npos) << message;

  message = ReadError("blank.csv", header + good + "\n" + row_with("1", "none"));
  EXPECT_NE(message.find(":3:"), std::string::npos) << message;

  message = ReadError("header.csv", "frame,object,view_x\n0,bunny,1\n");
  EXPECT_NE(message.find(":1:"), std::string::npos) << message;
  EXPECT_NE(message.find("view_y"), std::string::npos) << message;

  message = ReadError("empty.csv", "");
  EXPECT_NE(message.find("empty"), std::string::npos) << message;

  const std::filesystem::path missing = std::filesystem::temp_directory_path() / "no_such_gt.csv";
  try {
    ReadGroundTruth(missing);
    ADD_FAILURE() << "no error for a missing file";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find(missing.string()), std::string::npos);
  }
}

TEST(GroundTruth, ObjectNamesThatCsvCannotHoldAreRefused) {
  const TempFile file("comma.csv");
  std::vector<GroundTruthFrame> frames = RandomFrames(1);
  frames[0].object = "a,b";
  EXPECT_THROW(WriteGroundTruth(file.path(), frames), Error);
}

TEST(GroundTruth, CentreRayColumnsAreCheckedAgainstThePose) {
  const std::string header = std::string(GroundTruthHeader()) + "\n";
  // Centre 0.6,0,0.8 (36.87 degrees to the right), virtual camera at view +X, roll 0:
  // R_on rows (0,1,0), (0,0,-1), (-1,0,0); Q turns about the y axis by 36.87 degrees.
  const double c = 0.8;
  const double s = 0.6;
  const Eigen::Matrix3d q = (Eigen::Matrix3d() << c, 0, s, 0, 1, 0, -s, 0, c).finished();
  const Eigen::Matrix3d r_on = CameraFromObjectRotation(Eigen::Vector3d::UnitX(), 0.0);
  const Eigen::Matrix3d r = q * r_on;
  const auto row = [&](const Eigen::Vector3d& view, const std::string& ray) {
    std::string text = "0,bunny," + std::to_string(view.x()) + "," + std::to_string(view.y()) +
                       "," + std::to_string(view.z()) + ",0";
    for (int i = 0; i < 9; ++i) text += "," + std::to_string(r(i / 3, i % 3));
    return text + ",1.8,0,2.4,3,none," + ray + "\n";
  };
  const std::string off_axis = std::to_string(std::atan2(0.6, 0.8) * 180.0 / std::numbers::pi);
  const TempFile file("ray.csv");
  file.Write(header + row(Eigen::Vector3d::UnitX(), "0.6,0,0.8," + off_axis));
  const std::vector<GroundTruthFrame> frames = ReadGroundTruth(file.path());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_LT((frames[0].centre_ray_in_camera - Eigen::Vector3d(0.6, 0, 0.8)).norm(), 1e-12);

  // R's own optical axis is not the view: only with the ray does the row make sense.
  std::string message = ReadError("no_ray.csv", header + row(Eigen::Vector3d::UnitX(), "0,0,1,0"));
  EXPECT_NE(message.find("optical axis"), std::string::npos) << message;
  message = ReadError("angle.csv", header + row(Eigen::Vector3d::UnitX(), "0.6,0,0.8,10"));
  EXPECT_NE(message.find("off_axis_deg"), std::string::npos) << message;
  message = ReadError("long.csv", header + row(Eigen::Vector3d::UnitX(), "0.6,0,0.9," + off_axis));
  EXPECT_NE(message.find("centre ray"), std::string::npos) << message;
}

}  // namespace
}  // namespace silpose
