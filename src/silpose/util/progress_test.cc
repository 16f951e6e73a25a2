#include "silpose/util/progress.h"

#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

namespace silpose {
namespace {

TEST(ProgressBar, CountsEveryAdvanceFromSeveralThreads) {
  ProgressBar bar("test", 4000, /*enabled=*/false);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&bar] {
      for (int i = 0; i < 1000; ++i) bar.Advance();
    });
  }
  for (auto& thread : threads) thread.join();
  EXPECT_EQ(bar.done(), 4000);
}

TEST(ProgressBar, DrawsABarOrACountWhenTheTotalIsUnknown) {
  testing::internal::CaptureStderr();
  {
    ProgressBar bar("known", 10, /*enabled=*/true);
    bar.Advance(5);
  }
  const std::string known = testing::internal::GetCapturedStderr();
  EXPECT_NE(known.find("known [###############..............."), std::string::npos) << known;
  EXPECT_NE(known.find("5/10"), std::string::npos) << known;

  testing::internal::CaptureStderr();
  {
    ProgressBar bar("camera", 0, /*enabled=*/true);
    bar.Advance(7);
  }
  const std::string unknown = testing::internal::GetCapturedStderr();
  EXPECT_NE(unknown.find("camera 7 "), std::string::npos) << unknown;
  EXPECT_EQ(unknown.find('#'), std::string::npos) << unknown;
}

}  // namespace
}  // namespace silpose
