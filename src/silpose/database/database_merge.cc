#include "silpose/database/database_merge.h"

#include <map>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {
namespace {

template <typename T>
std::string Difference(const char* name, const T& a, const T& b) {
  if (a == b) return "";
  std::ostringstream text;
  text.precision(17);
  text << name << ": " << a << " vs " << b;
  return text.str();
}

std::string Join(const std::vector<double>& values) {
  std::ostringstream text;
  text.precision(17);
  for (size_t i = 0; i < values.size(); ++i) text << (i > 0 ? "," : "") << values[i];
  return text.str();
}

bool SameSphere(const ViewSphere& a, const ViewSphere& b) {
  return a.directions == b.directions && a.typical_spacing_rad == b.typical_spacing_rad &&
         a.neighbour_offsets == b.neighbour_offsets && a.neighbour_indices == b.neighbour_indices &&
         a.bin_of_view == b.bin_of_view && a.bin_centres == b.bin_centres;
}

}  // namespace

std::string FirstParameterDifference(const DatabaseParameters& a, const DatabaseParameters& b) {
  const std::string differences[] = {
      Difference("--views", a.view_sphere.num_views, b.view_sphere.num_views),
      Difference("--neighbour-radius", a.view_sphere.neighbour_radius_factor,
                 b.view_sphere.neighbour_radius_factor),
      Difference("--bins", a.view_sphere.num_bins, b.view_sphere.num_bins),
      Difference("k-means seed", a.view_sphere.kmeans_seed, b.view_sphere.kmeans_seed),
      Difference("k-means iterations", a.view_sphere.kmeans_max_iterations,
                 b.view_sphere.kmeans_max_iterations),
      Difference("--resolution", a.render.resolution_px, b.render.resolution_px),
      Difference("--distances", Join(a.distances_in_radii), Join(b.distances_in_radii)),
      Difference("--fill", a.render.fill_fraction, b.render.fill_fraction),
      Difference("--signature-length", a.signature.length, b.signature.length),
      Difference("minimum silhouette area", a.signature.min_area_px, b.signature.min_area_px),
      Difference("circularity threshold", a.signature.circular_threshold,
                 b.signature.circular_threshold),
  };
  for (const std::string& difference : differences) {
    if (!difference.empty()) return difference;
  }
  SILPOSE_ASSERT(a == b);
  return "";
}

void AppendDatabase(ViewDatabase&& shard, const std::string& shard_name, ViewDatabase* merged,
                    const std::string& merged_name) {
  if (merged->models.empty() && merged->sphere.num_views() == 0) {
    merged->parameters = shard.parameters;
    merged->sphere = std::move(shard.sphere);
  } else {
    const std::string difference = FirstParameterDifference(merged->parameters, shard.parameters);
    if (!difference.empty()) {
      ThrowError(shard_name, ": built with other parameters than ", merged_name, " (", difference,
                 "); databases merge only if built with the same build-db options");
    }
    if (!SameSphere(merged->sphere, shard.sphere)) {
      ThrowError(shard_name, ": its view sphere differs from that of ", merged_name,
                 " although the parameters are the same (built by another silpose version?)");
    }
  }
  for (ModelViews& model : shard.models) {
    if (merged->FindModel(model.name) >= 0) {
      ThrowError(shard_name, ": model '", model.name, "' is also in ", merged_name,
                 " (model names must be unique)");
    }
    merged->models.push_back(std::move(model));
  }
  // The models' signatures and spectra may refer to the shard's mapped file.
  for (auto& storage : shard.storage) merged->storage.push_back(std::move(storage));
  if (shard.views_unchecked) merged->views_unchecked = true;
  if (merged->source.empty()) merged->source = merged_name;
}

ViewDatabase MergeViewDatabases(const std::vector<std::filesystem::path>& paths) {
  if (paths.empty()) ThrowError("no database given to merge");
  ViewDatabase merged;
  std::map<std::string, std::string> file_of_model;
  for (const std::filesystem::path& path : paths) {
    // Every view checked now: the merged database is written out.
    ViewDatabase shard = ViewDatabase::Read(path, ViewChecks::kAtOpen);
    for (const ModelViews& model : shard.models) {
      const auto [where, inserted] = file_of_model.emplace(model.name, path.string());
      if (!inserted) {
        ThrowError(path.string(), ": model '", model.name, "' is also in ", where->second,
                   " (model names must be unique)");
      }
    }
    AppendDatabase(std::move(shard), path.string(), &merged, paths.front().string());
  }
  return merged;
}

}  // namespace silpose
