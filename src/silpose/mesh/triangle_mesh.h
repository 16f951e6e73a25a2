#pragma once
// Triangle meshes of the reference objects, in the mesh file's own frame and units
// (docs/conventions.md): nothing is recentred, rescaled or reoriented on loading.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace silpose {

struct TriangleMesh {
  /// Model name: the file stem ("bunny" for models/bunny.obj).
  std::string name;
  std::vector<Eigen::Vector3f> vertices;
  /// Vertex indices of each triangle (all < vertices.size()).
  std::vector<std::array<uint32_t, 3>> triangles;

  /// Object centre c: centre of the axis-aligned bounding box of the vertices.
  Eigen::Vector3d Centre() const;
  /// Object radius: largest distance from Centre() to a vertex.
  double Radius() const;
};

/// Loads OBJ, PLY (ASCII/binary), STL (ASCII/binary), OFF, glTF 2.0 (.gltf/.glb) and the other
/// formats assimp reads. All meshes and nodes of the file are merged into one triangle mesh, node
/// transforms applied, polygons triangulated; points and lines are dropped.
/// Throws silpose::Error naming the file if it is missing, unreadable, of an unknown format, has no
/// triangles, or has non-finite vertex coordinates.
TriangleMesh LoadMesh(const std::filesystem::path& path);

}  // namespace silpose
