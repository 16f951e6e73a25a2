#pragma once
// groundtruth.csv of a synthetic sequence folder (docs/conventions.md, "synth DIR"): one row per
// frame, header first, with the columns
//   frame,object,view_x,view_y,view_z,roll_deg,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,
//   distance,degradation,centre_ray_x,centre_ray_y,centre_ray_z,off_axis_deg
// `object` is the model's file stem; (view, roll) as in geometry/view_frame.h, of the virtual
// camera looking straight at the object centre (synth/trajectory.h); r.. and t.. the true 6-DOF
// pose camera_from_object (x_in_camera = R * x_in_object + t, OpenCV camera frame, t in model
// units); `distance` the camera distance from the object centre in object radii; `degradation`
// the frame's kind and mask effects (DegradationLabel of synth/degradation.h: none, missed, bad,
// or e.g. ragged+holes, bad+shadow); centre_ray_* the unit ray u (camera frame) along which the
// object centre is seen, and off_axis_deg its angle from the optical axis (R = Q R_on with Q the
// minimal rotation taking (0, 0, 1) to u; on the axis u = (0, 0, 1) and R = R_on). Numbers are
// written in the shortest form that reads back to the same double.

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "silpose/geometry/rigid3.h"
#include "silpose/synth/degradation.h"

namespace silpose {

/// One row of groundtruth.csv.
struct GroundTruthFrame {
  /// Frame number (mask file masks/<frame, six digits>.png).
  int frame = 0;
  /// Model name (the mesh file's stem).
  std::string object;
  /// Unit vector from the object centre towards the camera, model frame.
  Eigen::Vector3d view_dir_in_object = Eigen::Vector3d::UnitX();
  /// Camera roll, degrees, in (-180, 180].
  double roll_deg = 0.0;
  /// The 6-DOF pose (object_to_camera, as in POSES.csv).
  Rigid3 camera_from_object;
  /// Camera distance from the object centre, object radii; NaN if the file has no such column.
  double distance_in_radii = 0.0;
  /// Unit ray, camera frame, along which the object centre is seen; (0, 0, 1) (on the optical
  /// axis) if the file has no such columns.
  Eigen::Vector3d centre_ray_in_camera = Eigen::Vector3d::UnitZ();
  /// kNone if the file has no such column.
  FrameDegradation degradation = FrameDegradation::kNone;
  /// The effects applied to the mask (MaskEffect flags of synth/degradation.h); 0 if the file has
  /// no degradation column or it lists none.
  uint32_t mask_effects = 0;
};

/// The header line (without the newline).
const char* GroundTruthHeader();

/// Writes the rows in the given order. Throws silpose::Error naming the file if it cannot be
/// written or an object name contains a comma, a quote or a line break.
void WriteGroundTruth(const std::filesystem::path& path,
                      const std::vector<GroundTruthFrame>& frames);

/// Reads groundtruth.csv. Columns are found by their header names, in any order; extra columns are
/// ignored; `distance`, `degradation` and the centre ray columns are optional (files that only have
/// The columns of docs/conventions.md (Synthetic sequences) read fine; centre_ray_x, _y, _z come
/// together, off_axis_deg is checked against them when present). Accepts CRLF line ends and blank
/// lines at the end. Throws silpose::Error naming the file, and the line where it applies, if the
/// file is missing, a required column is missing, a row has the wrong number of fields, a number
/// does not parse or is not finite, a frame number is negative or not larger than the previous
/// row's, an object name is empty, a view direction is not of unit length, the centre ray is not a
/// unit vector in front of the camera or disagrees with off_axis_deg (tolerance 1e-3 degrees), R is
/// not a rotation, the view direction is not the virtual camera's optical axis reversed (-R^T u,
/// which is -R.row(2) on the axis), or a degradation label does not parse (ParseDegradationLabel)
/// (tolerances 1e-4, for files written with 6 decimals).
std::vector<GroundTruthFrame> ReadGroundTruth(const std::filesystem::path& path);

}  // namespace silpose
