#include "silpose/pose/pose_output.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>

#include "silpose/util/error.h"

namespace silpose {
namespace {

// Statistics (score, time, ...): 9 significant digits, as POSES.csv always had.
std::string Number(double value) {
  char buffer[64];
  const auto result =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, 9);
  return std::string(buffer, result.ptr);
}

// Pose entries: the shortest form that reads back to the same double.
std::string ExactNumber(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string OptionalNumber(double value) { return std::isfinite(value) ? Number(value) : ""; }

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + '"';
}

void Open(const std::filesystem::path& path, std::ofstream* stream) {
  stream->open(path, std::ios::out | std::ios::trunc | std::ios::binary);
  if (!*stream) {
    ThrowError(path.string(), ": cannot open for writing (", std::strerror(errno), ")");
  }
}

void WriteLine(const std::filesystem::path& path, std::ofstream* stream, const std::string& line) {
  if (!stream->is_open()) ThrowError(path.string(), ": write after close");
  *stream << line << '\n';
  stream->flush();
  if (!*stream) ThrowError(path.string(), ": write failed (", std::strerror(errno), ")");
}

void CloseChecked(const std::filesystem::path& path, std::ofstream* stream) {
  if (!stream->is_open()) return;
  stream->close();
  if (!*stream) ThrowError(path.string(), ": write failed when closing");
}

nlohmann::json JsonNumber(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

}  // namespace

const char* TrackStateName(TrackState state) {
  switch (state) {
    case TrackState::kTracking:
      return "tracking";
    case TrackState::kAmbiguous:
      return "ambiguous";
    case TrackState::kUnknownObject:
      return "unknown-object";
    case TrackState::kBadSegmentation:
      return "bad-segmentation";
    case TrackState::kLost:
      return "lost";
    case TrackState::kNoSilhouette:
      return "no-silhouette";
  }
  return "unknown";
}

bool ParseTrackState(std::string_view name, TrackState* state) {
  for (TrackState s :
       {TrackState::kTracking, TrackState::kAmbiguous, TrackState::kUnknownObject,
        TrackState::kBadSegmentation, TrackState::kLost, TrackState::kNoSilhouette}) {
    if (name == TrackStateName(s)) {
      *state = s;
      return true;
    }
  }
  return false;
}

const char* PosesCsvHeader() {
  return "frame,object,score,probability,view_x,view_y,view_z,roll_deg,status,time_ms,particles,"
         "effective_particles,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz,time_segment_ms,"
         "time_describe_ms,time_match_ms,time_pose_ms,time_refine_ms,confidence,state,iou,"
         "runner_up_object,runner_up_mass,runner_up_view_x,runner_up_view_y,runner_up_view_z,"
         "runner_up_roll_deg";
}

PosesCsvWriter::PosesCsvWriter(const std::filesystem::path& path) : path_(path) {
  Open(path_, &stream_);
  WriteLine(path_, &stream_, PosesCsvHeader());
}

void PosesCsvWriter::Write(const FrameResult& result) {
  std::string line = std::to_string(result.frame);
  line += ',' + CsvField(result.object >= 0 || !result.object_name.empty() ? result.object_name
                                                                           : std::string());
  line += ',' + OptionalNumber(result.score);
  line += ',' + OptionalNumber(result.probability);
  for (int i = 0; i < 3; ++i) {
    line += ',';
    if (result.view_dir_in_object) line += Number((*result.view_dir_in_object)[i]);
  }
  line += ',' + OptionalNumber(result.roll_deg);
  line += ',' + CsvField(result.status);
  line += ',' + OptionalNumber(result.time_ms);
  line += ',';
  if (result.particles > 0) line += std::to_string(result.particles);
  line += ',' + OptionalNumber(result.effective_particles);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      line += ',';
      if (result.camera_from_object) line += ExactNumber(result.camera_from_object->rotation(r, c));
    }
  }
  for (int i = 0; i < 3; ++i) {
    line += ',';
    if (result.camera_from_object) line += ExactNumber(result.camera_from_object->translation[i]);
  }
  for (const double ms : {result.time_segment_ms, result.time_describe_ms, result.time_match_ms,
                          result.time_pose_ms, result.time_refine_ms})
    line += ',' + OptionalNumber(ms);
  line += ',' + OptionalNumber(result.confidence);
  line += ',' + std::string(TrackStateName(result.state));
  line += ',' + OptionalNumber(result.iou);
  line += ',' + (result.runner_up_object >= 0 ? CsvField(result.runner_up_name) : std::string());
  line += ',' + OptionalNumber(result.runner_up_mass);
  for (int i = 0; i < 3; ++i) {
    line += ',';
    if (result.runner_up_view_dir) line += Number((*result.runner_up_view_dir)[i]);
  }
  line += ',' + OptionalNumber(result.runner_up_roll_deg);
  WriteLine(path_, &stream_, line);
}

void PosesCsvWriter::Close() { CloseChecked(path_, &stream_); }

JsonLinesWriter::JsonLinesWriter(const std::filesystem::path& path) : path_(path) {
  Open(path_, &stream_);
}

void JsonLinesWriter::Write(const FrameResult& result) {
  nlohmann::json object;
  object["frame"] = result.frame;
  object["frame_name"] =
      result.frame_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(result.frame_name);
  object["status"] = result.status;
  object["object"] =
      result.object_name.empty() ? nlohmann::json(nullptr) : nlohmann::json(result.object_name);
  object["object_index"] = result.object >= 0 ? nlohmann::json(result.object) : nullptr;
  object["score"] = JsonNumber(result.score);
  object["probability"] = JsonNumber(result.probability);
  if (result.view_dir_in_object) {
    const Eigen::Vector3d& d = *result.view_dir_in_object;
    object["view_dir"] = {d.x(), d.y(), d.z()};
  } else {
    object["view_dir"] = nullptr;
  }
  object["roll_deg"] = JsonNumber(result.roll_deg);
  object["time_ms"] = JsonNumber(result.time_ms);
  object["time_segment_ms"] = JsonNumber(result.time_segment_ms);
  object["time_describe_ms"] = JsonNumber(result.time_describe_ms);
  object["time_match_ms"] = JsonNumber(result.time_match_ms);
  object["time_pose_ms"] = JsonNumber(result.time_pose_ms);
  object["time_refine_ms"] = JsonNumber(result.time_refine_ms);
  object["particles"] = result.particles > 0 ? nlohmann::json(result.particles) : nullptr;
  object["effective_particles"] = JsonNumber(result.effective_particles);
  if (result.camera_from_object) {
    const Eigen::Matrix3d& rotation = result.camera_from_object->rotation;
    const Eigen::Vector3d& translation = result.camera_from_object->translation;
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) rows.push_back({rotation(r, 0), rotation(r, 1), rotation(r, 2)});
    object["pose"] = {{"R", rows}, {"t", {translation.x(), translation.y(), translation.z()}}};
  } else {
    object["pose"] = nullptr;
  }
  object["confidence"] = JsonNumber(result.confidence);
  object["state"] = TrackStateName(result.state);
  object["iou"] = JsonNumber(result.iou);
  if (result.runner_up_object >= 0) {
    nlohmann::json runner_up;
    runner_up["object"] = result.runner_up_name;
    runner_up["object_index"] = result.runner_up_object;
    runner_up["mass"] = JsonNumber(result.runner_up_mass);
    if (result.runner_up_view_dir) {
      const Eigen::Vector3d& d = *result.runner_up_view_dir;
      runner_up["view_dir"] = {d.x(), d.y(), d.z()};
    } else {
      runner_up["view_dir"] = nullptr;
    }
    runner_up["roll_deg"] = JsonNumber(result.runner_up_roll_deg);
    object["runner_up"] = runner_up;
  } else {
    object["runner_up"] = nullptr;
  }
  // Replace invalid UTF-8 in names rather than throwing midway through a run.
  WriteLine(path_, &stream_, object.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

void JsonLinesWriter::Close() { CloseChecked(path_, &stream_); }

bool BopOutputOptions::Check(std::string* error) const {
  auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (scene_id < 0) return fail("scene_id must be >= 0");
  for (int id : object_ids) {
    if (id < 0) return fail("object ids must be >= 0");
  }
  if (!(model_unit_mm > 0.0) || !std::isfinite(model_unit_mm)) {
    return fail("model_unit_mm must be positive and finite");
  }
  return true;
}

BopCsvWriter::BopCsvWriter(const std::filesystem::path& path, const BopOutputOptions& options)
    : path_(path), options_(options) {
  std::string error;
  if (!options_.Check(&error)) ThrowError(path_.string(), ": invalid BOP output options: ", error);
  Open(path_, &stream_);
  WriteLine(path_, &stream_, "scene_id,im_id,obj_id,score,R,t,time");
}

bool BopCsvWriter::Write(const FrameResult& result) {
  if (result.object < 0 || !result.camera_from_object) return false;
  int object_id = result.object + 1;
  if (!options_.object_ids.empty()) {
    if (result.object >= static_cast<int>(options_.object_ids.size())) {
      ThrowError(path_.string(), ": no BOP object id for model index ", result.object, " (",
                 options_.object_ids.size(), " ids given)");
    }
    object_id = options_.object_ids[static_cast<size_t>(result.object)];
  }
  const Rigid3& pose = *result.camera_from_object;
  std::string line = std::to_string(options_.scene_id) + ',' +
                     std::to_string(result.image_id >= 0 ? result.image_id : result.frame) + ',' +
                     std::to_string(object_id) + ',' +
                     Number(std::isfinite(result.score) ? result.score : 0.0) + ',';
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (r + c > 0) line += ' ';
      line += ExactNumber(pose.rotation(r, c));
    }
  }
  line += ',';
  for (int i = 0; i < 3; ++i) {
    if (i > 0) line += ' ';
    line += ExactNumber(pose.translation[i] * options_.model_unit_mm);
  }
  line += ',' + Number(std::isfinite(result.time_ms) ? result.time_ms / 1000.0 : -1.0);
  WriteLine(path_, &stream_, line);
  return true;
}

void BopCsvWriter::Close() { CloseChecked(path_, &stream_); }

}  // namespace silpose
