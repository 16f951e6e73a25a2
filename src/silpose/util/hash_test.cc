#include "silpose/util/hash.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "silpose/util/error.h"

namespace silpose {
namespace {

TEST(Hash, FileHashEqualsByteHashAndDetectsEverySingleByteChange) {
  const std::string content(100000, 'x');
  const auto path = std::filesystem::temp_directory_path() / "silpose_hash_test.bin";
  { std::ofstream(path, std::ios::binary) << content; }
  EXPECT_EQ(HashFile(path), HashBytes(content.data(), content.size()));
  std::string changed = content;
  for (size_t i = 0; i < changed.size(); i += 997) {
    changed[i] = 'y';
    EXPECT_NE(HashBytes(changed.data(), changed.size()), HashBytes(content.data(), content.size()));
    changed[i] = 'x';
  }
  std::filesystem::remove(path);
}

TEST(Hash, MissingFileNamesTheFile) {
  try {
    HashFile("/nonexistent/silpose_missing.obj");
    FAIL() << "expected silpose::Error";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("silpose_missing.obj"), std::string::npos);
  }
}

}  // namespace
}  // namespace silpose
