#include "silpose/util/threads.h"

#include <sched.h>

#include <algorithm>
#include <thread>

namespace silpose {

int AvailableCores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(1, CPU_COUNT(&set));
  return std::max(1U, std::thread::hardware_concurrency());
}

int WorkerThreads(int requested) {
  const int cores = AvailableCores();
  return requested > 0 ? std::min(requested, cores) : cores;
}

}  // namespace silpose
