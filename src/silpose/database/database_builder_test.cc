#include "silpose/database/database_builder.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "silpose/util/error.h"
#include "silpose/util/hash.h"

namespace silpose {
namespace {

// An L-shaped prism (no symmetry in its outline for most views) written as OBJ.
std::filesystem::path WriteLPrism(const std::filesystem::path& directory, const std::string& name) {
  const double xy[6][2] = {{0, 0}, {3, 0}, {3, 1}, {1, 1}, {1, 2.2}, {0, 2.2}};
  std::ofstream obj(directory / (name + ".obj"));
  for (double z : {0.0, 0.7}) {
    for (const auto& p : xy) obj << "v " << p[0] << " " << p[1] << " " << z << "\n";
  }
  // Bottom and top as fans over the L (convex pieces: quads 0-1-2-3 and 0-3-4-5).
  obj << "f 1 3 2\nf 1 4 3\nf 1 5 4\nf 1 6 5\n";
  obj << "f 7 8 9\nf 7 9 10\nf 7 10 11\nf 7 11 12\n";
  for (int i = 0; i < 6; ++i) {
    const int a = i + 1;
    const int b = (i + 1) % 6 + 1;
    obj << "f " << a << " " << b << " " << b + 6 << "\nf " << a << " " << b + 6 << " " << a + 6
        << "\n";
  }
  return directory / (name + ".obj");
}

class DatabaseBuilderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ =
        std::filesystem::temp_directory_path() / ("silpose_builder_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  static DatabaseBuildOptions SmallOptions(int threads) {
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 60;
    options.parameters.render.resolution_px = 96;
    options.parameters.signature.length = 180;
    options.num_threads = threads;
    return options;
  }

  std::filesystem::path directory_;
};

TEST_F(DatabaseBuilderTest, BuildsEveryViewAndRecordsTheModel) {
  const auto path = WriteLPrism(directory_, "lprism");
  const ViewDatabase database = BuildViewDatabase({path}, SmallOptions(2));
  ASSERT_EQ(database.models.size(), 1u);
  const ModelViews& model = database.models[0];
  EXPECT_EQ(model.name, "lprism");
  EXPECT_EQ(model.mesh_hash, HashFile(path));
  EXPECT_EQ(model.num_triangles, 20u);
  EXPECT_NEAR(model.centre[0], 1.5, 1e-6);
  EXPECT_NEAR(model.radius, std::sqrt(1.5 * 1.5 + 1.1 * 1.1 + 0.35 * 0.35), 1e-5);
  const size_t shells = database.parameters.distances_in_radii.size();
  ASSERT_EQ(shells, 4u);  // the default shells
  ASSERT_EQ(model.views.size(), 60u * shells);
  EXPECT_EQ(model.signatures.size(), 60u * shells * 180u);
  // The geometry is kept for refinement.
  EXPECT_EQ(model.mesh.triangles.size(), 20u);
  // The L turns onto itself about no axis; the slab's mid-plane z = 0.35 is its one mirror.
  EXPECT_FALSE(model.symmetry.HasRotations()) << model.symmetry.Describe();
  ASSERT_EQ(model.symmetry.mirrors.size(), 1u) << model.symmetry.Describe();
  EXPECT_NEAR(std::abs(model.symmetry.mirrors[0].normal.normalized().z()), 1.0, 1e-6);
  EXPECT_NEAR(model.symmetry.mirrors[0].offset.z(), 0.35, 1e-6);
  for (const ViewRecord& view : model.views) {
    EXPECT_EQ(view.status, SignatureStatus::kOk);
    EXPECT_FALSE(view.flags & kSilhouetteTouchesBorder);
    // The bounding sphere fills 90% of the image: the silhouette is inside it.
    EXPECT_LT(view.mean_radius_px, 0.45 * 96);
    EXPECT_GT(view.mean_radius_px, 5.0);
  }
}

TEST_F(DatabaseBuilderTest, FarShellsApproachTheOrthographicOutline) {
  // Perspective changes the outline with 1 / distance: a shell at 20 radii is much closer to the
  // outline seen from very far (1000 radii, nearly orthographic) than the paper's 3 radii.
  const auto path = WriteLPrism(directory_, "lprism");
  DatabaseBuildOptions options = SmallOptions(2);
  options.parameters.distances_in_radii = {3.0, 20.0, 1000.0};
  const ViewDatabase database = BuildViewDatabase({path}, options);
  const ModelViews& model = database.models[0];
  double near_gap = 0.0, far_gap = 0.0;
  for (int v = 0; v < 60; ++v) {
    const auto near = model.Signature(v, 0);
    const auto far = model.Signature(v, 1);
    const auto ortho = model.Signature(v, 2);
    for (size_t k = 0; k < near.size(); ++k) {
      near_gap += std::abs(near[k] - ortho[k]);
      far_gap += std::abs(far[k] - ortho[k]);
    }
  }
  EXPECT_GT(near_gap, 0.0);
  EXPECT_LT(far_gap, 0.35 * near_gap);
}

TEST_F(DatabaseBuilderTest, ThreadCountDoesNotChangeTheResult) {
  const auto path = WriteLPrism(directory_, "lprism");
  const ViewDatabase one = BuildViewDatabase({path}, SmallOptions(1));
  const ViewDatabase two = BuildViewDatabase({path}, SmallOptions(2));
  EXPECT_EQ(one.Serialize(), two.Serialize());
}

TEST_F(DatabaseBuilderTest, BadInputNamesTheFile) {
  const auto path = WriteLPrism(directory_, "lprism");
  try {
    BuildViewDatabase({path, directory_ / "missing.obj"}, SmallOptions(1));
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("missing.obj"), std::string::npos) << error.what();
  }
  std::filesystem::create_directories(directory_ / "other");
  const auto twin = WriteLPrism(directory_ / "other", "lprism");
  EXPECT_THROW(BuildViewDatabase({path, twin}, SmallOptions(1)), Error);
  EXPECT_THROW(BuildViewDatabase({}, SmallOptions(1)), Error);
  DatabaseBuildOptions bad = SmallOptions(1);
  bad.parameters.signature.length = 7;
  EXPECT_THROW(BuildViewDatabase({path}, bad), Error);
}

TEST_F(DatabaseBuilderTest, DegenerateMeshesAreRefusedByName) {
  // Three collinear vertices: a radius, but no area and no silhouette from any view.
  const auto path = directory_ / "needle.obj";
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 3 2\n";
  DatabaseBuildOptions options;
  options.parameters.view_sphere.num_views = 20;
  options.parameters.view_sphere.num_bins = 3;
  options.num_threads = 1;
  try {
    BuildViewDatabase({path}, options);
    ADD_FAILURE() << "a collinear mesh was accepted";
  } catch (const Error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("needle"), std::string::npos) << message;
    EXPECT_NE(message.find("degenerate"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace silpose
