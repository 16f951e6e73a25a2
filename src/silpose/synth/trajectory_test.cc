#include "silpose/synth/trajectory.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

TrajectoryOptions Orbit(int frames, double step_deg) {
  TrajectoryOptions options;
  options.kind = TrajectoryKind::kOrbit;
  options.num_frames = frames;
  options.orbit.step_deg = step_deg;
  return options;
}

TrajectoryOptions Walk(int frames, uint64_t seed) {
  TrajectoryOptions options;
  options.kind = TrajectoryKind::kWalk;
  options.num_frames = frames;
  options.walk.seed = seed;
  return options;
}

// ----- orbit ------------------------------------------------------------------------------------

void ExpectOrbitProperties(const TrajectoryOptions& options) {
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  ASSERT_EQ(static_cast<int>(frames.size()), options.num_frames);
  const Eigen::Vector3d normal =
      frames[0].view_dir_in_object.cross(frames[1].view_dir_in_object).normalized();
  for (size_t k = 0; k < frames.size(); ++k) {
    const TrajectoryFrame& frame = frames[k];
    EXPECT_NEAR(frame.view_dir_in_object.norm(), 1.0, 1e-12);
    // One great circle: every view is perpendicular to the plane's normal.
    EXPECT_NEAR(frame.view_dir_in_object.dot(normal), 0.0, 1e-12) << "frame " << k;
    EXPECT_EQ(frame.roll_deg, WrapDegrees(options.orbit.roll_deg));
    EXPECT_EQ(frame.distance_in_radii, options.orbit.distance_in_radii);
    EXPECT_EQ(frame.object, 0);
    if (k > 0) {
      EXPECT_NEAR(AngleDeg(frames[k - 1].view_dir_in_object, frame.view_dir_in_object),
                  std::abs(options.orbit.step_deg), 1e-9)
          << "frame " << k;
    }
  }
  // The plane is tilted by tilt_deg against the equator.
  EXPECT_NEAR(std::acos(std::abs(normal.z())) * 180.0 / std::numbers::pi, options.orbit.tilt_deg,
              1e-9);
}

TEST(Orbit, ConsecutiveViewsAreOneStepApartOnOneGreatCircle) {
  ExpectOrbitProperties(Orbit(360, 1.0));
  TrajectoryOptions other = Orbit(144, 2.5);
  other.orbit.tilt_deg = 60.0;
  other.orbit.node_azimuth_deg = 40.0;
  other.orbit.start_deg = 17.0;
  other.orbit.roll_deg = 200.0;  // reported wrapped: -160
  other.orbit.distance_in_radii = 4.5;
  ExpectOrbitProperties(other);
  ExpectOrbitProperties(Orbit(90, -4.0));
}

TEST(Orbit, ClosesTheLoopAfter360OverStepFrames) {
  for (double step : {1.0, 2.0, 7.5}) {
    TrajectoryOptions options = Orbit(1, step);
    options.num_frames = options.orbit.FramesPerLoop();
    EXPECT_EQ(options.num_frames, static_cast<int>(std::lround(360.0 / step)));
    const std::vector<TrajectoryFrame> loop = GenerateTrajectory(options);
    // The last frame is one step before the first; one more frame would be the first again.
    EXPECT_NEAR(AngleDeg(loop.back().view_dir_in_object, loop.front().view_dir_in_object), step,
                1e-9);
    ++options.num_frames;
    const std::vector<TrajectoryFrame> longer = GenerateTrajectory(options);
    EXPECT_LT((longer.back().view_dir_in_object - loop.front().view_dir_in_object).norm(), 1e-12);
  }
}

TEST(Orbit, DefaultCircleIsTiltedThirtyDegreesAndStaysAwayFromThePoles) {
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(Orbit(360, 1.0));
  double max_z = -1.0;
  double min_z = 1.0;
  for (const TrajectoryFrame& frame : frames) {
    max_z = std::max(max_z, frame.view_dir_in_object.z());
    min_z = std::min(min_z, frame.view_dir_in_object.z());
  }
  EXPECT_NEAR(max_z, 0.5, 1e-9);  // sin 30 deg, reached at frame 90
  EXPECT_NEAR(min_z, -0.5, 1e-9);
  EXPECT_LT((frames[0].view_dir_in_object - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_GT(frames[90].view_dir_in_object.z(), 0.0);  // going up after the node
}

TEST(Orbit, InvalidOptionsAreRefusedWithTheirName) {
  std::string error;
  OrbitOptions orbit;
  orbit.step_deg = 0.0;
  EXPECT_FALSE(orbit.Check(&error));
  EXPECT_NE(error.find("step"), std::string::npos);
  orbit = OrbitOptions();
  orbit.tilt_deg = 95.0;
  EXPECT_FALSE(orbit.Check(&error));
  EXPECT_NE(error.find("tilt"), std::string::npos);
  orbit = OrbitOptions();
  orbit.distance_in_radii = 1.0;
  EXPECT_FALSE(orbit.Check(&error));
  EXPECT_NE(error.find("distance"), std::string::npos);
  TrajectoryOptions options = Orbit(0, 1.0);
  EXPECT_THROW(GenerateTrajectory(options), Error);
}

// ----- walk -------------------------------------------------------------------------------------

TEST(Walk, IsDeterministicForASeedAndDiffersForAnother) {
  const std::vector<TrajectoryFrame> a = GenerateTrajectory(Walk(200, 7));
  const std::vector<TrajectoryFrame> b = GenerateTrajectory(Walk(200, 7));
  const std::vector<TrajectoryFrame> c = GenerateTrajectory(Walk(200, 8));
  ASSERT_EQ(a.size(), 200u);
  double difference = 0.0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].view_dir_in_object, b[k].view_dir_in_object);
    EXPECT_EQ(a[k].roll_deg, b[k].roll_deg);
    EXPECT_EQ(a[k].distance_in_radii, b[k].distance_in_radii);
    difference += (a[k].view_dir_in_object - c[k].view_dir_in_object).norm();
  }
  EXPECT_GT(difference / static_cast<double>(a.size()), 0.1);
}

// Mean frame-to-frame change of the angular velocity over mean speed: small for a smooth path.
double Jerkiness(const std::vector<TrajectoryFrame>& frames) {
  double speed_sum = 0.0;
  double change_sum = 0.0;
  for (size_t k = 2; k < frames.size(); ++k) {
    const Eigen::Vector3d v1 = frames[k - 1].view_dir_in_object - frames[k - 2].view_dir_in_object;
    const Eigen::Vector3d v2 = frames[k].view_dir_in_object - frames[k - 1].view_dir_in_object;
    speed_sum += v2.norm();
    change_sum += (v2 - v1).norm();
  }
  return change_sum / speed_sum;
}

TEST(Walk, StepsAreBoundedAndThePathIsSmooth) {
  TrajectoryOptions options = Walk(2000, 3);
  const WalkOptions& walk = options.walk;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  double step_sum = 0.0;
  double max_roll_change = 0.0;
  for (size_t k = 1; k < frames.size(); ++k) {
    EXPECT_NEAR(frames[k].view_dir_in_object.norm(), 1.0, 1e-12);
    const double step = AngleDeg(frames[k - 1].view_dir_in_object, frames[k].view_dir_in_object);
    EXPECT_LE(step, walk.max_speed_factor * walk.speed_sigma_deg + 1e-9) << "frame " << k;
    step_sum += step;
    // Roll change beyond carrying the camera along with the view.
    const double carried = TransportRoll(frames[k - 1].view_dir_in_object, frames[k - 1].roll_deg,
                                         frames[k].view_dir_in_object);
    max_roll_change =
        std::max(max_roll_change, std::abs(WrapDegrees(frames[k].roll_deg - carried)));
  }
  // The 2-D velocity has spread sigma per axis: mean speed sigma * sqrt(pi / 2).
  const double mean_step = step_sum / static_cast<double>(frames.size() - 1);
  EXPECT_GT(mean_step, 0.8 * walk.speed_sigma_deg);
  EXPECT_LT(mean_step, 1.6 * walk.speed_sigma_deg);
  // The roll turns, smoothly: stationary spread 0.5 deg per frame.
  EXPECT_GT(max_roll_change, 0.3);
  EXPECT_LT(max_roll_change, 6.0 * walk.roll_speed_sigma_deg);

  // Momentum makes it smooth: without it every step is independent.
  EXPECT_LT(Jerkiness(frames), 0.5);
  options.walk.momentum = 0.0;
  EXPECT_GT(Jerkiness(GenerateTrajectory(options)), 1.0);
}

TEST(Walk, DistanceStaysWithinItsRangeAndMoves) {
  TrajectoryOptions options = Walk(3000, 11);
  options.walk.distance_min_radii = 2.5;
  options.walk.distance_max_radii = 4.0;
  options.walk.distance_sigma = 0.02;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  EXPECT_NEAR(frames[0].distance_in_radii, std::sqrt(2.5 * 4.0), 1e-12);  // geometric mean
  double low = 1e9;
  double high = 0.0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const double d = frames[k].distance_in_radii;
    EXPECT_GE(d, 2.5 * (1 - 1e-12));
    EXPECT_LE(d, 4.0 * (1 + 1e-12));
    if (k > 0) {  // smooth: a few percent per frame at most
      EXPECT_LT(std::abs(std::log(d / frames[k - 1].distance_in_radii)), 0.1);
    }
    low = std::min(low, d);
    high = std::max(high, d);
  }
  EXPECT_LT(low, 2.7);  // explores the range
  EXPECT_GT(high, 3.8);
}

TEST(Walk, StartsWhereAsked) {
  TrajectoryOptions options = Walk(5, 1);
  options.walk.start_view_dir = Eigen::Vector3d(0.0, 2.0, 0.0);
  options.walk.start_roll_deg = 30.0;
  options.walk.start_distance_radii = 5.0;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  EXPECT_EQ(frames[0].view_dir_in_object, Eigen::Vector3d::UnitY());
  EXPECT_EQ(frames[0].roll_deg, 30.0);
  EXPECT_EQ(frames[0].distance_in_radii, 5.0);
  options.walk.start_distance_radii = 7.0;  // outside [3, 6]
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("start distance"), std::string::npos);
}

TEST(Walk, RandomStartsCoverTheSphere) {
  // Uniform start: the mean of many start directions is near the centre.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (uint64_t seed = 0; seed < 400; ++seed) {
    sum += GenerateTrajectory(Walk(1, seed))[0].view_dir_in_object;
  }
  EXPECT_LT(sum.norm() / 400.0, 0.15);
}

// ----- handheld ---------------------------------------------------------------------------------

TrajectoryOptions Handheld(int frames, uint64_t seed) {
  TrajectoryOptions options;
  options.kind = TrajectoryKind::kHandheld;
  options.num_frames = frames;
  options.handheld.seed = seed;
  return options;
}

Eigen::Matrix3d VirtualCamera(const TrajectoryFrame& frame) {
  return CameraFromObjectRotation(frame.view_dir_in_object, frame.roll_deg);
}

// Rotation vector (camera frame, degrees) turning frame a's virtual camera into frame b's.
Eigen::Vector3d TurnDeg(const TrajectoryFrame& a, const TrajectoryFrame& b) {
  const Eigen::AngleAxisd turn(VirtualCamera(b) * VirtualCamera(a).transpose());
  return turn.axis() * turn.angle() * 180.0 / std::numbers::pi;
}

double OffAxisDeg(const Eigen::Vector3d& ray) { return AngleDeg(ray, Eigen::Vector3d::UnitZ()); }

TEST(Handheld, SpeedsStayInTheRangeWithPausesReversalsAndSmoothChanges) {
  TrajectoryOptions options = Handheld(3000, 5);
  options.handheld.cut_probability = 0.0;
  const HandheldOptions& hand = options.handheld;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  ASSERT_EQ(frames.size(), 3000u);
  int paused = 0;
  int in_range = 0;
  int reversals = 0;
  double previous_speed = 0.0;
  Eigen::Vector3d last_motion = Eigen::Vector3d::Zero();  // last step that moved
  for (size_t k = 1; k < frames.size(); ++k) {
    EXPECT_FALSE(frames[k].cut);
    const Eigen::Vector3d turn = TurnDeg(frames[k - 1], frames[k]);
    const double speed = turn.norm();
    EXPECT_LE(speed, hand.speed_max_deg + 1e-6) << "frame " << k;
    // Smooth: the speed changes by at most the acceleration (the axis turns a little too).
    EXPECT_LE(std::abs(speed - previous_speed), hand.acceleration_deg + 0.5) << "frame " << k;
    previous_speed = speed;
    paused += speed < 0.05;
    in_range += speed >= hand.speed_min_deg - 1e-6;
    if (speed > 0.5) {
      // Turning back: the rotation vector points against the last movement's.
      if (last_motion.norm() > 0.0 && turn.dot(last_motion) < 0.0) ++reversals;
      last_motion = turn;
    }
  }
  const double n = static_cast<double>(frames.size() - 1);
  EXPECT_GT(paused / n, 0.03);   // pauses: about 15 % of the segments
  EXPECT_GT(in_range / n, 0.6);  // mostly moving at a speed of the range
  EXPECT_GE(reversals, 10);      // about a quarter of the moving segments turn back
  EXPECT_LT(reversals / n, 0.05);
}

TEST(Handheld, TheSpeedRangeCanReachThirtyDegreesPerFrame) {
  TrajectoryOptions options = Handheld(1500, 2);
  options.handheld.speed_min_deg = 20.0;
  options.handheld.speed_max_deg = 30.0;
  options.handheld.pause_probability = 0.0;
  options.handheld.reverse_probability = 0.0;
  options.handheld.cut_probability = 0.0;
  ASSERT_TRUE(options.Check());
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  double fastest = 0.0;
  int in_range = 0;
  for (size_t k = 1; k < frames.size(); ++k) {
    const double speed = TurnDeg(frames[k - 1], frames[k]).norm();
    EXPECT_LE(speed, 30.0 + 1e-6);
    fastest = std::max(fastest, speed);
    in_range += speed >= 20.0 - 1e-6;
  }
  EXPECT_GT(fastest, 28.0);
  EXPECT_GT(in_range, 1400);  // only the first few frames accelerate
}

TEST(Handheld, ViewAndRollTurnTogetherAndAreCarriedOverThePoles) {
  // Slow rotations that pass over the poles now and then: the virtual camera read back from
  // (view, roll) must turn by the speed, with no jump where the roll reference flips.
  TrajectoryOptions options = Handheld(4000, 9);
  options.handheld.cut_probability = 0.0;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  double closest_to_pole = 1.0;
  double roll_change = 0.0;
  double view_change = 0.0;
  for (size_t k = 1; k < frames.size(); ++k) {
    EXPECT_NEAR(frames[k].view_dir_in_object.norm(), 1.0, 1e-12);
    EXPECT_GT(frames[k].roll_deg, -180.0);
    EXPECT_LE(frames[k].roll_deg, 180.0);
    EXPECT_LE(TurnDeg(frames[k - 1], frames[k]).norm(), 15.0 + 1e-6) << "frame " << k;
    closest_to_pole = std::min(closest_to_pole, 1.0 - std::abs(frames[k].view_dir_in_object.z()));
    view_change += AngleDeg(frames[k - 1].view_dir_in_object, frames[k].view_dir_in_object);
    const double carried = TransportRoll(frames[k - 1].view_dir_in_object, frames[k - 1].roll_deg,
                                         frames[k].view_dir_in_object);
    roll_change += std::abs(WrapDegrees(frames[k].roll_deg - carried));
  }
  EXPECT_LT(closest_to_pole, 1e-3);  // came within 2.6 degrees of a pole
  // A full 3-D rotation: both the view and the roll (beyond transport) change substantially.
  EXPECT_GT(view_change, 1000.0);
  EXPECT_GT(roll_change, 1000.0);
}

TEST(Handheld, CutsHappenAtTheConfiguredRate) {
  for (const double rate : {0.0, 0.01, 0.05}) {
    TrajectoryOptions options = Handheld(5000, 13);
    options.handheld.cut_probability = rate;
    const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
    int cuts = 0;
    EXPECT_FALSE(frames[0].cut);
    for (size_t k = 1; k < frames.size(); ++k) {
      if (frames[k].cut) {
        ++cuts;
      } else {
        EXPECT_LE(TurnDeg(frames[k - 1], frames[k]).norm(), 15.0 + 1e-6) << "frame " << k;
      }
    }
    const double expected = rate * 4999.0;
    // Binomial: within 5 standard deviations (and none at all for rate 0).
    EXPECT_NEAR(cuts, expected, 5.0 * std::sqrt(expected * (1.0 - rate)) + 1e-9) << rate;
  }
  // A cut jumps to an unrelated view: on average 90+ degrees away.
  TrajectoryOptions options = Handheld(5000, 13);
  options.handheld.cut_probability = 0.05;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  double jump_sum = 0.0;
  int jumps = 0;
  for (size_t k = 1; k < frames.size(); ++k) {
    if (!frames[k].cut) continue;
    jump_sum += TurnDeg(frames[k - 1], frames[k]).norm();
    ++jumps;
  }
  ASSERT_GT(jumps, 0);
  EXPECT_GT(jump_sum / jumps, 90.0);
}

TEST(Handheld, DistanceAndOffAxisAngleStayInRangeAndWander) {
  TrajectoryOptions options = Handheld(4000, 21);
  options.handheld.distance_min_radii = 4.0;
  options.handheld.distance_max_radii = 10.0;
  options.handheld.max_off_axis_deg = 25.0;
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);  // no camera
  double low = 1e9;
  double high = 0.0;
  double widest = 0.0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const TrajectoryFrame& frame = frames[k];
    EXPECT_GE(frame.distance_in_radii, 4.0);
    EXPECT_LE(frame.distance_in_radii, 10.0);
    EXPECT_NEAR(frame.centre_ray_in_camera.norm(), 1.0, 1e-12);
    const double off_axis = OffAxisDeg(frame.centre_ray_in_camera);
    EXPECT_LE(off_axis, 25.0 + 1e-9) << "frame " << k;
    if (k > 0) {  // smooth
      EXPECT_LT(std::abs(std::log(frame.distance_in_radii / frames[k - 1].distance_in_radii)), 0.1);
      EXPECT_LT(AngleDeg(frame.centre_ray_in_camera, frames[k - 1].centre_ray_in_camera), 2.0);
    }
    low = std::min(low, frame.distance_in_radii);
    high = std::max(high, frame.distance_in_radii);
    widest = std::max(widest, off_axis);
  }
  EXPECT_LT(low, 5.0);
  EXPECT_GT(high, 8.0);
  EXPECT_GT(widest, 20.0);
}

TEST(Handheld, KeepsTheBoundingSphereInsideTheCameraImage) {
  const PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.0);
  TrajectoryOptions options = Handheld(3000, 4);
  options.handheld.camera = camera;
  options.handheld.off_axis_speed_deg = 1.0;  // reach the image border often
  const std::vector<TrajectoryFrame> frames = GenerateTrajectory(options);
  double widest = 0.0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const TrajectoryFrame& frame = frames[k];
    ASSERT_TRUE(BoundingSphereInImage(camera, frame.distance_in_radii, frame.centre_ray_in_camera))
        << "frame " << k;
    // Check the sphere's outline directly: points on its rim project inside the image.
    const Eigen::Vector3d centre = frame.distance_in_radii * frame.centre_ray_in_camera;
    for (int i = 0; i < 16; ++i) {
      const double a = 2.0 * std::numbers::pi * i / 16.0;
      for (const Eigen::Vector3d& rim : {Eigen::Vector3d(std::cos(a), std::sin(a), 0.0),
                                         Eigen::Vector3d(std::cos(a), 0.0, std::sin(a)),
                                         Eigen::Vector3d(0.0, std::cos(a), std::sin(a))}) {
        const Eigen::Vector2d pixel = camera.Project(centre + rim);
        EXPECT_GT(pixel.x(), -0.5);
        EXPECT_LT(pixel.x(), 639.5);
        EXPECT_GT(pixel.y(), -0.5);
        EXPECT_LT(pixel.y(), 479.5);
      }
    }
    widest = std::max(widest, OffAxisDeg(frame.centre_ray_in_camera));
  }
  EXPECT_GT(widest, 15.0);  // still moves off the axis
  // Too close for the image: centred.
  options.handheld.distance_min_radii = 1.2;
  options.handheld.distance_max_radii = 1.3;
  for (const TrajectoryFrame& frame : GenerateTrajectory(options)) {
    EXPECT_EQ(frame.centre_ray_in_camera, Eigen::Vector3d::UnitZ());
  }
}

TEST(Handheld, BoundingSphereTestAccountsForLensDistortion) {
  PinholeCamera camera = PinholeCamera::Centered(640, 480, 525.0);
  // At 10 radii, 20 degrees to the right: near the right border.
  const double angle = 20.0 * std::numbers::pi / 180.0;
  const Eigen::Vector3d ray(std::sin(angle), 0.0, std::cos(angle));
  ASSERT_TRUE(BoundingSphereInImage(camera, 10.0, ray));
  EXPECT_FALSE(BoundingSphereInImage(camera, 3.0, ray));
  // Barrel distortion pulls the border in: the undistorted image is wider, the sphere fits better.
  camera.distortion = {-0.3, 0.1, 0.0, 0.0, 0.0};
  EXPECT_TRUE(BoundingSphereInImage(camera, 10.0, ray));
  // Strong pincushion distortion pushes the image content out (the middle of the right border
  // sees ideal x = 0.44 instead of 0.61, less than the sphere's rim at tan 25.7 deg = 0.48).
  camera.distortion = {2.0, 0.0, 0.0, 0.0, 0.0};
  EXPECT_FALSE(BoundingSphereInImage(camera, 10.0, ray));
}

TEST(Handheld, IsDeterministicForASeedAndDiffersForAnother) {
  const std::vector<TrajectoryFrame> a = GenerateTrajectory(Handheld(300, 7));
  const std::vector<TrajectoryFrame> b = GenerateTrajectory(Handheld(300, 7));
  const std::vector<TrajectoryFrame> c = GenerateTrajectory(Handheld(300, 8));
  double difference = 0.0;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].view_dir_in_object, b[k].view_dir_in_object);
    EXPECT_EQ(a[k].roll_deg, b[k].roll_deg);
    EXPECT_EQ(a[k].distance_in_radii, b[k].distance_in_radii);
    EXPECT_EQ(a[k].centre_ray_in_camera, b[k].centre_ray_in_camera);
    EXPECT_EQ(a[k].cut, b[k].cut);
    difference += (a[k].view_dir_in_object - c[k].view_dir_in_object).norm();
  }
  EXPECT_GT(difference / static_cast<double>(a.size()), 0.1);
}

TEST(Handheld, InvalidOptionsAreRefusedWithTheirName) {
  const auto refused = [](const HandheldOptions& hand, const char* word) {
    std::string error;
    EXPECT_FALSE(hand.Check(&error)) << word;
    EXPECT_NE(error.find(word), std::string::npos) << error;
  };
  HandheldOptions hand;
  EXPECT_TRUE(hand.Check());
  hand.speed_min_deg = 10.0;
  hand.speed_max_deg = 5.0;
  refused(hand, "speed");
  hand = HandheldOptions();
  hand.speed_max_deg = 50.0;
  refused(hand, "speed");
  hand = HandheldOptions();
  hand.cut_probability = 1.5;
  refused(hand, "cut");
  hand = HandheldOptions();
  hand.pause_probability = -0.1;
  refused(hand, "pause");
  hand = HandheldOptions();
  hand.distance_min_radii = 1.0;
  refused(hand, "distance");
  hand = HandheldOptions();
  hand.max_off_axis_deg = 70.0;
  refused(hand, "off-axis");
  hand = HandheldOptions();
  hand.segment_min_frames = 0;
  refused(hand, "segment");
  TrajectoryOptions options = Handheld(10, 1);
  options.handheld.momentum = 1.0;
  EXPECT_THROW(GenerateTrajectory(options), Error);
}

TEST(TrajectoryKinds, OrbitAndWalkStayOnTheAxisWithoutCuts) {
  for (const TrajectoryOptions& options : {Orbit(30, 3.0), Walk(30, 2)}) {
    for (const TrajectoryFrame& frame : GenerateTrajectory(options)) {
      EXPECT_EQ(frame.centre_ray_in_camera, Eigen::Vector3d::UnitZ());
      EXPECT_FALSE(frame.cut);
    }
  }
  EXPECT_STREQ(TrajectoryKindName(TrajectoryKind::kHandheld), "handheld");
}

// ----- object switches --------------------------------------------------------------------------

std::vector<int> Objects(const TrajectoryOptions& options) {
  std::vector<int> objects;
  for (const TrajectoryFrame& frame : GenerateTrajectory(options)) objects.push_back(frame.object);
  return objects;
}

TEST(ObjectSwitches, FramesFromASwitchOnShowItsObject) {
  TrajectoryOptions options = Orbit(8, 1.0);
  options.object_switches = {{3, 1}};
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 0, 0, 1, 1, 1, 1, 1}));
  options.object_switches = {{2, 2}, {5, 0}, {7, 1}};
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 0, 2, 2, 2, 0, 0, 1}));
  options.kind = TrajectoryKind::kWalk;  // the same for a walk
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 0, 2, 2, 2, 0, 0, 1}));

  options.object_switches = {{5, 1}, {5, 0}};
  std::string error;
  EXPECT_FALSE(options.Check(&error));
  EXPECT_NE(error.find("increasing"), std::string::npos);
  options.object_switches = {{-1, 1}};
  EXPECT_FALSE(options.Check(&error));
}

TEST(ObjectSwitches, CyclicSwitchesSplitTheSequence) {
  TrajectoryOptions options = Orbit(10, 1.0);
  options.object_switches = CyclicObjectSwitches(3, 10);
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 0, 0, 1, 1, 1, 2, 2, 2, 2}));
  options.object_switches = CyclicObjectSwitches(2, 10, 4);
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 0, 0, 0, 1, 1, 1, 1, 0, 0}));
  EXPECT_TRUE(CyclicObjectSwitches(1, 10).empty());
  // More objects than frames: some never appear, the switches stay valid.
  options.num_frames = 2;
  options.object_switches = CyclicObjectSwitches(5, 2);
  EXPECT_TRUE(options.Check());
  EXPECT_EQ(Objects(options), (std::vector<int>{0, 3}));
}

}  // namespace
}  // namespace silpose
