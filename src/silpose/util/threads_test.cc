#include "silpose/util/threads.h"

#include <gtest/gtest.h>

namespace silpose {
namespace {

TEST(Threads, RequestsAreCappedAtTheAvailableCores) {
  const int cores = AvailableCores();
  ASSERT_GE(cores, 1);
  EXPECT_EQ(WorkerThreads(0), cores);
  EXPECT_EQ(WorkerThreads(1), 1);
  EXPECT_EQ(WorkerThreads(cores + 7), cores);
  EXPECT_EQ(WorkerThreads(-3), cores);
}

}  // namespace
}  // namespace silpose
