// Inputs the fuzzers (fuzz/, docs/fuzzing.md) found mishandled, each reduced to what went wrong.
// Most of them fail only under the sanitizers (the 'asan' preset), which CI runs them with.

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/core.hpp>
#include <string>

#include "silpose/database/view_database.h"
#include "silpose/geometry/view_sphere.h"
#include "silpose/io/avi_file.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

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

}  // namespace
}  // namespace silpose
