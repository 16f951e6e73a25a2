#include "silpose/synth/trajectory.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <sstream>

#include "silpose/geometry/view_frame.h"
#include "silpose/synth/synth_random.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using synth_internal::StandardNormal;
using synth_internal::Uniform01;

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr int kMaxFrames = 1000000;

bool Fail(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
  return false;
}

bool Finite(double value) { return std::isfinite(value); }

// A unit vector perpendicular to unit `d`, chosen deterministically.
Eigen::Vector3d Perpendicular(const Eigen::Vector3d& d) {
  Eigen::Index axis = 0;
  d.cwiseAbs().minCoeff(&axis);
  return d.cross(Eigen::Vector3d::Unit(axis)).normalized();
}

std::vector<TrajectoryFrame> Orbit(const OrbitOptions& orbit, int num_frames) {
  const double node = orbit.node_azimuth_deg * kDegToRad;
  const double tilt = orbit.tilt_deg * kDegToRad;
  // Orthonormal basis of the circle's plane: the node on the equator, and the direction a quarter
  // turn further, raised by the tilt.
  const Eigen::Vector3d a(std::cos(node), std::sin(node), 0.0);
  const Eigen::Vector3d b(-std::sin(node) * std::cos(tilt), std::cos(node) * std::cos(tilt),
                          std::sin(tilt));
  std::vector<TrajectoryFrame> frames(static_cast<size_t>(num_frames));
  for (int k = 0; k < num_frames; ++k) {
    // Angle reduced to one turn first, so long sequences keep full precision.
    const double angle_deg = std::fmod(orbit.start_deg + k * orbit.step_deg, 360.0);
    const double angle = angle_deg * kDegToRad;
    TrajectoryFrame& frame = frames[static_cast<size_t>(k)];
    frame.view_dir_in_object = (std::cos(angle) * a + std::sin(angle) * b).normalized();
    frame.roll_deg = WrapDegrees(orbit.roll_deg);
    frame.distance_in_radii = orbit.distance_in_radii;
  }
  return frames;
}

std::vector<TrajectoryFrame> Walk(const WalkOptions& walk, int num_frames) {
  std::mt19937_64 engine(walk.seed);
  const double m = walk.momentum;
  const double innovation = std::sqrt(1.0 - m * m);
  const double speed_sigma = walk.speed_sigma_deg * kDegToRad;
  const double max_speed = walk.max_speed_factor * speed_sigma;
  const double log_min = std::log(walk.distance_min_radii);
  const double log_max = std::log(walk.distance_max_radii);

  Eigen::Vector3d view;
  if (walk.start_view_dir) {
    view = walk.start_view_dir->normalized();
  } else {
    // Uniform on the sphere: uniform height and azimuth (Archimedes).
    const double z = 2.0 * Uniform01(engine) - 1.0;
    const double azimuth = 2.0 * std::numbers::pi * Uniform01(engine);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    view = Eigen::Vector3d(r * std::cos(azimuth), r * std::sin(azimuth), z);
  }
  auto tangent_noise = [&](const Eigen::Vector3d& at) {
    const Eigen::Vector3d e1 = Perpendicular(at);
    const Eigen::Vector3d e2 = at.cross(e1);
    const double n1 = StandardNormal(engine);
    const double n2 = StandardNormal(engine);
    return Eigen::Vector3d(speed_sigma * (n1 * e1 + n2 * e2));
  };
  // Velocities (angular velocity in radians per frame, tangent to the sphere at `view`; roll in
  // degrees per frame; log-distance per frame), started from their stationary distributions.
  Eigen::Vector3d velocity = tangent_noise(view);
  double roll_velocity = walk.roll_speed_sigma_deg * StandardNormal(engine);
  double log_distance_velocity = walk.distance_sigma * StandardNormal(engine);
  double roll = walk.start_roll_deg;
  double distance = walk.start_distance_radii
                        ? *walk.start_distance_radii
                        : std::sqrt(walk.distance_min_radii * walk.distance_max_radii);
  double log_distance = std::log(distance);

  std::vector<TrajectoryFrame> frames(static_cast<size_t>(num_frames));
  for (int k = 0; k < num_frames; ++k) {
    TrajectoryFrame& frame = frames[static_cast<size_t>(k)];
    frame.view_dir_in_object = view;
    frame.roll_deg = WrapDegrees(roll);
    frame.distance_in_radii = distance;
    if (k + 1 == num_frames) break;

    // View: update the velocity, cap its length, move along the great circle, carry it along.
    velocity = m * velocity + innovation * tangent_noise(view);
    velocity -= velocity.dot(view) * view;  // stay tangent despite rounding
    double speed = velocity.norm();
    if (speed > max_speed) {
      velocity *= max_speed / speed;
      speed = max_speed;
    }
    Eigen::Vector3d next_view = view;
    if (speed > 0.0) {
      const Eigen::Vector3d heading = velocity / speed;
      next_view = (std::cos(speed) * view + std::sin(speed) * heading).normalized();
      velocity = speed * (std::cos(speed) * heading - std::sin(speed) * view);
    }
    // Roll: keep the camera orientation while moving, then turn it.
    roll_velocity =
        m * roll_velocity + innovation * walk.roll_speed_sigma_deg * StandardNormal(engine);
    roll = TransportRoll(view, roll, next_view) + roll_velocity;
    view = next_view;
    // Distance: a bounded walk of log(distance), reflected at the limits.
    log_distance_velocity =
        m * log_distance_velocity + innovation * walk.distance_sigma * StandardNormal(engine);
    log_distance += log_distance_velocity;
    if (log_distance > log_max) {
      log_distance = 2.0 * log_max - log_distance;
      log_distance_velocity = -log_distance_velocity;
    }
    if (log_distance < log_min) {
      log_distance = 2.0 * log_min - log_distance;
      log_distance_velocity = -log_distance_velocity;
    }
    log_distance = std::clamp(log_distance, log_min, log_max);
    distance = std::clamp(std::exp(log_distance), walk.distance_min_radii, walk.distance_max_radii);
  }
  return frames;
}

}  // namespace

bool OrbitOptions::Check(std::string* error) const {
  if (!Finite(step_deg) || step_deg == 0.0 || std::abs(step_deg) > 180.0) {
    return Fail(error, "orbit step must be non-zero and at most 180 degrees per frame");
  }
  if (!Finite(tilt_deg) || tilt_deg < 0.0 || tilt_deg > 90.0) {
    return Fail(error, "orbit tilt must be in [0, 90] degrees");
  }
  if (!Finite(node_azimuth_deg) || !Finite(start_deg) || !Finite(roll_deg)) {
    return Fail(error, "orbit node azimuth, start angle and roll must be finite");
  }
  if (!Finite(distance_in_radii) || distance_in_radii <= 1.0) {
    return Fail(error, "orbit distance must be > 1 object radius (the camera outside the object)");
  }
  return true;
}

int OrbitOptions::FramesPerLoop() const {
  return static_cast<int>(std::lround(360.0 / std::abs(step_deg)));
}

bool WalkOptions::Check(std::string* error) const {
  if (start_view_dir) {
    const double norm = start_view_dir->norm();
    if (!Finite(norm) || norm < 1e-12) {
      return Fail(error, "walk start view direction must be finite and non-zero");
    }
  }
  if (!Finite(start_roll_deg)) return Fail(error, "walk start roll must be finite");
  if (!Finite(speed_sigma_deg) || speed_sigma_deg < 0.0 || speed_sigma_deg > 90.0) {
    return Fail(error, "walk angular speed spread must be in [0, 90] degrees per frame");
  }
  if (!Finite(max_speed_factor) || max_speed_factor <= 0.0) {
    return Fail(error, "walk maximum speed factor must be > 0");
  }
  if (!Finite(roll_speed_sigma_deg) || roll_speed_sigma_deg < 0.0 || roll_speed_sigma_deg > 90.0) {
    return Fail(error, "walk roll speed spread must be in [0, 90] degrees per frame");
  }
  if (!Finite(distance_min_radii) || !Finite(distance_max_radii) || distance_min_radii <= 1.0 ||
      distance_max_radii < distance_min_radii) {
    return Fail(error, "walk distance range must satisfy 1 < min <= max (object radii)");
  }
  if (start_distance_radii && !(*start_distance_radii >= distance_min_radii &&
                                *start_distance_radii <= distance_max_radii)) {
    return Fail(error, "walk start distance must lie within the distance range");
  }
  if (!Finite(distance_sigma) || distance_sigma < 0.0 || distance_sigma > 1.0) {
    return Fail(error, "walk distance spread must be in [0, 1] per frame");
  }
  if (!Finite(momentum) || momentum < 0.0 || momentum >= 1.0) {
    return Fail(error, "walk momentum must be in [0, 1)");
  }
  return true;
}

const char* TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kOrbit:
      return "orbit";
    case TrajectoryKind::kWalk:
      return "walk";
  }
  return "?";
}

bool TrajectoryOptions::Check(std::string* error) const {
  if (num_frames < 1 || num_frames > kMaxFrames) {
    return Fail(error, "frame count must be in [1, 1000000]");
  }
  if (kind == TrajectoryKind::kOrbit && !orbit.Check(error)) return false;
  if (kind == TrajectoryKind::kWalk && !walk.Check(error)) return false;
  for (size_t i = 0; i < object_switches.size(); ++i) {
    const ObjectSwitch& s = object_switches[i];
    std::ostringstream where;
    where << "object switch " << i + 1 << " (frame " << s.frame << ", object " << s.object << ")";
    if (s.frame < 0 || s.object < 0) {
      return Fail(error, where.str() + ": frame and object must be >= 0");
    }
    if (i > 0 && s.frame <= object_switches[i - 1].frame) {
      return Fail(error, where.str() + ": switches must be in increasing frame order");
    }
  }
  return true;
}

std::vector<TrajectoryFrame> GenerateTrajectory(const TrajectoryOptions& options) {
  std::string problem;
  if (!options.Check(&problem)) ThrowError("invalid trajectory options: ", problem);
  std::vector<TrajectoryFrame> frames = options.kind == TrajectoryKind::kOrbit
                                            ? Orbit(options.orbit, options.num_frames)
                                            : Walk(options.walk, options.num_frames);
  size_t next_switch = 0;
  int object = 0;
  for (int k = 0; k < options.num_frames; ++k) {
    while (next_switch < options.object_switches.size() &&
           options.object_switches[next_switch].frame <= k) {
      object = options.object_switches[next_switch++].object;
    }
    frames[static_cast<size_t>(k)].object = object;
  }
  return frames;
}

std::vector<ObjectSwitch> CyclicObjectSwitches(int num_objects, int num_frames, int every_frames) {
  std::vector<ObjectSwitch> switches;
  if (num_objects <= 1 || num_frames <= 0) return switches;
  if (every_frames > 0) {
    int object = 0;
    for (int frame = 0; frame < num_frames; frame += every_frames) {
      switches.push_back({frame, object});
      object = (object + 1) % num_objects;
      if (frame > num_frames - every_frames) break;  // next frame would overflow int
    }
    return switches;
  }
  for (int object = 0; object < num_objects; ++object) {
    const auto frame = static_cast<int>(static_cast<int64_t>(object) * num_frames / num_objects);
    if (frame >= num_frames || (!switches.empty() && frame <= switches.back().frame)) continue;
    switches.push_back({frame, object});
  }
  return switches;
}

}  // namespace silpose
