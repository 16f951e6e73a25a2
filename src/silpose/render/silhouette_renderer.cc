#include "silpose/render/silhouette_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>

#include "silpose/geometry/view_frame.h"
#include "silpose/render/rasterizer.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

using render_internal::CameraVertices;
using render_internal::Viewport;

// The mask being filled.
struct Raster {
  uint8_t* data;
  size_t stride;
  size_t size;  // Bytes in the (continuous) buffer.
};

// kLeadingBytes[n]: 8 bytes, the first n of them 255.
constexpr std::array<std::array<uint8_t, 8>, 9> kLeadingBytes = [] {
  std::array<std::array<uint8_t, 8>, 9> table{};
  for (size_t n = 0; n <= 8; ++n) {
    for (size_t i = 0; i < n; ++i) table[n][i] = 255;
  }
  return table;
}();

// Sets `count` bytes from `offset` to 255 (nothing if count <= 0; 0 <= offset <= size). Without
// branches for spans of at most 8 pixels (the common case: fine meshes at low resolution give many
// short and empty spans): one 8-byte read-or-write that leaves the bytes after the span unchanged.
inline void SetSpan(const Raster& raster, size_t offset, int count) {
  uint8_t* const first = raster.data + offset;
  if (count > 8 || offset + 8 > raster.size) {
    if (count > 0) std::memset(first, 255, static_cast<size_t>(count));
    return;
  }
  uint64_t word;
  uint64_t leading;
  std::memcpy(&word, first, 8);
  std::memcpy(&leading, kLeadingBytes[static_cast<size_t>(std::max(count, 0))].data(), 8);
  word |= leading;
  std::memcpy(first, &word, 8);
}

}  // namespace

void RenderSilhouette(const TriangleMesh& mesh, const PinholeCamera& camera,
                      const Rigid3& camera_from_object, cv::Mat* mask, FaceCulling culling) {
  SILPOSE_ASSERT(mask != nullptr);
  std::string error;
  if (!camera.Check(&error)) ThrowError("invalid camera: ", error);
  // Continuous, so that a short span may be written as 8 bytes reaching into the next row.
  if (!mask->isContinuous()) mask->release();
  mask->create(camera.height_px, camera.width_px, CV_8UC1);
  mask->setTo(cv::Scalar(0));

  thread_local CameraVertices vertices;
  if (!render_internal::TransformVertices(mesh, camera, camera_from_object, &vertices)) return;

  const Raster raster{mask->data, mask->step[0], mask->total()};
  render_internal::RasterizeMesh(
      mesh, vertices, camera, Viewport(camera.width_px, camera.height_px),
      [](const std::array<uint32_t, 3>&) {},
      [&raster](int row, int begin, int end) {
        SetSpan(raster, static_cast<size_t>(row) * raster.stride + static_cast<size_t>(begin),
                end - begin);
      },
      culling == FaceCulling::kBackFaces);
}

bool ViewRenderOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (resolution_px < 32 || resolution_px > 16384) {
    message << "resolution_px must be in [32, 16384], got " << resolution_px;
  } else if (!std::isfinite(distance_in_radii) || !(distance_in_radii > 1.0)) {
    message << "distance_in_radii must be finite and > 1, got " << distance_in_radii;
  } else if (!(fill_fraction > 0.0 && fill_fraction <= 1.0)) {
    message << "fill_fraction must be in (0, 1], got " << fill_fraction;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

PinholeCamera ViewCamera(const ViewRenderOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid view render options: ", error);
  // A sphere of radius r at distance D = k r on the optical axis is seen under the half-angle
  // asin(1 / k); its image is a disc of radius f * tan(asin(1 / k)) = f / sqrt(k^2 - 1), which must
  // be fill_fraction * resolution / 2.
  const double k = options.distance_in_radii;
  const double focal_px =
      options.fill_fraction * 0.5 * options.resolution_px * std::sqrt(k * k - 1.0);
  return PinholeCamera::Centered(options.resolution_px, options.resolution_px, focal_px);
}

void RenderView(const TriangleMesh& mesh, const Eigen::Vector3d& view_dir_in_object,
                double roll_deg, const ViewRenderOptions& options, cv::Mat* mask) {
  const PinholeCamera camera = ViewCamera(options);  // Checks the options.
  const double view_norm = view_dir_in_object.norm();
  if (!(view_norm > 0.0) || !std::isfinite(view_norm)) {
    ThrowError("view direction must be non-zero and finite, got (", view_dir_in_object.x(), ", ",
               view_dir_in_object.y(), ", ", view_dir_in_object.z(), ")");
  }
  if (!std::isfinite(roll_deg)) ThrowError("roll_deg must be finite, got ", roll_deg);
  if (mesh.triangles.empty()) ThrowError("mesh '", mesh.name, "' has no triangles");
  const double radius = mesh.Radius();
  if (!(radius > 0.0) || !std::isfinite(radius)) {
    ThrowError("mesh '", mesh.name, "' has radius ", radius, "; it must be positive and finite");
  }
  const Rigid3 camera_from_object = CameraFromObjectAtView(
      view_dir_in_object, roll_deg, options.distance_in_radii * radius, mesh.Centre());
  RenderSilhouette(mesh, camera, camera_from_object, mask);
}

}  // namespace silpose
