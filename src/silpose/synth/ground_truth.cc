#include "silpose/synth/ground_truth.h"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <string_view>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr std::array<const char*, 24> kColumns = {
    "frame",    "object",      "view_x",       "view_y",       "view_z",       "roll_deg",
    "r00",      "r01",         "r02",          "r10",          "r11",          "r12",
    "r20",      "r21",         "r22",          "tx",           "ty",           "tz",
    "distance", "degradation", "centre_ray_x", "centre_ray_y", "centre_ray_z", "off_axis_deg"};
constexpr size_t kRequiredColumns = 18;  // all but distance and degradation
constexpr double kTolerance = 1e-4;
constexpr size_t kNone = std::numeric_limits<size_t>::max();

double OffAxisDeg(const Eigen::Vector3d& ray) {
  return std::atan2(std::hypot(ray.x(), ray.y()), ray.z()) * 180.0 / std::numbers::pi;
}

// Shortest decimal form that reads back to the same double (-0 is written as 0).
void AppendNumber(std::string* line, double value) {
  if (value == 0.0) value = 0.0;  // "0", not "-0"
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  line->append(buffer, result.ptr);
}

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t begin = 0;
  while (true) {
    const size_t comma = line.find(',', begin);
    if (comma == std::string_view::npos) {
      fields.push_back(line.substr(begin));
      return fields;
    }
    fields.push_back(line.substr(begin, comma - begin));
    begin = comma + 1;
  }
}

std::string_view Trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) {
    text.remove_suffix(1);
  }
  return text;
}

class RowParser {
 public:
  RowParser(const std::filesystem::path& path, int line_number,
            const std::vector<std::string_view>& fields)
      : path_(path), line_(line_number), fields_(fields) {}

  [[noreturn]] void Fail(const std::string& message) const {
    ThrowError(path_.string(), ":", line_, ": ", message);
  }

  std::string_view Field(size_t index, const char* column) const {
    const std::string_view field = Trim(fields_[index]);
    if (field.empty()) Fail(std::string("column '") + column + "' is empty");
    return field;
  }

  double Number(size_t index, const char* column) const {
    const std::string_view field = Field(index, column);
    double value = 0.0;
    // from_chars does not take a leading '+'; accept it, as other writers may produce it.
    const std::string_view digits = field.front() == '+' ? field.substr(1) : field;
    const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (result.ec != std::errc() || result.ptr != digits.data() + digits.size()) {
      Fail(std::string("column '") + column + "': '" + std::string(field) + "' is not a number");
    }
    if (!std::isfinite(value)) {
      Fail(std::string("column '") + column + "': '" + std::string(field) + "' is not finite");
    }
    return value;
  }

  int Integer(size_t index, const char* column) const {
    const std::string_view field = Field(index, column);
    int value = 0;
    const auto result = std::from_chars(field.data(), field.data() + field.size(), value);
    if (result.ec != std::errc() || result.ptr != field.data() + field.size()) {
      Fail(std::string("column '") + column + "': '" + std::string(field) + "' is not an integer");
    }
    return value;
  }

 private:
  const std::filesystem::path& path_;
  int line_;
  const std::vector<std::string_view>& fields_;
};

}  // namespace

const char* GroundTruthHeader() {
  return "frame,object,view_x,view_y,view_z,roll_deg,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,"
         "distance,degradation,centre_ray_x,centre_ray_y,centre_ray_z,off_axis_deg";
}

void WriteGroundTruth(const std::filesystem::path& path,
                      const std::vector<GroundTruthFrame>& frames) {
  std::ofstream file(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open for writing");
  std::string text = GroundTruthHeader();
  text += '\n';
  for (const GroundTruthFrame& frame : frames) {
    if (frame.object.find_first_of(",\"\r\n") != std::string::npos) {
      ThrowError(path.string(), ": object name '", frame.object,
                 "' contains a comma, quote or line break, which CSV cannot hold unquoted");
    }
    text += std::to_string(frame.frame);
    text += ',';
    text += frame.object;
    for (int i = 0; i < 3; ++i) {
      text += ',';
      AppendNumber(&text, frame.view_dir_in_object[i]);
    }
    text += ',';
    AppendNumber(&text, frame.roll_deg);
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) {
        text += ',';
        AppendNumber(&text, frame.camera_from_object.rotation(row, col));
      }
    }
    for (int i = 0; i < 3; ++i) {
      text += ',';
      AppendNumber(&text, frame.camera_from_object.translation[i]);
    }
    text += ',';
    AppendNumber(&text, frame.distance_in_radii);
    text += ',';
    text += DegradationLabel(frame.degradation, frame.mask_effects);
    for (int i = 0; i < 3; ++i) {
      text += ',';
      AppendNumber(&text, frame.centre_ray_in_camera[i]);
    }
    text += ',';
    AppendNumber(&text, OffAxisDeg(frame.centre_ray_in_camera));
    text += '\n';
  }
  file << text;
  file.close();
  if (!file) ThrowError(path.string(), ": write failed (disk full?)");
}

std::vector<GroundTruthFrame> ReadGroundTruth(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    ThrowError(path.string(), ": no such ground-truth file");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) ThrowError(path.string(), ": cannot open");

  std::string line;
  int line_number = 0;
  // The header: where each known column is.
  if (!std::getline(file, line)) ThrowError(path.string(), ": empty file (expected a CSV header)");
  ++line_number;
  std::vector<std::string_view> header = SplitFields(line);
  std::array<size_t, kColumns.size()> column_of;
  column_of.fill(std::numeric_limits<size_t>::max());
  for (size_t i = 0; i < header.size(); ++i) {
    const std::string_view name = Trim(header[i]);
    for (size_t c = 0; c < kColumns.size(); ++c) {
      if (name == kColumns[c]) {
        if (column_of[c] != std::numeric_limits<size_t>::max()) {
          ThrowError(path.string(), ":1: column '", kColumns[c], "' appears twice in the header");
        }
        column_of[c] = i;
      }
    }
  }
  for (size_t c = 0; c < kRequiredColumns; ++c) {
    if (column_of[c] == std::numeric_limits<size_t>::max()) {
      ThrowError(path.string(), ":1: not a ground-truth file: the header has no column '",
                 kColumns[c], "' (expected ", GroundTruthHeader(), ")");
    }
  }
  const size_t num_fields = header.size();
  const bool has_distance = column_of[18] != std::numeric_limits<size_t>::max();
  const bool has_degradation = column_of[19] != std::numeric_limits<size_t>::max();
  const int ray_columns =
      (column_of[20] != kNone) + (column_of[21] != kNone) + (column_of[22] != kNone);
  if (ray_columns != 0 && ray_columns != 3) {
    ThrowError(path.string(), ":1: centre_ray_x, centre_ray_y and centre_ray_z must come together");
  }
  const bool has_ray = ray_columns == 3;
  const bool has_off_axis = column_of[23] != kNone;

  std::vector<GroundTruthFrame> frames;
  int blank_lines = 0;
  while (std::getline(file, line)) {
    ++line_number;
    if (Trim(line).empty()) {
      ++blank_lines;
      continue;
    }
    if (blank_lines > 0) {
      ThrowError(path.string(), ":", line_number - blank_lines, ": blank line inside the table");
    }
    const std::vector<std::string_view> fields = SplitFields(line);
    const RowParser row(path, line_number, fields);
    if (fields.size() != num_fields) {
      row.Fail("expected " + std::to_string(num_fields) + " fields as in the header, got " +
               std::to_string(fields.size()));
    }
    GroundTruthFrame frame;
    frame.frame = row.Integer(column_of[0], kColumns[0]);
    if (frame.frame < 0) row.Fail("frame number " + std::to_string(frame.frame) + " is negative");
    if (!frames.empty() && frame.frame <= frames.back().frame) {
      row.Fail("frame " + std::to_string(frame.frame) + " does not follow frame " +
               std::to_string(frames.back().frame) + " (frames must increase)");
    }
    frame.object = std::string(row.Field(column_of[1], kColumns[1]));
    for (int i = 0; i < 3; ++i) {
      const size_t c = 2u + static_cast<size_t>(i);
      frame.view_dir_in_object[i] = row.Number(column_of[c], kColumns[c]);
    }
    frame.roll_deg = row.Number(column_of[5], kColumns[5]);
    for (int i = 0; i < 9; ++i) {
      const size_t c = 6u + static_cast<size_t>(i);
      frame.camera_from_object.rotation(i / 3, i % 3) = row.Number(column_of[c], kColumns[c]);
    }
    for (int i = 0; i < 3; ++i) {
      const size_t c = 15u + static_cast<size_t>(i);
      frame.camera_from_object.translation[i] = row.Number(column_of[c], kColumns[c]);
    }
    frame.distance_in_radii = has_distance ? row.Number(column_of[18], kColumns[18])
                                           : std::numeric_limits<double>::quiet_NaN();
    if (has_degradation) {
      const std::string_view name = row.Field(column_of[19], kColumns[19]);
      if (!ParseDegradationLabel(name, &frame.degradation, &frame.mask_effects)) {
        row.Fail("column 'degradation': '" + std::string(name) +
                 "' is not none, missed, or bad and mask effects (e.g. ragged+holes) joined by +");
      }
    }
    if (has_ray) {
      for (int i = 0; i < 3; ++i) {
        const size_t c = 20u + static_cast<size_t>(i);
        frame.centre_ray_in_camera[i] = row.Number(column_of[c], kColumns[c]);
      }
      if (std::abs(frame.centre_ray_in_camera.norm() - 1.0) > kTolerance ||
          !(frame.centre_ray_in_camera.z() > 0.0)) {
        row.Fail(
            "the centre ray (centre_ray_x, _y, _z) is not a unit vector in front of the camera");
      }
    }
    if (has_off_axis) {
      const double off_axis = row.Number(column_of[23], kColumns[23]);
      if (std::abs(off_axis - OffAxisDeg(frame.centre_ray_in_camera)) > 1e-3) {
        row.Fail("column 'off_axis_deg' is not the angle of the centre ray from the optical axis");
      }
    }
    if (std::abs(frame.view_dir_in_object.norm() - 1.0) > kTolerance) {
      row.Fail("the view direction (view_x, view_y, view_z) is not a unit vector");
    }
    const Eigen::Matrix3d& rotation = frame.camera_from_object.rotation;
    if (!(rotation * rotation.transpose()).isApprox(Eigen::Matrix3d::Identity(), kTolerance) ||
        rotation.determinant() < 0.0) {
      row.Fail("r00..r22 is not a rotation matrix");
    }
    // The virtual camera's optical axis in the model frame is R^T u (R.row(2) for u = e_z).
    if ((frame.view_dir_in_object + rotation.transpose() * frame.centre_ray_in_camera).norm() >
        10 * kTolerance) {
      row.Fail(
          "the view direction is not the camera's optical axis reversed (-r20, -r21, -r22, or "
          "-R^T u with a centre ray u)");
    }
    frames.push_back(std::move(frame));
  }
  if (file.bad()) ThrowError(path.string(), ": read error");
  return frames;
}

}  // namespace silpose
