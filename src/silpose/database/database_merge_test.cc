#include "silpose/database/database_merge.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "silpose/database/database_builder.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

class DatabaseMergeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ =
        std::filesystem::temp_directory_path() / ("silpose_merge_" + std::to_string(::getpid()));
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  static DatabaseBuildOptions TinyOptions() {
    DatabaseBuildOptions options;
    options.parameters.view_sphere.num_views = 40;
    options.parameters.view_sphere.num_bins = 4;
    options.parameters.render.resolution_px = 64;
    options.parameters.signature.length = 64;
    options.parameters.distances_in_radii = {3.0, 7.0};
    options.num_threads = 2;
    return options;
  }
  static std::filesystem::path Model(const std::string& name) {
    return std::filesystem::path(SILPOSE_SAMPLE_MODELS_DIR) / (name + ".obj");
  }
  std::filesystem::path Build(const std::vector<std::filesystem::path>& meshes,
                              const std::string& name,
                              const DatabaseBuildOptions& options = TinyOptions()) {
    const std::filesystem::path path = directory_ / name;
    BuildViewDatabase(meshes, options).Write(path);
    return path;
  }

  std::filesystem::path directory_;
};

TEST_F(DatabaseMergeTest, MergedShardsAreByteIdenticalToOneBuild) {
  const std::string whole =
      BuildViewDatabase({Model("cow"), Model("hand")}, TinyOptions()).Serialize();
  const auto cow = Build({Model("cow")}, "cow.db");
  const auto hand = Build({Model("hand")}, "hand.db");
  const ViewDatabase merged = MergeViewDatabases({cow, hand});
  ASSERT_EQ(merged.models.size(), 2u);
  EXPECT_EQ(merged.models[0].name, "cow");
  EXPECT_EQ(merged.models[1].name, "hand");
  EXPECT_TRUE(merged.Serialize() == whole);
  // The other order gives the other model order (and so other bytes).
  const ViewDatabase swapped = MergeViewDatabases({hand, cow});
  EXPECT_EQ(swapped.models[0].name, "hand");
  EXPECT_FALSE(swapped.Serialize() == whole);
  // One shard merges to itself.
  EXPECT_TRUE(MergeViewDatabases({cow}).Serialize() == ViewDatabase::Read(cow).Serialize());
}

TEST_F(DatabaseMergeTest, RefusesOtherParametersNamingTheFileAndTheParameter) {
  const auto cow = Build({Model("cow")}, "cow.db");
  DatabaseBuildOptions other = TinyOptions();
  other.parameters.distances_in_radii = {3.0, 8.0};
  const auto hand = Build({Model("hand")}, "hand8.db", other);
  try {
    MergeViewDatabases({cow, hand});
    FAIL() << "merged databases of other parameters";
  } catch (const Error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(hand.string()), std::string::npos) << message;
    EXPECT_NE(message.find("--distances: 3,7 vs 3,8"), std::string::npos) << message;
  }
  other = TinyOptions();
  other.parameters.view_sphere.num_views = 41;
  const auto views = Build({Model("hand")}, "hand41.db", other);
  EXPECT_THROW(MergeViewDatabases({cow, views}), Error);
}

TEST_F(DatabaseMergeTest, RefusesAModelTwiceAndMissingFiles) {
  const auto cow = Build({Model("cow")}, "cow.db");
  const auto both = Build({Model("hand"), Model("cow")}, "both.db");
  try {
    MergeViewDatabases({cow, both});
    FAIL() << "merged a model twice";
  } catch (const Error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(both.string() + ": model 'cow' is also in " + cow.string()),
              std::string::npos)
        << message;
  }
  EXPECT_THROW(MergeViewDatabases({}), Error);
  try {
    MergeViewDatabases({cow, directory_ / "missing.db"});
    FAIL() << "merged a missing file";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("missing.db: no such file"), std::string::npos);
  }
}

TEST(FirstParameterDifference, EmptyForEqualParameters) {
  DatabaseParameters a;
  DatabaseParameters b;
  EXPECT_EQ(FirstParameterDifference(a, b), "");
  b.render.resolution_px = 100;
  EXPECT_EQ(FirstParameterDifference(a, b), "--resolution: 512 vs 100");
}

}  // namespace
}  // namespace silpose
