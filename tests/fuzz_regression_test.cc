// Inputs the fuzzers (fuzz/, docs/fuzzing.md) found mishandled, each reduced to what went wrong.
// Most of them fail only under the sanitizers (the 'asan' preset), which CI runs them with.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <string>

#include "silpose/database/view_database.h"
#include "silpose/geometry/view_sphere.h"
#include "silpose/io/avi_file.h"
#include "silpose/mesh/triangle_mesh.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

std::string ReadBytes(const std::string& path) {
  std::ifstream stream(path, std::ios::binary);
  EXPECT_TRUE(stream) << path;
  return {std::istreambuf_iterator<char>(stream), std::istreambuf_iterator<char>()};
}

// A database whose views have no neighbours (an empty neighbour list) read back: reading an empty
// array passed memcpy a null pointer (undefined behaviour, reported by UBSan).
TEST(FuzzRegression, DatabaseWithAnEmptyNeighbourListReadsBack) {
  ViewDatabase database;
  database.parameters.view_sphere.num_views = 8;
  database.parameters.view_sphere.num_bins = 2;
  database.parameters.signature.length = 16;
  database.parameters.render.resolution_px = 64;
  database.parameters.distances_in_radii = {3.0};
  database.sphere = BuildViewSphere(database.parameters.view_sphere);
  database.sphere.neighbour_indices.clear();
  std::fill(database.sphere.neighbour_offsets.begin(), database.sphere.neighbour_offsets.end(), 0u);
  const std::string bytes = database.Serialize();
  const ViewDatabase read = ViewDatabase::Deserialize(bytes, "empty-neighbours.db");
  EXPECT_TRUE(read.sphere.neighbour_indices.empty());
  EXPECT_EQ(read.Serialize(), bytes);
}

// An AVI whose 8-bit frames are uncompressed by the stream header's handler while the format names
// another compression: the frames were looked up in an empty palette (UBSan: an offset applied to
// a null pointer). Now they are read with a grey ramp, or the file is refused with a message.
TEST(FuzzRegression, EightBitAviWithoutAPaletteIsReadOrRefused) {
  const std::string path =
      std::string(SILPOSE_FUZZ_CORPUS_DIR) + "/avi/regression-8bit-without-palette.avi";
  try {
    AviReader reader(path);
    cv::Mat frame;
    for (int i = 0; i < 64 && reader.Read(&frame); ++i) EXPECT_FALSE(frame.empty());
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("regression-8bit-without-palette.avi"),
              std::string::npos)
        << error.what();
  }
}

// A file named .glb whose content neither glTF reader recognised: assimp then tried every reader
// on the content, read it as a Quick3D file and asked for 1.5 TB for its materials (fatal under
// AddressSanitizer; elsewhere a bad_alloc caught inside assimp). Now the file is refused first.
TEST(FuzzRegression, GlbFileWithQuick3dContentIsRefusedBeforeAssimpReadsIt) {
  const std::string input =
      ReadBytes(std::string(SILPOSE_FUZZ_CORPUS_DIR) + "/mesh/regression-glb-read-as-quick3d");
  ASSERT_EQ(input.substr(1, 8), "quick3do");  // byte 0 picks the extension (.glb) in the fuzzer
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "regression-quick3d.glb";
  std::ofstream(path, std::ios::binary) << input.substr(1);
  try {
    (void)LoadMesh(path);
    ADD_FAILURE() << "loaded";
  } catch (const Error& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(path.string(), 0), 0u) << message;
    EXPECT_NE(message.find("not that of a .glb file"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace silpose
