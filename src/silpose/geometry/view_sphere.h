#pragma once
// Near-uniform viewpoints on the unit sphere (paper 4.1), their neighbour graph (the particle
// filter's motion model) and their K-means bins (KLD-sampling, paper 4.3).
//
// Sampling: spherical Fibonacci lattice (golden-angle spiral, points at equal-area latitude bands):
// any count, deterministic, no clustering at the poles; covering radius 0.77 sqrt(4 pi / N) (a
// hexagonal lattice would give 0.62), nearest-neighbour angles within about 12% of each other.
// (The paper used Mitchell's successive orthogonal images; uniformity figures for this lattice are
// measured in view_sphere_test.cc and docs/conventions.md.)

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace silpose {

struct ViewSphereOptions {
  /// Number of viewpoints (>= 4).
  int num_views = 1000;
  /// Two views are neighbours if their angular distance is at most this factor times the typical
  /// spacing (the median nearest-neighbour angle). > 1.
  double neighbour_radius_factor = 1.5;
  /// Largest neighbour_radius_factor accepted: about 33 neighbours per view.
  static constexpr double kMaxNeighbourRadiusFactor = 3.0;
  /// Largest mean number of neighbours per view a database file may hold.
  static constexpr int kMaxMeanNeighbours = 64;
  /// K of the K-means clustering of the view directions (1 <= K <= num_views).
  int num_bins = 10;
  /// Seed of the K-means initialisation (k-means++), for reproducible bins.
  uint64_t kmeans_seed = 1;
  /// Lloyd iterations at most.
  int kmeans_max_iterations = 100;

  bool Check(std::string* error = nullptr) const;
};

/// The sampled view sphere. Views are indexed 0..num_views-1.
struct ViewSphere {
  /// Unit view directions (object centre -> camera), model frame.
  std::vector<Eigen::Vector3d> directions;
  /// Median angle, in radians, between a view and its nearest neighbour.
  double typical_spacing_rad = 0.0;
  /// Neighbour graph in CSR form: neighbours of view i are
  /// neighbour_indices[neighbour_offsets[i] .. neighbour_offsets[i+1]), sorted by index, never i.
  std::vector<uint32_t> neighbour_offsets;
  std::vector<uint32_t> neighbour_indices;
  /// K-means bin of each view, in [0, K).
  std::vector<uint32_t> bin_of_view;
  /// Unit-length bin centres (K-means centroids projected back on the sphere).
  std::vector<Eigen::Vector3d> bin_centres;

  int num_views() const { return static_cast<int>(directions.size()); }
  int num_bins() const { return static_cast<int>(bin_centres.size()); }
  std::span<const uint32_t> Neighbours(int view) const {
    return {neighbour_indices.data() + neighbour_offsets[view],
            neighbour_indices.data() + neighbour_offsets[view + 1]};
  }
  /// Index of the view closest in angle to `direction` (need not be unit). Linear scan.
  int NearestView(const Eigen::Vector3d& direction) const;
};

/// Builds the sphere: lattice, neighbour graph, K-means bins. Deterministic for given options.
/// Throws silpose::Error if the options are invalid.
ViewSphere BuildViewSphere(const ViewSphereOptions& options);

/// The spherical Fibonacci lattice alone: `count` unit vectors.
std::vector<Eigen::Vector3d> FibonacciSphere(int count);

/// Uniformity figures of a set of unit vectors (angles in radians).
struct SphereSamplingStats {
  /// Largest angular distance from any point of the sphere to its nearest sample (estimated with a
  /// dense probe set).
  double covering_radius_rad = 0.0;
  double min_nearest_neighbour_rad = 0.0;
  double max_nearest_neighbour_rad = 0.0;
  /// min / max nearest-neighbour distance (1 = perfectly even).
  double spacing_ratio = 0.0;
};
SphereSamplingStats MeasureSphereSampling(const std::vector<Eigen::Vector3d>& directions,
                                          int probe_count = 200000);

/// K-means on unit vectors (Euclidean, k-means++ seeding with `seed`); returns the label of each
/// point and writes the unit-length centres.
std::vector<uint32_t> KMeansOnSphere(const std::vector<Eigen::Vector3d>& points, int k,
                                     uint64_t seed, int max_iterations,
                                     std::vector<Eigen::Vector3d>* centres);

}  // namespace silpose
