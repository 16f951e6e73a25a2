// Image formats at the command line: PNG and JPEG masks are read without OpenCV's image codecs
// (so a command starts without loading them and the libraries they pull in); other formats load
// them on demand from silpose's codecs plugin, and without the plugin are refused clearly.

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "cli_runner.h"
#include "silpose/io/image_codec.h"

namespace silpose {
namespace {

class CliImageFormatsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = std::filesystem::temp_directory_path() /
              ("silpose_cli_image_formats_" + std::to_string(::getpid()));
    std::filesystem::create_directories(folder_);
    const std::string models = SILPOSE_SAMPLE_MODELS_DIR;
    const CommandResult build = Silpose("build-db " + models + "/bunny.obj " + models +
                                        "/elephant.obj --views 200 --distances 3 -o " + Db());
    ASSERT_EQ(build.exit_code, 0) << build.err;
    cv::Mat mask(240, 320, CV_8UC1, cv::Scalar(0));
    cv::ellipse(mask, {160, 120}, {70, 40}, 20, 0, 360, cv::Scalar(255), cv::FILLED);
    cv::circle(mask, {215, 80}, 25, cv::Scalar(255), cv::FILLED);
    for (const char* extension : {".png", ".jpg", ".bmp"}) {
      ASSERT_TRUE(WriteImage(folder_ / (std::string("mask") + extension), mask));
    }
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(folder_); }

  static std::string Db() { return (folder_ / "two.db").string(); }
  static std::string Mask(const char* extension) {
    return (folder_ / (std::string("mask") + extension)).string();
  }
  // `silpose match`, with the dynamic loader's list of every library it loaded in `libraries`.
  static CommandResult MatchListingLibraries(const std::string& mask, std::string* libraries) {
    const auto log = folder_ / "loader";
    std::filesystem::create_directories(log);
    ::setenv("LD_DEBUG", "files", 1);
    ::setenv("LD_DEBUG_OUTPUT", (log / "files").c_str(), 1);  // files.<pid>, one per process
    CommandResult run = Silpose("match -d " + Db() + " " + mask);
    ::unsetenv("LD_DEBUG");
    ::unsetenv("LD_DEBUG_OUTPUT");
    libraries->clear();
    for (const auto& entry : std::filesystem::directory_iterator(log)) {
      std::ifstream file(entry.path());
      libraries->append(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
    }
    std::filesystem::remove_all(log);
    return run;
  }
  // The best match's row (rank 1) of `match`'s table.
  static std::string BestRow(const std::string& out) {
    const size_t start = out.find("\n   1 ");
    return start == std::string::npos
               ? ""
               : out.substr(start + 1, out.find('\n', start + 1) - start - 1);
  }

  static inline std::filesystem::path folder_;
};

TEST_F(CliImageFormatsTest, PngAndJpegMasksAreMatchedWithoutLoadingOpenCvsCodecs) {
  for (const char* extension : {".png", ".jpg"}) {
    std::string libraries;
    const CommandResult run = MatchListingLibraries(Mask(extension), &libraries);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(libraries.find("libopencv_core"), std::string::npos) << "the loader listed nothing";
    EXPECT_EQ(libraries.find("libopencv_imgcodecs"), std::string::npos) << extension;
    EXPECT_EQ(libraries.find("libsilpose_opencv_codecs"), std::string::npos) << extension;
    EXPECT_FALSE(BestRow(run.out).empty()) << run.out;
  }
}

TEST_F(CliImageFormatsTest, OtherFormatsLoadOpenCvsCodecsAndMatchTheSame) {
  const CommandResult png = Silpose("match -d " + Db() + " " + Mask(".png"));
  std::string libraries;
  const CommandResult bmp = MatchListingLibraries(Mask(".bmp"), &libraries);
  ASSERT_EQ(bmp.exit_code, 0) << bmp.err;
  EXPECT_NE(libraries.find("libsilpose_opencv_codecs"), std::string::npos);
  EXPECT_NE(libraries.find("libopencv_imgcodecs"), std::string::npos);
  EXPECT_EQ(BestRow(bmp.out), BestRow(png.out));
  EXPECT_FALSE(BestRow(png.out).empty()) << png.out;
}

TEST_F(CliImageFormatsTest, WithoutThePluginOtherFormatsAreRefusedNamingTheFile) {
  ::setenv("SILPOSE_OPENCV_CODECS", "/nonexistent/libsilpose_opencv_codecs.so", 1);
  const CommandResult bmp = Silpose("match -d " + Db() + " " + Mask(".bmp"));
  const CommandResult png = Silpose("match -d " + Db() + " " + Mask(".png"));
  ::unsetenv("SILPOSE_OPENCV_CODECS");
  EXPECT_NE(bmp.exit_code, 0);
  EXPECT_NE(bmp.err.find(Mask(".bmp")), std::string::npos) << bmp.err;
  EXPECT_NE(bmp.err.find("/nonexistent/libsilpose_opencv_codecs.so"), std::string::npos) << bmp.err;
  EXPECT_NE(bmp.err.find("convert the image to PNG"), std::string::npos) << bmp.err;
  EXPECT_EQ(png.exit_code, 0) << png.err;
}

TEST_F(CliImageFormatsTest, ThePluginIsNeverLoadedFromTheWorkingFolder) {
  // Started by its bare name from PATH, the program's own path is not in argv[0]: the plugin must
  // still be looked for beside the real executable, never relative to the working folder (which
  // may belong to someone else). Copies of the plugin wait where relative paths would find them.
  const auto work = folder_ / "untrusted";
  const auto inside = work / "inside";
  for (const auto& copy : {inside / "silpose", work / "lib" / "silpose"}) {
    std::filesystem::create_directories(copy);
    std::filesystem::copy_file(SILPOSE_CODECS_PLUGIN, copy / "libsilpose_opencv_codecs.so",
                               std::filesystem::copy_options::overwrite_existing);
  }
  const auto log = folder_ / "loader_untrusted";
  std::filesystem::create_directories(log);
  const std::string binary_dir = std::filesystem::path(SILPOSE_BINARY).parent_path().string();
  const std::string command = "cd " + inside.string() +
                              " && LD_DEBUG=files LD_DEBUG_OUTPUT=" + (log / "files").string() +
                              " PATH=" + binary_dir + ":$PATH silpose match -d " + Db() + " " +
                              Mask(".bmp") + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << command;
  std::string loaded;  // every plugin the loader opened, one per line
  for (const auto& entry : std::filesystem::directory_iterator(log)) {
    std::ifstream file(entry.path());
    for (std::string line; std::getline(file, line);) {
      const size_t at = line.find("file=");
      if (at == std::string::npos) continue;
      const std::string path = line.substr(at + 5, line.find(' ', at) - at - 5);
      if (path.find("libsilpose_opencv_codecs") == std::string::npos) continue;
      EXPECT_EQ(path.front(), '/') << path;
      EXPECT_EQ(path.find(work.string()), std::string::npos) << path;
      loaded += path + "\n";
    }
  }
  std::filesystem::remove_all(log);
  std::filesystem::remove_all(work);
  EXPECT_FALSE(loaded.empty()) << "the loader listed no plugin";
}

}  // namespace
}  // namespace silpose
