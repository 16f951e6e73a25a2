#include "silpose/util/parallel.h"

#include <algorithm>
#include <exception>

#include "silpose/util/error.h"
#include "silpose/util/threads.h"

#ifdef SILPOSE_PARALLEL_STD_THREADS
#include <atomic>
#include <mutex>
#include <thread>
#include <vector>
#else
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>
#include <oneapi/tbb/task_arena.h>
#include <oneapi/tbb/task_group.h>
#endif

namespace silpose {

void ParallelFor(int begin, int end, int grain, int num_threads,
                 const std::function<void(int, int)>& body, const std::function<void()>& beside) {
  if (grain < 1) ThrowError("ParallelFor: grain must be >= 1, got ", grain);
  const int threads = WorkerThreads(num_threads);
#ifdef SILPOSE_PARALLEL_STD_THREADS
  std::atomic<int> next{begin};
  std::atomic<bool> stop{false};
  std::mutex failure_mutex;
  std::exception_ptr failure;
  const auto guarded = [&](const std::function<void()>& work) {
    try {
      work();
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      stop = true;
    }
  };
  const auto chunks = [&] {
    guarded([&] {
      while (!stop) {
        const int first = next.fetch_add(grain);
        if (first >= end) break;
        body(first, std::min(end, first + grain));
      }
    });
  };
  std::vector<std::thread> workers;
  if (beside) {
    workers.emplace_back([&] { guarded(beside); });
  }
  for (int t = 1; t < threads; ++t) workers.emplace_back(chunks);
  chunks();
  for (std::thread& worker : workers) worker.join();
  if (failure) std::rethrow_exception(failure);
#else
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::task_group group;
    if (beside) group.run(beside);
    try {
      if (end > begin) {
        tbb::parallel_for(
            tbb::blocked_range<int>(begin, end, static_cast<size_t>(grain)),
            [&](const tbb::blocked_range<int>& range) { body(range.begin(), range.end()); },
            tbb::simple_partitioner());  // chunks of at most `grain`, as documented
      }
    } catch (...) {
      group.wait();  // `beside` refers to the caller's objects: let it finish first
      throw;
    }
    group.wait();
  });
#endif
}

const char* ParallelBackend() {
#ifdef SILPOSE_PARALLEL_STD_THREADS
  return "std::thread";
#else
  return "tbb";
#endif
}

}  // namespace silpose
