#include "silpose/geometry/view_sphere.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <utility>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// Slack added to search radii so that rounding never drops a point that is within the radius.
constexpr double kSearchMargin = 1e-9;

/// Angle between two unit vectors, accurate at all angles (acos loses precision near 0 and pi).
/// Symmetric in its arguments bit for bit.
double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

double Colatitude(const Eigen::Vector3d& p) { return std::atan2(std::hypot(p.x(), p.y()), p.z()); }

double Longitude(const Eigen::Vector3d& p) { return std::atan2(p.y(), p.x()); }

/// Uniform double in [0, 1) from the raw 64-bit output (platform independent, unlike
/// std::uniform_real_distribution).
double UniformUnit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Spatial index of unit vectors: latitude bands of equal angular height, each cut into longitude
/// cells about as wide as they are high, sized for ~2 points per cell if the points are spread
/// evenly. Cap queries visit only the cells that can intersect the cap, so a nearest-neighbour or
/// fixed-radius query costs O(1) for evenly spread points (and stays exact for any set).
class SphereGrid {
 public:
  explicit SphereGrid(const std::vector<Eigen::Vector3d>& points) {
    const size_t n = points.size();
    const double target_cell = std::sqrt(8.0 * kPi / static_cast<double>(std::max<size_t>(n, 1)));
    num_bands_ = std::clamp(static_cast<int>(std::ceil(kPi / target_cell)), 1, 4096);
    band_height_ = kPi / num_bands_;
    band_first_cell_.assign(num_bands_ + 1, 0);
    for (int b = 0; b < num_bands_; ++b) {
      const double mid = (b + 0.5) * band_height_;
      const int cells =
          std::max(1, static_cast<int>(std::ceil(kTwoPi * std::sin(mid) / band_height_)));
      band_first_cell_[b + 1] = band_first_cell_[b] + cells;
    }
    const int num_cells = band_first_cell_[num_bands_];

    std::vector<int> cell_of(n);
    cell_begin_.assign(num_cells + 1, 0);
    for (size_t i = 0; i < n; ++i) {
      cell_of[i] = CellOf(points[i]);
      ++cell_begin_[cell_of[i] + 1];
    }
    for (int c = 0; c < num_cells; ++c) cell_begin_[c + 1] += cell_begin_[c];
    std::vector<uint32_t> fill(cell_begin_.begin(), cell_begin_.end() - 1);
    points_.resize(n);
    indices_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t slot = fill[cell_of[i]]++;
      points_[slot] = points[i];
      indices_[slot] = static_cast<uint32_t>(i);
    }
  }

  /// Calls visit(index, angle) for every point within `radius` (radians) of the unit vector `q`.
  template <typename Visit>
  void ForEachInCap(const Eigen::Vector3d& q, double radius, Visit&& visit) const {
    const double theta = Colatitude(q);
    const double phi = Longitude(q);
    const double reach = radius + kSearchMargin;
    const double min_dot = std::cos(std::min(reach, kPi)) - 1e-12;
    const int b0 = std::max(0, static_cast<int>(std::floor((theta - reach) / band_height_)));
    const int b1 =
        std::min(num_bands_ - 1, static_cast<int>(std::floor((theta + reach) / band_height_)));
    // Longitude half-width of the cap; unbounded if the cap contains a pole.
    double half_width = kPi;
    if (theta - reach > 0.0 && theta + reach < kPi) {
      const double ratio = std::sin(reach) / std::sin(theta);
      if (ratio < 1.0) half_width = std::asin(ratio) + kSearchMargin;
    }
    for (int b = b0; b <= b1; ++b) {
      const int first = band_first_cell_[b];
      const int m = band_first_cell_[b + 1] - first;
      if (half_width >= kPi) {
        VisitCells(first, first + m, q, radius, min_dot, visit);
        continue;
      }
      const double scale = m / kTwoPi;
      const int c0 = static_cast<int>(std::floor((phi - half_width + kPi) * scale));
      const int c1 = static_cast<int>(std::floor((phi + half_width + kPi) * scale));
      if (c1 - c0 + 1 >= m) {
        VisitCells(first, first + m, q, radius, min_dot, visit);
        continue;
      }
      for (int c = c0; c <= c1; ++c) {
        const int wrapped = ((c % m) + m) % m;
        VisitCells(first + wrapped, first + wrapped + 1, q, radius, min_dot, visit);
      }
    }
  }

  /// Index of the point nearest to the unit vector `q`, other than `exclude` (ties: lowest index),
  /// or -1 if there is none. Writes its angle to *angle.
  int Nearest(const Eigen::Vector3d& q, int64_t exclude, double* angle) const {
    double radius = band_height_;
    while (true) {
      int64_t best = -1;
      double best_angle = std::numeric_limits<double>::infinity();
      ForEachInCap(q, radius, [&](uint32_t index, double a) {
        if (index == exclude) return;
        if (a < best_angle || (a == best_angle && index < best)) {
          best = index;
          best_angle = a;
        }
      });
      if (best >= 0) {
        *angle = best_angle;
        return static_cast<int>(best);
      }
      if (radius >= kPi) return -1;
      radius = std::min(kPi, 2.0 * radius);
    }
  }

 private:
  int CellOf(const Eigen::Vector3d& p) const {
    const int band = std::min(num_bands_ - 1, static_cast<int>(Colatitude(p) / band_height_));
    const int first = band_first_cell_[band];
    const int m = band_first_cell_[band + 1] - first;
    const int cell = static_cast<int>((Longitude(p) + kPi) / kTwoPi * m);
    return first + std::clamp(cell, 0, m - 1);
  }

  template <typename Visit>
  void VisitCells(int cell_begin, int cell_end, const Eigen::Vector3d& q, double radius,
                  double min_dot, Visit& visit) const {
    for (uint32_t k = cell_begin_[cell_begin]; k < cell_begin_[cell_end]; ++k) {
      const Eigen::Vector3d& p = points_[k];
      if (p.dot(q) < min_dot) continue;
      const double a = AngleBetween(q, p);
      if (a <= radius) visit(indices_[k], a);
    }
  }

  int num_bands_ = 1;
  double band_height_ = kPi;
  std::vector<int> band_first_cell_;  // per band, plus the total at the end
  std::vector<uint32_t> cell_begin_;  // CSR offsets into points_/indices_, per cell
  std::vector<Eigen::Vector3d> points_;
  std::vector<uint32_t> indices_;
};

double Median(std::vector<double> values) {
  SILPOSE_ASSERT(!values.empty());
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower =
      *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

/// k-means++ seeding: the first centre uniformly, each next one with probability proportional to
/// the squared distance to the nearest centre chosen so far.
std::vector<Eigen::Vector3d> SeedKMeansPlusPlus(const std::vector<Eigen::Vector3d>& points, int k,
                                                std::mt19937_64& rng) {
  const size_t n = points.size();
  std::vector<bool> chosen(n, false);
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(k);
  size_t first = std::min(n - 1, static_cast<size_t>(UniformUnit(rng) * static_cast<double>(n)));
  chosen[first] = true;
  centres.push_back(points[first]);
  std::vector<double> d2(n);
  for (size_t i = 0; i < n; ++i) d2[i] = (points[i] - points[first]).squaredNorm();
  for (int c = 1; c < k; ++c) {
    double total = 0.0;
    for (size_t i = 0; i < n; ++i) total += d2[i];
    size_t pick = n;
    if (total > 0.0) {
      const double target = UniformUnit(rng) * total;
      double cumulative = 0.0;
      for (size_t i = 0; i < n; ++i) {
        if (d2[i] <= 0.0) continue;
        pick = i;  // the last positive one, should rounding leave target beyond the sum
        cumulative += d2[i];
        if (cumulative > target) break;
      }
    } else {
      // Every remaining point coincides with a centre: take the first one not chosen yet.
      for (size_t i = 0; i < n && pick == n; ++i) {
        if (!chosen[i]) pick = i;
      }
    }
    SILPOSE_ASSERT(pick < n);
    chosen[pick] = true;
    centres.push_back(points[pick]);
    for (size_t i = 0; i < n; ++i) {
      d2[i] = std::min(d2[i], (points[i] - points[pick]).squaredNorm());
    }
  }
  return centres;
}

/// Label of the nearest centre of each point (ties: lowest centre index). The centres are unit
/// vectors, so the Euclidean nearest is the one with the largest dot product.
void AssignToNearest(const std::vector<Eigen::Vector3d>& points,
                     const std::vector<Eigen::Vector3d>& centres, std::vector<uint32_t>* labels) {
  for (size_t i = 0; i < points.size(); ++i) {
    uint32_t best = 0;
    double best_dot = points[i].dot(centres[0]);
    for (size_t c = 1; c < centres.size(); ++c) {
      const double d = points[i].dot(centres[c]);
      if (d > best_dot) {
        best_dot = d;
        best = static_cast<uint32_t>(c);
      }
    }
    (*labels)[i] = best;
  }
}

/// Gives each empty cluster the point farthest from its current centre, taken from a cluster that
/// keeps at least one point. Returns the number of clusters re-seeded.
int FillEmptyClusters(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<Eigen::Vector3d>& centres, std::vector<uint32_t>* labels) {
  const size_t n = points.size();
  std::vector<int> counts(centres.size(), 0);
  for (uint32_t label : *labels) ++counts[label];
  std::vector<bool> moved(n, false);
  int refilled = 0;
  for (size_t c = 0; c < centres.size(); ++c) {
    if (counts[c] > 0) continue;
    size_t far = n;
    double far_d2 = -1.0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t label = (*labels)[i];
      if (moved[i] || counts[label] < 2) continue;
      const double d2 = (points[i] - centres[label]).squaredNorm();
      if (d2 > far_d2) {
        far_d2 = d2;
        far = i;
      }
    }
    SILPOSE_ASSERT(far < n);  // k <= n leaves a cluster with two points while one is empty
    --counts[(*labels)[far]];
    (*labels)[far] = static_cast<uint32_t>(c);
    counts[c] = 1;
    moved[far] = true;
    ++refilled;
  }
  return refilled;
}

/// Unit-length mean of each cluster; a cluster whose mean vanishes keeps its previous centre.
void UpdateCentres(const std::vector<Eigen::Vector3d>& points, const std::vector<uint32_t>& labels,
                   std::vector<Eigen::Vector3d>* centres) {
  std::vector<Eigen::Vector3d> sums(centres->size(), Eigen::Vector3d::Zero());
  for (size_t i = 0; i < points.size(); ++i) sums[labels[i]] += points[i];
  for (size_t c = 0; c < centres->size(); ++c) {
    const double norm = sums[c].norm();
    if (norm > 1e-12) (*centres)[c] = sums[c] / norm;
  }
}

}  // namespace

bool ViewSphereOptions::Check(std::string* error) const {
  std::ostringstream message;
  if (num_views < 4 || num_views > 1'000'000) {
    message << "view sphere option num_views must be between 4 and 1000000, got " << num_views;
  } else if (!(std::isfinite(neighbour_radius_factor) && neighbour_radius_factor > 1.0 &&
               neighbour_radius_factor <= kMaxNeighbourRadiusFactor)) {
    message << "view sphere option neighbour_radius_factor must be greater than 1 and at most "
            << kMaxNeighbourRadiusFactor << ", got " << neighbour_radius_factor;
  } else if (num_bins < 1 || num_bins > num_views) {
    message << "view sphere option num_bins must be between 1 and num_views (" << num_views
            << "), got " << num_bins;
  } else if (kmeans_max_iterations < 1) {
    message << "view sphere option kmeans_max_iterations must be at least 1, got "
            << kmeans_max_iterations;
  } else {
    return true;
  }
  if (error != nullptr) *error = message.str();
  return false;
}

int ViewSphere::NearestView(const Eigen::Vector3d& direction) const {
  SILPOSE_ASSERT(!directions.empty());
  const double norm = direction.norm();
  SILPOSE_ASSERT(norm > 0.0 && std::isfinite(norm));
  const Eigen::Vector3d d = direction / norm;
  int best = 0;
  double best_dot = d.dot(directions[0]);
  for (size_t i = 1; i < directions.size(); ++i) {
    const double dot = d.dot(directions[i]);
    if (dot > best_dot) {
      best_dot = dot;
      best = static_cast<int>(i);
    }
  }
  return best;
}

std::vector<Eigen::Vector3d> FibonacciSphere(int count) {
  if (count < 0) ThrowError("FibonacciSphere: count must be non-negative, got ", count);
  const double golden_angle = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> points;
  points.reserve(count);
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    points.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return points;
}

SphereSamplingStats MeasureSphereSampling(const std::vector<Eigen::Vector3d>& directions,
                                          int probe_count) {
  if (directions.size() < 2) {
    ThrowError("MeasureSphereSampling: needs at least 2 directions, got ", directions.size());
  }
  if (probe_count < 1) {
    ThrowError("MeasureSphereSampling: probe_count must be at least 1, got ", probe_count);
  }
  std::vector<Eigen::Vector3d> unit(directions.size());
  for (size_t i = 0; i < directions.size(); ++i) {
    const double norm = directions[i].norm();
    if (!(norm > 0.0 && std::isfinite(norm))) {
      ThrowError("MeasureSphereSampling: direction ", i, " is zero or not finite");
    }
    unit[i] = directions[i] / norm;
  }
  const SphereGrid grid(unit);

  SphereSamplingStats stats;
  stats.min_nearest_neighbour_rad = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < unit.size(); ++i) {
    double angle = 0.0;
    grid.Nearest(unit[i], static_cast<int64_t>(i), &angle);
    stats.min_nearest_neighbour_rad = std::min(stats.min_nearest_neighbour_rad, angle);
    stats.max_nearest_neighbour_rad = std::max(stats.max_nearest_neighbour_rad, angle);
  }
  stats.spacing_ratio = stats.max_nearest_neighbour_rad > 0.0
                            ? stats.min_nearest_neighbour_rad / stats.max_nearest_neighbour_rad
                            : 0.0;

  // Probes: a denser Fibonacci lattice, turned by a fixed generic rotation so that it shares no
  // symmetry axis (and no points) with a Fibonacci sample set.
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  const std::vector<Eigen::Vector3d> probes = FibonacciSphere(probe_count);
  for (const Eigen::Vector3d& probe : probes) {
    double angle = 0.0;
    grid.Nearest(turn * probe, -1, &angle);
    stats.covering_radius_rad = std::max(stats.covering_radius_rad, angle);
  }
  return stats;
}

std::vector<uint32_t> KMeansOnSphere(const std::vector<Eigen::Vector3d>& points, int k,
                                     uint64_t seed, int max_iterations,
                                     std::vector<Eigen::Vector3d>* centres) {
  SILPOSE_ASSERT(centres != nullptr);
  if (k < 1 || static_cast<size_t>(k) > points.size()) {
    ThrowError("KMeansOnSphere: k must be between 1 and the number of points (", points.size(),
               "), got ", k);
  }
  if (max_iterations < 1) {
    ThrowError("KMeansOnSphere: max_iterations must be at least 1, got ", max_iterations);
  }
  std::mt19937_64 rng(seed);
  *centres = SeedKMeansPlusPlus(points, k, rng);
  for (Eigen::Vector3d& centre : *centres) centre.normalize();

  // Lloyd iterations with the centres constrained to the sphere: assignment to the nearest unit
  // centre, update to the cluster mean projected back on the sphere (the minimiser of the summed
  // squared Euclidean distances among unit vectors). The labels returned are then those of the
  // nearest returned centre whenever the iterations converged.
  std::vector<uint32_t> labels(points.size(), 0);
  std::vector<uint32_t> assigned(points.size(), 0);
  std::vector<uint32_t> previous_assigned;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    AssignToNearest(points, *centres, &assigned);
    // Converged if nothing moved; the second test ends the cycle of a cluster that keeps emptying
    // (duplicate points tied between two centres).
    const bool converged = iteration > 0 && (assigned == labels || assigned == previous_assigned);
    labels = assigned;
    FillEmptyClusters(points, *centres, &labels);
    UpdateCentres(points, labels, centres);
    if (converged) break;
    previous_assigned = assigned;
  }
  return labels;
}

ViewSphere BuildViewSphere(const ViewSphereOptions& options) {
  std::string error;
  if (!options.Check(&error)) ThrowError(error);

  ViewSphere sphere;
  sphere.directions = FibonacciSphere(options.num_views);
  const std::vector<Eigen::Vector3d>& directions = sphere.directions;
  const size_t n = directions.size();
  const SphereGrid grid(directions);

  std::vector<int> nearest(n);
  std::vector<double> nearest_angle(n);
  for (size_t i = 0; i < n; ++i) {
    nearest[i] = grid.Nearest(directions[i], static_cast<int64_t>(i), &nearest_angle[i]);
  }
  sphere.typical_spacing_rad = Median(nearest_angle);

  // Neighbour pairs (i < j) within the radius, then the nearest view of any view left alone.
  const double radius = options.neighbour_radius_factor * sphere.typical_spacing_rad;
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  std::vector<uint32_t> degree(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const auto self = static_cast<uint32_t>(i);
    grid.ForEachInCap(directions[i], radius, [&](uint32_t j, double) {
      if (j <= self) return;
      edges.emplace_back(self, j);
      ++degree[self];
      ++degree[j];
    });
  }
  for (size_t i = 0; i < n; ++i) {
    if (degree[i] > 0) continue;
    const auto a = static_cast<uint32_t>(i);
    const auto b = static_cast<uint32_t>(nearest[i]);
    edges.emplace_back(std::min(a, b), std::max(a, b));
    ++degree[a];
    ++degree[b];
  }

  sphere.neighbour_offsets.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    sphere.neighbour_offsets[i + 1] = sphere.neighbour_offsets[i] + degree[i];
  }
  sphere.neighbour_indices.resize(sphere.neighbour_offsets[n]);
  std::vector<uint32_t> fill(sphere.neighbour_offsets.begin(), sphere.neighbour_offsets.end() - 1);
  for (const auto& [a, b] : edges) {
    sphere.neighbour_indices[fill[a]++] = b;
    sphere.neighbour_indices[fill[b]++] = a;
  }
  for (size_t i = 0; i < n; ++i) {
    std::sort(sphere.neighbour_indices.begin() + sphere.neighbour_offsets[i],
              sphere.neighbour_indices.begin() + sphere.neighbour_offsets[i + 1]);
  }

  sphere.bin_of_view = KMeansOnSphere(directions, options.num_bins, options.kmeans_seed,
                                      options.kmeans_max_iterations, &sphere.bin_centres);
  return sphere;
}

}  // namespace silpose
