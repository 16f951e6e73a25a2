#include "silpose/synth/trajectory.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <utility>

#include "silpose/geometry/view_frame.h"
#include "silpose/pose/lens_distortion.h"
#include "silpose/synth/synth_random.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using synth_internal::StandardNormal;
using synth_internal::Uniform;
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

// ----- handheld ---------------------------------------------------------------------------------

// The image of a camera in ideal normalised coordinates, as a rectangle [x0, x1] x [y0, y1] that
// the image's outer pixel edges enclose (with distortion: the largest axis-aligned rectangle inside
// the undistorted image of the border, sampled).
struct IdealImageBox {
  double x0 = 0.0;
  double x1 = 0.0;
  double y0 = 0.0;
  double y1 = 0.0;
};

IdealImageBox ImageBox(const PinholeCamera& camera) {
  const double left = -0.5;
  const double right = camera.width_px - 0.5;
  const double top = -0.5;
  const double bottom = camera.height_px - 0.5;
  IdealImageBox box;
  box.x0 = (left - camera.principal_x_px) / camera.focal_x_px;
  box.x1 = (right - camera.principal_x_px) / camera.focal_x_px;
  box.y0 = (top - camera.principal_y_px) / camera.focal_y_px;
  box.y1 = (bottom - camera.principal_y_px) / camera.focal_y_px;
  if (!HasDistortion(camera)) return box;
  constexpr int kSamples = 64;
  box = {-1e9, 1e9, -1e9, 1e9};
  auto ideal = [&](double u, double v, Eigen::Vector2d* point) {
    return PixelToIdealNormalized(camera, Eigen::Vector2d(u, v), point);
  };
  for (int i = 0; i <= kSamples; ++i) {
    const double a = static_cast<double>(i) / kSamples;
    const double u = left + a * (right - left);
    const double v = top + a * (bottom - top);
    Eigen::Vector2d point;
    if (ideal(left, v, &point)) box.x0 = std::max(box.x0, point.x());
    if (ideal(right, v, &point)) box.x1 = std::min(box.x1, point.x());
    if (ideal(u, top, &point)) box.y0 = std::max(box.y0, point.y());
    if (ideal(u, bottom, &point)) box.y1 = std::min(box.y1, point.y());
  }
  return box;
}

// The cone from the camera centre around the unit ray `u` with sin(half-angle) = 1 / distance
// (the bounding sphere) lies inside the pyramid over `box`: the angle from u to each side plane is
// at least the half-angle.
bool SphereInBox(const IdealImageBox& box, double distance_in_radii, const Eigen::Vector3d& u) {
  const double sine = 1.0 / distance_in_radii;
  auto inside = [&](const Eigen::Vector3d& normal) { return normal.normalized().dot(u) >= sine; };
  return inside({1.0, 0.0, -box.x0}) && inside({-1.0, 0.0, box.x1}) &&
         inside({0.0, 1.0, -box.y0}) && inside({0.0, -1.0, box.y1});
}

Eigen::Vector3d RayOfOffset(const Eigen::Vector2d& offset) {
  return Eigen::Vector3d(offset.x(), offset.y(), 1.0).normalized();
}

Eigen::Vector3d RandomUnitVector(std::mt19937_64& engine) {
  const double z = 2.0 * Uniform01(engine) - 1.0;
  const double azimuth = 2.0 * std::numbers::pi * Uniform01(engine);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(azimuth), r * std::sin(azimuth), z};
}

// A uniformly random orientation: a uniform view direction and a uniform roll.
Eigen::Quaterniond RandomOrientation(std::mt19937_64& engine) {
  const Eigen::Vector3d view = RandomUnitVector(engine);
  const double roll = Uniform(engine, -180.0, 180.0);
  return Eigen::Quaterniond(CameraFromObjectRotation(view, roll)).normalized();
}

// Moves the unit vector `point` along the great circle in the direction of the tangent `velocity`
// (radians per frame) and carries the velocity along.
void MoveOnSphere(Eigen::Vector3d* point, Eigen::Vector3d* velocity) {
  *velocity -= velocity->dot(*point) * *point;
  const double speed = velocity->norm();
  if (speed <= 0.0) return;
  const Eigen::Vector3d heading = *velocity / speed;
  const Eigen::Vector3d moved = (std::cos(speed) * *point + std::sin(speed) * heading).normalized();
  *velocity = speed * (std::cos(speed) * heading - std::sin(speed) * *point);
  *point = moved;
}

std::vector<TrajectoryFrame> Handheld(const HandheldOptions& hand, int num_frames) {
  std::mt19937_64 engine(hand.seed);
  const double m = hand.momentum;
  const double innovation = std::sqrt(1.0 - m * m);
  const std::optional<IdealImageBox> box =
      hand.camera ? std::optional<IdealImageBox>(ImageBox(*hand.camera)) : std::nullopt;
  const double max_offset = std::tan(hand.max_off_axis_deg * kDegToRad);
  const double log_min = std::log(hand.distance_min_radii);
  const double log_max = std::log(hand.distance_max_radii);
  auto tangent_noise = [&](const Eigen::Vector3d& at, double sigma) {
    const Eigen::Vector3d e1 = Perpendicular(at);
    const Eigen::Vector3d e2 = at.cross(e1);
    const double n1 = StandardNormal(engine);
    const double n2 = StandardNormal(engine);
    return Eigen::Vector3d(sigma * (n1 * e1 + n2 * e2));
  };

  // Orientation of the virtual camera, rotation axis (camera frame) and its velocity.
  Eigen::Quaterniond orientation = RandomOrientation(engine);
  Eigen::Vector3d axis = RandomUnitVector(engine);
  const double axis_sigma = hand.axis_wander_deg * kDegToRad;
  Eigen::Vector3d axis_velocity = tangent_noise(axis, axis_sigma);
  // Speed profile: signed speed (degrees per frame), the current segment's target and length left,
  // and the sign of the last moving segment.
  double speed = 0.0;
  double target = 0.0;
  int segment_left = 0;
  double direction = 1.0;
  // Distance: log(distance) and its velocity.
  double log_distance = Uniform(engine, log_min, log_max);
  double log_distance_velocity = hand.distance_sigma * StandardNormal(engine);
  // Offset of the object centre in normalised image coordinates, and its velocity.
  const double offset_sigma = hand.off_axis_speed_deg * kDegToRad;
  const double start_radius = max_offset * std::sqrt(Uniform01(engine));
  const double start_angle = 2.0 * std::numbers::pi * Uniform01(engine);
  Eigen::Vector2d offset(start_radius * std::cos(start_angle),
                         start_radius * std::sin(start_angle));
  Eigen::Vector2d offset_velocity(offset_sigma * StandardNormal(engine),
                                  offset_sigma * StandardNormal(engine));

  // Keeps the offset within the cone of max_off_axis_deg and, with a camera, the bounding sphere
  // inside the image: shrinks it towards the centre and turns an outward velocity back.
  auto confine_offset = [&](double distance) {
    double scale = 1.0;
    const double norm = offset.norm();
    if (norm > max_offset) scale = norm > 0.0 ? max_offset / norm : 0.0;
    if (box && !SphereInBox(*box, distance, RayOfOffset(scale * offset))) {
      if (!SphereInBox(*box, distance, Eigen::Vector3d::UnitZ())) {
        scale = 0.0;  // does not fit even centred: centre it
      } else {
        double low = 0.0;
        double high = scale;
        for (int i = 0; i < 40; ++i) {
          const double mid = 0.5 * (low + high);
          (SphereInBox(*box, distance, RayOfOffset(mid * offset)) ? low : high) = mid;
        }
        scale = low;
      }
    }
    if (scale < 1.0) {
      if (norm > 0.0) {
        const Eigen::Vector2d outward = offset / norm;
        const double radial = offset_velocity.dot(outward);
        if (radial > 0.0) offset_velocity -= 2.0 * radial * outward;
      }
      offset *= scale;
    }
  };
  confine_offset(std::exp(log_distance));

  std::vector<TrajectoryFrame> frames(static_cast<size_t>(num_frames));
  bool cut = false;
  for (int k = 0; k < num_frames; ++k) {
    TrajectoryFrame& frame = frames[static_cast<size_t>(k)];
    ViewAndRollFromRotation(orientation.toRotationMatrix(), &frame.view_dir_in_object,
                            &frame.roll_deg);
    frame.distance_in_radii =
        std::clamp(std::exp(log_distance), hand.distance_min_radii, hand.distance_max_radii);
    frame.centre_ray_in_camera = RayOfOffset(offset);
    frame.cut = cut;
    if (k + 1 == num_frames) break;

    // Speed: a new segment when the current one is over, then towards its target.
    if (segment_left == 0) {
      segment_left = hand.segment_min_frames +
                     static_cast<int>(Uniform01(engine) *
                                      (hand.segment_max_frames - hand.segment_min_frames + 1));
      segment_left = std::min(segment_left, hand.segment_max_frames);
      const double kind = Uniform01(engine);
      const double magnitude = Uniform(engine, hand.speed_min_deg, hand.speed_max_deg);
      const double turn = Uniform01(engine);
      if (kind < hand.pause_probability) {
        target = 0.0;
      } else {
        if (turn < hand.reverse_probability) direction = -direction;
        target = direction * magnitude;
      }
    }
    --segment_left;
    speed += std::clamp(target - speed, -hand.acceleration_deg, hand.acceleration_deg);
    // Turn the object about the axis, then let the axis wander.
    orientation =
        (Eigen::Quaterniond(Eigen::AngleAxisd(speed * kDegToRad, axis)) * orientation).normalized();
    axis_velocity = m * axis_velocity + innovation * tangent_noise(axis, axis_sigma);
    MoveOnSphere(&axis, &axis_velocity);
    // A cut: the view jumps, a new segment starts (the hand keeps its speed).
    cut = Uniform01(engine) < hand.cut_probability;
    const Eigen::Quaterniond jump = RandomOrientation(engine);
    if (cut) {
      orientation = jump;
      segment_left = 0;
    }
    // Distance: a bounded walk of log(distance), reflected at the limits.
    log_distance_velocity =
        m * log_distance_velocity + innovation * hand.distance_sigma * StandardNormal(engine);
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
    // Position in the image.
    const double n1 = StandardNormal(engine);
    const double n2 = StandardNormal(engine);
    offset_velocity = m * offset_velocity + innovation * offset_sigma * Eigen::Vector2d(n1, n2);
    offset += offset_velocity;
    confine_offset(std::exp(log_distance));
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

bool HandheldOptions::Check(std::string* error) const {
  if (!Finite(speed_min_deg) || !Finite(speed_max_deg) || speed_min_deg < 0.0 ||
      speed_max_deg < speed_min_deg || speed_max_deg > 45.0) {
    return Fail(error, "handheld speed range must satisfy 0 <= min <= max <= 45 degrees per frame");
  }
  if (!Finite(acceleration_deg) || acceleration_deg <= 0.0 || acceleration_deg > 90.0) {
    return Fail(error, "handheld acceleration must be in (0, 90] degrees per frame per frame");
  }
  if (segment_min_frames < 1 || segment_max_frames < segment_min_frames ||
      segment_max_frames > 10000) {
    return Fail(error, "handheld segment lengths must satisfy 1 <= min <= max <= 10000 frames");
  }
  const std::pair<double, const char*> probabilities[] = {
      {pause_probability, "handheld pause probability must be in [0, 1]"},
      {reverse_probability, "handheld reverse probability must be in [0, 1]"},
      {cut_probability, "handheld cut probability must be in [0, 1]"}};
  for (const auto& [value, message] : probabilities) {
    if (!Finite(value) || value < 0.0 || value > 1.0) return Fail(error, message);
  }
  if (!Finite(axis_wander_deg) || axis_wander_deg < 0.0 || axis_wander_deg > 90.0) {
    return Fail(error, "handheld axis wander must be in [0, 90] degrees per frame");
  }
  if (!Finite(distance_min_radii) || !Finite(distance_max_radii) || distance_min_radii <= 1.0 ||
      distance_max_radii < distance_min_radii) {
    return Fail(error, "handheld distance range must satisfy 1 < min <= max (object radii)");
  }
  if (!Finite(distance_sigma) || distance_sigma < 0.0 || distance_sigma > 1.0) {
    return Fail(error, "handheld distance spread must be in [0, 1] per frame");
  }
  if (!Finite(max_off_axis_deg) || max_off_axis_deg < 0.0 || max_off_axis_deg > 60.0) {
    return Fail(error, "handheld maximum off-axis angle must be in [0, 60] degrees");
  }
  if (!Finite(off_axis_speed_deg) || off_axis_speed_deg < 0.0 || off_axis_speed_deg > 10.0) {
    return Fail(error, "handheld off-axis speed must be in [0, 10] degrees per frame");
  }
  if (!Finite(momentum) || momentum < 0.0 || momentum >= 1.0) {
    return Fail(error, "handheld momentum must be in [0, 1)");
  }
  if (camera) {
    std::string problem;
    if (!camera->Check(&problem)) return Fail(error, "handheld camera: " + problem);
  }
  return true;
}

const char* TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kOrbit:
      return "orbit";
    case TrajectoryKind::kWalk:
      return "walk";
    case TrajectoryKind::kHandheld:
      return "handheld";
  }
  return "?";
}

bool TrajectoryOptions::Check(std::string* error) const {
  if (num_frames < 1 || num_frames > kMaxFrames) {
    return Fail(error, "frame count must be in [1, 1000000]");
  }
  if (kind == TrajectoryKind::kOrbit && !orbit.Check(error)) return false;
  if (kind == TrajectoryKind::kWalk && !walk.Check(error)) return false;
  if (kind == TrajectoryKind::kHandheld && !handheld.Check(error)) return false;
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
  std::vector<TrajectoryFrame> frames;
  switch (options.kind) {
    case TrajectoryKind::kOrbit:
      frames = Orbit(options.orbit, options.num_frames);
      break;
    case TrajectoryKind::kWalk:
      frames = Walk(options.walk, options.num_frames);
      break;
    case TrajectoryKind::kHandheld:
      frames = Handheld(options.handheld, options.num_frames);
      break;
  }
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

bool BoundingSphereInImage(const PinholeCamera& camera, double distance_in_radii,
                           const Eigen::Vector3d& centre_ray_in_camera) {
  return distance_in_radii > 1.0 &&
         SphereInBox(ImageBox(camera), distance_in_radii, centre_ray_in_camera.normalized());
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
