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

namespace silpose {
namespace {

TEST(Hash, HasherOfPiecesEqualsTheHashOfTheirConcatenation) {
  const std::string text = "the quick brown fox jumps over the lazy dog, twice over";
  for (size_t cut = 0; cut <= text.size(); cut += 7) {
    Hasher hasher;
    hasher.Update(text.data(), cut);
    hasher.Update(text.data() + cut, text.size() - cut);
    EXPECT_EQ(hasher.Digest(), HashBytes(text.data(), text.size())) << cut;
  }
  Hasher seeded(42);
  seeded.Update(text.data(), text.size());
  EXPECT_EQ(seeded.Digest(), HashBytes(text.data(), text.size(), 42));
  EXPECT_NE(seeded.Digest(), HashBytes(text.data(), text.size()));
}

}  // namespace
}  // namespace silpose
