#include "silpose/mesh/triangle_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "silpose/util/error.h"

// assimp 5.2.5 leaks on some error paths (e.g. its STL reader on a truncated ASCII STL file), which
// the corrupt-file tests exercise. Used only by LeakSanitizer (SILPOSE_SANITIZE builds).
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }

namespace silpose {
namespace {

namespace fs = std::filesystem;

// A cube with an offset and a non-unit size, so that any recentring, rescaling or axis change by
// the loader shows up. All coordinates are exact in float.
const Eigen::Vector3d kCubeCentre(10.0, -3.0, 4.0);
constexpr double kCubeHalfEdge = 1.25;

// Corner i has coordinate bits (x, y, z) = (i & 1, i & 2, i & 4).
Eigen::Vector3f CubeCorner(int i) {
  const Eigen::Vector3d sign((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
  return (kCubeCentre + kCubeHalfEdge * sign).cast<float>();
}

// Twelve outward-facing (counter-clockwise) triangles, two per face.
// clang-format off
constexpr std::array<std::array<uint32_t, 3>, 12> kCubeTriangles = {{
    {0, 4, 6}, {0, 6, 2},  // -x
    {1, 3, 7}, {1, 7, 5},  // +x
    {0, 1, 5}, {0, 5, 4},  // -y
    {2, 6, 7}, {2, 7, 3},  // +y
    {0, 2, 3}, {0, 3, 1},  // -z
    {4, 5, 7}, {4, 7, 6}}};  // +z
// clang-format on

// The six faces as outward quads.
constexpr std::array<std::array<uint32_t, 4>, 6> kCubeQuads = {
    {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}}};

std::string Number(double value) {
  std::ostringstream stream;
  stream.precision(9);
  stream << value;
  return stream.str();
}

std::string Xyz(const Eigen::Vector3f& p) {
  return Number(p.x()) + " " + Number(p.y()) + " " + Number(p.z());
}

// Little-endian binary writers.
void AppendU8(std::string& out, uint8_t value) { out.push_back(static_cast<char>(value)); }
void AppendU16(std::string& out, uint16_t value) {
  for (int shift = 0; shift < 16; shift += 8) AppendU8(out, static_cast<uint8_t>(value >> shift));
}
void AppendU32(std::string& out, uint32_t value) {
  for (int shift = 0; shift < 32; shift += 8) AppendU8(out, static_cast<uint8_t>(value >> shift));
}
void AppendF32(std::string& out, float value) { AppendU32(out, std::bit_cast<uint32_t>(value)); }
void AppendXyz(std::string& out, const Eigen::Vector3f& p) {
  for (int k = 0; k < 3; ++k) AppendF32(out, p[k]);
}
// Big-endian writer.
void AppendBigEndian(std::string& out, uint64_t value, int bytes) {
  for (int k = bytes - 1; k >= 0; --k) AppendU8(out, static_cast<uint8_t>(value >> (8 * k)));
}

std::string CubeObj() {
  std::string out = "# cube\n";
  for (int i = 0; i < 8; ++i) out += "v " + Xyz(CubeCorner(i)) + "\n";
  for (const auto& t : kCubeTriangles) {
    out += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " +
           std::to_string(t[2] + 1) + "\n";
  }
  return out;
}

std::string CubeOff() {
  std::string out = "OFF\n8 12 0\n";
  for (int i = 0; i < 8; ++i) out += Xyz(CubeCorner(i)) + "\n";
  for (const auto& t : kCubeTriangles) {
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
           "\n";
  }
  return out;
}

std::string PlyHeader(const std::string& format) {
  return "ply\nformat " + format +
         " 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 12\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string CubeAsciiPly() {
  std::string out = PlyHeader("ascii");
  for (int i = 0; i < 8; ++i) out += Xyz(CubeCorner(i)) + "\n";
  for (const auto& t : kCubeTriangles) {
    out += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) +
           "\n";
  }
  return out;
}

std::string CubeBinaryPly() {
  std::string out = PlyHeader("binary_little_endian");
  for (int i = 0; i < 8; ++i) AppendXyz(out, CubeCorner(i));
  for (const auto& t : kCubeTriangles) {
    AppendU8(out, 3);
    for (uint32_t v : t) AppendU32(out, v);
  }
  return out;
}

std::string CubeAsciiStl() {
  std::string out = "solid cube\n";
  for (const auto& t : kCubeTriangles) {
    out += "  facet normal 0 0 0\n    outer loop\n";
    for (uint32_t v : t) out += "      vertex " + Xyz(CubeCorner(static_cast<int>(v))) + "\n";
    out += "    endloop\n  endfacet\n";
  }
  return out + "endsolid cube\n";
}

// A binary STL header must not start with "solid" (that marks ASCII STL).
std::string BinaryStlHeader(uint32_t triangle_count) {
  std::string out = "binary STL written by silpose triangle_mesh_test";
  out.resize(80, '\0');
  AppendU32(out, triangle_count);
  return out;
}

std::string BinaryStlTriangle(const std::array<uint32_t, 3>& t) {
  std::string out;
  AppendXyz(out, Eigen::Vector3f::Zero());  // normal
  for (uint32_t v : t) AppendXyz(out, CubeCorner(static_cast<int>(v)));
  AppendU16(out, 0);  // attribute byte count
  return out;
}

std::string CubeBinaryStl() {
  std::string out = BinaryStlHeader(12);
  for (const auto& t : kCubeTriangles) out += BinaryStlTriangle(t);
  return out;
}

std::string Base64(const std::string& bytes) {
  static constexpr char kDigits[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t group = 0;
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    for (size_t k = 0; k < 3; ++k) {
      const uint32_t byte = k < n ? static_cast<uint8_t>(bytes[i + k]) : 0u;
      group |= byte << (16 - 8 * k);
    }
    for (size_t k = 0; k < 4; ++k) {
      out += k <= n ? kDigits[(group >> (18 - 6 * k)) & 63u] : '=';
    }
  }
  return out;
}

// glTF 2.0 buffer: 8 float positions, then 36 indices of 16 or 32 bits.
struct GltfBuffer {
  std::string bytes;
  size_t positions_length = 0;
  int index_component_type = 0;  // 5123 UNSIGNED_SHORT or 5125 UNSIGNED_INT
};

GltfBuffer CubeGltfBuffer(bool short_indices) {
  GltfBuffer buffer;
  for (int i = 0; i < 8; ++i) AppendXyz(buffer.bytes, CubeCorner(i));
  buffer.positions_length = buffer.bytes.size();
  for (const auto& t : kCubeTriangles) {
    for (uint32_t v : t) {
      if (short_indices) {
        AppendU16(buffer.bytes, static_cast<uint16_t>(v));
      } else {
        AppendU32(buffer.bytes, v);
      }
    }
  }
  buffer.index_component_type = short_indices ? 5123 : 5125;
  return buffer;
}

// `nodes` is the JSON array of nodes; node 0 is the scene's root. `buffer_uri` is empty for GLB.
std::string CubeGltfJson(const GltfBuffer& buffer, const std::string& buffer_uri,
                         const std::string& nodes) {
  const std::string uri = buffer_uri.empty() ? "" : ", \"uri\": \"" + buffer_uri + "\"";
  const std::string index_length = std::to_string(buffer.bytes.size() - buffer.positions_length);
  return R"({
  "asset": {"version": "2.0", "generator": "silpose triangle_mesh_test"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": )" +
         nodes +
         R"(,
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
  "buffers": [{"byteLength": )" +
         std::to_string(buffer.bytes.size()) + uri + R"(}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": )" +
         std::to_string(buffer.positions_length) + R"(, "target": 34962},
    {"buffer": 0, "byteOffset": )" +
         std::to_string(buffer.positions_length) + ", \"byteLength\": " + index_length +
         R"(, "target": 34963}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
     "min": [)" +
         Number(CubeCorner(0).x()) + ", " + Number(CubeCorner(0).y()) + ", " +
         Number(CubeCorner(0).z()) + R"(],
     "max": [)" +
         Number(CubeCorner(7).x()) + ", " + Number(CubeCorner(7).y()) + ", " +
         Number(CubeCorner(7).z()) + R"(]},
    {"bufferView": 1, "componentType": )" +
         std::to_string(buffer.index_component_type) + R"(, "count": 36, "type": "SCALAR"}
  ]
}
)";
}

constexpr char kSingleNode[] = R"([{"mesh": 0}])";

std::string CubeGltf(const std::string& nodes = kSingleNode) {
  const GltfBuffer buffer = CubeGltfBuffer(/*short_indices=*/true);
  return CubeGltfJson(buffer, "data:application/octet-stream;base64," + Base64(buffer.bytes),
                      nodes);
}

std::string CubeGlb() {
  const GltfBuffer buffer = CubeGltfBuffer(/*short_indices=*/false);
  std::string json = CubeGltfJson(buffer, "", kSingleNode);
  json.resize((json.size() + 3) / 4 * 4, ' ');
  std::string bin = buffer.bytes;
  bin.resize((bin.size() + 3) / 4 * 4, '\0');
  std::string out;
  AppendU32(out, 0x46546C67u);  // "glTF"
  AppendU32(out, 2);
  AppendU32(out, static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  AppendU32(out, static_cast<uint32_t>(json.size()));
  AppendU32(out, 0x4E4F534Au);  // "JSON"
  out += json;
  AppendU32(out, static_cast<uint32_t>(bin.size()));
  AppendU32(out, 0x004E4942u);  // "BIN\0"
  out += bin;
  return out;
}

// Each test gets a fresh temporary directory, removed afterwards.
class LoadMeshTest : public testing::Test {
 protected:
  void SetUp() override {
    const testing::TestInfo* info = testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    for (char& c : name) {
      if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    }
    std::random_device random;
    dir_ = fs::temp_directory_path() / ("silpose_mesh_test_" + name + "_" +
                                        std::to_string(random()) + std::to_string(random()));
    ASSERT_TRUE(fs::create_directories(dir_)) << dir_;
  }

  void TearDown() override {
    std::error_code ignored;
    fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add, ignored);
    fs::remove_all(dir_, ignored);
  }

  fs::path Write(const std::string& file_name, const std::string& bytes) const {
    const fs::path path = dir_ / file_name;
    std::ofstream stream(path, std::ios::binary);
    stream << bytes;
    EXPECT_TRUE(stream.good()) << path;
    return path;
  }

  // LoadMesh must throw silpose::Error naming the file and containing `problem`, printing nothing.
  void ExpectLoadError(const fs::path& path, const std::string& problem) const {
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    std::string message;
    try {
      LoadMesh(path);
    } catch (const Error& error) {
      message = error.what();
    } catch (const std::exception& other) {
      ADD_FAILURE() << "unexpected exception: " << other.what();
    }
    const std::string out = testing::internal::GetCapturedStdout();
    const std::string err = testing::internal::GetCapturedStderr();
    ASSERT_FALSE(message.empty()) << "expected silpose::Error loading " << path;
    EXPECT_EQ(message.rfind(path.string(), 0), 0u) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << message;
    EXPECT_EQ(out, "");
    EXPECT_EQ(err, "");
  }

  fs::path dir_;
};

void ExpectBox(const TriangleMesh& mesh, const Eigen::Vector3d& lower,
               const Eigen::Vector3d& upper) {
  ASSERT_FALSE(mesh.vertices.empty());
  Eigen::Vector3f low = mesh.vertices.front(), high = mesh.vertices.front();
  for (const Eigen::Vector3f& v : mesh.vertices) {
    low = low.cwiseMin(v);
    high = high.cwiseMax(v);
  }
  EXPECT_LT((low.cast<double>() - lower).norm(), 1e-6) << low.transpose();
  EXPECT_LT((high.cast<double>() - upper).norm(), 1e-6) << high.transpose();
}

void ExpectCube(const TriangleMesh& mesh, const Eigen::Vector3d& centre, double half_edge) {
  EXPECT_EQ(mesh.triangles.size(), 12u);
  EXPECT_EQ(mesh.vertices.size(), 8u);
  for (const auto& triangle : mesh.triangles) {
    for (uint32_t v : triangle) EXPECT_LT(v, mesh.vertices.size());
  }
  EXPECT_LT((mesh.Centre() - centre).norm(), 1e-5) << mesh.Centre().transpose();
  EXPECT_NEAR(mesh.Radius(), half_edge * std::sqrt(3.0), 1e-5);
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(half_edge);
  ExpectBox(mesh, centre - half, centre + half);
  // Every face has area 2 * half_edge * 2 * half_edge (triangle areas sum to the cube's surface).
  double area = 0.0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  EXPECT_NEAR(area, 6.0 * 4.0 * half_edge * half_edge, 1e-4);
}

struct CubeFormat {
  const char* label;
  const char* extension;
  std::function<std::string()> write;
};

class LoadCubeTest : public LoadMeshTest, public testing::WithParamInterface<CubeFormat> {};

TEST_P(LoadCubeTest, KeepsUnitsAndFrame) {
  const fs::path path = Write(std::string("cube") + GetParam().extension, GetParam().write());
  const TriangleMesh mesh = LoadMesh(path);
  EXPECT_EQ(mesh.name, "cube");
  ExpectCube(mesh, kCubeCentre, kCubeHalfEdge);
}

INSTANTIATE_TEST_SUITE_P(Formats, LoadCubeTest,
                         testing::Values(CubeFormat{"Obj", ".obj", CubeObj},
                                         CubeFormat{"Off", ".off", CubeOff},
                                         CubeFormat{"AsciiPly", ".ply", CubeAsciiPly},
                                         CubeFormat{"BinaryPly", ".ply", CubeBinaryPly},
                                         CubeFormat{"AsciiStl", ".stl", CubeAsciiStl},
                                         CubeFormat{"BinaryStl", ".stl", CubeBinaryStl},
                                         CubeFormat{"Gltf", ".gltf", [] { return CubeGltf(); }},
                                         CubeFormat{"Glb", ".glb", CubeGlb}),
                         [](const testing::TestParamInfo<CubeFormat>& param_info) {
                           return std::string(param_info.param.label);
                         });

TEST_F(LoadMeshTest, AppliesNestedGltfNodeTransforms) {
  // Root node: translation (1, 2, 3) and scale 2; its child holds the mesh, translated (0.5, 0, 0).
  // World = T(1,2,3) S(2) T(0.5,0,0): the cube centre goes to 2 (c + (0.5, 0, 0)) + (1, 2, 3).
  const std::string nodes = R"([
    {"children": [1], "translation": [1, 2, 3], "scale": [2, 2, 2]},
    {"mesh": 0, "translation": [0.5, 0, 0]}])";
  const TriangleMesh mesh = LoadMesh(Write("moved.gltf", CubeGltf(nodes)));
  EXPECT_EQ(mesh.name, "moved");
  const Eigen::Vector3d centre =
      2.0 * (kCubeCentre + Eigen::Vector3d(0.5, 0, 0)) + Eigen::Vector3d(1, 2, 3);  // (22, -4, 11)
  ExpectCube(mesh, centre, 2.0 * kCubeHalfEdge);
}

TEST_F(LoadMeshTest, InstancesAMeshOncePerNode) {
  // The same mesh in two nodes, 10 units apart along x: two cubes.
  const std::string nodes = R"([
    {"children": [1, 2]},
    {"mesh": 0},
    {"mesh": 0, "translation": [10, 0, 0]}])";
  const TriangleMesh mesh = LoadMesh(Write("two.gltf", CubeGltf(nodes)));
  EXPECT_EQ(mesh.triangles.size(), 24u);
  EXPECT_EQ(mesh.vertices.size(), 16u);
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(kCubeHalfEdge);
  ExpectBox(mesh, kCubeCentre - half, kCubeCentre + Eigen::Vector3d(10, 0, 0) + half);
}

TEST_F(LoadMeshTest, TriangulatesQuads) {
  const TriangleMesh mesh =
      LoadMesh(Write("quad.obj", "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nf 1 2 3 4\n"));
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.vertices.size(), 4u);
  double area = 0.0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    area += 0.5 * static_cast<double>((b - a).cross(c - a).norm());
  }
  EXPECT_NEAR(area, 2.0, 1e-6);
  EXPECT_LT((mesh.Centre() - Eigen::Vector3d(1, 0.5, 0)).norm(), 1e-6);
  EXPECT_NEAR(mesh.Radius(), std::sqrt(1.25), 1e-6);
}

TEST_F(LoadMeshTest, LoadsWhileOtherThreadsAllocate) {
  // assimp reads in a child process forked from this one while three other threads allocate and
  // free memory (as a Python program's or a parallel build's threads do). A child that inherits a
  // lock one of them held waits for it forever; it must be noticed and the file read again, so
  // that every load ends with the mesh.
  const std::filesystem::path path =
      Write("quad.obj", "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nf 1 2 3 4\n");
  std::atomic<bool> done{false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&done, t] {
      std::mt19937 random(static_cast<unsigned>(t));
      std::vector<std::vector<char>> held(16);
      while (!done.load(std::memory_order_relaxed)) {
        // Small blocks and large ones (which take the allocator's global paths).
        const size_t size = random() % 4 == 0 ? 200000 + random() % 100000 : 16 + random() % 4000;
        held[random() % held.size()].assign(size, 'x');
      }
    });
  }
  for (int i = 0; i < 20; ++i) {
    const TriangleMesh mesh = LoadMesh(path);
    EXPECT_EQ(mesh.triangles.size(), 2u);
    EXPECT_EQ(mesh.vertices.size(), 4u);
  }
  done = true;
  for (std::thread& thread : threads) thread.join();
}

TEST_F(LoadMeshTest, MergesObjectsAndDropsPointsLinesAndUnusedVertices) {
  // Two objects sharing an edge, a line, a point and a far-away vertex that no triangle uses.
  const std::string obj =
      "o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
      "o second\nv 1 1 0\nf 2 4 3\n"
      "o extras\nv 100 100 100\nl 1 5\np 5\n";
  const TriangleMesh mesh = LoadMesh(Write("parts.obj", obj));
  EXPECT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.vertices.size(), 4u);
  EXPECT_LT((mesh.Centre() - Eigen::Vector3d(0.5, 0.5, 0)).norm(), 1e-6);
  EXPECT_NEAR(mesh.Radius(), std::sqrt(0.5), 1e-6);
}

TEST(TriangleMesh, CentreIsBoxCentreAndRadiusTheFarthestVertex) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 4, 0}, {0.5f, 0.5f, 0}};
  mesh.triangles = {{0, 1, 2}};
  EXPECT_TRUE(mesh.Centre().isApprox(Eigen::Vector3d(1, 2, 0)));
  EXPECT_NEAR(mesh.Radius(), std::sqrt(5.0), 1e-12);
  const TriangleMesh empty;
  EXPECT_EQ(empty.Centre(), Eigen::Vector3d::Zero());
  EXPECT_EQ(empty.Radius(), 0.0);
}

TEST_F(LoadMeshTest, MissingFile) { ExpectLoadError(dir_ / "missing_model.obj", "no such file"); }

TEST_F(LoadMeshTest, Directory) {
  fs::create_directory(dir_ / "models.obj");
  ExpectLoadError(dir_ / "models.obj", "directory");
}

TEST_F(LoadMeshTest, UnreadableFile) {
  const fs::path path = Write("locked.obj", CubeObj());
  fs::permissions(path, fs::perms::none);
  if (std::ifstream(path)) GTEST_SKIP() << "running with permission to read any file (root?)";
  ExpectLoadError(path, "cannot open");
}

TEST_F(LoadMeshTest, EmptyFile) { ExpectLoadError(Write("empty.obj", ""), "empty"); }

TEST_F(LoadMeshTest, ObjWithoutFaces) {
  ExpectLoadError(Write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no triangles");
}

TEST_F(LoadMeshTest, ObjWithOnlyLines) {
  ExpectLoadError(Write("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n"), "no triangles");
}

TEST_F(LoadMeshTest, NonFiniteCoordinates) {
  // assimp parses "nan" and "inf" to the IEEE values (and its vertex joining then merges all NaN
  // vertices into one); the loader must reject them.
  ExpectLoadError(Write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
                  "has a non-finite coordinate");
  ExpectLoadError(Write("inf.obj", "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n"),
                  "has a non-finite coordinate");
  ExpectLoadError(Write("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
                  "vertex 1 has a non-finite coordinate");
}

TEST_F(LoadMeshTest, TruncatedBinaryStl) {
  // The header promises 100 triangles, the file holds 1.
  ExpectLoadError(Write("truncated.stl", BinaryStlHeader(100) + BinaryStlTriangle({0, 1, 2})),
                  "cannot read mesh");
}

TEST_F(LoadMeshTest, BinaryGarbageWithPlyExtension) {
  std::mt19937 random(7);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(random());
  ExpectLoadError(Write("garbage.ply", garbage), "cannot read mesh");
}

TEST_F(LoadMeshTest, GarbageWithUnknownExtension) {
  // assimp sniffs the content of files with unknown extensions; garbage must fail cleanly.
  ExpectLoadError(Write("text.xyz123", "this is not a mesh\n"), "cannot read mesh");
  for (unsigned seed = 0; seed < 20; ++seed) {
    std::mt19937 random(seed);
    std::string garbage(1 + random() % 5000, '\0');
    for (char& c : garbage) c = static_cast<char>(random());
    ExpectLoadError(Write("garbage" + std::to_string(seed) + ".xyz123", garbage),
                    "cannot read mesh");
  }
}

std::vector<std::pair<std::string, std::string>> AllCubeFiles() {
  return {{"cut.obj", CubeObj()},
          {"cut.off", CubeOff()},
          {"cut.ply", CubeAsciiPly()},
          {"cut_binary.ply", CubeBinaryPly()},
          {"cut.stl", CubeAsciiStl()},
          {"cut_binary.stl", CubeBinaryStl()},
          {"cut.gltf", CubeGltf()},
          {"cut.glb", CubeGlb()},
          {"cut_ply.xyz123", CubeAsciiPly()},
          {"cut_off.xyz123", CubeOff()}};
}

// Loading must throw silpose::Error naming the file or return at most the cube's triangles (a
// number cut short in an ASCII file may still make a vertex).
void ExpectErrorOrPartialCube(const fs::path& path) {
  try {
    const TriangleMesh mesh = LoadMesh(path);
    EXPECT_LE(mesh.triangles.size(), 12u) << path;
  } catch (const Error& error) {
    EXPECT_EQ(std::string(error.what()).rfind(path.string(), 0), 0u) << error.what();
  }
}

TEST_F(LoadMeshTest, FilesCutAtEveryLength) {
  // assimp 5.2.5 hangs, crashes or aborts on some of these (PLY, OFF): they must fail cleanly.
  for (const auto& [name, content] : AllCubeFiles()) {
    for (size_t length = 1; length < content.size(); ++length) {
      ExpectErrorOrPartialCube(Write(name, content.substr(0, length)));
    }
  }
}

TEST_F(LoadMeshTest, FilesWithRandomlyChangedBytes) {
  std::mt19937 random(2024);
  for (const auto& [name, content] : AllCubeFiles()) {
    for (int trial = 0; trial < 100; ++trial) {
      std::string changed = content;
      for (int k = 0; k < 3; ++k) {
        changed[random() % changed.size()] = "0123456789 -.\n#e"[random() % 16];
        changed[random() % changed.size()] = static_cast<char>(random());
      }
      const fs::path path = Write(name, changed);
      try {
        LoadMesh(path);
      } catch (const Error& error) {
        EXPECT_EQ(std::string(error.what()).rfind(path.string(), 0), 0u) << error.what();
      }
    }
  }
}

TEST_F(LoadMeshTest, OffVariantsCommentsColoursAndLargePolygons) {
  // COFF: counts on the keyword line, comments, colours after coordinates and after faces.
  std::string off = "# a cube\nCOFF 8 6 0 # counts\n\n";
  for (int i = 0; i < 8; ++i) off += Xyz(CubeCorner(i)) + " 255 0 0 255\n";
  for (const auto& q : kCubeQuads) {
    off += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) +
           " " + std::to_string(q[3]) + "  0.5 0.5 0.5\n";
  }
  ExpectCube(LoadMesh(Write("cube.off", off)), kCubeCentre, kCubeHalfEdge);

  // One 12-sided face (assimp's own OFF reader drops faces of more than 9 vertices).
  std::string polygon = "OFF\n12 1 0\n";
  std::string face = "12";
  for (int k = 0; k < 12; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / 12.0;
    polygon += Number(std::cos(angle)) + " " + Number(std::sin(angle)) + " 7\n";
    face += " " + std::to_string(k);
  }
  const TriangleMesh mesh = LoadMesh(Write("dodecagon.off", polygon + face + "\n"));
  EXPECT_EQ(mesh.triangles.size(), 10u);
  EXPECT_EQ(mesh.vertices.size(), 12u);
  EXPECT_NEAR(mesh.Radius(), 1.0, 1e-6);

  ExpectLoadError(Write("homogeneous.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n"),
                  "not supported");
  ExpectLoadError(Write("bad_index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
                  "references vertex 3");
}

TEST_F(LoadMeshTest, PlyBigEndianDoublesQuadsAndExtraData) {
  // Faces before vertices, quads, "vertex_index", extra properties and an element to skip.
  std::string ply =
      "ply\r\nformat binary_big_endian 1.0\r\ncomment written by a test\r\n"
      "element face 6\r\nproperty uchar flags\r\nproperty list uchar uint vertex_index\r\n"
      "element vertex 8\r\nproperty double z\r\nproperty double y\r\nproperty double x\r\n"
      "property list int int extra\r\nproperty uchar red\r\n"
      "element material 1\r\nproperty float shininess\r\nend_header\r\n";
  for (const auto& q : kCubeQuads) {
    AppendU8(ply, 7);
    AppendU8(ply, 4);
    for (uint32_t v : q) AppendBigEndian(ply, v, 4);
  }
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3f p = CubeCorner(i);
    for (int k = 2; k >= 0; --k) {
      AppendBigEndian(ply, std::bit_cast<uint64_t>(static_cast<double>(p[k])), 8);
    }
    AppendBigEndian(ply, 2, 4);  // a list of two ints
    AppendBigEndian(ply, 11, 4);
    AppendBigEndian(ply, 12, 4);
    AppendU8(ply, 200);
  }
  AppendBigEndian(ply, std::bit_cast<uint32_t>(0.5f), 4);
  ExpectCube(LoadMesh(Write("cube.ply", ply)), kCubeCentre, kCubeHalfEdge);
}

TEST_F(LoadMeshTest, PlyErrors) {
  const std::string header = PlyHeader("ascii");
  std::string vertices;
  for (int i = 0; i < 8; ++i) vertices += Xyz(CubeCorner(i)) + "\n";
  std::string faces;
  for (int f = 0; f < 11; ++f) faces += "3 0 1 2\n";
  ExpectLoadError(Write("out_of_range.ply", header + vertices + faces + "3 0 1 8\n"),
                  "references vertex 8");
  ExpectLoadError(Write("short.ply", header + vertices + faces), "truncated");
  ExpectLoadError(Write("no_end.ply", "ply\nformat ascii 1.0\nelement vertex 8\n"), "end_header");
  ExpectLoadError(Write("word.ply", header + vertices + faces + "3 0 1 two\n"), "not a number");
  ExpectLoadError(Write("type.ply",
                        "ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\n"
                        "end_header\n1\n"),
                  "bad PLY header line 'property real x'");
  ExpectLoadError(Write("no_xyz.ply",
                        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "end_header\n1\n"),
                  "no x, y and z");
  // A huge count in a short binary file fails before anything is allocated for it.
  ExpectLoadError(Write("huge.ply",
                        "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                        "property float x\nproperty float y\nproperty float z\n"
                        "end_header\n"),
                  "truncated");
}

TEST_F(LoadMeshTest, RecognisesPlyAndOffContentWithoutTheirExtension) {
  ExpectCube(LoadMesh(Write("cube_ply.xyz123", CubeBinaryPly())), kCubeCentre, kCubeHalfEdge);
  ExpectCube(LoadMesh(Write("cube_off", CubeOff())), kCubeCentre, kCubeHalfEdge);
  ExpectCube(LoadMesh(Write("cube_obj.xyz123", CubeObj())), kCubeCentre, kCubeHalfEdge);
}

TEST_F(LoadMeshTest, CorruptGlbLengths) {
  std::string glb = CubeGlb();
  glb[15] = '\x7f';  // JSON chunk length: about 2 GB
  ExpectLoadError(Write("corrupt.glb", glb), "exceed the file size");
}

TEST_F(LoadMeshTest, ContentOfAnotherFormatUnderASharedExtensionIsRefused) {
  // Neither glTF reader recognises these; assimp would try all its readers on the content and read
  // them as Quick3D files (one such file, found by the mesh fuzzer, asked for 1.5 TB).
  const std::string quick3d = std::string("quick3Do") + std::string(64, '\0');
  ExpectLoadError(Write("quick3d.glb", quick3d), "not that of a .glb file");
  ExpectLoadError(Write("quick3d.gltf", quick3d), "not that of a .gltf file");
  // A name that is only the extension is claimed as assimp claims it (by the name's end).
  ExpectLoadError(Write(".glb", quick3d), "not that of a .glb file");
  // The same content under no extension is recognised as Quick3D, which is not read (below).
  ExpectLoadError(Write("quick3d", quick3d), "Quick3D files are not read");
  // Valid files of both glTF versions' extensions still load, and so does a file whose name ends
  // in an extension of several dots (Ogre's .mesh.xml, among the many readers of .xml).
  ExpectCube(LoadMesh(Write("cube.glb", CubeGlb())), kCubeCentre, kCubeHalfEdge);
  ExpectCube(LoadMesh(Write("cube.gltf", CubeGltf())), kCubeCentre, kCubeHalfEdge);
  const std::string ogre = R"(<mesh><submeshes>
  <submesh material="m" usesharedvertices="false" use32bitindexes="false" operationtype="triangle_list">
    <faces count="1"><face v1="0" v2="1" v3="2"/></faces>
    <geometry vertexcount="3"><vertexbuffer positions="true">
      <vertex><position x="0" y="0" z="5"/></vertex>
      <vertex><position x="1" y="0" z="5"/></vertex>
      <vertex><position x="0" y="1" z="5"/></vertex>
    </vertexbuffer></geometry>
  </submesh>
</submeshes></mesh>
)";
  for (const char* name : {"triangle.mesh.xml", "TRIANGLE.MESH.XML"}) {
    const TriangleMesh mesh = LoadMesh(Write(name, ogre));
    EXPECT_EQ(mesh.triangles.size(), 1u) << name;
    EXPECT_EQ(mesh.vertices.size(), 3u) << name;
  }
  // ... but not as plain .xml: none of the .xml readers recognises it.
  ExpectLoadError(Write("triangle.xml", ogre), "not that of a .xml file");
}

TEST_F(LoadMeshTest, QuickThreeDFilesAreRefusedBeforeAssimpReadsThem) {
  // A Quick3D header (signature, version, then the counts of meshes, materials and textures)
  // and one mesh chunk whose vertex count asks for about 1.2 GB; assimp's reader would allocate
  // and fill them before it noticed that the file ends.
  std::string quick3d = std::string("quick3Do") + std::string("\x01\x00", 2);
  for (const uint32_t count : {1u, 0u, 0u})
    quick3d += std::string(reinterpret_cast<const char*>(&count), 4);
  quick3d += 'm';
  const uint32_t vertices = 100'000'000u;
  quick3d += std::string(reinterpret_cast<const char*>(&vertices), 4);
  // Under its own extensions, and under names no reader claims (assimp recognises it by content).
  for (const char* name : {"part.q3o", "PART.Q3S", "part", "part.xyz123"}) {
    ExpectLoadError(Write(name, quick3d), "Quick3D files are not read");
  }
  // Another format's file that mentions the signature in its text still loads by its extension,
  // and other content under a name no reader claims is still recognised by content.
  ExpectCube(LoadMesh(Write("quick3do.obj", "# quick3Do\n" + CubeObj())), kCubeCentre,
             kCubeHalfEdge);
  ExpectCube(LoadMesh(Write("cube.xyz123", CubeObj())), kCubeCentre, kCubeHalfEdge);
}

TEST_F(LoadMeshTest, ColladaKeepsItsUpAxis) {
  // assimp would rotate this Z-up file to Y-up; the loader keeps the file's axes.
  const std::string dae = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="9">0 0 5 1 0 5 0 1 5</float_array>
      <technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>
        <param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common>
    </source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node>
  </visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
  const TriangleMesh mesh = LoadMesh(Write("z_up.dae", dae));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  ExpectBox(mesh, Eigen::Vector3d(0, 0, 5), Eigen::Vector3d(1, 1, 5));

  // One letter in an index list: assimp's reader would add indices until the memory ran out.
  const auto with = [&dae](const std::string& from, const std::string& to) {
    std::string changed = dae;
    const size_t at = changed.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return changed.replace(at, from.size(), to);
  };
  ExpectLoadError(Write("letter.dae", with("<p>0 1 2</p>", "<p>0 x 2</p>")),
                  "a Collada <p> list holds \"x\", not an integer");
  ExpectLoadError(Write("inf.dae", with("<p>0 1 2</p>", "<p>0 1 inf</p>")),
                  "<p> list holds \"inf\"");
}

TEST_F(LoadMeshTest, AReaderThatCrashesOnAFileMakesThatFilesError) {
  // One "-1" too many at the end of an X3D face list: assimp's X3D reader frees a face twice and
  // the process would end (SIGABRT). assimp reads in a child process, so the crash is the file's
  // error (under AddressSanitizer the child reports the double free and exits instead).
  const std::string x3d =
      "<?xml version='1.0' encoding='UTF-8'?>\n<X3D profile='Interchange' version='3.3'><Scene>"
      "<Shape><IndexedFaceSet coordIndex='0 1 2 -1 -1'><Coordinate point='0 0 5 1 0 5 0 1 5'/>"
      "</IndexedFaceSet></Shape></Scene></X3D>\n";
  ExpectLoadError(Write("double_free.x3d", x3d), "the reader of its format");
  ExpectLoadError(Write("double_free_again.x3d", x3d), "the file is probably corrupt");
  // The caller goes on: the same file without the extra "-1" loads, through the same child.
  std::string valid = x3d;
  valid.replace(valid.find(" -1 -1'"), 7, " -1'");
  const TriangleMesh mesh = LoadMesh(Write("triangle.x3d", valid));
  ASSERT_EQ(mesh.triangles.size(), 1u);
  ExpectBox(mesh, Eigen::Vector3d(0, 0, 5), Eigen::Vector3d(1, 1, 5));
}

TEST_F(LoadMeshTest, ACountTheMemoryCannotHoldIsReportedAsSuch) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizers' allocators stop the process at such a request";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
  GTEST_SKIP() << "the sanitizers' allocators stop the process at such a request";
#endif
#endif
  // A DirectX mesh whose face count asks for about 100 GB: assimp catches the failed allocation
  // and keeps only "std::bad_alloc"; the message says what it means.
  const std::string x =
      "xof 0303txt 0032\nMesh m {\n 3;\n 0.0;0.0;0.0;,\n 1.0;0.0;0.0;,\n 0.0;1.0;0.0;;\n"
      " 4294967295;\n 3;0,1,2;;\n}\n";
  ExpectLoadError(Write("huge.x", x), "asks for more memory than there is");
  // The same mesh with its true face count loads.
  std::string one = x;
  one.replace(one.find("4294967295"), 10, "1");
  EXPECT_EQ(LoadMesh(Write("one.x", one)).triangles.size(), 1u);
}

TriangleMesh Cube() {
  TriangleMesh mesh;
  mesh.name = "cube";
  for (int i = 0; i < 8; ++i) mesh.vertices.push_back(CubeCorner(i));
  mesh.triangles.assign(kCubeTriangles.begin(), kCubeTriangles.end());
  return mesh;
}

TEST(IsClosedSurface, TellsAClosedSurfaceFromOpenAndInconsistentOnes) {
  const TriangleMesh cube = Cube();
  EXPECT_TRUE(IsClosedSurface(cube));

  // A face missing: its edges are traversed once.
  TriangleMesh open = cube;
  open.triangles.pop_back();
  EXPECT_FALSE(IsClosedSurface(open));

  // One triangle turned over: two of its edges are traversed twice the same way.
  TriangleMesh flipped = cube;
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  EXPECT_FALSE(IsClosedSurface(flipped));

  // Turned inside out as a whole: still closed (orientation is not asked for).
  TriangleMesh inverted = cube;
  for (auto& triangle : inverted.triangles) std::swap(triangle[1], triangle[2]);
  EXPECT_TRUE(IsClosedSurface(inverted));

  // Two separate cubes, and a cube with a zero-area triangle (a repeated vertex) added.
  TriangleMesh two = cube;
  for (const auto& triangle : cube.triangles) {
    two.triangles.push_back({triangle[0] + 8, triangle[1] + 8, triangle[2] + 8});
  }
  for (int i = 0; i < 8; ++i) two.vertices.push_back(CubeCorner(i) + Eigen::Vector3f(5, 0, 0));
  EXPECT_TRUE(IsClosedSurface(two));
  TriangleMesh with_sliver = cube;
  with_sliver.triangles.push_back({0, 0, 7});
  EXPECT_TRUE(IsClosedSurface(with_sliver));

  EXPECT_FALSE(IsClosedSurface(TriangleMesh{}));
}

TEST(IsClosedSurface, IdentifiesVerticesByPosition) {
  // Every triangle with its own three vertices, as a loader that keeps per-face normals gives:
  // closed by position, though no two triangles share a vertex index.
  const TriangleMesh cube = Cube();
  TriangleMesh split;
  for (const auto& triangle : cube.triangles) {
    const auto first = static_cast<uint32_t>(split.vertices.size());
    for (uint32_t v : triangle) split.vertices.push_back(cube.vertices[v]);
    split.triangles.push_back({first, first + 1, first + 2});
  }
  EXPECT_TRUE(IsClosedSurface(split));
  // A vertex moved off its position opens the surface there.
  split.vertices[0].x() += 1e-3f;
  EXPECT_FALSE(IsClosedSurface(split));
}

TEST(IsClosedSurface, SampleModelsAreClosed) {
  // The database build renders closed meshes with half the triangles
  // (render/silhouette_renderer.h).
  for (const char* name : {"anchor", "bunny", "cow", "elephant", "hand"}) {
    const fs::path path = fs::path(SILPOSE_SAMPLE_MODELS_DIR) / (std::string(name) + ".obj");
    EXPECT_TRUE(IsClosedSurface(LoadMesh(path))) << path;
  }
}

TEST(SampleModels, LoadWithTrianglesAndPositiveRadius) {
  const fs::path dir = SILPOSE_SAMPLE_MODELS_DIR;
  std::vector<fs::path> models;
  std::error_code error;
  if (fs::is_directory(dir, error)) {
    for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
      if (entry.path().extension() == ".obj") models.push_back(entry.path());
    }
  }
  if (models.empty()) GTEST_SKIP() << "no .obj sample models in " << dir;
  for (const fs::path& path : models) {
    SCOPED_TRACE(path.string());
    const TriangleMesh mesh = LoadMesh(path);
    EXPECT_EQ(mesh.name, path.stem().string());
    EXPECT_GT(mesh.triangles.size(), 0u);
    EXPECT_GT(mesh.Radius(), 0.0);
    for (const auto& triangle : mesh.triangles) {
      for (uint32_t v : triangle) ASSERT_LT(v, mesh.vertices.size());
    }
  }
}

}  // namespace
}  // namespace silpose
