#include "silpose/util/parallel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "silpose/util/error.h"

// Whether this test is built with ThreadSanitizer (the library then is too).
#if defined(__SANITIZE_THREAD__)
constexpr bool kThreadSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
constexpr bool kThreadSanitizer = true;
#else
constexpr bool kThreadSanitizer = false;
#endif
#else
constexpr bool kThreadSanitizer = false;
#endif

namespace silpose {
namespace {

TEST(Parallel, UnderThreadSanitizerTheLoopsRunOnStdThread) {
  EXPECT_EQ(std::string(ParallelBackend()), kThreadSanitizer ? "std::thread" : "tbb");
}

// Also run under ThreadSanitizer (the 'tsan' preset), where ParallelFor uses std::thread.
TEST(Parallel, EveryIndexOnceInChunksOfAtMostTheGrain) {
  for (const int threads : {1, 2, 0}) {
    for (const int grain : {1, 3, 8, 1000}) {
      std::vector<int> hits(101, 0);  // each index written by the one chunk that has it
      std::mutex mutex;
      std::vector<std::pair<int, int>> chunks;
      ParallelFor(0, 101, grain, threads, [&](int first, int last) {
        for (int i = first; i < last; ++i) ++hits[static_cast<size_t>(i)];
        const std::lock_guard<std::mutex> lock(mutex);
        chunks.emplace_back(first, last);
      });
      EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), 101) << threads << " " << grain;
      for (const auto& [first, last] : chunks) {
        EXPECT_LT(first, last);
        EXPECT_LE(last - first, grain);
      }
    }
  }
  int calls = 0;
  ParallelFor(5, 5, 4, 2, [&](int, int) { ++calls; });
  EXPECT_EQ(calls, 0);
  EXPECT_THROW(ParallelFor(0, 4, 0, 1, [](int, int) {}), Error);
}

TEST(Parallel, BesideRunsOnceWhileTheChunksRun) {
  std::atomic<int> beside_runs{0};
  std::atomic<int> sum{0};
  ParallelFor(
      0, 64, 4, 2,
      [&](int first, int last) {
        for (int i = first; i < last; ++i) sum += i;
      },
      [&] { ++beside_runs; });
  EXPECT_EQ(beside_runs.load(), 1);
  EXPECT_EQ(sum.load(), 63 * 64 / 2);
  // Also with nothing to loop over.
  ParallelFor(
      0, 0, 4, 2, [](int, int) {}, [&] { ++beside_runs; });
  EXPECT_EQ(beside_runs.load(), 2);
}

TEST(Parallel, TheFirstExceptionIsRethrownAfterEveryThreadStopped) {
  std::atomic<int> running{0};
  try {
    ParallelFor(0, 1000, 1, 2, [&](int first, int) {
      ++running;
      if (first == 10) {
        --running;
        throw std::runtime_error("chunk 10 failed");
      }
      --running;
    });
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "chunk 10 failed");
  }
  EXPECT_EQ(running.load(), 0);  // nothing still running after the rethrow
  try {
    ParallelFor(
        0, 8, 2, 2, [](int, int) {}, [] { throw std::runtime_error("beside failed"); });
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "beside failed");
  }
}

}  // namespace
}  // namespace silpose
