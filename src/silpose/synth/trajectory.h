#pragma once
// Camera trajectories for synthetic sequences: per frame, which object is seen, from which view
// direction, with which roll and at which distance. View direction and roll follow
// geometry/view_frame.h (view_dir_in_object: unit vector from the object centre towards the
// camera, model frame; roll about the optical axis relative to the model's +Z seen as "up").
//
// Three kinds:
//  - orbit: the paper's flight around the object (section 5): the camera moves along a great circle
//    of the view sphere by a fixed angle per frame, at a constant distance and a constant roll.
//  - walk: a smooth random walk of view direction, roll and distance, driven by a seeded
//    std::mt19937_64 and deterministic for a seed.
//  - handheld: an object turned by hand in front of a static camera: bursts of rotation at varying
//    speeds about a slowly wandering axis, pauses, reversals and rare cuts, while the distance and
//    the object's position in the image wander (HandheldOptions). Seeded, deterministic.
//
// Off-axis frames. view_dir_in_object and roll_deg always describe the *virtual* camera that looks
// straight at the object centre c: its rotation is R_on = CameraFromObjectRotation(view_dir,
// roll_deg) (geometry/view_frame.h). The real camera sees the object centre along the unit ray
// u = centre_ray_in_camera (OpenCV camera frame); with Q the minimal rotation taking the optical
// axis (0, 0, 1) to u (RotationFromOpticalAxisTo, pose/pose_from_silhouette.h) and D the distance
// in model units, the real pose is
//   camera_from_object: R = Q * R_on,  t = D * u - R * c.
// For u = (0, 0, 1) (orbit, walk) Q is the identity and the object centre projects to the
// principal point.

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "silpose/geometry/pinhole_camera.h"

namespace silpose {

/// Ground truth of one frame of a trajectory.
struct TrajectoryFrame {
  /// Index of the object seen (into the model list of the sequence).
  int object = 0;
  /// Unit vector from the object centre towards the camera centre, model frame.
  Eigen::Vector3d view_dir_in_object = Eigen::Vector3d::UnitX();
  /// Camera roll about its optical axis, degrees, in (-180, 180] (geometry/view_frame.h).
  double roll_deg = 0.0;
  /// Distance from the object centre to the camera centre, in object radii (> 1).
  double distance_in_radii = 3.0;
  /// Unit vector, OpenCV camera frame, along which the camera sees the object centre (see the top
  /// of this file); (0, 0, 1): on the optical axis.
  Eigen::Vector3d centre_ray_in_camera = Eigen::Vector3d::UnitZ();
  /// True if the view jumped at this frame (a cut of the handheld trajectory): the frame does not
  /// continue the motion of the previous one. Always false for orbit and walk.
  bool cut = false;
};

/// The orbit: a great circle of the view sphere. The circle's plane is the equator (the model's XY
/// plane) turned by `tilt_deg` about the horizontal axis at azimuth `node_azimuth_deg`; the circle
/// therefore crosses the equator going up at the "node" (cos a, sin a, 0), a = node azimuth, and
/// reaches elevation tilt_deg a quarter turn later. Frame k is at angle start_deg + k * step_deg
/// along the circle from the node.
///
/// The default tilt of 30 degrees sees the object from elevations -30..30 degrees and keeps away
/// from the poles (view along +-Z), where the roll reference turns quickly: a tilt of 0 would be
/// the equator (never seeing the top or bottom), a tilt of 90 a meridian through both poles. With
/// num_frames = 360 / step_deg the orbit closes: the next frame would be the first one again.
struct OrbitOptions {
  /// Angle between consecutive views along the circle, degrees (non-zero, |step| <= 180; negative
  /// flies the other way). The paper's sequences move 1 degree per frame.
  double step_deg = 1.0;
  /// Inclination of the circle to the equator, degrees, in [0, 90].
  double tilt_deg = 30.0;
  /// Azimuth (about +Z, from +X towards +Y) where the circle crosses the equator going up, degrees.
  double node_azimuth_deg = 0.0;
  /// Angle along the circle, from the node, of frame 0, degrees.
  double start_deg = 0.0;
  /// Constant roll, degrees (the roll number is kept, so the model's +Z stays "up" in the image).
  double roll_deg = 0.0;
  /// Constant camera distance from the object centre, object radii (> 1).
  double distance_in_radii = 3.0;

  bool Check(std::string* error = nullptr) const;
  /// Frames for one closed loop: round(360 / |step_deg|).
  int FramesPerLoop() const;
};

/// The random walk. Each of the three motions is a velocity that follows a first-order
/// autoregressive process, v' = momentum * v + sqrt(1 - momentum^2) * sigma * N(0, 1), so the
/// velocity changes little from frame to frame (smooth path) while its stationary spread stays
/// sigma:
///  - view direction: a 2-D angular velocity in the tangent plane of the sphere (sigma per axis,
///    the step length capped at max_speed_factor * sigma); the view moves along the great circle in
///    that direction and the velocity is carried along (parallel transport);
///  - roll: the camera orientation is carried along with the view (TransportRoll, so the camera
///    does not spin where the roll reference turns near the poles), then turned by the roll
///    velocity;
///  - distance: the velocity of log(distance); the distance bounces back at the range limits.
/// Every velocity starts from its stationary distribution.
struct WalkOptions {
  /// Seed of the walk (std::mt19937_64; the same seed gives the same walk).
  uint64_t seed = 1;
  /// First view direction (need not be unit); empty: drawn uniformly on the sphere from the seed.
  std::optional<Eigen::Vector3d> start_view_dir;
  /// First roll, degrees.
  double start_roll_deg = 0.0;
  /// Spread (standard deviation per tangent axis) of the angular velocity, degrees per frame (>=
  /// 0).
  double speed_sigma_deg = 1.0;
  /// The view moves at most max_speed_factor * speed_sigma_deg per frame (> 0).
  double max_speed_factor = 3.0;
  /// Spread of the roll velocity, degrees per frame (>= 0).
  double roll_speed_sigma_deg = 0.5;
  /// Distance range, object radii (1 < min <= max).
  double distance_min_radii = 3.0;
  double distance_max_radii = 6.0;
  /// First distance, object radii, within the range; empty: the geometric mean of the range.
  std::optional<double> start_distance_radii;
  /// Spread of the relative distance change per frame (of d(log distance)), >= 0.
  double distance_sigma = 0.01;
  /// Frame-to-frame correlation of every velocity, in [0, 1): 0 = independent steps (a jagged
  /// walk), close to 1 = long straight stretches. Correlation time about 1 / (1 - momentum) frames.
  double momentum = 0.95;

  bool Check(std::string* error = nullptr) const;
};

/// The hand-held object. The virtual camera's orientation relative to the object (R_on, see the
/// top of this file) turns each frame about an axis fixed in the camera frame, by the signed speed
/// of that frame: R_on(k+1) = Rot(axis_k, speed_k) * R_on(k), so view direction and roll change
/// together and nothing special happens near the poles (view and roll are read off R_on).
///  - Speed profile: consecutive segments of segment_min_frames..segment_max_frames frames
///  (uniform).
///    Each segment has a target speed: 0 with pause_probability (a pause), else uniform in
///    [speed_min_deg, speed_max_deg], turning back (negative: a reversal of the previous turning
///    direction) with reverse_probability. The speed approaches the target by at most
///    acceleration_deg per frame, so it changes smoothly (a reversal slows down, stops and turns).
///  - Axis: a unit vector in the camera frame doing a smooth random walk on the sphere, turning by
///    about axis_wander_deg per frame.
///  - Cuts: with cut_probability per frame the orientation jumps to a uniformly random one (view
///    and roll), TrajectoryFrame::cut is set, and a new segment starts.
///  - Distance: a smooth random walk of log(distance) within [distance_min_radii,
///    distance_max_radii] (reflected at the limits), velocity spread distance_sigma per frame.
///  - Position in the image: the object centre's ray u (TrajectoryFrame::centre_ray_in_camera)
///    wanders smoothly (its normalised image position (u_x/u_z, u_y/u_z) has a velocity of spread
///    off_axis_speed_deg per frame), at most max_off_axis_deg from the optical axis. With a
///    `camera`, the offset is also shrunk (towards the optical axis) as far as needed for the
///    object's bounding sphere to project inside the image (lens distortion included); where even
///    the centred sphere does not fit (too close for the camera), the object is centred.
/// The first orientation is uniformly random; the first distance is uniform in log(distance); the
/// first offset is random within the allowed region. All draws come from std::mt19937_64(seed).
struct HandheldOptions {
  /// Seed (std::mt19937_64; the same seed gives the same trajectory).
  uint64_t seed = 1;
  /// Range of the segments' rotation speeds, degrees per frame (0 <= min <= max <= 45).
  double speed_min_deg = 2.0;
  double speed_max_deg = 15.0;
  /// Largest change of the rotation speed from one frame to the next, degrees per frame per frame
  /// (> 0).
  double acceleration_deg = 2.0;
  /// Range of the segment lengths, frames (1 <= min <= max <= 10000).
  int segment_min_frames = 3;
  int segment_max_frames = 40;
  /// Probability that a segment is a pause (target speed 0), in [0, 1].
  double pause_probability = 0.15;
  /// Probability that a moving segment turns back (reverses the turning direction), in [0, 1].
  double reverse_probability = 0.25;
  /// Probability per frame of a cut (a jump to a random view and roll), in [0, 1].
  double cut_probability = 0.01;
  /// How fast the rotation axis wanders, degrees per frame (spread of its angular velocity, >= 0,
  /// <= 90).
  double axis_wander_deg = 2.0;
  /// Distance range, object radii (1 < min <= max).
  double distance_min_radii = 4.0;
  double distance_max_radii = 10.0;
  /// Spread of the relative distance change per frame (of d(log distance)), in [0, 1].
  double distance_sigma = 0.01;
  /// Largest angle between the object centre's ray and the optical axis, degrees, in [0, 60].
  double max_off_axis_deg = 25.0;
  /// Spread of the speed of the object centre across the image, degrees per frame, in [0, 10].
  double off_axis_speed_deg = 0.3;
  /// Frame-to-frame correlation of the velocities of axis, distance and offset, in [0, 1).
  double momentum = 0.95;
  /// The camera whose image the object must stay in (see above); empty: only max_off_axis_deg
  /// limits the offset. SyntheticSequence fills in its own camera when this is empty.
  std::optional<PinholeCamera> camera;

  bool Check(std::string* error = nullptr) const;
};

/// From frame `frame` on, the sequence shows object `object` (an index into its model list).
struct ObjectSwitch {
  int frame = 0;
  int object = 0;
};

enum class TrajectoryKind { kOrbit, kWalk, kHandheld };

/// "orbit" / "walk" / "handheld".
const char* TrajectoryKindName(TrajectoryKind kind);

struct TrajectoryOptions {
  TrajectoryKind kind = TrajectoryKind::kOrbit;
  /// Number of frames, in [1, 1000000] (mask file names have six digits).
  int num_frames = 360;
  OrbitOptions orbit;
  WalkOptions walk;
  HandheldOptions handheld;
  /// Object changes, by increasing frame (frames >= 0, objects >= 0). Frames before the first
  /// switch show object 0; empty: object 0 throughout.
  std::vector<ObjectSwitch> object_switches;

  bool Check(std::string* error = nullptr) const;
};

/// Generates the trajectory (deterministic). Throws silpose::Error if the options are invalid.
std::vector<TrajectoryFrame> GenerateTrajectory(const TrajectoryOptions& options);

/// Whether the bounding sphere of an object at `distance_in_radii` object radii along the unit ray
/// `centre_ray_in_camera` (camera frame) projects entirely inside `camera`'s image (lens distortion
/// included: the sphere must stay inside the undistorted image of the image border).
bool BoundingSphereInImage(const PinholeCamera& camera, double distance_in_radii,
                           const Eigen::Vector3d& centre_ray_in_camera);

/// Switches that split `num_frames` frames into consecutive segments of `every_frames` frames
/// showing objects 0, 1, ..., num_objects - 1, 0, 1, ... in turn. every_frames <= 0: one segment
/// per object, in order, their lengths differing by at most one frame (object i from frame
/// floor(i * num_frames / num_objects)). Empty for a single object.
std::vector<ObjectSwitch> CyclicObjectSwitches(int num_objects, int num_frames,
                                               int every_frames = 0);

}  // namespace silpose
