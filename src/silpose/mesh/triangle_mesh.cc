#include "silpose/mesh/triangle_mesh.h"

#include <assimp/BaseImporter.h>
#include <assimp/config.h>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <assimp/Importer.hpp>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <csignal>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "silpose/util/child_process.h"
#include "silpose/util/error.h"

// Formats are read by assimp, except OFF and PLY: assimp 5.2.5 hangs on a PLY file whose header is
// cut off, reads past the end of truncated binary PLY data, accepts out-of-range PLY face indices,
// aborts (ai_assert) on truncated OFF files and drops OFF faces of more than 9 vertices. Both
// formats are simple, so they are read here, with every count and index checked against the file.

namespace silpose {
namespace {

namespace fs = std::filesystem;

/// Vertices (in the output frame) and the triangles of one part of a file, indices into
/// `positions`.
struct Part {
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::array<uint32_t, 3>> triangles;
};

// Hashable exact identity of a vertex position (-0 and +0 are the same position).
struct PositionKey {
  std::array<uint32_t, 3> bits;
  bool operator==(const PositionKey&) const = default;
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& key) const {
    uint64_t hash = 1469598103934665603ull;  // FNV-1a over the three words
    for (uint32_t word : key.bits) hash = (hash ^ word) * 1099511628211ull;
    return static_cast<size_t>(hash);
  }
};

/// Merges parts into one mesh. Only vertices used by a triangle are kept, and vertices with exactly
/// equal positions are shared, also across parts (so a cube has 8 vertices in every format).
class MeshBuilder {
 public:
  MeshBuilder(const fs::path& path, TriangleMesh& mesh) : path_(path), mesh_(mesh) {}

  void Add(const Part& part) {
    constexpr uint32_t kUnset = std::numeric_limits<uint32_t>::max();
    output_index_.assign(part.positions.size(), kUnset);
    for (const std::array<uint32_t, 3>& triangle : part.triangles) {
      std::array<uint32_t, 3> output;
      for (size_t k = 0; k < 3; ++k) {
        const uint32_t v = triangle[k];
        SILPOSE_ASSERT(v < part.positions.size());
        if (output_index_[v] == kUnset) output_index_[v] = AddVertex(part.positions[v]);
        output[k] = output_index_[v];
      }
      mesh_.triangles.push_back(output);
    }
  }

 private:
  uint32_t AddVertex(const Eigen::Vector3d& position) {
    const Eigen::Vector3f p = position.cast<float>();
    if (!p.allFinite()) {
      ThrowError(path_.string(), ": vertex ", mesh_.vertices.size(),
                 " has a non-finite coordinate");
    }
    const PositionKey key{{std::bit_cast<uint32_t>(p.x() + 0.0f),
                           std::bit_cast<uint32_t>(p.y() + 0.0f),
                           std::bit_cast<uint32_t>(p.z() + 0.0f)}};
    const auto [it, inserted] =
        index_of_position_.try_emplace(key, static_cast<uint32_t>(mesh_.vertices.size()));
    if (inserted) {
      if (mesh_.vertices.size() == std::numeric_limits<uint32_t>::max()) {
        ThrowError(path_.string(), ": too many vertices");
      }
      mesh_.vertices.push_back(p);
    }
    return it->second;
  }

  const fs::path& path_;
  TriangleMesh& mesh_;
  std::unordered_map<PositionKey, uint32_t, PositionKeyHash> index_of_position_;
  std::vector<uint32_t> output_index_;  // per vertex of the current part
};

[[noreturn]] void ThrowUnreadable(const fs::path& path, const std::string& reason) {
  ThrowError(path.string(), ": cannot read mesh: ", reason);
}

/// Appends the triangles of a polygon with the given vertex indices, as a fan (as OFF and PLY
/// polygons are convex in practice). Polygons of fewer than 3 vertices (points, lines) are dropped.
void AddPolygon(const std::vector<uint32_t>& polygon, Part& part) {
  for (size_t k = 2; k < polygon.size(); ++k) {
    part.triangles.push_back({polygon[0], polygon[k - 1], polygon[k]});
  }
}

void CheckIndices(const fs::path& path, const Part& part) {
  for (const std::array<uint32_t, 3>& triangle : part.triangles) {
    for (uint32_t v : triangle) {
      if (v >= part.positions.size()) {
        ThrowUnreadable(path, "a face references vertex " + std::to_string(v) + " but there are " +
                                  std::to_string(part.positions.size()) + " vertices");
      }
    }
  }
}

// File text for an error message: printable ASCII only, at most 40 characters.
std::string Quote(std::string_view text) {
  std::string quoted = "'";
  for (char c : text.substr(0, 40)) quoted += (c >= ' ' && c <= '~') ? c : '?';
  return quoted + (text.size() > 40 ? "...'" : "'");
}

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f'; }

std::optional<double> ParseNumber(std::string_view token) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

std::optional<uint32_t> ParseIndex(double value) {
  if (!(value >= 0.0 && value <= std::numeric_limits<uint32_t>::max()) ||
      value != std::floor(value)) {
    return std::nullopt;
  }
  return static_cast<uint32_t>(value);
}

// ------------------------------------------------------------------------------------------------
// OFF (Geomview object file format): "[ST][C][N]OFF", then "vertices faces edges", then one vertex
// per line (x y z, anything after ignored), then one face per line (n i_1 ... i_n, colour ignored).

std::vector<std::string_view> SplitTokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && IsSpace(line[i])) ++i;
    const size_t start = i;
    while (i < line.size() && !IsSpace(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// The token lists of the lines with content, comments removed.
std::vector<std::vector<std::string_view>> ContentLines(std::string_view text) {
  std::vector<std::vector<std::string_view>> lines;
  while (!text.empty()) {
    const size_t end = std::min(text.find('\n'), text.size());
    std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    line = line.substr(0, std::min(line.find('#'), line.size()));
    std::vector<std::string_view> tokens = SplitTokens(line);
    if (!tokens.empty()) lines.push_back(std::move(tokens));
  }
  return lines;
}

// Whether `token` is an OFF keyword: optional ST, C, N, 4, n prefixes, then OFF.
bool IsOffKeyword(std::string_view token) {
  for (std::string_view prefix : {"ST", "C", "N", "4", "n"}) {
    if (token.starts_with(prefix)) token.remove_prefix(prefix.size());
  }
  return token == "OFF";
}

Part ReadOff(const fs::path& path, std::string_view text) {
  const std::vector<std::vector<std::string_view>> lines = ContentLines(text);
  size_t line = 0;
  size_t token = 0;
  if (!lines.empty() && IsOffKeyword(lines[0][0])) {
    const std::string_view keyword = lines[0][0];
    if (keyword.find('4') != std::string_view::npos ||
        keyword.find('n') != std::string_view::npos) {
      ThrowUnreadable(path, "OFF variant " + Quote(keyword) + " is not supported");
    }
    if (lines[0].size() > 1 && lines[0][1] == "BINARY") {
      ThrowUnreadable(path, "binary OFF is not supported");
    }
    if (lines[0].size() > 1) {
      token = 1;  // the counts follow the keyword on the same line
    } else {
      line = 1;
    }
  }
  if (line >= lines.size() || lines[line].size() < token + 2) {
    ThrowUnreadable(path, "OFF header has no vertex and face counts");
  }
  const std::optional<double> vertex_count = ParseNumber(lines[line][token]);
  const std::optional<double> face_count = ParseNumber(lines[line][token + 1]);
  const std::optional<uint32_t> vertex_total =
      vertex_count ? ParseIndex(*vertex_count) : std::nullopt;
  const std::optional<uint32_t> face_total = face_count ? ParseIndex(*face_count) : std::nullopt;
  if (!vertex_total || !face_total) {
    ThrowUnreadable(path, "OFF header has invalid vertex or face counts");
  }
  // Plain values from here on (GCC 12 takes an optional read after the test for uninitialised).
  const uint32_t vertices = vertex_total.value_or(0);
  const uint32_t faces = face_total.value_or(0);
  ++line;
  if (lines.size() - line < size_t{vertices} + faces) {
    ThrowUnreadable(path, "OFF file has fewer lines than its " + std::to_string(vertices) +
                              " vertices and " + std::to_string(faces) +
                              " faces need (truncated file?)");
  }

  Part part;
  part.positions.reserve(vertices);
  for (uint32_t v = 0; v < vertices; ++v, ++line) {
    const std::vector<std::string_view>& tokens = lines[line];
    Eigen::Vector3d position;
    for (int k = 0; k < 3; ++k) {
      const std::optional<double> value =
          k < static_cast<int>(tokens.size()) ? ParseNumber(tokens[k]) : std::nullopt;
      if (!value) ThrowUnreadable(path, "OFF vertex " + std::to_string(v) + " is not x y z");
      position[k] = *value;
    }
    part.positions.push_back(position);
  }
  std::vector<uint32_t> polygon;
  for (uint32_t f = 0; f < faces; ++f, ++line) {
    const std::vector<std::string_view>& tokens = lines[line];
    const std::optional<double> count = ParseNumber(tokens[0]);
    const std::optional<uint32_t> n = count ? ParseIndex(*count) : std::nullopt;
    if (!n || tokens.size() - 1 < *n) {
      ThrowUnreadable(path, "OFF face " + std::to_string(f) + " is not n i_1 ... i_n");
    }
    polygon.clear();
    for (uint32_t k = 1; k <= *n; ++k) {
      const std::optional<double> value = ParseNumber(tokens[k]);
      const std::optional<uint32_t> index = value ? ParseIndex(*value) : std::nullopt;
      if (!index) ThrowUnreadable(path, "OFF face " + std::to_string(f) + " has a bad index");
      polygon.push_back(*index);
    }
    AddPolygon(polygon, part);
  }
  CheckIndices(path, part);
  return part;
}

// ------------------------------------------------------------------------------------------------
// PLY (Stanford polygon file format), ASCII and binary: element "vertex" with properties x, y, z
// and element "face" with list property "vertex_indices" (or "vertex_index"); other data is
// skipped.

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<PlyType> ParsePlyType(std::string_view name) {
  static const std::pair<std::string_view, PlyType> kTypes[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [type_name, type] : kTypes) {
    if (name == type_name) return type;
  }
  return std::nullopt;
}

size_t SizeOf(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // of the value, or of the list items
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

/// Reads the values of the PLY body, in ASCII or binary, never past its end.
class PlyReader {
 public:
  PlyReader(const fs::path& path, std::string_view body, PlyFormat format)
      : path_(path), body_(body), format_(format) {}

  double Read(PlyType type) {
    if (format_ == PlyFormat::kAscii) return ReadAscii();
    const size_t size = SizeOf(type);
    if (body_.size() - position_ < size) ThrowTruncated();
    unsigned char bytes[8];
    std::memcpy(bytes, body_.data() + position_, size);
    position_ += size;
    const bool swap =
        (format_ == PlyFormat::kBinaryLittleEndian) != (std::endian::native == std::endian::little);
    if (swap) std::reverse(bytes, bytes + size);
    return Decode(type, bytes);
  }

  /// Throws if fewer than `count` values of `type` can be left (an ASCII value takes at least one
  /// byte), before anything is allocated for them.
  void Require(uint64_t count, PlyType type) const {
    const size_t value_size = format_ == PlyFormat::kAscii ? 1 : SizeOf(type);
    if (count > (body_.size() - position_) / value_size) ThrowTruncated();
  }

  [[noreturn]] void ThrowTruncated() const {
    ThrowUnreadable(path_, "PLY data ends early (truncated file?)");
  }

 private:
  double ReadAscii() {
    while (position_ < body_.size() && IsSpace(body_[position_])) ++position_;
    const size_t start = position_;
    while (position_ < body_.size() && !IsSpace(body_[position_])) ++position_;
    if (position_ == start) ThrowTruncated();
    const std::optional<double> value = ParseNumber(body_.substr(start, position_ - start));
    if (!value) {
      ThrowUnreadable(
          path_, "PLY value " + Quote(body_.substr(start, position_ - start)) + " is not a number");
    }
    return *value;
  }

  template <typename T>
  static double As(const unsigned char* bytes) {
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return static_cast<double>(value);
  }

  static double Decode(PlyType type, const unsigned char* bytes) {
    switch (type) {
      case PlyType::kInt8:
        return As<int8_t>(bytes);
      case PlyType::kUint8:
        return As<uint8_t>(bytes);
      case PlyType::kInt16:
        return As<int16_t>(bytes);
      case PlyType::kUint16:
        return As<uint16_t>(bytes);
      case PlyType::kInt32:
        return As<int32_t>(bytes);
      case PlyType::kUint32:
        return As<uint32_t>(bytes);
      case PlyType::kFloat32:
        return As<float>(bytes);
      case PlyType::kFloat64:
        return As<double>(bytes);
    }
    return 0.0;
  }

  const fs::path& path_;
  std::string_view body_;
  PlyFormat format_;
  size_t position_ = 0;
};

bool StartsWithCaseInsensitive(std::string_view text, std::string_view lower_case_prefix) {
  if (text.size() < lower_case_prefix.size()) return false;
  for (size_t k = 0; k < lower_case_prefix.size(); ++k) {
    if (std::tolower(static_cast<unsigned char>(text[k])) != lower_case_prefix[k]) return false;
  }
  return true;
}

[[noreturn]] void ThrowBadPlyHeaderLine(const fs::path& path, std::string_view line) {
  if (line.ends_with('\r')) line.remove_suffix(1);
  ThrowUnreadable(path, "bad PLY header line " + Quote(line));
}

// Whether the file starts like a PLY file (case-insensitively, as assimp's PLY reader checks).
bool IsPlyMagic(std::string_view text) { return StartsWithCaseInsensitive(text, "ply"); }

Part ReadPly(const fs::path& path, std::string_view text) {
  const std::string_view first_line = text.substr(0, std::min(text.find('\n'), text.size()));
  const std::vector<std::string_view> magic = SplitTokens(first_line);
  if (magic.size() != 1 || magic[0].size() != 3 || !IsPlyMagic(magic[0])) {
    ThrowUnreadable(path, "not a PLY file (its first line is not 'ply')");
  }

  // Header: one keyword line at a time up to "end_header".
  std::optional<PlyFormat> format;
  std::vector<PlyElement> elements;
  size_t offset = first_line.size() + 1;
  bool header_ended = false;
  while (!header_ended) {
    const size_t end = text.find('\n', offset);
    if (end == std::string_view::npos) {
      ThrowUnreadable(path, "PLY header has no end_header line (truncated file?)");
    }
    const std::string_view line = text.substr(offset, end - offset);
    const std::vector<std::string_view> tokens = SplitTokens(line);
    offset = end + 1;
    if (tokens.empty()) continue;
    const std::string_view keyword = tokens[0];
    if (keyword == "comment" || keyword == "obj_info") {
      continue;
    } else if (keyword == "end_header") {
      header_ended = true;
    } else if (keyword == "format") {
      if (tokens.size() < 2) ThrowBadPlyHeaderLine(path, line);
      if (tokens[1] == "ascii") {
        format = PlyFormat::kAscii;
      } else if (tokens[1] == "binary_little_endian") {
        format = PlyFormat::kBinaryLittleEndian;
      } else if (tokens[1] == "binary_big_endian") {
        format = PlyFormat::kBinaryBigEndian;
      } else {
        ThrowUnreadable(path, "unknown PLY format " + Quote(tokens[1]));
      }
    } else if (keyword == "element") {
      if (tokens.size() < 3) ThrowBadPlyHeaderLine(path, line);
      PlyElement element;
      element.name = tokens[1];
      const auto [ptr, error] =
          std::from_chars(tokens[2].data(), tokens[2].data() + tokens[2].size(), element.count);
      if (error != std::errc() || ptr != tokens[2].data() + tokens[2].size()) {
        ThrowBadPlyHeaderLine(path, line);
      }
      elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (elements.empty()) ThrowUnreadable(path, "PLY header has a property before any element");
      PlyProperty property;
      if (tokens.size() >= 5 && tokens[1] == "list") {
        const std::optional<PlyType> count_type = ParsePlyType(tokens[2]);
        const std::optional<PlyType> item_type = ParsePlyType(tokens[3]);
        if (!count_type || !item_type) ThrowBadPlyHeaderLine(path, line);
        property = {std::string(tokens[4]), *item_type, true, *count_type};
      } else if (tokens.size() >= 3) {
        const std::optional<PlyType> type = ParsePlyType(tokens[1]);
        if (!type) ThrowBadPlyHeaderLine(path, line);
        property = {std::string(tokens[2]), *type, false, PlyType::kUint8};
      } else {
        ThrowBadPlyHeaderLine(path, line);
      }
      elements.back().properties.push_back(std::move(property));
    } else {
      ThrowBadPlyHeaderLine(path, line);
    }
  }
  if (!format) ThrowUnreadable(path, "PLY header has no format line");

  Part part;
  std::vector<uint32_t> polygon;
  PlyReader reader(path, text.substr(offset), *format);
  for (const PlyElement& element : elements) {
    if (element.properties.empty()) continue;  // no data to read
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    std::array<int, 3> xyz = {-1, -1, -1};  // property index of x, y, z
    int indices = -1;                       // property index of the face's vertex list
    for (size_t p = 0; p < element.properties.size(); ++p) {
      const PlyProperty& property = element.properties[p];
      if (is_vertex && !property.is_list) {
        for (int k = 0; k < 3; ++k) {
          if (property.name.size() == 1 && property.name[0] == "xyz"[k]) {
            xyz[k] = static_cast<int>(p);
          }
        }
      }
      if (is_face && property.is_list && indices < 0 &&
          (property.name == "vertex_indices" || property.name == "vertex_index")) {
        indices = static_cast<int>(p);
      }
    }
    if (is_vertex && std::find(xyz.begin(), xyz.end(), -1) != xyz.end()) {
      ThrowUnreadable(path, "PLY vertex element has no x, y and z properties");
    }
    if (is_face && indices < 0) {
      ThrowUnreadable(path, "PLY face element has no vertex_indices list");
    }
    if (is_vertex) {
      if (element.count > std::numeric_limits<uint32_t>::max()) reader.ThrowTruncated();
      reader.Require(element.count * element.properties.size(), PlyType::kUint8);
      part.positions.reserve(part.positions.size() + element.count);
    }
    for (uint64_t i = 0; i < element.count; ++i) {
      Eigen::Vector3d position = Eigen::Vector3d::Zero();
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (!property.is_list) {
          const double value = reader.Read(property.type);
          for (int k = 0; k < 3; ++k) {
            if (xyz[k] == static_cast<int>(p)) position[k] = value;
          }
          continue;
        }
        const std::optional<uint32_t> count = ParseIndex(reader.Read(property.count_type));
        if (!count) ThrowUnreadable(path, "PLY list has a bad length");
        reader.Require(*count, property.type);
        const bool is_polygon = static_cast<int>(p) == indices;
        if (is_polygon) polygon.clear();
        for (uint32_t k = 0; k < *count; ++k) {
          const double value = reader.Read(property.type);
          if (!is_polygon) continue;
          const std::optional<uint32_t> index = ParseIndex(value);
          if (!index) ThrowUnreadable(path, "PLY face " + std::to_string(i) + " has a bad index");
          polygon.push_back(*index);
        }
        if (is_polygon) AddPolygon(polygon, part);
      }
      if (is_vertex) part.positions.push_back(position);
    }
  }
  CheckIndices(path, part);
  return part;
}

// ------------------------------------------------------------------------------------------------
// Everything else: assimp.

Eigen::Affine3d ToEigen(const aiMatrix4x4& m) {
  Eigen::Affine3d transform = Eigen::Affine3d::Identity();
  transform.matrix() << m.a1, m.a2, m.a3, m.a4,  //
      m.b1, m.b2, m.b3, m.b4,                    //
      m.c1, m.c2, m.c3, m.c4,                    //
      0.0, 0.0, 0.0, 1.0;
  return transform;
}

// Runs an assimp step that returns the scene, or null with the reason in the importer's error.
template <typename Step>
const aiScene* RunAssimp(const fs::path& path, const Assimp::Importer& importer, const Step& step) {
  const aiScene* scene = nullptr;
  try {
    scene = step();
  } catch (const std::exception& exception) {  // assimp normally catches its own exceptions
    ThrowUnreadable(path, exception.what());
  }
  if (scene == nullptr) {
    const std::string reason = importer.GetErrorString();
    // assimp catches a failed allocation and keeps only its name: say what it means.
    if (reason == "std::bad_alloc") {
      ThrowUnreadable(path,
                      "the file asks for more memory than there is (a corrupt count or size?)");
    }
    ThrowUnreadable(path, reason.empty() ? "unknown assimp error" : reason);
  }
  return scene;
}

bool HasPolygons(const aiScene& scene) {
  if (scene.mMeshes == nullptr) return false;
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    const aiMesh* mesh = scene.mMeshes[m];
    if (mesh != nullptr && mesh->mNumFaces > 0 &&
        (mesh->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON))) {
      return true;
    }
  }
  return false;
}

// Adds every mesh instance of the node tree, placed by the product of the node transforms down
// from the root, as one part.
void AddAssimpScene(const aiScene& scene, MeshBuilder& builder) {
  // Depth-first walk with an explicit stack: a deep node tree cannot overflow the call stack.
  std::vector<std::pair<const aiNode*, Eigen::Affine3d>> stack;
  stack.emplace_back(scene.mRootNode, ToEigen(scene.mRootNode->mTransformation));
  Part part;
  while (!stack.empty()) {
    const auto [node, transform] = stack.back();
    stack.pop_back();
    for (unsigned c = 0; c < node->mNumChildren; ++c) {
      const aiNode* child = node->mChildren[c];
      stack.emplace_back(child, transform * ToEigen(child->mTransformation));
    }
    for (unsigned m = 0; m < node->mNumMeshes; ++m) {
      SILPOSE_ASSERT(node->mMeshes[m] < scene.mNumMeshes);
      const aiMesh& mesh = *scene.mMeshes[node->mMeshes[m]];
      if (!(mesh.mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) continue;  // points, lines
      part.positions.resize(mesh.mNumVertices);
      for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D& p = mesh.mVertices[v];
        part.positions[v] = transform * Eigen::Vector3d(p.x, p.y, p.z);
      }
      part.triangles.clear();
      for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices != 3) continue;  // a point or line among the triangles
        part.triangles.push_back({face.mIndices[0], face.mIndices[1], face.mIndices[2]});
      }
      builder.Add(part);
    }
  }
}

std::string LowerCaseExtension(const fs::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

// When several of assimp's readers claim a file's name (glTF 1 and glTF 2 share .gltf and .glb;
// several XML formats share .xml) and none of them recognises the content, assimp tries every
// reader it has on the content and may read the file as some other format: a corrupt .glb file
// was taken for a Quick3D file whose header asked for terabytes. Such a file is refused: its name
// says a format its content is not in. (A file of another format under a shared extension, e.g.
// an X3D file named .xml, must be given its own extension.) The readers are found as assimp finds
// them: a reader claims the file if its name ends, case aside, with "." and one of the reader's
// extensions (so Ogre's .mesh.xml is its own). Quick3D files are refused too (below).
void CheckContentMatchesName(const fs::path& path, const Assimp::Importer& importer) {
  std::string name = path.filename().string();
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::vector<Assimp::BaseImporter*> readers;  // the readers that claim the file's name
  std::string claimed;                         // the shortest extension claimed, for the message
  Assimp::BaseImporter* quick3d_reader = nullptr;
  for (size_t i = 0; i < importer.GetImporterCount(); ++i) {
    Assimp::BaseImporter* reader = importer.GetImporter(i);
    if (reader == nullptr) continue;
    std::set<std::string> extensions;
    reader->GetExtensionList(extensions);
    if (extensions.contains("q3o")) quick3d_reader = reader;
    for (std::string extension : extensions) {
      for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (!name.ends_with("." + extension)) continue;
      readers.push_back(reader);
      if (claimed.empty() || extension.size() < claimed.size()) claimed = extension;
      break;
    }
  }
  // Quick3D: assimp's reader sizes its arrays by the counts in the file before it reads them, so
  // a few corrupt bytes can make it ask for terabytes (refused by the allocator) or for gigabytes
  // it then fills (which can exhaust the machine's memory). The format is not read at all: not
  // under its own extensions, nor when assimp would recognise it by content (no reader claims the
  // name and the Quick3D reader recognises the file).
  if (quick3d_reader != nullptr) {
    bool quick3d = std::find(readers.begin(), readers.end(), quick3d_reader) != readers.end();
    if (!quick3d && readers.empty()) {
      try {
        quick3d = quick3d_reader->CanRead(path.string(), importer.GetIOHandler(), true);
      } catch (const std::exception& exception) {
        ThrowUnreadable(path, exception.what());
      }
    }
    if (quick3d) {
      ThrowUnreadable(path,
                      "Quick3D files are not read (a corrupt one can exhaust the memory); convert "
                      "the mesh to OBJ, PLY, STL or glTF");
    }
  }
  if (readers.size() < 2) return;  // assimp reads the file with the one reader, or by content
  for (Assimp::BaseImporter* reader : readers) {
    bool recognised = false;
    try {
      recognised = reader->CanRead(path.string(), importer.GetIOHandler(), true);
    } catch (const std::exception& exception) {
      ThrowUnreadable(path, exception.what());
    }
    if (recognised) return;
  }
  ThrowUnreadable(path, "the content is not that of a ." + claimed + " file");
}

void ReadWithAssimp(const fs::path& path, MeshBuilder& builder) {
  Assimp::Importer importer;  // no assimp DefaultLogger is created, so assimp prints nothing
  CheckContentMatchesName(path, importer);
  // Keep the file's own axes for Collada (assimp would otherwise rotate Z-up files to Y-up). No
  // unit scaling: aiProcess_GlobalScale is not requested and FBX is not converted to metres.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  importer.SetPropertyBool(AI_CONFIG_FBX_CONVERT_TO_M, false);
  importer.SetPropertyBool(AI_CONFIG_PP_PTV_NORMALIZE, false);
  importer.SetPropertyFloat(AI_CONFIG_GLOBAL_SCALE_FACTOR_KEY, 1.0f);
  // Skeleton-only files must not turn into a made-up bone mesh.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);

  // Import without post-processing first, so that a file without polygons (e.g. a point cloud,
  // which assimp's validation rejects as "contains no faces") is reported as having no triangles.
  const aiScene* scene =
      RunAssimp(path, importer, [&] { return importer.ReadFile(path.string(), 0); });
  if (!HasPolygons(*scene)) ThrowError(path.string(), ": mesh has no triangles");
  // Validate before any other step: a corrupt scene from a malformed file (null pointers, faces
  // without indices, out-of-range indices) becomes an error rather than an assimp assertion abort.
  scene = RunAssimp(path, importer,
                    [&] { return importer.ApplyPostProcessing(aiProcess_ValidateDataStructure); });
  // Polygons become triangles, vertices identical in every attribute are shared, and each mesh
  // holds one primitive type. Deliberately absent: aiProcess_GlobalScale,
  // aiProcess_PreTransformVertices (node transforms are applied while merging),
  // aiProcess_MakeLeftHanded and anything else that changes units or axes.
  scene = RunAssimp(path, importer, [&] {
    return importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                        aiProcess_SortByPType);
  });
  if (scene->mRootNode == nullptr) ThrowUnreadable(path, "the file has no scene graph");
  AddAssimpScene(*scene, builder);
}

// assimp's readers of some formats (DirectX .x, Collada, X3D, its own .assbin among them) crash on
// corrupt files inside Importer::ReadFile (a segmentation fault on an index or offset they do not
// check, a double free, a failed internal assertion), where no check of the result can come first.
// So assimp reads in a child process: a crash there becomes this file's error, not the caller's
// end, and the child's address space is capped so that a file asking for absurd sizes cannot take
// the machine's memory. The child sends back the merged mesh (or its error) through a pipe.

// Whether this build runs under a sanitizer, whose allocator reserves far more address space than
// it uses (no cap then).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

// In the child: at most half of the machine's memory more than the address space it starts with.
void CapReaderMemory() {
  if (kSanitized) return;
  const long page = sysconf(_SC_PAGESIZE);
  const long pages = sysconf(_SC_PHYS_PAGES);
  if (page <= 0 || pages <= 0) return;
  unsigned long long mapped_pages = 0;
  if (FILE* statm = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(statm, "%llu", &mapped_pages) != 1) mapped_pages = 0;
    std::fclose(statm);
  }
  const auto limit = static_cast<rlim_t>(mapped_pages * static_cast<unsigned long long>(page) +
                                         static_cast<unsigned long long>(pages / 2) *
                                             static_cast<unsigned long long>(page));
  rlimit current{};
  if (getrlimit(RLIMIT_AS, &current) != 0) return;
  if (current.rlim_cur != RLIM_INFINITY && current.rlim_cur <= limit) return;
  rlimit capped = current;
  capped.rlim_cur = limit;
  (void)setrlimit(RLIMIT_AS, &capped);
}

// The child's message: 0, the vertex and triangle counts (uint64) and their data as the mesh holds
// them; or 1 and the error's text.
static_assert(sizeof(Eigen::Vector3f) == 12 && sizeof(std::array<uint32_t, 3>) == 12);

std::string EncodeMesh(const TriangleMesh& mesh) {
  const uint64_t counts[2] = {mesh.vertices.size(), mesh.triangles.size()};
  std::string bytes(1, '\0');
  bytes.append(reinterpret_cast<const char*>(counts), sizeof(counts));
  bytes.append(reinterpret_cast<const char*>(mesh.vertices.data()), 12 * counts[0]);
  bytes.append(reinterpret_cast<const char*>(mesh.triangles.data()), 12 * counts[1]);
  return bytes;
}

void DecodeMesh(const fs::path& path, std::string_view bytes, TriangleMesh& mesh) {
  uint64_t counts[2] = {0, 0};
  if (bytes.size() < 1 + sizeof(counts)) {
    ThrowUnreadable(path, "its reader returned an incomplete mesh");
  }
  std::memcpy(counts, bytes.data() + 1, sizeof(counts));
  const uint64_t body = bytes.size() - 1 - sizeof(counts);
  if (counts[0] > body / 12 || counts[1] > body / 12 || 12 * (counts[0] + counts[1]) != body) {
    ThrowUnreadable(path, "its reader returned an incomplete mesh");
  }
  const char* data = bytes.data() + 1 + sizeof(counts);
  mesh.vertices.resize(counts[0]);
  std::memcpy(mesh.vertices.data(), data, 12 * counts[0]);
  mesh.triangles.resize(counts[1]);
  std::memcpy(mesh.triangles.data(), data + 12 * counts[0], 12 * counts[1]);
  for (const std::array<uint32_t, 3>& t : mesh.triangles) {
    for (const uint32_t i : t) {
      if (i >= counts[0]) ThrowUnreadable(path, "its reader returned a malformed mesh");
    }
  }
}

void ReadWithAssimpInChild(const fs::path& path, TriangleMesh& mesh) {
  const auto read_in_child = [&]() -> std::string {
    CapReaderMemory();
    // What a crashing reader prints (glibc's, assimp's or a sanitizer's report) is not the
    // file's error, which the parent reports.
    const int null = open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (null >= 0) (void)dup2(null, STDERR_FILENO);
    try {
      TriangleMesh read;
      MeshBuilder builder(path, read);
      ReadWithAssimp(path, builder);
      return EncodeMesh(read);
    } catch (const std::exception& exception) {
      return std::string(1, '\1') + exception.what();
    } catch (...) {
      return std::string(1, '\1') + path.string() + ": cannot read mesh: unknown error";
    }
  };
  // A child forked while another thread of this process held a lock can wait for it forever
  // (RunInChildProcess explains): it is killed and the reading tried again; the lock is seldom
  // held twice in a row.
  constexpr int kAttempts = 3;
  ChildProcessResult child;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    child = RunInChildProcess(read_in_child);
    if (!child.started || !child.stuck) break;
  }
  if (!child.started || child.stuck) {
    // No child could be made, or none got anywhere: assimp reads here, as it would anyway.
    MeshBuilder builder(path, mesh);
    ReadWithAssimp(path, builder);
    return;
  }
  const int status = child.wait_status;
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    const char* name = sigabbrev_np(signal);
    ThrowUnreadable(path, "the reader of its format crashed on it (SIG" +
                              std::string(name != nullptr ? name : std::to_string(signal)) +
                              "); the file is probably corrupt");
  }
  const std::string& message = child.output;
  if (message.empty() || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    ThrowUnreadable(path, "the reader of its format failed on it (exit status " +
                              std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                              "); the file is probably corrupt");
  }
  if (message[0] == '\1') ThrowError(message.substr(1));  // the child's error names the file
  DecodeMesh(path, message, mesh);
}

// The first `max_bytes` bytes of the file (all of it by default).
std::string ReadFileBytes(const fs::path& path,
                          size_t max_bytes = std::numeric_limits<size_t>::max()) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (status.type() == fs::file_type::not_found) ThrowError(path.string(), ": no such file");
  if (error) ThrowError(path.string(), ": cannot access file: ", error.message());
  if (status.type() == fs::file_type::directory) {
    ThrowError(path.string(), ": is a directory, not a mesh file");
  }
  std::ifstream stream(path, std::ios::binary);
  if (!stream) ThrowError(path.string(), ": cannot open file for reading");
  std::string bytes;
  std::vector<char> buffer(1 << 16);
  while (stream && bytes.size() < max_bytes) {
    stream.read(buffer.data(),
                static_cast<std::streamsize>(std::min(buffer.size(), max_bytes - bytes.size())));
    bytes.append(buffer.data(), static_cast<size_t>(stream.gcount()));
  }
  if (stream.bad()) ThrowError(path.string(), ": read error");
  if (bytes.empty()) ThrowError(path.string(), ": file is empty");
  return bytes;
}

uint32_t LittleEndianU32(std::string_view bytes) {
  uint32_t value = 0;
  for (size_t k = 0; k < 4; ++k) value |= uint32_t{static_cast<unsigned char>(bytes[k])} << (8 * k);
  return value;
}

// Binary glTF: assimp allocates whatever a (corrupt) header claims, up to 4 GB, before it notices
// that the file is shorter; check the lengths against the file first.
void CheckGlbHeader(const fs::path& path, std::string_view head) {
  if (!head.starts_with("glTF")) return;
  std::error_code error;
  const uintmax_t file_size = fs::file_size(path, error);
  if (error) return;  // let assimp report it
  if (head.size() < 20 || LittleEndianU32(head.substr(8)) > file_size ||
      LittleEndianU32(head.substr(12)) > file_size - 20) {
    ThrowUnreadable(path, "binary glTF header lengths exceed the file size (truncated file?)");
  }
}

// Collada: assimp's reader of an index list (<p>, <vcount>, <v>, <h>, <int_array>) does not
// move past a token that is not a number and keeps adding indices until the memory runs out (one
// letter in a <p> list made it take every gigabyte it was allowed). Every token of those lists is
// checked to be an integer first.
void CheckColladaIndexLists(const fs::path& path, std::string_view head) {
  if (head.find("<COLLADA") == std::string_view::npos) return;
  const std::string text = ReadFileBytes(path);
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  for (const std::string_view tag : {"p", "vcount", "v", "h", "int_array"}) {
    std::string open(1, '<');
    open.append(tag);
    for (size_t at = text.find(open); at != std::string::npos; at = text.find(open, at + 1)) {
      const size_t after = at + open.size();
      if (after >= text.size() || !(text[after] == '>' || is_space(text[after]))) continue;
      const size_t start_end = text.find('>', after);
      if (start_end == std::string::npos) return;  // assimp reports the broken XML
      if (text[start_end - 1] == '/') continue;    // an empty element
      const size_t content_end = std::min(text.find('<', start_end), text.size());
      size_t k = start_end + 1;
      while (k < content_end) {
        while (k < content_end && is_space(text[k])) ++k;
        const size_t token = k;
        while (k < content_end && !is_space(text[k])) ++k;
        if (k == token) break;
        size_t digit = token + ((text[token] == '-' || text[token] == '+') ? 1 : 0);
        bool integer = digit < k;
        for (; digit < k && integer; ++digit) {
          integer = std::isdigit(static_cast<unsigned char>(text[digit])) != 0;
        }
        if (!integer) {
          std::string reason = "a Collada <";
          reason.append(tag).append("> list holds \"");
          reason.append(text, token, std::min<size_t>(k - token, 20)).append("\", not an integer");
          ThrowUnreadable(path, reason);
        }
      }
    }
  }
}

// Whether the file is OFF by its extension or, when the extension is not a format's, by its first
// word (or first three letters, which is how assimp would pick its OFF reader).
bool IsOff(const std::string& extension, std::string_view text) {
  if (extension == ".off") return true;
  if (!extension.empty() && Assimp::Importer().IsExtensionSupported(extension)) return false;
  const std::vector<std::vector<std::string_view>> first =
      ContentLines(text.substr(0, std::min(text.find('\n'), text.size())));
  return (!first.empty() && IsOffKeyword(first[0][0])) || StartsWithCaseInsensitive(text, "off");
}

}  // namespace

Eigen::Vector3d TriangleMesh::Centre() const {
  if (vertices.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3f lower = vertices.front();
  Eigen::Vector3f upper = vertices.front();
  for (const Eigen::Vector3f& v : vertices) {
    lower = lower.cwiseMin(v);
    upper = upper.cwiseMax(v);
  }
  return 0.5 * (lower.cast<double>() + upper.cast<double>());
}

double TriangleMesh::Radius() const {
  const Eigen::Vector3d centre = Centre();
  double squared = 0.0;
  for (const Eigen::Vector3f& v : vertices) {
    squared = std::max(squared, (v.cast<double>() - centre).squaredNorm());
  }
  return std::sqrt(squared);
}

bool IsClosedSurface(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) return false;
  // Vertices by position: the index of the first vertex at each position (bit pattern of the
  // coordinates, with -0 taken as 0).
  struct PositionHash {
    size_t operator()(const std::array<uint32_t, 3>& key) const {
      uint64_t hash = 0x9E3779B97F4A7C15ull;
      for (uint32_t word : key) hash = (hash ^ word) * 0x100000001B3ull;
      return static_cast<size_t>(hash ^ (hash >> 29));
    }
  };
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, PositionHash> first_at;
  first_at.reserve(mesh.vertices.size());
  std::vector<uint32_t> canonical(mesh.vertices.size());
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    std::array<uint32_t, 3> key{};
    for (int k = 0; k < 3; ++k) {
      const float value = mesh.vertices[i][k] == 0.0f ? 0.0f : mesh.vertices[i][k];
      key[static_cast<size_t>(k)] = std::bit_cast<uint32_t>(value);
    }
    canonical[i] = first_at.try_emplace(key, static_cast<uint32_t>(i)).first->second;
  }
  // Per undirected edge, traversals low -> high minus high -> low.
  std::unordered_map<uint64_t, int64_t> balance;
  balance.reserve(3 * mesh.triangles.size());
  for (const std::array<uint32_t, 3>& triangle : mesh.triangles) {
    std::array<uint32_t, 3> v{};
    for (size_t k = 0; k < 3; ++k) {
      if (triangle[k] >= mesh.vertices.size()) return false;
      v[k] = canonical[triangle[k]];
    }
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t from = v[k];
      const uint32_t to = v[(k + 1) % 3];
      const uint64_t key = (static_cast<uint64_t>(std::min(from, to)) << 32) | std::max(from, to);
      balance[key] += from < to ? 1 : -1;
    }
  }
  if (balance.empty()) return false;
  return std::all_of(balance.begin(), balance.end(),
                     [](const auto& entry) { return entry.second == 0; });
}

TriangleMesh LoadMesh(const fs::path& path) {
  TriangleMesh mesh;
  mesh.name = path.stem().string();
  MeshBuilder builder(path, mesh);
  const std::string head = ReadFileBytes(path, 4096);  // enough to recognise the format
  const std::string extension = LowerCaseExtension(path);
  if (extension == ".ply" || IsPlyMagic(head)) {
    builder.Add(ReadPly(path, ReadFileBytes(path)));
  } else if (IsOff(extension, head)) {
    builder.Add(ReadOff(path, ReadFileBytes(path)));
  } else {
    CheckGlbHeader(path, head);
    CheckColladaIndexLists(path, head);
    // assimp reads the file itself (and any files it references), in a child process.
    ReadWithAssimpInChild(path, mesh);
  }
  if (mesh.triangles.empty()) ThrowError(path.string(), ": mesh has no triangles");
  for (const std::array<uint32_t, 3>& triangle : mesh.triangles) {
    for (uint32_t v : triangle) SILPOSE_ASSERT(v < mesh.vertices.size());
  }
  return mesh;
}

}  // namespace silpose
