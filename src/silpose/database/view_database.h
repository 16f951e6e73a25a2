#pragma once
// The reference view database (paper 4.1): for every model, the polar signature of its silhouette
// seen from every viewpoint of one view sphere, with the sphere's neighbour graph and K-means bins.
//
// File format (docs/database-format.md): little-endian binary, an 8-byte magic number "SILPOSDB",
// a format version, the payload size, the payload (every generation parameter, per model its name
// and the XXH64 hash of its mesh file, per view its silhouette record and signature, the graph and
// bins) and an XXH64 checksum of everything before it. Reading checks magic, version, size and
// checksum before it parses anything, and every value after; a truncated, corrupt, foreign or
// other-version file is refused with a silpose::Error naming the file and the problem.

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "silpose/geometry/view_sphere.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/shape/polar_signature.h"

namespace silpose {

/// Every parameter that shaped a database; two databases with equal parameters are comparable.
struct DatabaseParameters {
  ViewSphereOptions view_sphere;
  ViewRenderOptions render;
  SignatureOptions signature;

  bool Check(std::string* error = nullptr) const;
  bool operator==(const DatabaseParameters& other) const;
};

/// What the silhouette of one database view looked like when the database was built.
struct ViewRecord {
  SignatureStatus status = SignatureStatus::kEmpty;
  /// SilhouetteFlag bits.
  uint32_t flags = 0;
  /// Silhouette measurements in the database image (pixels), for pose recovery from scale and
  /// position: see PolarSignature.
  float mean_radius_px = 0.0f;
  float centroid_x_px = 0.0f;
  float centroid_y_px = 0.0f;
  float area_px = 0.0f;
  float relative_std = 0.0f;
};

/// All views of one model.
struct ModelViews {
  /// The model's name: its mesh file's stem.
  std::string name;
  /// The mesh path as given when the database was built (informative).
  std::string source_path;
  /// XXH64 of the mesh file's bytes.
  uint64_t mesh_hash = 0;
  /// Object centre and radius in model units (mesh/triangle_mesh.h).
  double centre[3] = {0.0, 0.0, 0.0};
  double radius = 0.0;
  uint32_t num_vertices = 0;
  uint32_t num_triangles = 0;
  /// One record per view.
  std::vector<ViewRecord> views;
  /// Signatures, view-major: view v is signatures[v * M, (v + 1) * M). Unusable views are all 0.
  std::vector<float> signatures;

  std::span<const float> Signature(int view) const;
  std::span<float> MutableSignature(int view);
  int signature_length() const;
};

class ViewDatabase {
 public:
  /// Format version written by this build, and the only one it reads.
  static constexpr uint32_t kFormatVersion = 1;

  DatabaseParameters parameters;
  ViewSphere sphere;
  std::vector<ModelViews> models;

  int num_views() const { return sphere.num_views(); }
  int signature_length() const { return parameters.signature.length; }
  /// Index of the model with this name, or -1.
  int FindModel(const std::string& name) const;

  /// Writes the database (atomically: to a temporary file renamed over `path`).
  /// Throws silpose::Error naming the file if it cannot be written.
  void Write(const std::filesystem::path& path) const;
  /// Serialises to bytes (what Write writes).
  std::string Serialize() const;

  /// Reads and checks a database file. Throws silpose::Error naming the file and the problem.
  static ViewDatabase Read(const std::filesystem::path& path);
  /// Parses bytes; `source` names them in error messages.
  static ViewDatabase Deserialize(std::string_view bytes, const std::string& source);
};

}  // namespace silpose
