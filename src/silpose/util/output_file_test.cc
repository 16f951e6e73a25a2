#include "silpose/util/output_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {
namespace {

class OutputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 ("silpose_output_file_" + std::to_string(::getpid()));
    std::filesystem::remove_all(directory_);
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }

  std::string Contents(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
  }

  std::filesystem::path directory_;
};

std::string MessageOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST_F(OutputFileTest, AtomicWriteReplacesARegularFileAndLeavesNoTemporary) {
  const auto path = directory_ / "a.db";
  std::ofstream(path) << "old";
  // A stale temporary file of a killed run is neither used nor removed.
  std::ofstream(directory_ / "a.db.tmp") << "stale";
  WriteFileAtomically(path, "new contents");
  EXPECT_EQ(Contents(path), "new contents");
  EXPECT_EQ(Contents(directory_ / "a.db.tmp"), "stale");
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(directory_)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 2);
}

TEST_F(OutputFileTest, AtomicWriteRefusesFifosSymlinksAndFolders) {
  const auto fifo = directory_ / "pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string message = MessageOf([&] { WriteFileAtomically(fifo, "x"); });
  EXPECT_NE(message.find("FIFO"), std::string::npos) << message;
  EXPECT_NE(message.find(fifo.string()), std::string::npos) << message;
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));

  const auto target = directory_ / "target";
  std::ofstream(target) << "kept";
  const auto link = directory_ / "link";
  std::filesystem::create_symlink(target, link);
  message = MessageOf([&] { WriteFileAtomically(link, "x"); });
  EXPECT_NE(message.find("symbolic link"), std::string::npos) << message;
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  EXPECT_EQ(Contents(target), "kept");

  message = MessageOf([&] { WriteFileAtomically(directory_, "x"); });
  EXPECT_NE(message.find("folder"), std::string::npos) << message;
}

TEST_F(OutputFileTest, CheckOutputPathNamesTheProblem) {
  EXPECT_NO_THROW(CheckOutputPath(directory_ / "new.csv", "-o"));
  std::string message = MessageOf([&] { CheckOutputPath(directory_ / "no" / "x.csv", "--json"); });
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
  EXPECT_NE(message.find("--json"), std::string::npos) << message;
  message = MessageOf([&] { CheckOutputPath(directory_, "-o"); });
  EXPECT_NE(message.find("folder"), std::string::npos) << message;
  EXPECT_NO_THROW(CheckOutputPath("/dev/null", "-o"));
}

TEST_F(OutputFileTest, ASecondLockOnTheSameOutputIsRefusedWithThePid) {
  const auto path = directory_ / "poses.csv";
  {
    OutputLock first(path);
    ASSERT_TRUE(first.locked());
    EXPECT_TRUE(std::filesystem::exists(directory_ / "poses.csv.lock"));
    // flock locks belong to the open file: a second open in the same process conflicts too.
    const std::string message = MessageOf([&] { OutputLock second(path); });
    EXPECT_NE(message.find("another silpose process"), std::string::npos) << message;
    EXPECT_NE(message.find("pid " + std::to_string(::getpid())), std::string::npos) << message;
  }
  EXPECT_FALSE(std::filesystem::exists(directory_ / "poses.csv.lock"));
  OutputLock again(path);
  EXPECT_TRUE(again.locked());
  // Devices are not locked.
  EXPECT_FALSE(OutputLock("/dev/null").locked());
}

}  // namespace
}  // namespace silpose
