#include "silpose/filter/particle_filter.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <random>
#include <type_traits>

#include "silpose/database/database_builder.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;

// The filter keeps references to its sphere and spectra: no temporaries.
static_assert(std::is_constructible_v<ParticleFilter, const ViewSphere&, const ViewSpectra&>);
static_assert(!std::is_constructible_v<ParticleFilter, ViewSphere&&, const ViewSpectra&>);
static_assert(!std::is_constructible_v<ParticleFilter, const ViewSphere&, ViewSpectra&&>);

// The true pose of one frame.
struct TruePose {
  int object = 0;
  Eigen::Vector3d view_dir = Eigen::Vector3d::UnitZ();
  double roll_deg = 0.0;
};

// A smooth camera path: the camera orbits the object about a random axis by `step_deg` per frame
// while turning about its optical axis by `roll_rate_deg` per frame.
std::vector<TruePose> SmoothPath(uint64_t seed, int object, int frames, double step_deg = 1.5,
                                 double roll_rate_deg = 0.5) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d start = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
  const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
  const double start_roll = std::uniform_real_distribution<double>(-180.0, 180.0)(rng);
  const Eigen::Matrix3d camera_from_object_0 = CameraFromObjectRotation(start, start_roll);
  std::vector<TruePose> path;
  for (int t = 0; t < frames; ++t) {
    const Eigen::Matrix3d orbit = Eigen::AngleAxisd(t * step_deg * kDegToRad, axis).matrix();
    TruePose pose;
    pose.object = object;
    ViewAndRollFromRotation(camera_from_object_0 * orbit.transpose(), &pose.view_dir,
                            &pose.roll_deg);
    pose.roll_deg = WrapDegrees(pose.roll_deg + roll_rate_deg * t);
    path.push_back(pose);
  }
  return path;
}

enum class Degradation { kNone, kErosion, kOccluder };

// The database of three sample models (1000 views as by default, where the likelihood was tuned;
// 256 px to keep the test fast), their meshes, and helpers to render frames as a video camera would
// see them: 640 x 480, another distance and focal length than the database's.
class ParticleFilterTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::vector<std::filesystem::path> paths;
    for (const char* name : {"bunny", "cow", "hand"}) {
      paths.push_back(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) /
                      (std::string(name) + ".obj"));
    }
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 1000;
    options.parameters.render.resolution_px = 256;
    database_ = new ViewDatabase(BuildViewDatabase(paths, options));
    spectra_ = new ViewSpectra(*database_);
    meshes_ = new std::vector<TriangleMesh>();
    for (const auto& path : paths) meshes_->push_back(LoadMesh(path));
  }
  static void TearDownTestSuite() {
    delete meshes_;
    delete spectra_;
    delete database_;
  }

  static const ViewSphere& Sphere() { return database_->sphere; }

  static cv::Mat RenderFrame(const TruePose& pose, Degradation degradation = Degradation::kNone) {
    const TriangleMesh& mesh = (*meshes_)[static_cast<size_t>(pose.object)];
    cv::Mat mask;
    RenderSilhouette(
        mesh, PinholeCamera::Centered(640, 480, 600.0),
        CameraFromObjectAtView(pose.view_dir, pose.roll_deg, 4.0 * mesh.Radius(), mesh.Centre()),
        &mask);
    if (degradation == Degradation::kErosion) {
      cv::erode(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {25, 25}));
    } else if (degradation == Degradation::kOccluder) {
      // A box over a quarter of the silhouette's bounding box, at its upper left.
      const cv::Rect box = cv::boundingRect(mask);
      cv::rectangle(
          mask,
          cv::Rect(box.x + box.width / 8, box.y + box.height / 8, box.width / 2, box.height / 2),
          cv::Scalar(0), cv::FILLED);
    }
    return mask;
  }

  static std::vector<float> Signature(const TruePose& pose,
                                      Degradation degradation = Degradation::kNone) {
    const SignatureResult result = ExtractSignature(RenderFrame(pose, degradation));
    EXPECT_TRUE(result.ok());
    return result.signature.radii;
  }

  // Angle between the estimated view and the true one, in units of the database's view spacing.
  static double ViewErrorInSpacings(const FilterEstimate& estimate, const TruePose& pose) {
    const Eigen::Vector3d& view = Sphere().directions[static_cast<size_t>(estimate.view)];
    return std::acos(std::clamp(view.dot(pose.view_dir), -1.0, 1.0)) / Sphere().typical_spacing_rad;
  }

  static bool Right(const FilterEstimate& estimate, const TruePose& pose) {
    // Within two spacings: the nearest view or one of its neighbours.
    return estimate.object == pose.object && ViewErrorInSpacings(estimate, pose) < 2.0;
  }

  static double WeightSum(const ParticleFilter& filter) {
    double sum = 0.0;
    for (const Particle& p : filter.particles()) sum += p.weight;
    return sum;
  }

  static ViewDatabase* database_;
  static ViewSpectra* spectra_;
  static std::vector<TriangleMesh>* meshes_;
};

ViewDatabase* ParticleFilterTest::database_ = nullptr;
ViewSpectra* ParticleFilterTest::spectra_ = nullptr;
std::vector<TriangleMesh>* ParticleFilterTest::meshes_ = nullptr;

TEST_F(ParticleFilterTest, IdentifiesObjectAndViewFromNoInitialPoseWithinTenFrames) {
  for (int object = 0; object < 3; ++object) {
    const std::vector<TruePose> path = SmoothPath(10 + object, object, 30);
    ParticleFilterOptions options;
    options.seed = 3;
    ParticleFilter filter(Sphere(), *spectra_, options);
    int first_right = -1;
    std::vector<double> errors;
    for (size_t t = 0; t < path.size(); ++t) {
      const FilterEstimate estimate = filter.Step(Signature(path[t]));
      const bool right = Right(estimate, path[t]);
      if (right && first_right < 0) first_right = static_cast<int>(t);
      if (t >= 10) {
        EXPECT_EQ(estimate.object, object) << "frame " << t;
        errors.push_back(ViewErrorInSpacings(estimate, path[t]));
      }
    }
    EXPECT_GE(first_right, 0) << "object " << object;
    EXPECT_LE(first_right, 9) << "object " << object;
    // From frame 10 on the pose stays near the truth: the nearest database view is at most the
    // covering radius (0.77 spacings) away. The worst frame may stray a little further: how far
    // depends on the floating-point details of the build (2.01 spacings in a clang build with
    // the sanitizers, below 2 with gcc).
    std::sort(errors.begin(), errors.end());
    EXPECT_LT(errors[errors.size() / 2], 1.0) << "object " << object;
    EXPECT_LT(errors.back(), 2.5) << "object " << object;
  }
}

TEST_F(ParticleFilterTest, ReidentifiesTheObjectWithinTenFramesAfterASwitch) {
  for (const auto& [first, second] : {std::pair{0, 2}, std::pair{1, 0}}) {
    std::vector<TruePose> path = SmoothPath(20 + first, first, 25);
    const std::vector<TruePose> after = SmoothPath(30 + second, second, 25);
    path.insert(path.end(), after.begin(), after.end());
    ParticleFilterOptions options;
    options.seed = 5;
    ParticleFilter filter(Sphere(), *spectra_, options);
    int right_since = -1;
    for (size_t t = 0; t < path.size(); ++t) {
      const FilterEstimate estimate = filter.Step(Signature(path[t]));
      if (t == 24) {
        EXPECT_TRUE(Right(estimate, path[t])) << "before the switch";
      }
      if (t >= 25) {
        if (!Right(estimate, path[t])) {
          right_since = -1;
        } else if (right_since < 0) {
          right_since = static_cast<int>(t);
        }
      }
    }
    // Right from at most 10 frames after the switch to the end.
    EXPECT_GE(right_since, 25) << first << " -> " << second;
    EXPECT_LE(right_since, 25 + 10) << first << " -> " << second;
  }
}

TEST_F(ParticleFilterTest, ArbiterDecidesOnlyBetweenTheChoiceAndAHigherScoringOtherMode) {
  // Object 0, then object 2 from frame 12, every third frame eroded: the frames after the switch
  // and the degraded ones are where the best-scoring particle leaves the estimate's mode.
  std::vector<TruePose> path = SmoothPath(61, 0, 12);
  const std::vector<TruePose> after = SmoothPath(62, 2, 18);
  path.insert(path.end(), after.begin(), after.end());
  std::vector<std::vector<float>> signatures;
  for (size_t t = 0; t < path.size(); ++t) {
    signatures.push_back(
        Signature(path[t], t % 3 == 2 ? Degradation::kErosion : Degradation::kNone));
  }
  ParticleFilterOptions options;
  options.seed = 8;
  const auto angle_deg = [](int a, int b) {
    const double c = Sphere().directions[static_cast<size_t>(a)].dot(
        Sphere().directions[static_cast<size_t>(b)]);
    return std::acos(std::clamp(c, -1.0, 1.0)) / kDegToRad;
  };
  struct Call {
    FilterEstimate::Hypothesis chosen, challenger;
  };
  const auto run = [&](bool with_arbiter, bool prefer_challenger, std::vector<Call>* calls) {
    ParticleFilter filter(Sphere(), *spectra_, options);
    if (with_arbiter) {
      filter.SetArbiter([=](const FilterEstimate::Hypothesis& chosen,
                            const FilterEstimate::Hypothesis& challenger) {
        calls->push_back({chosen, challenger});
        return prefer_challenger;
      });
    }
    std::vector<FilterEstimate> estimates;
    for (const std::vector<float>& signature : signatures) {
      estimates.push_back(filter.Step(signature));
    }
    return estimates;
  };
  std::vector<Call> none;
  const std::vector<FilterEstimate> plain = run(false, false, &none);
  std::vector<Call> refused;
  const std::vector<FilterEstimate> kept = run(true, false, &refused);
  ASSERT_FALSE(refused.empty());
  // Asked only about a challenger that scored higher, outside the choice's mode (the sample
  // models have no rotational symmetry: plain angles), with both rolls known.
  for (const Call& call : refused) {
    EXPECT_GT(call.challenger.score, call.chosen.score);
    EXPECT_TRUE(call.chosen.roll_known && call.challenger.roll_known);
    EXPECT_TRUE(call.challenger.object != call.chosen.object ||
                angle_deg(call.challenger.view, call.chosen.view) > options.mode_radius_deg);
  }
  // An arbiter that keeps the choice changes nothing.
  ASSERT_EQ(kept.size(), plain.size());
  int asked = 0;
  for (size_t t = 0; t < kept.size(); ++t) {
    EXPECT_EQ(kept[t].object, plain[t].object) << t;
    EXPECT_EQ(kept[t].view, plain[t].view) << t;
    EXPECT_EQ(kept[t].roll_deg, plain[t].roll_deg) << t;
    EXPECT_EQ(kept[t].object_probability, plain[t].object_probability) << t;
    EXPECT_FALSE(plain[t].arbitrated);
    EXPECT_FALSE(kept[t].challenger_won);
    // The top particle is reported in every measured frame, and no particle scored higher than it.
    EXPECT_GE(kept[t].top.score, kept[t].score) << t;
    EXPECT_GE(kept[t].top.object, 0);
    asked += kept[t].arbitrated;
  }
  EXPECT_EQ(asked, static_cast<int>(refused.size()));
  // An arbiter that prefers the challenger: it is reported, with half of the weight.
  std::vector<Call> granted;
  const std::vector<FilterEstimate> moved = run(true, true, &granted);
  int won = 0;
  for (const FilterEstimate& estimate : moved) {
    if (!estimate.arbitrated) continue;
    ++won;
    EXPECT_TRUE(estimate.challenger_won);
    EXPECT_EQ(estimate.object, estimate.top.object);
    EXPECT_EQ(estimate.view, estimate.top.view);
    EXPECT_EQ(estimate.score, estimate.top.score);
    EXPECT_GE(estimate.weight, 0.5 - 1e-9);
    EXPECT_GE(estimate.object_probability[static_cast<size_t>(estimate.object)], 0.5 - 1e-9);
  }
  EXPECT_GT(won, 0);
  EXPECT_EQ(won, static_cast<int>(granted.size()));
}

TEST_F(ParticleFilterTest, ReflectModeMovesTheModeToItsMirrorTwinAndNothingElse) {
  const std::vector<TruePose> path = SmoothPath(63, 1, 12);
  ParticleFilterOptions options;
  options.seed = 9;
  ParticleFilter filter(Sphere(), *spectra_, options);
  FilterEstimate estimate;
  for (const TruePose& pose : path) estimate = filter.Step(Signature(pose));
  ASSERT_EQ(estimate.object, 1);
  // A mirror plane with a generic normal.
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.5, 0.8).normalized();
  const Eigen::Matrix3d a = Eigen::Matrix3d::Identity() - 2.0 * n * n.transpose();
  const Eigen::Matrix3d f = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  const std::vector<Particle> before = filter.particles();
  filter.ReflectMode(estimate.object, estimate.view, a);
  const std::vector<Particle>& after = filter.particles();
  ASSERT_EQ(after.size(), before.size());
  const auto direction = [](int view) { return Sphere().directions[static_cast<size_t>(view)]; };
  const Eigen::Vector3d centre = direction(estimate.view);
  const double spacing_deg = Sphere().typical_spacing_rad / kDegToRad;
  int moved = 0;
  for (size_t i = 0; i < after.size(); ++i) {
    const Particle& p = before[i];
    const Particle& q = after[i];
    EXPECT_EQ(q.object, p.object);
    EXPECT_EQ(q.weight, p.weight);
    EXPECT_EQ(q.roll_known, p.roll_known);
    const bool in_mode =
        p.object == estimate.object &&
        std::acos(std::clamp(direction(p.view).dot(centre), -1.0, 1.0)) / kDegToRad <=
            options.mode_radius_deg;
    if (!in_mode) {
      EXPECT_EQ(q.view, p.view);
      EXPECT_EQ(q.roll_deg, p.roll_deg);
      continue;
    }
    ++moved;
    // At the database view nearest the twin direction -A d ...
    const Eigen::Vector3d twin = -(a * direction(p.view));
    EXPECT_EQ(q.view, Sphere().NearestView(twin));
    EXPECT_LT(std::acos(std::clamp(direction(q.view).dot(twin), -1.0, 1.0)) / kDegToRad,
              spacing_deg);
    if (!p.roll_known) continue;
    // ... with the roll of F R A: up to the grid's offset of the view, the same rotation.
    const Eigen::Matrix3d expected =
        f * CameraFromObjectRotation(direction(p.view), p.roll_deg) * a;
    const Eigen::Matrix3d got = CameraFromObjectRotation(direction(q.view), q.roll_deg);
    EXPECT_LT(Eigen::AngleAxisd(Eigen::Matrix3d(expected.transpose() * got)).angle() / kDegToRad,
              1.5 * spacing_deg);
  }
  EXPECT_GT(moved, static_cast<int>(after.size()) / 4);
  // The filter goes on from there.
  const FilterEstimate next = filter.Step(Signature(path.back()));
  EXPECT_TRUE(next.measured);
  EXPECT_THROW(filter.ReflectMode(5, 0, a), Error);
  EXPECT_THROW(filter.ReflectMode(0, -1, a), Error);
}

TEST_F(ParticleFilterTest, ProposalCoversEveryObjectOnlyWhenTheParticlesLoseTheFrame) {
  // Object 0 for 20 frames, then object 2: the switch is a frame the particles lose.
  std::vector<TruePose> path = SmoothPath(50, 0, 20);
  const std::vector<TruePose> after = SmoothPath(51, 2, 12);
  path.insert(path.end(), after.begin(), after.end());
  ParticleFilterOptions options;
  options.seed = 9;
  options.proposal_objects_per_frame = 0;  // only the most probable object when confident
  ParticleFilter filter(Sphere(), *spectra_, options);
  const int views = options.proposal_views;
  int cheap = 0;
  int right_after_switch = 0;
  for (size_t t = 0; t < path.size(); ++t) {
    const FilterEstimate estimate = filter.Step(Signature(path[t]));
    if (t == 0) {
      EXPECT_EQ(estimate.proposed, 3) << "first frame: each object's best view";
    }
    if (t >= 10 && t < 20) cheap += estimate.proposed == views;
    // A proposal covers the most probable object (views) and some others (one each).
    EXPECT_GE(estimate.proposed, views) << "frame " << t;
    EXPECT_LE(estimate.proposed, views + 2) << "frame " << t;
    if (t == 20) {
      EXPECT_EQ(estimate.proposed, views + 2) << "the switch: every object";
    }
    if (t >= 25) right_after_switch += Right(estimate, path[t]);
  }
  // Tracking a clean silhouette, most frames propose for the tracked object only.
  EXPECT_GE(cheap, 8);
  EXPECT_EQ(right_after_switch, static_cast<int>(path.size()) - 25);

  // Enough objects per frame for all of them: every frame covers every object.
  options.proposal_objects_per_frame = 2;
  ParticleFilter every(Sphere(), *spectra_, options);
  for (size_t t = 1; t < 12; ++t) {
    const FilterEstimate estimate = every.Step(Signature(path[t]));
    if (t > 1) {
      EXPECT_EQ(estimate.proposed, views + 2) << "frame " << t;
    }
  }
}

TEST_F(ParticleFilterTest, PredictionOnlyFramesAreReportedAndKeepTheFilterValid) {
  const std::vector<TruePose> path = SmoothPath(40, 1, 30);
  ParticleFilter filter(Sphere(), *spectra_);
  const size_t count = filter.particles().size();
  // No silhouette at all in the first frames.
  for (int t = 0; t < 3; ++t) {
    const FilterEstimate estimate = filter.Predict();
    EXPECT_FALSE(estimate.measured);
    EXPECT_FALSE(estimate.roll_known);
    EXPECT_EQ(estimate.frame, t);
    EXPECT_EQ(static_cast<size_t>(estimate.num_particles), count);
    EXPECT_NEAR(WeightSum(filter), 1.0, 1e-9);
  }
  FilterEstimate last;
  for (size_t t = 3; t < path.size(); ++t) {
    // Every third frame has no usable silhouette.
    last = t % 3 == 0 ? filter.Predict() : filter.Step(Signature(path[t]));
    EXPECT_EQ(last.measured, t % 3 != 0);
    EXPECT_EQ(last.frame, static_cast<int64_t>(t));
    EXPECT_NEAR(WeightSum(filter), 1.0, 1e-9);
    EXPECT_NEAR(
        std::accumulate(last.object_probability.begin(), last.object_probability.end(), 0.0), 1.0,
        1e-9);
  }
  EXPECT_TRUE(Right(last, path.back()));
  EXPECT_EQ(filter.BestHistory().size(), path.size());
}

TEST_F(ParticleFilterTest, EndsOnTheRightObjectAndPoseWithOneFrameInFiveBadlyDegraded) {
  for (int object = 0; object < 3; ++object) {
    const std::vector<TruePose> path = SmoothPath(50 + object, object, 50);
    ParticleFilterOptions options;
    options.seed = 7;
    ParticleFilter filter(Sphere(), *spectra_, options);
    int right_object = 0, good_late = 0, right_late = 0;
    bool last_good_right = false;
    for (size_t t = 0; t < path.size(); ++t) {
      const bool bad = t % 5 == 2;
      const Degradation degradation =
          !bad ? Degradation::kNone
               : (t % 10 == 2 ? Degradation::kErosion : Degradation::kOccluder);
      const FilterEstimate estimate = filter.Step(Signature(path[t], degradation));
      // The object is known after a few frames, even on the bad ones; the pose is right by the
      // end (a bad frame among the first can start the search on a look-alike view, paper 5.2:
      // "usually recovers within few frames").
      if (t >= 10) right_object += estimate.object == object ? 1 : 0;
      if (t + 10 >= path.size() && !bad) {
        ++good_late;
        last_good_right = Right(estimate, path[t]);
        right_late += last_good_right;
      }
    }
    EXPECT_GE(right_object, 38) << "object " << object;
    // Of the last ten frames' good ones (eight), nearly all have the right pose, the last one
    // surely: a bad frame can push the estimate off by a view for a frame or two, and how often
    // depends on the floating-point details of the build (gcc -O3: none; clang with the
    // sanitizers: two).
    EXPECT_EQ(good_late, 8);
    EXPECT_GE(right_late, 6) << "object " << object;
    EXPECT_TRUE(last_good_right) << "object " << object;
  }
}

TEST_F(ParticleFilterTest, EffectiveSampleSizeIsReportedAndResamplingTriggersBelowTheThreshold) {
  EXPECT_DOUBLE_EQ(EffectiveSampleSize(std::vector<double>(8, 0.125)), 8.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize(std::vector<double>{0.0, 1.0, 0.0}), 1.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize(std::vector<double>{0.5, 0.5, 0.0, 0.0}), 2.0);
  EXPECT_DOUBLE_EQ(EffectiveSampleSize(std::vector<double>{}), 0.0);

  const std::vector<TruePose> path = SmoothPath(60, 2, 16);
  {
    // Never resampling: the reported ESS is that of the weights the frame leaves.
    ParticleFilterOptions options;
    options.resample_threshold = 0.0;
    ParticleFilter filter(Sphere(), *spectra_, options);
    for (const TruePose& pose : path) {
      const FilterEstimate estimate = filter.Step(Signature(pose));
      EXPECT_FALSE(estimate.resampled);
      std::vector<double> weights;
      for (const Particle& p : filter.particles()) weights.push_back(p.weight);
      EXPECT_NEAR(std::accumulate(weights.begin(), weights.end(), 0.0), 1.0, 1e-9);
      EXPECT_NEAR(estimate.effective_particles, EffectiveSampleSize(weights), 1e-6);
    }
  }
  // Default: resample exactly when ESS < 2N/3.
  ParticleFilter filter(Sphere(), *spectra_);
  int resampled = 0;
  int kept = 0;
  for (size_t t = 0; t < path.size(); ++t) {
    // A prediction-only frame after each measured one: weights hardly change, no resampling.
    for (const bool measured : {true, false}) {
      const FilterEstimate estimate = measured ? filter.Step(Signature(path[t])) : filter.Predict();
      EXPECT_EQ(estimate.resampled,
                estimate.effective_particles < 2.0 / 3.0 * estimate.num_particles)
          << "frame " << estimate.frame;
      EXPECT_LE(estimate.effective_particles, estimate.num_particles + 1e-9);
      EXPECT_GE(estimate.effective_particles, 1.0 - 1e-9);
      (estimate.resampled ? resampled : kept) += 1;
      EXPECT_NEAR(WeightSum(filter), 1.0, 1e-9);
      // Fixed count: resampling keeps the total.
      EXPECT_EQ(estimate.num_particles_after, 3 * 60);
    }
  }
  EXPECT_GT(resampled, 0);
  EXPECT_GT(kept, 0);
}

TEST(SystematicResampling, CountsAreFloorOrCeilOfTheExpectedAndSumToTheDraw) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<double> weights(37);
    for (double& w : weights) w = uniform(rng) < 0.3 ? 0.0 : uniform(rng);
    const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
    const int count = 1 + static_cast<int>(rng() % 200);
    const std::vector<int> counts = SystematicResampleCounts(weights, count, uniform(rng));
    EXPECT_EQ(std::accumulate(counts.begin(), counts.end(), 0), count);
    for (size_t i = 0; i < weights.size(); ++i) {
      const double expected = count * weights[i] / total;
      EXPECT_GE(counts[i], std::floor(expected - 1e-9)) << i;
      EXPECT_LE(counts[i], std::ceil(expected + 1e-9)) << i;
      if (weights[i] == 0.0) {
        EXPECT_EQ(counts[i], 0);
      }
    }
  }
  EXPECT_THROW(SystematicResampleCounts(std::vector<double>{0.0, 0.0}, 3, 0.5), Error);
  EXPECT_THROW(SystematicResampleCounts(std::vector<double>{1.0}, 3, 1.0), Error);
}

TEST(KldSampling, BoundFollowsFoxsFormula) {
  EXPECT_NEAR(StandardNormalQuantile(0.5), 0.0, 1e-12);
  EXPECT_NEAR(StandardNormalQuantile(0.975), 1.959964, 1e-6);
  EXPECT_NEAR(StandardNormalQuantile(0.99), 2.326348, 1e-6);
  EXPECT_NEAR(StandardNormalQuantile(0.01), -2.326348, 1e-6);
  EXPECT_THROW(StandardNormalQuantile(1.0), Error);

  EXPECT_EQ(KldParticleCount(0, 0.01, 0.01), 0);
  EXPECT_EQ(KldParticleCount(1, 0.01, 0.01), 0);
  // (k-1)/(2 eps) (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z)^3 with z = 2.326348 (delta = 0.01).
  for (int k : {2, 3, 10, 50}) {
    const double a = 2.0 / (9.0 * (k - 1));
    const double expected = (k - 1) / 0.02 * std::pow(1.0 - a + std::sqrt(a) * 2.326348, 3.0);
    EXPECT_NEAR(KldParticleCount(k, 0.01, 0.01), std::ceil(expected), 1.0) << k;
  }
  EXPECT_EQ(KldParticleCount(2, 0.01, 0.01), 330);
  EXPECT_EQ(KldParticleCount(10, 0.01, 0.01), 1085);
  // More bins need more particles; a looser bound fewer.
  for (int k = 2; k < 30; ++k) {
    EXPECT_LT(KldParticleCount(k, 0.01, 0.01), KldParticleCount(k + 1, 0.01, 0.01));
    EXPECT_LT(KldParticleCount(k, 0.05, 0.01), KldParticleCount(k, 0.01, 0.01));
  }
}

TEST_F(ParticleFilterTest, KldShrinksTheParticleCountAsParticlesConcentrateButKeepsTheFloor) {
  const std::vector<TruePose> path = SmoothPath(70, 0, 30);
  ParticleFilterOptions options;
  options.adaptive = true;
  options.max_particles_per_object = 200;
  options.min_particles_per_object = 8;
  options.dormant_particles_per_object = 8;  // one floor for every object
  options.seed = 9;
  ParticleFilter filter(Sphere(), *spectra_, options);
  std::vector<int> totals;
  FilterEstimate estimate;
  for (const TruePose& pose : path) {
    estimate = filter.Step(Signature(pose));
    totals.push_back(estimate.num_particles_after);
    std::vector<int> per_object(3, 0);
    for (const Particle& p : filter.particles()) ++per_object[static_cast<size_t>(p.object)];
    for (int o = 0; o < 3; ++o) {
      EXPECT_GE(per_object[static_cast<size_t>(o)], options.min_particles_per_object);
      EXPECT_LE(per_object[static_cast<size_t>(o)], options.max_particles_per_object);
    }
  }
  EXPECT_TRUE(Right(estimate, path.back()));
  // Spread over the whole sphere at first, every object hits many bins and takes the cap; once
  // concentrated on one object's few views, the others keep the floor and the total drops.
  const int early = *std::max_element(totals.begin(), totals.begin() + 3);
  EXPECT_EQ(early, 3 * options.max_particles_per_object);
  EXPECT_LE(totals.back(), options.max_particles_per_object + 2 * options.min_particles_per_object);
  EXPECT_LT(totals.back(), early / 2);
  std::vector<int> per_object(3, 0);
  for (const Particle& p : filter.particles()) ++per_object[static_cast<size_t>(p.object)];
  EXPECT_EQ(per_object[1], options.min_particles_per_object);
  EXPECT_EQ(per_object[2], options.min_particles_per_object);
}

TEST_F(ParticleFilterTest, DormantObjectsKeepTheirOwnFloorAndAreFoundAgainAfterASwitch) {
  // Object 0, then a switch to object 2, adaptive with the default floors: objects below the
  // dormant probability keep dormant_particles_per_object (1), the others at least
  // min_particles_per_object; the proposal still finds the new object within 10 frames.
  std::vector<TruePose> path = SmoothPath(40, 0, 30);
  const std::vector<TruePose> after = SmoothPath(41, 2, 30);
  path.insert(path.end(), after.begin(), after.end());
  ParticleFilterOptions options;
  options.adaptive = true;
  options.seed = 4;
  ASSERT_EQ(options.dormant_particles_per_object, 1);
  ASSERT_LT(options.dormant_particles_per_object, options.min_particles_per_object);
  ParticleFilter filter(Sphere(), *spectra_, options);
  int right_since = -1;
  int dormant_frames = 0;
  for (size_t t = 0; t < path.size(); ++t) {
    const FilterEstimate estimate = filter.Step(Signature(path[t]));
    if (t >= 30) {
      if (!Right(estimate, path[t])) {
        right_since = -1;
      } else if (right_since < 0) {
        right_since = static_cast<int>(t);
      }
    }
    if (!estimate.resampled) continue;
    // Right after a resampling each object holds its floor or more; the weights it was given are
    // its probability (Resample spreads each object's mass evenly over its particles).
    std::vector<int> count(3, 0);
    std::vector<double> mass(3, 0.0);
    for (const Particle& p : filter.particles()) {
      ++count[static_cast<size_t>(p.object)];
      mass[static_cast<size_t>(p.object)] += p.weight;
    }
    for (size_t o = 0; o < 3; ++o) {
      EXPECT_GE(count[o], options.dormant_particles_per_object) << "frame " << t;
      EXPECT_LE(count[o], options.max_particles_per_object) << "frame " << t;
    }
    // While an object is tracked (object 0, then object 2) the tracked one keeps at least the
    // ordinary floor; the others, once dormant, settle to one particle each (KLD may still give a
    // dormant object more in the frame its many particles are drawn from, right after a switch).
    if (t >= 10 && Right(estimate, path[t])) {
      const auto tracked = static_cast<size_t>(estimate.object);
      EXPECT_GE(count[tracked], options.min_particles_per_object) << "frame " << t;
      bool settled = true;
      for (size_t o = 0; o < 3; ++o) {
        if (o != tracked) {
          settled = settled && mass[o] < options.dormant_probability && count[o] == 1;
        }
      }
      if (settled) ++dormant_frames;
    }
  }
  // How often the filter resamples depends on rounding (fewer frames in sanitizer builds).
  EXPECT_GE(dormant_frames, 10);
  // At the end object 2 is tracked, and the two others (object 0 tracked before) hold one each.
  std::vector<int> final_count(3, 0);
  for (const Particle& p : filter.particles()) ++final_count[static_cast<size_t>(p.object)];
  EXPECT_EQ(final_count[0], 1);
  EXPECT_EQ(final_count[1], 1);
  EXPECT_GE(final_count[2], options.min_particles_per_object);
  EXPECT_GE(right_since, 30);
  EXPECT_LE(right_since, 30 + 10);
}

TEST_F(ParticleFilterTest, BestHistoryHasOneStatePerFrameEndingWithTheEstimate) {
  const std::vector<TruePose> path = SmoothPath(80, 1, 25);
  ParticleFilter filter(Sphere(), *spectra_);
  EXPECT_TRUE(filter.BestHistory().empty());
  FilterEstimate estimate;
  for (size_t t = 0; t < path.size(); ++t) {
    estimate = t == 12 ? filter.Predict() : filter.Step(Signature(path[t]));
    const std::vector<PoseState> history = filter.BestHistory();
    ASSERT_EQ(history.size(), t + 1);
    for (size_t f = 0; f < history.size(); ++f) {
      EXPECT_EQ(history[f].frame, static_cast<int64_t>(f));
    }
    EXPECT_EQ(history.back().object, estimate.object);
    EXPECT_EQ(history.back().view, estimate.view);
    EXPECT_EQ(history.back().roll_deg, estimate.roll_deg);
    EXPECT_EQ(history.back().score, estimate.score);
  }
  // The history follows the truth once identified: the same object throughout its last frames,
  // its views moving by a few view spacings at most from frame to frame (the sequence is slow).
  const std::vector<PoseState> history = filter.BestHistory();
  const double max_step_rad = 4.0 * Sphere().typical_spacing_rad;
  for (size_t f = 15; f < history.size(); ++f) {
    EXPECT_EQ(history[f].object, path[f].object);
    const double step =
        std::acos(std::clamp(Sphere().directions[static_cast<size_t>(history[f].view)].dot(
                                 Sphere().directions[static_cast<size_t>(history[f - 1].view)]),
                             -1.0, 1.0));
    EXPECT_LE(step, max_step_rad) << "frame " << f;
  }
}

TEST_F(ParticleFilterTest, MostLikelyHistoryExplainsTheFramesBestOfAllParticleHistories) {
  const std::vector<TruePose> path = SmoothPath(40, 1, 40);
  ParticleFilterOptions options;
  options.max_history_frames = 0;
  ParticleFilter filter(Sphere(), *spectra_, options);
  EXPECT_TRUE(filter.MostLikelyHistory().empty());
  for (size_t t = 0; t < path.size(); ++t) {
    if (t == 7) {
      filter.Predict();
    } else {
      filter.Step(Signature(path[t], t % 5 == 3 ? Degradation::kOccluder : Degradation::kNone));
    }
  }
  // The path log-likelihood of a history from frame `from` on, the best score per frame taken
  // over every particle's history and the last estimate's (computed here independently of the
  // filter).
  std::vector<std::vector<PoseState>> histories = {filter.BestHistory()};
  for (const Particle& p : filter.particles()) histories.push_back(ParticleFilter::History(p));
  const auto path_log_likelihood = [&](const std::vector<PoseState>& history, int64_t from) {
    double sum = 0.0;
    for (const PoseState& state : history) {
      if (state.frame < from || !state.measured) continue;
      float best = -1.0f;
      for (const std::vector<PoseState>& other : histories)
        best = std::max(best, other[static_cast<size_t>(state.frame)].score);
      sum += std::log(std::exp(options.likelihood_sharpness * (state.score - best)) +
                      options.likelihood_floor);
    }
    return sum;
  };
  for (int64_t from : {int64_t{0}, int64_t{30}}) {
    const std::vector<PoseState> chosen = filter.MostLikelyHistory(from);
    ASSERT_EQ(chosen.size(), path.size());
    EXPECT_FALSE(chosen[7].measured);
    EXPECT_TRUE(chosen[8].measured);
    const double chosen_sum = path_log_likelihood(chosen, from);
    for (const std::vector<PoseState>& other : histories)
      EXPECT_GE(chosen_sum, path_log_likelihood(other, from) - 1e-9);
    // It names the filmed object at the end.
    EXPECT_EQ(chosen.back().object, path.back().object);
  }
  // A history never leaves its object: the most likely one of another object stays on it.
  const std::vector<PoseState> other = filter.MostLikelyHistory(0, 2);
  ASSERT_EQ(other.size(), path.size());
  for (const PoseState& state : other) EXPECT_EQ(state.object, 2);
}

TEST_F(ParticleFilterTest, SmoothedStateIsTheHeaviestAncestorOfTheFrame) {
  const std::vector<TruePose> path = SmoothPath(41, 0, 30);
  ParticleFilter filter(Sphere(), *spectra_);
  EXPECT_FALSE(filter.SmoothedState(0).has_value());
  for (const TruePose& pose : path) filter.Step(Signature(pose));
  EXPECT_FALSE(filter.SmoothedState(30).has_value());  // not processed yet
  for (int64_t frame : {int64_t{29}, int64_t{20}, int64_t{12}}) {
    const std::optional<PoseState> state = filter.SmoothedState(frame);
    ASSERT_TRUE(state.has_value());
    EXPECT_EQ(state->frame, frame);
    // Independently: the particles' ancestors in that frame, weighted by today's weights.
    std::vector<double> object_mass(3, 0.0);
    bool is_ancestor = false;
    for (const Particle& p : filter.particles()) {
      const PoseState ancestor = ParticleFilter::History(p)[static_cast<size_t>(frame)];
      object_mass[static_cast<size_t>(ancestor.object)] += p.weight;
      is_ancestor |= ancestor.object == state->object && ancestor.view == state->view &&
                     ancestor.roll_deg == state->roll_deg && ancestor.score == state->score;
    }
    EXPECT_TRUE(is_ancestor);
    EXPECT_EQ(state->object,
              std::max_element(object_mass.begin(), object_mass.end()) - object_mass.begin());
    // The bunny, seen clearly: the right object, and a view near the true one.
    EXPECT_EQ(state->object, 0);
    const double angle_deg =
        std::acos(std::clamp(Sphere().directions[static_cast<size_t>(state->view)].dot(
                                 path[static_cast<size_t>(frame)].view_dir),
                             -1.0, 1.0)) /
        kDegToRad;
    EXPECT_LT(angle_deg, 15.0) << "frame " << frame;
    // Asked for another object: that object's ancestors only.
    const std::optional<PoseState> other = filter.SmoothedState(frame, 2);
    ASSERT_TRUE(other.has_value());
    EXPECT_EQ(other->object, 2);
  }
}

TEST(ParticleFilterHistory, LiveNodesStayBoundedOverManyFrames) {
  // A tiny database (2 models, 60 views, 96 px, 128 directions) and a few of its own views as a
  // cheap measurement, 20 000 frames.
  DatabaseBuildOptions build;
  build.parameters.view_sphere.num_views = 60;
  build.parameters.render.resolution_px = 96;
  build.parameters.signature.length = 128;
  build.num_threads = 1;
  const std::filesystem::path models(SILPOSE_SAMPLE_MODELS_DIR);
  const ViewDatabase database = BuildViewDatabase({models / "cow.obj", models / "hand.obj"}, build);
  const ViewSpectra spectra(database);
  std::vector<std::vector<float>> frames;
  for (int view : {0, 1, 2}) {
    const auto signature = database.models[0].Signature(view);
    frames.emplace_back(signature.begin(), signature.end());
  }
  ParticleFilterOptions options;
  options.particles_per_object = 20;
  options.min_particles_per_object = 5;
  constexpr int kFrames = 20000;
  const int particles = 2 * options.particles_per_object;
  {
    ParticleFilter filter(database.sphere, spectra, options);
    int64_t live_at_half = 0;
    for (int t = 0; t < kFrames; ++t) {
      filter.Step(frames[static_cast<size_t>(t / 50) % frames.size()]);
      if (t == kFrames / 2 - 1) live_at_half = filter.CountLiveHistoryNodes();
    }
    const int64_t live = filter.CountLiveHistoryNodes();
    // One common trunk per object (resampling is stratified by object: lineages merge only
    // within an object), one node per frame each, and a bushy crown of a few frames per particle;
    // not one chain per particle (N * T = 800 000).
    EXPECT_LE(live, 2 * kFrames + 50 * particles);
    EXPECT_LE(live - live_at_half, 2 * (kFrames / 2) + 50 * particles);
    EXPECT_EQ(filter.BestHistory().size(), static_cast<size_t>(kFrames));
  }
  // With a history cap the memory does not grow with the frame count at all.
  options.max_history_frames = 500;
  ParticleFilter filter(database.sphere, spectra, options);
  int64_t most_live = 0;
  for (int t = 0; t < kFrames; ++t) {
    filter.Step(frames[static_cast<size_t>(t / 50) % frames.size()]);
    if (t % 1000 == 999) most_live = std::max(most_live, filter.CountLiveHistoryNodes());
  }
  EXPECT_LE(most_live, 2 * 2 * 500 + 50 * particles);
  const size_t kept = filter.BestHistory().size();
  EXPECT_GE(kept, 500u);
  EXPECT_LT(kept, 1000u);
  EXPECT_EQ(filter.BestHistory().back().frame, kFrames - 1);
}

TEST(ParticleFilterHistory, DestroyingAHundredThousandFramesOfHistoryDoesNotOverflowTheStack) {
  DatabaseBuildOptions build;
  build.parameters.view_sphere.num_views = 20;
  build.parameters.render.resolution_px = 64;
  build.parameters.signature.length = 64;
  build.num_threads = 1;
  const ViewDatabase database =
      BuildViewDatabase({std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / "cow.obj"}, build);
  const ViewSpectra spectra(database);
  ParticleFilterOptions options;
  options.particles_per_object = 1;
  options.min_particles_per_object = 1;
  auto filter = std::make_unique<ParticleFilter>(database.sphere, spectra, options);
  constexpr int kFrames = 100000;
  for (int t = 0; t < kFrames; ++t) filter->Predict();
  EXPECT_EQ(filter->CountLiveHistoryNodes(), kFrames);
  EXPECT_EQ(filter->BestHistory().size(), static_cast<size_t>(kFrames));
  filter.reset();  // a recursive destruction would need ~100 000 nested frames

  // The same for a bare chain of a million nodes.
  std::shared_ptr<const HistoryNode> chain;
  for (int64_t t = 0; t < 1000000; ++t) {
    chain = std::make_shared<const HistoryNode>(PoseState{t, 0, 0, 0.0, false, 0.0f}, chain);
  }
  chain.reset();
  SUCCEED();
}

TEST_F(ParticleFilterTest, SameSeedGivesTheSameEstimates) {
  const std::vector<TruePose> path = SmoothPath(90, 2, 12);
  std::vector<std::vector<float>> signatures;
  for (const TruePose& pose : path) signatures.push_back(Signature(pose));
  auto run = [&](uint64_t seed) {
    ParticleFilterOptions options;
    options.seed = seed;
    ParticleFilter filter(Sphere(), *spectra_, options);
    std::vector<FilterEstimate> estimates;
    for (size_t t = 0; t < signatures.size(); ++t) {
      estimates.push_back(t == 5 ? filter.Predict() : filter.Step(signatures[t]));
    }
    std::vector<int> views;
    for (const Particle& p : filter.particles()) views.push_back(p.view);
    return std::pair{estimates, views};
  };
  const auto [first, first_views] = run(42);
  const auto [second, second_views] = run(42);
  ASSERT_EQ(first.size(), second.size());
  for (size_t t = 0; t < first.size(); ++t) {
    EXPECT_EQ(first[t].object, second[t].object);
    EXPECT_EQ(first[t].view, second[t].view);
    EXPECT_EQ(first[t].roll_deg, second[t].roll_deg);
    EXPECT_EQ(first[t].score, second[t].score);
    EXPECT_EQ(first[t].effective_particles, second[t].effective_particles);
    EXPECT_EQ(first[t].resampled, second[t].resampled);
    EXPECT_EQ(first[t].object_probability, second[t].object_probability);
  }
  EXPECT_EQ(first_views, second_views);
  EXPECT_NE(run(43).second, first_views);
}

// Two runs' estimates, frame by frame, bit for bit.
void ExpectSameEstimates(const std::vector<FilterEstimate>& a,
                         const std::vector<FilterEstimate>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t t = 0; t < a.size(); ++t) {
    EXPECT_EQ(a[t].object, b[t].object) << "frame " << t;
    EXPECT_EQ(a[t].view, b[t].view) << "frame " << t;
    EXPECT_EQ(a[t].roll_deg, b[t].roll_deg) << "frame " << t;
    EXPECT_EQ(a[t].score, b[t].score) << "frame " << t;
    EXPECT_EQ(a[t].object_probability, b[t].object_probability) << "frame " << t;
    EXPECT_EQ(a[t].num_particles_after, b[t].num_particles_after) << "frame " << t;
  }
}

TEST_F(ParticleFilterTest, WithoutHistoryTheEstimatesAreTheSameAndNoHistoryIsKept) {
  // A walk with a prediction-only frame and a jump to another object, so that proposals,
  // resampling and the estimate rule all run; the histories must not change any of them, with a
  // fixed or an adaptive particle count.
  std::vector<TruePose> path = SmoothPath(91, 2, 14);
  const std::vector<TruePose> other = SmoothPath(92, 0, 10);
  path.insert(path.end(), other.begin(), other.end());
  std::vector<std::vector<float>> signatures;
  for (const TruePose& pose : path) signatures.push_back(Signature(pose));
  for (const bool adaptive : {false, true}) {
    SCOPED_TRACE(adaptive ? "adaptive" : "fixed count");
    auto run = [&](bool keep_history) {
      ParticleFilterOptions options;
      options.seed = 7;
      options.adaptive = adaptive;
      options.keep_history = keep_history;
      options.max_history_frames = 5;  // the cut runs too when history is kept
      auto filter = std::make_unique<ParticleFilter>(Sphere(), *spectra_, options);
      std::vector<FilterEstimate> estimates;
      for (size_t t = 0; t < signatures.size(); ++t) {
        estimates.push_back(t == 6 ? filter->Predict() : filter->Step(signatures[t]));
      }
      return std::pair{std::move(filter), estimates};
    };
    const auto [kept, with] = run(true);
    const auto [none, without] = run(false);
    ExpectSameEstimates(with, without);
    ASSERT_EQ(kept->particles().size(), none->particles().size());
    for (size_t i = 0; i < kept->particles().size(); ++i) {
      EXPECT_EQ(kept->particles()[i].view, none->particles()[i].view);
      EXPECT_EQ(kept->particles()[i].weight, none->particles()[i].weight);
      EXPECT_EQ(none->particles()[i].history, nullptr);
    }
    // The history was there to lose: kept, it reaches back to the last cut; without, nothing.
    const int64_t recent = static_cast<int64_t>(with.size()) - 2;
    EXPECT_GE(kept->BestHistory().size(), 5u);
    EXPECT_GT(kept->CountLiveHistoryNodes(), 0);
    EXPECT_TRUE(kept->SmoothedState(recent).has_value());
    EXPECT_TRUE(none->BestHistory().empty());
    EXPECT_TRUE(none->MostLikelyHistory().empty());
    EXPECT_FALSE(none->SmoothedState(recent).has_value());
    EXPECT_EQ(none->CountLiveHistoryNodes(), 0);
  }
}

TEST_F(ParticleFilterTest, TheAvx2AndBaselineBuildsOfTheInnerLoopsGiveTheSameEstimates) {
  // The correlation's evaluation, the proposal's ranking and the mask scans have an AVX2 build
  // (util/cpu_features.h) that must not change a result: every estimate and particle bit for bit,
  // with a fixed and an adaptive count, through proposals, resampling and a switch of object.
  const bool had_avx2 = Avx2Enabled();
  if (!SetAvx2Enabled(true)) GTEST_SKIP() << "this processor has no AVX2";
  std::vector<TruePose> path = SmoothPath(93, 1, 12);
  const std::vector<TruePose> other = SmoothPath(94, 2, 8);
  path.insert(path.end(), other.begin(), other.end());
  for (const bool adaptive : {false, true}) {
    SCOPED_TRACE(adaptive ? "adaptive" : "fixed count");
    auto run = [&](bool avx2) {
      SetAvx2Enabled(avx2);
      ParticleFilterOptions options;
      options.seed = 11;
      options.adaptive = adaptive;
      auto filter = std::make_unique<ParticleFilter>(Sphere(), *spectra_, options);
      std::vector<FilterEstimate> estimates;
      for (const TruePose& pose : path) estimates.push_back(filter->Step(Signature(pose)));
      return std::pair{std::move(filter), estimates};
    };
    const auto [vector_filter, vector_estimates] = run(true);
    const auto [baseline_filter, baseline_estimates] = run(false);
    ExpectSameEstimates(vector_estimates, baseline_estimates);
    ASSERT_EQ(vector_filter->particles().size(), baseline_filter->particles().size());
    for (size_t i = 0; i < vector_filter->particles().size(); ++i) {
      EXPECT_EQ(vector_filter->particles()[i].view, baseline_filter->particles()[i].view);
      EXPECT_EQ(vector_filter->particles()[i].roll_deg, baseline_filter->particles()[i].roll_deg);
      EXPECT_EQ(vector_filter->particles()[i].score, baseline_filter->particles()[i].score);
      EXPECT_EQ(vector_filter->particles()[i].weight, baseline_filter->particles()[i].weight);
    }
    // The run found the objects, so the loops compared did real work.
    EXPECT_EQ(vector_estimates[11].object, 1);
    EXPECT_EQ(vector_estimates.back().object, 2);
  }
  SetAvx2Enabled(had_avx2);
}

TEST_F(ParticleFilterTest, InvalidOptionsAndForeignSpectraAreErrors) {
  auto make = [](const ParticleFilterOptions& options) {
    ParticleFilter filter(Sphere(), *spectra_, options);
  };
  ParticleFilterOptions options;
  options.particles_per_object = 0;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.likelihood_sharpness = -1.0;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.min_particles_per_object = options.particles_per_object + 1;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.max_particles_per_object = options.particles_per_object - 1;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.kld_delta = 0.0;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.object_switch_probability = 1.0;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.dormant_particles_per_object = -1;
  EXPECT_THROW(make(options), Error);
  options = {};
  options.dormant_probability = 1.5;
  EXPECT_THROW(make(options), Error);
  EXPECT_TRUE(ParticleFilterOptions{}.Check());

  ParticleFilter filter(Sphere(), *spectra_);
  CircularCorrelator other(500);
  EXPECT_THROW(filter.Step(other.Transform(std::vector<float>(500, 1.0f))), Error);
  EXPECT_THROW(filter.Step(std::vector<float>(999, 1.0f)), Error);
  ViewSphereOptions sphere_options;
  sphere_options.num_views = 100;
  const ViewSphere other_sphere = BuildViewSphere(sphere_options);
  EXPECT_THROW(ParticleFilter(other_sphere, *spectra_), Error);
}

// The filter carries rolls between neighbouring views by a per-edge constant: that relies on
// parallel transport commuting with a roll about the optical axis.
TEST_F(ParticleFilterTest, RollTransportIsAdditive) {
  for (int view = 0; view < Sphere().num_views(); view += 7) {
    const Eigen::Vector3d& from = Sphere().directions[static_cast<size_t>(view)];
    for (const uint32_t neighbour : Sphere().Neighbours(view)) {
      const Eigen::Vector3d& to = Sphere().directions[neighbour];
      const double offset = TransportRoll(from, 0.0, to);
      for (double roll : {-170.0, -45.0, 0.0, 33.0, 179.0}) {
        EXPECT_NEAR(WrapDegrees(TransportRoll(from, roll, to) - (roll + offset)), 0.0, 1e-6);
      }
    }
  }
}

}  // namespace
}  // namespace silpose
