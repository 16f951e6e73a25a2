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

/// Whether the triangles close up: with vertices identified by position (so that vertices split by
/// normals or texture coordinates count as one), every edge is traversed as often in one direction
/// as in the other, as in a watertight, consistently oriented surface (also one of several parts,
/// or with non-manifold edges). Triangles with a repeated vertex are left out. Then every line of
/// sight from a point outside the mesh's bounding sphere that crosses the surface crosses it at
/// least once through a triangle facing the viewer and once through one facing away, so either
/// half of the triangles alone covers the whole silhouette (RenderSilhouette's FaceCulling).
/// False for a mesh without triangles.
bool IsClosedSurface(const TriangleMesh& mesh);

/// Loads OBJ, PLY (ASCII/binary), STL (ASCII/binary), OFF, glTF 2.0 (.gltf/.glb) and the other
/// formats assimp reads, except Quick3D (.q3o, .q3s: its reader trusts the counts in the file, so
/// a corrupt one can exhaust the memory). All meshes and nodes of the file are merged into one
/// triangle mesh, node transforms applied, polygons triangulated; points and lines are dropped.
/// PLY and OFF are read by silpose, the other formats by assimp in a child process (fork), so that
/// a reader that crashes on a corrupt file, or asks for more than half of the machine's memory,
/// makes that file's error (a child that waits forever for a lock it inherited is killed and the
/// file read again: RunInChildProcess, silpose/util/child_process.h). Throws silpose::Error naming
/// the file if it is missing, unreadable, of an unknown format, has no triangles, or has non-finite
/// vertex coordinates.
TriangleMesh LoadMesh(const std::filesystem::path& path);

}  // namespace silpose
