#include "silpose/geometry/view_sphere.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kRadToDeg = 180.0 / kPi;

double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// Ideal spacing scale for n points: the side of a square of the area per point.
double IdealSpacing(int n) { return std::sqrt(4.0 * kPi / n); }

std::vector<double> BruteForceNearestAngles(const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> nearest(points.size(), std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t j = 0; j < points.size(); ++j) {
      if (i != j) nearest[i] = std::min(nearest[i], Angle(points[i], points[j]));
    }
  }
  return nearest;
}

Eigen::Vector3d RandomDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

ViewSphereOptions Options(int num_views, int num_bins = 10) {
  ViewSphereOptions options;
  options.num_views = num_views;
  options.num_bins = num_bins;
  return options;
}

TEST(FibonacciSphere, PointsAreUnitOnEqualAreaBandsAndBalanced) {
  for (int n : {1, 4, 100, 1000, 5000}) {
    const std::vector<Eigen::Vector3d> points = FibonacciSphere(n);
    ASSERT_EQ(static_cast<int>(points.size()), n);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) {
      EXPECT_NEAR(points[i].norm(), 1.0, 1e-14) << "n=" << n << " i=" << i;
      EXPECT_NEAR(points[i].z(), 1.0 - (2.0 * i + 1.0) / n, 1e-15);
      sum += points[i];
    }
    // z is balanced exactly; the golden-angle azimuths make x and y nearly so (measured: 2.4e-4
    // of n at n = 100, 1.3e-5 at 1000).
    if (n >= 100) {
      EXPECT_LT(sum.norm() / n, 1e-3) << "n=" << n;
    }
  }
  EXPECT_TRUE(FibonacciSphere(0).empty());
  EXPECT_THROW(FibonacciSphere(-1), Error);
}

TEST(FibonacciSphere, UniformityFigures) {
  // Measured with 200000 probes (covering radius / sqrt(4 pi / N), spacing ratio):
  //   N = 100: 0.766, 0.901;  N = 1000: 0.758, 0.887;  N = 5000: 0.740, 0.877.
  // The exact covering radius of the lattice (largest circumradius of its Delaunay triangles) is
  // 0.770 sqrt(4 pi / N) at all three sizes; the probe estimate can only fall below it, by at most
  // the probes' own covering radius (0.46 degrees for 200000 probes). A hexagonal lattice would
  // reach 0.620.
  struct Case {
    int n;
    double max_covering_over_ideal;
    double min_covering_over_ideal;
    double min_spacing_ratio;
  };
  for (const Case& c :
       {Case{100, 0.78, 0.74, 0.87}, Case{1000, 0.78, 0.72, 0.86}, Case{5000, 0.78, 0.70, 0.85}}) {
    const auto start = std::chrono::steady_clock::now();
    const SphereSamplingStats stats = MeasureSphereSampling(FibonacciSphere(c.n), 200000);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double ideal = IdealSpacing(c.n);
    const double covering_over_ideal = stats.covering_radius_rad / ideal;
    std::cout << "[uniformity] N=" << c.n << " ideal_spacing_deg=" << ideal * kRadToDeg
              << " covering_deg=" << stats.covering_radius_rad * kRadToDeg
              << " covering/ideal=" << covering_over_ideal
              << " min_nn_deg=" << stats.min_nearest_neighbour_rad * kRadToDeg
              << " max_nn_deg=" << stats.max_nearest_neighbour_rad * kRadToDeg
              << " spacing_ratio=" << stats.spacing_ratio << " (" << seconds << " s)\n";
    std::string prefix = "N";
    prefix += std::to_string(c.n) + "_";
    RecordProperty(prefix + "covering_deg", std::to_string(stats.covering_radius_rad * kRadToDeg));
    RecordProperty(prefix + "spacing_ratio", std::to_string(stats.spacing_ratio));
    EXPECT_LE(covering_over_ideal, c.max_covering_over_ideal) << "N=" << c.n;
    EXPECT_GE(covering_over_ideal, c.min_covering_over_ideal) << "N=" << c.n;
    EXPECT_LT(seconds, 20.0) << "N=" << c.n;  // brute force (N x 200000 angles) would not pass
    EXPECT_GE(stats.spacing_ratio, c.min_spacing_ratio) << "N=" << c.n;
    EXPECT_LE(stats.min_nearest_neighbour_rad, stats.max_nearest_neighbour_rad);
    // The midpoint of a point and its nearest neighbour is half their angle from every sample.
    EXPECT_GE(stats.covering_radius_rad, 0.5 * stats.max_nearest_neighbour_rad);
  }
}

TEST(MeasureSphereSampling, OctahedronHasTheKnownCoveringRadius) {
  const std::vector<Eigen::Vector3d> octahedron = {
      Eigen::Vector3d::UnitX(),  -Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
      -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),  -Eigen::Vector3d::UnitZ()};
  const SphereSamplingStats stats = MeasureSphereSampling(octahedron, 20000);
  // The deepest holes are the face centres, acos(1/sqrt(3)) = 54.7356 degrees from the vertices.
  const double exact = std::acos(1.0 / std::sqrt(3.0));
  EXPECT_LE(stats.covering_radius_rad, exact + 1e-12);
  EXPECT_GE(stats.covering_radius_rad, exact - 1.0 / kRadToDeg);
  EXPECT_NEAR(stats.min_nearest_neighbour_rad, kPi / 2, 1e-12);
  EXPECT_NEAR(stats.max_nearest_neighbour_rad, kPi / 2, 1e-12);
  EXPECT_NEAR(stats.spacing_ratio, 1.0, 1e-12);
}

TEST(MeasureSphereSampling, MatchesBruteForceOnClusteredPoints) {
  // Uneven sets exercise the grid's widening search: tight clusters plus a few loners.
  std::mt19937 rng(3);
  std::vector<Eigen::Vector3d> points;
  for (int cluster = 0; cluster < 3; ++cluster) {
    const Eigen::Vector3d axis = RandomDirection(rng);
    for (int i = 0; i < 150; ++i)
      points.push_back((axis + 0.05 * RandomDirection(rng)).normalized());
  }
  for (int i = 0; i < 10; ++i) points.push_back(RandomDirection(rng));
  points.push_back(Eigen::Vector3d::UnitZ());  // a pole
  const SphereSamplingStats stats = MeasureSphereSampling(points, 50000);
  const std::vector<double> nearest = BruteForceNearestAngles(points);
  EXPECT_DOUBLE_EQ(stats.min_nearest_neighbour_rad,
                   *std::min_element(nearest.begin(), nearest.end()));
  EXPECT_DOUBLE_EQ(stats.max_nearest_neighbour_rad,
                   *std::max_element(nearest.begin(), nearest.end()));

  // Independent lower bound of the covering radius from random probes (brute force).
  double random_probe_bound = 0.0;
  for (int probe = 0; probe < 5000; ++probe) {
    const Eigen::Vector3d q = RandomDirection(rng);
    double best = kPi;
    for (const Eigen::Vector3d& p : points) best = std::min(best, Angle(q, p));
    random_probe_bound = std::max(random_probe_bound, best);
  }
  // 50000 probes are within ~1 degree of every point of the sphere.
  EXPECT_GE(stats.covering_radius_rad, random_probe_bound - 1.5 / kRadToDeg);
  EXPECT_LE(stats.covering_radius_rad, kPi);
  EXPECT_THROW(MeasureSphereSampling({Eigen::Vector3d::UnitX()}), Error);
  EXPECT_THROW(MeasureSphereSampling(points, 0), Error);
}

TEST(ViewSphere, BuildIsDeterministic) {
  const ViewSphereOptions options = Options(2000, 25);
  const ViewSphere a = BuildViewSphere(options);
  const ViewSphere b = BuildViewSphere(options);
  ASSERT_EQ(a.num_views(), 2000);
  ASSERT_EQ(b.num_views(), 2000);
  for (int i = 0; i < a.num_views(); ++i) {
    EXPECT_EQ(a.directions[i], b.directions[i]) << i;
  }
  EXPECT_EQ(a.typical_spacing_rad, b.typical_spacing_rad);
  EXPECT_EQ(a.neighbour_offsets, b.neighbour_offsets);
  EXPECT_EQ(a.neighbour_indices, b.neighbour_indices);
  EXPECT_EQ(a.bin_of_view, b.bin_of_view);
  ASSERT_EQ(a.num_bins(), 25);
  for (int k = 0; k < a.num_bins(); ++k) EXPECT_EQ(a.bin_centres[k], b.bin_centres[k]) << k;
}

TEST(ViewSphere, TypicalSpacingIsTheMedianNearestNeighbourAngle) {
  const ViewSphere sphere = BuildViewSphere(Options(1001));
  std::vector<double> nearest = BruteForceNearestAngles(sphere.directions);
  std::nth_element(nearest.begin(), nearest.begin() + 500, nearest.end());
  EXPECT_DOUBLE_EQ(sphere.typical_spacing_rad, nearest[500]);
}

TEST(ViewSphere, NeighbourGraphIsSymmetricAndMatchesTheRadius) {
  for (int n : {100, 1000}) {
    const ViewSphereOptions options = Options(n);
    const ViewSphere sphere = BuildViewSphere(options);
    const double radius = options.neighbour_radius_factor * sphere.typical_spacing_rad;
    ASSERT_EQ(sphere.neighbour_offsets.size(), static_cast<size_t>(n) + 1);
    ASSERT_EQ(sphere.neighbour_offsets.back(), sphere.neighbour_indices.size());
    int min_degree = n;
    int max_degree = 0;
    for (int i = 0; i < n; ++i) {
      const auto neighbours = sphere.Neighbours(i);
      min_degree = std::min(min_degree, static_cast<int>(neighbours.size()));
      max_degree = std::max(max_degree, static_cast<int>(neighbours.size()));
      EXPECT_TRUE(std::is_sorted(neighbours.begin(), neighbours.end())) << i;
      EXPECT_TRUE(std::adjacent_find(neighbours.begin(), neighbours.end()) == neighbours.end());
      std::vector<bool> listed(n, false);
      for (uint32_t j : neighbours) {
        ASSERT_LT(j, static_cast<uint32_t>(n));
        EXPECT_NE(static_cast<int>(j), i) << "self loop";
        listed[j] = true;
        EXPECT_LE(Angle(sphere.directions[i], sphere.directions[j]), radius + 1e-12);
        const auto back = sphere.Neighbours(static_cast<int>(j));
        EXPECT_TRUE(std::binary_search(back.begin(), back.end(), static_cast<uint32_t>(i)))
            << i << " -> " << j << " is not symmetric";
      }
      for (int j = 0; j < n; ++j) {
        if (j != i && Angle(sphere.directions[i], sphere.directions[j]) < radius - 1e-12) {
          EXPECT_TRUE(listed[j]) << j << " is within the radius of " << i << " but not listed";
        }
      }
    }
    const double mean_degree = static_cast<double>(sphere.neighbour_indices.size()) / n;
    std::cout << "[neighbours] N=" << n << " spacing_deg=" << sphere.typical_spacing_rad * kRadToDeg
              << " radius_deg=" << radius * kRadToDeg << " mean_degree=" << mean_degree
              << " min_degree=" << min_degree << " max_degree=" << max_degree << "\n";
    std::string key = "N";
    key += std::to_string(n) + "_mean_degree";
    RecordProperty(key, std::to_string(mean_degree));
    EXPECT_GE(min_degree, 1);
    // Measured: mean 5.88 (N = 100) and 6.00 (N = 1000), degrees 5 to 7: the lattice is locally
    // close to hexagonal and 1.5 spacings reaches the first ring only.
    EXPECT_GE(mean_degree, 5.5);
    EXPECT_LE(mean_degree, 7.0);
    EXPECT_LE(max_degree, 8);
  }
}

TEST(ViewSphere, EveryViewHasANeighbourEvenWithATightRadius) {
  ViewSphereOptions options = Options(500);
  options.neighbour_radius_factor = 1.0001;
  const ViewSphere sphere = BuildViewSphere(options);
  const double radius = options.neighbour_radius_factor * sphere.typical_spacing_rad;
  int beyond_radius = 0;
  for (int i = 0; i < sphere.num_views(); ++i) {
    const auto neighbours = sphere.Neighbours(i);
    EXPECT_FALSE(neighbours.empty()) << i;
    for (uint32_t j : neighbours) {
      const auto back = sphere.Neighbours(static_cast<int>(j));
      EXPECT_TRUE(std::binary_search(back.begin(), back.end(), static_cast<uint32_t>(i)));
      if (Angle(sphere.directions[i], sphere.directions[j]) > radius) ++beyond_radius;
    }
  }
  // The radius alone leaves views without neighbours; they were given their nearest one.
  EXPECT_GT(beyond_radius, 0);
}

TEST(ViewSphere, KMeansBinsAreConvergedAndBalanced) {
  const ViewSphere sphere = BuildViewSphere(Options(1000, 10));
  ASSERT_EQ(sphere.num_bins(), 10);
  ASSERT_EQ(sphere.bin_of_view.size(), 1000u);
  std::vector<int> sizes(10, 0);
  for (const Eigen::Vector3d& centre : sphere.bin_centres) EXPECT_NEAR(centre.norm(), 1.0, 1e-12);
  for (int i = 0; i < 1000; ++i) {
    const uint32_t label = sphere.bin_of_view[i];
    ASSERT_LT(label, 10u);
    ++sizes[label];
    double best = -2.0;
    for (const Eigen::Vector3d& centre : sphere.bin_centres) {
      best = std::max(best, sphere.directions[i].dot(centre));
    }
    EXPECT_GE(sphere.directions[i].dot(sphere.bin_centres[label]), best - 1e-12)
        << "view " << i << " is not in the bin of its nearest centre";
  }
  // Each centre is the (projected) mean of its bin.
  for (int k = 0; k < 10; ++k) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int i = 0; i < 1000; ++i) {
      if (sphere.bin_of_view[i] == static_cast<uint32_t>(k)) sum += sphere.directions[i];
    }
    EXPECT_NEAR((sum.normalized() - sphere.bin_centres[k]).norm(), 0.0, 1e-12);
  }
  const auto [smallest, largest] = std::minmax_element(sizes.begin(), sizes.end());
  std::cout << "[kmeans] N=1000 K=10 bin sizes min=" << *smallest << " max=" << *largest << "\n";
  EXPECT_GT(*smallest, 0);
  // Measured: 94 to 104 views per bin.
  EXPECT_LT(static_cast<double>(*largest) / *smallest, 1.3);
}

TEST(KMeansOnSphere, RecoversSeparatedClusters) {
  // Four tight clusters at the vertices of a tetrahedron.
  const std::vector<Eigen::Vector3d> axes = {
      Eigen::Vector3d(1, 1, 1).normalized(), Eigen::Vector3d(1, -1, -1).normalized(),
      Eigen::Vector3d(-1, 1, -1).normalized(), Eigen::Vector3d(-1, -1, 1).normalized()};
  std::mt19937 rng(11);
  std::vector<Eigen::Vector3d> points;
  std::vector<int> truth;
  for (int i = 0; i < 400; ++i) {
    truth.push_back(i % 4);
    points.push_back((axes[i % 4] + 0.1 * RandomDirection(rng)).normalized());
  }
  for (uint64_t seed : {1u, 2u, 3u}) {
    std::vector<Eigen::Vector3d> centres;
    const std::vector<uint32_t> labels = KMeansOnSphere(points, 4, seed, 50, &centres);
    ASSERT_EQ(centres.size(), 4u);
    for (int i = 0; i < 400; ++i) {
      // Same true cluster <=> same label (compare with the first member of each cluster).
      EXPECT_EQ(labels[i], labels[i % 4]) << "seed " << seed << " point " << i;
      for (int t = 0; t < 4; ++t) {
        if (t != i % 4) {
          EXPECT_NE(labels[i], labels[t]);
        }
      }
    }
    for (int t = 0; t < 4; ++t) {
      EXPECT_LT(Angle(centres[labels[t]], axes[t]), 2.0 / kRadToDeg) << "seed " << seed;
    }
  }
}

TEST(KMeansOnSphere, NoEmptyBinWithDuplicatePointsOrOnePointPerBin) {
  const std::vector<Eigen::Vector3d> duplicates = {
      Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX(),
      Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitY()};
  for (uint64_t seed = 0; seed < 10; ++seed) {
    std::vector<Eigen::Vector3d> centres;
    const std::vector<uint32_t> labels = KMeansOnSphere(duplicates, 3, seed, 20, &centres);
    std::vector<int> sizes(3, 0);
    for (uint32_t label : labels) ++sizes[label];
    for (int k = 0; k < 3; ++k) EXPECT_GT(sizes[k], 0) << "seed " << seed << " bin " << k;
  }
  const std::vector<Eigen::Vector3d> points = FibonacciSphere(30);
  std::vector<Eigen::Vector3d> centres;
  const std::vector<uint32_t> labels = KMeansOnSphere(points, 30, 5, 10, &centres);
  std::vector<uint32_t> sorted = labels;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_TRUE(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR((centres[labels[i]] - points[i]).norm(), 0.0, 1e-12);
  }
  EXPECT_THROW(KMeansOnSphere(points, 0, 1, 10, &centres), Error);
  EXPECT_THROW(KMeansOnSphere(points, 31, 1, 10, &centres), Error);
  EXPECT_THROW(KMeansOnSphere(points, 3, 1, 0, &centres), Error);
}

TEST(ViewSphere, NearestViewFindsTheClosestView) {
  const ViewSphere sphere = BuildViewSphere(Options(1000));
  for (int i = 0; i < sphere.num_views(); ++i) {
    EXPECT_EQ(sphere.NearestView(sphere.directions[i]), i);
    EXPECT_EQ(sphere.NearestView(3.5 * sphere.directions[i]), i);  // need not be unit
  }
  std::mt19937 rng(5);
  for (int probe = 0; probe < 200; ++probe) {
    const Eigen::Vector3d q = RandomDirection(rng);
    const int nearest = sphere.NearestView(0.2 * q);
    for (const Eigen::Vector3d& d : sphere.directions) {
      EXPECT_LE(Angle(q, sphere.directions[nearest]), Angle(q, d) + 1e-12);
    }
  }
}

TEST(ViewSphereOptions, InvalidOptionsThrowNamingTheField) {
  std::string error;
  EXPECT_TRUE(ViewSphereOptions().Check(&error)) << error;
  EXPECT_TRUE(ViewSphereOptions().Check());

  struct Case {
    ViewSphereOptions options;
    std::string field;
    std::string value;
  };
  const auto with = [](auto set) {
    ViewSphereOptions options;
    set(options);
    return options;
  };
  const std::vector<Case> cases = {
      {with([](ViewSphereOptions& o) { o.num_views = 3; }), "num_views", "3"},
      {with([](ViewSphereOptions& o) { o.num_views = 1'000'001; }), "num_views", "1000001"},
      {with([](ViewSphereOptions& o) { o.neighbour_radius_factor = 1.0; }),
       "neighbour_radius_factor", "1"},
      {with([](ViewSphereOptions& o) {
         o.neighbour_radius_factor = std::numeric_limits<double>::quiet_NaN();
       }),
       "neighbour_radius_factor", "nan"},
      {with([](ViewSphereOptions& o) {
         o.neighbour_radius_factor = std::numeric_limits<double>::infinity();
       }),
       "neighbour_radius_factor", "inf"},
      {with([](ViewSphereOptions& o) { o.num_bins = 0; }), "num_bins", "0"},
      {with([](ViewSphereOptions& o) {
         o.num_views = 20;
         o.num_bins = 21;
       }),
       "num_bins", "21"},
      {with([](ViewSphereOptions& o) { o.kmeans_max_iterations = 0; }), "kmeans_max_iterations",
       "0"},
  };

  for (const Case& c : cases) {
    error.clear();
    EXPECT_FALSE(c.options.Check(&error)) << c.field;
    EXPECT_NE(error.find(c.field), std::string::npos) << error;
    EXPECT_NE(error.find(c.value), std::string::npos) << error;
    EXPECT_FALSE(c.options.Check());  // a null error pointer is allowed
    try {
      BuildViewSphere(c.options);
      ADD_FAILURE() << "no exception for " << c.field;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace silpose
