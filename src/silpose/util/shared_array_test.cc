#include "silpose/util/shared_array.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "silpose/util/error.h"
#include "silpose/util/mapped_file.h"

namespace silpose {
namespace {

TEST(SharedArray, OwnedArraysCopyTheirElementsReferringOnesTheReference) {
  SharedArray<int> owned(std::vector<int>{1, 2, 3});
  SharedArray<int> copy = owned;
  copy.mutable_data()[0] = 9;
  EXPECT_EQ(owned[0], 1);  // an owned copy is independent
  EXPECT_FALSE(owned.referring());

  const int external[4] = {4, 5, 6, 7};
  const SharedArray<int> refer = SharedArray<int>::Refer(external, 4);
  EXPECT_TRUE(refer.referring());
  EXPECT_EQ(refer.data(), external);
  EXPECT_EQ(refer.owned_bytes(), 0u);
  SharedArray<int> second = refer;
  EXPECT_EQ(second.data(), external);  // the reference, not the elements
  // Reading a non-const referring array never copies it.
  EXPECT_EQ(second[2], 6);
  EXPECT_EQ(std::span<const int>(second).data(), external);
  EXPECT_TRUE(second.referring());
  // Writing copies first: the external elements never change.
  second.mutable_span()[0] = 40;
  EXPECT_FALSE(second.referring());
  EXPECT_NE(second.data(), external);
  EXPECT_EQ(external[0], 4);
  EXPECT_EQ(second.ToVector(), (std::vector<int>{40, 5, 6, 7}));
  EXPECT_EQ(refer, SharedArray<int>(std::vector<int>{4, 5, 6, 7}));
  EXPECT_FALSE(refer == second);
  // Resizing a referring array keeps the elements it had.
  SharedArray<int> grown = refer;
  grown.resize(6);
  EXPECT_EQ(grown.ToVector(), (std::vector<int>{4, 5, 6, 7, 0, 0}));
  // Moving leaves the source empty and the target pointing at the same elements.
  SharedArray<int> moved = std::move(grown);
  EXPECT_EQ(moved.size(), 6u);
  EXPECT_TRUE(grown.empty());  // NOLINT(bugprone-use-after-move): moved-from state is specified
}

TEST(MappedFile, MapsRegularFilesAndReadsWhatCannotBeMapped) {
  const auto folder = std::filesystem::temp_directory_path() /
                      ("silpose_mapped_file_" + std::to_string(::getpid()));
  std::filesystem::create_directories(folder);
  const auto path = folder / "data.bin";
  { std::ofstream(path, std::ios::binary) << "mapped bytes"; }
  const auto file = MappedFile::Open(path);
  EXPECT_TRUE(file->mapped());
  EXPECT_EQ(file->bytes(), "mapped bytes");
  // Renaming another file over it leaves the mapping as it was.
  const auto other = folder / "other.bin";
  { std::ofstream(other, std::ios::binary) << "new content!"; }
  std::filesystem::rename(other, path);
  EXPECT_EQ(file->bytes(), "mapped bytes");
  // An empty file cannot be mapped: it is read (as nothing).
  const auto empty = folder / "empty.bin";
  { std::ofstream(empty, std::ios::binary); }
  const auto none = MappedFile::Open(empty);
  EXPECT_FALSE(none->mapped());
  EXPECT_TRUE(none->bytes().empty());
  // Missing files and folders are named.
  try {
    (void)MappedFile::Open(folder / "missing.bin");
    ADD_FAILURE();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("missing.bin: no such file"), std::string::npos);
  }
  EXPECT_THROW((void)MappedFile::Open(folder), Error);
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace silpose
