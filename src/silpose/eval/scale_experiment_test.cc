#include "silpose/eval/scale_experiment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {
namespace {

std::vector<TriangleMesh> SampleMeshes(std::initializer_list<const char*> names) {
  std::vector<TriangleMesh> meshes;
  for (const char* name : names) {
    meshes.push_back(
        LoadMesh(std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / (std::string(name) + ".obj")));
  }
  return meshes;
}

TEST(ScaleExperiment, NoTwoStretchesAreProportional) {
  for (size_t a = 0; a < kScaleStretches.size(); ++a) {
    for (size_t b = a + 1; b < kScaleStretches.size(); ++b) {
      double mean_a = 0.0, mean_b = 0.0;
      for (int i = 0; i < 3; ++i) {
        mean_a += kScaleStretches[a][static_cast<size_t>(i)] / 3.0;
        mean_b += kScaleStretches[b][static_cast<size_t>(i)] / 3.0;
      }
      double largest = 0.0;
      for (size_t i = 0; i < 3; ++i) {
        largest = std::max(
            largest, std::abs(kScaleStretches[a][i] / mean_a - kScaleStretches[b][i] / mean_b));
      }
      EXPECT_GE(largest, 0.14) << "stretches " << a << " and " << b;
    }
  }
}

TEST(ScaleExperiment, CatalogueStretchesEachMeshAlongItsAxes) {
  const std::vector<TriangleMesh> meshes = SampleMeshes({"bunny", "cow"});
  const std::vector<TriangleMesh> catalogue = StretchedCatalogue(meshes, 7);
  ASSERT_EQ(catalogue.size(), 7u);
  const std::vector<std::string> names = {"bunny_0", "cow_0", "bunny_1", "cow_1",
                                          "bunny_2", "cow_2", "bunny_3"};
  for (size_t i = 0; i < catalogue.size(); ++i) {
    EXPECT_EQ(catalogue[i].name, names[i]);
    const TriangleMesh& base = meshes[i % 2];
    const auto& factors = kScaleStretches[i / 2];
    ASSERT_EQ(catalogue[i].vertices.size(), base.vertices.size());
    EXPECT_EQ(catalogue[i].triangles, base.triangles);
    for (size_t v = 0; v < base.vertices.size(); v += 97) {
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_FLOAT_EQ(
            catalogue[i].vertices[v][axis],
            static_cast<float>(base.vertices[v][axis] * factors[static_cast<size_t>(axis)]));
      }
    }
  }
  EXPECT_THROW(StretchedCatalogue(meshes, 21), Error);
  EXPECT_THROW(StretchedCatalogue({}, 1), Error);
}

TEST(ScaleExperiment, WrittenObjReadsBackAsTheSameShape) {
  const std::vector<TriangleMesh> catalogue = StretchedCatalogue(SampleMeshes({"hand"}), 2);
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "scale_experiment_hand_1.obj";
  WriteObj(catalogue[1], path);
  const TriangleMesh read = LoadMesh(path);
  EXPECT_EQ(read.name, "scale_experiment_hand_1");
  EXPECT_EQ(read.triangles.size(), catalogue[1].triangles.size());
  EXPECT_NEAR(read.Radius(), catalogue[1].Radius(), 1e-5 * catalogue[1].Radius());
  EXPECT_LT((read.Centre() - catalogue[1].Centre()).norm(), 1e-5 * catalogue[1].Radius());
  std::filesystem::remove(path);
  EXPECT_THROW(WriteObj(catalogue[0], std::filesystem::path("/nonexistent-folder/x.obj")), Error);
}

TEST(ScaleExperiment, OptionsAreChecked) {
  ScaleExperimentOptions options;
  std::string error;
  EXPECT_TRUE(options.Check(20, &error)) << error;
  EXPECT_FALSE(options.Check(19, &error));  // 200 objects need 20 meshes
  EXPECT_NE(error.find("200"), std::string::npos) << error;
  ScaleExperimentOptions empty = options;
  empty.view_counts.clear();
  EXPECT_FALSE(empty.Check(20));
  ScaleExperimentOptions skip = options;
  skip.skip_frames = skip.frames;
  EXPECT_FALSE(skip.Check(20));
  ScaleExperimentOptions views = options;
  views.view_counts = {2};
  EXPECT_FALSE(views.Check(20, &error));
  EXPECT_NE(error.find("database options"), std::string::npos) << error;
}

// Both sweeps on tiny databases (256 px renderings, 60 and 120 views): every point measured once,
// file sizes in proportion to the views, the fixed filter's particle count as set, the
// temporary files removed.
TEST(ScaleExperiment, MeasuresEveryPointOnceAndCleansUp) {
  const std::vector<TriangleMesh> meshes = SampleMeshes({"bunny", "cow", "hand"});
  ScaleExperimentOptions options;
  options.object_counts = {2, 6};
  options.views_per_object = 60;
  options.view_counts = {60, 120};
  options.objects = 2;
  options.parameters.render.resolution_px = 256;
  options.num_flown = 1;
  options.frames = 14;
  options.skip_frames = 4;
  options.particles_per_object = 20;
  options.build_threads = 1;
  const std::filesystem::path work = std::filesystem::path(::testing::TempDir()) / "scale_work";
  std::filesystem::remove_all(work);
  std::filesystem::create_directories(work);
  options.work_dir = work;

  std::vector<std::pair<int, int>> built;
  int reported = 0;
  const ScaleExperimentResult result = RunScaleExperiment(
      meshes, options, [&](int objects, int views) { built.emplace_back(objects, views); },
      [&](const ScalePoint&) { ++reported; });
  ASSERT_EQ(result.points.size(), 3u);  // (2, 60) is in both sweeps
  EXPECT_EQ(built, (std::vector<std::pair<int, int>>{{2, 60}, {2, 120}, {6, 60}}));
  EXPECT_EQ(reported, 3);
  EXPECT_TRUE(std::filesystem::is_empty(work));

  const ScalePoint& small = result.points[0];
  const ScalePoint& more_views = result.points[1];
  const ScalePoint& more_objects = result.points[2];
  EXPECT_EQ(more_objects.objects, 6);
  // The file grows with the views (about 1.2 kB a view of a compact database, beside the fixed
  // stored meshes) and with the objects.
  EXPECT_GT(more_views.file_bytes / small.file_bytes, 1.3);
  EXPECT_LT(more_views.file_bytes / small.file_bytes, 2.1);
  EXPECT_GT(more_objects.file_bytes / small.file_bytes, 2.4);
  EXPECT_LT(more_objects.file_bytes / small.file_bytes, 3.1);
  for (const ScalePoint& p : result.points) {
    EXPECT_GT(p.build_seconds, 0.0);
    ASSERT_EQ(p.flown.size(), 1u);
    for (const ScaleMethodStats* stats : {&p.brute_force, &p.filter, &p.adaptive}) {
      EXPECT_EQ(stats->frames, options.frames - options.skip_frames);
      EXPECT_GT(stats->ms_per_frame_mean, 0.0);
      EXPECT_GT(stats->ms_per_frame_median, 0.0);
    }
    EXPECT_EQ(p.brute_force.particles_mean, 0.0);
    EXPECT_DOUBLE_EQ(p.filter.particles_mean, 20.0 * p.objects);
    EXPECT_GT(p.adaptive.particles_mean, 0.0);
    EXPECT_LE(p.adaptive.particles_mean, 300.0 * p.objects);
  }
  EXPECT_EQ(result.ObjectSweep().size(), 2u);
  ASSERT_EQ(result.ViewSweep().size(), 2u);
  EXPECT_EQ(result.ViewSweep()[1]->views_per_object, 120);

  const std::filesystem::path csv = work / "costs.csv";
  WriteScaleTable(csv, result);
  std::ifstream file(csv);
  std::vector<std::string> lines;
  for (std::string line; std::getline(file, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0].rfind("objects,views_per_object,shells,total_views,file_mb,build_s,", 0), 0u);
  EXPECT_EQ(lines[3].rfind("6,60,1,360,", 0), 0u) << lines[3];
  const Figure figure = ScaleFigure(result);
  EXPECT_EQ(figure.panels.size(), 4u);
  EXPECT_TRUE(figure.Check());
  EXPECT_EQ(figure.panels[0].series[0].x, (std::vector<double>{2, 6}));
  EXPECT_EQ(figure.panels[1].series[0].x, (std::vector<double>{60, 120}));
}

TEST(ScaleExperiment, AMissingWorkFolderIsAnErrorNamingIt) {
  ScaleExperimentOptions options;
  options.object_counts = {1};
  options.view_counts = {60};
  options.views_per_object = 60;
  options.objects = 1;
  options.work_dir = "/nonexistent-scale-folder";
  try {
    RunScaleExperiment(SampleMeshes({"bunny"}), options);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-scale-folder"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace silpose
