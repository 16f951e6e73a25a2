#include "silpose/util/progress.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace silpose
