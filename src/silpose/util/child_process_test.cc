#include "silpose/util/child_process.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

namespace silpose {
namespace {

TEST(ChildProcess, ReturnsWhatTheWorkReturned) {
  // More than a pipe holds at once, with bytes of every value.
  std::string expected;
  for (int i = 0; i < 300000; ++i) expected.push_back(static_cast<char>(i * 7 % 256));
  const ChildProcessResult result = RunInChildProcess([&] { return expected; });
  ASSERT_TRUE(result.started);
  EXPECT_FALSE(result.stuck);
  ASSERT_TRUE(WIFEXITED(result.wait_status));
  EXPECT_EQ(WEXITSTATUS(result.wait_status), 0);
  EXPECT_EQ(result.output, expected);
}

TEST(ChildProcess, ACrashOrAnExceptionEndsTheChildOnly) {
  const ChildProcessResult killed = RunInChildProcess([]() -> std::string {
    std::raise(SIGKILL);
    return "never";
  });
  ASSERT_TRUE(killed.started);
  EXPECT_FALSE(killed.stuck);
  ASSERT_TRUE(WIFSIGNALED(killed.wait_status));
  EXPECT_EQ(WTERMSIG(killed.wait_status), SIGKILL);
  EXPECT_TRUE(killed.output.empty());

  const ChildProcessResult threw =
      RunInChildProcess([]() -> std::string { throw std::runtime_error("no"); });
  ASSERT_TRUE(threw.started);
  ASSERT_TRUE(WIFEXITED(threw.wait_status));
  EXPECT_EQ(WEXITSTATUS(threw.wait_status), 70);
}

TEST(ChildProcess, AChildWaitingForALockHeldAtTheForkIsKilledAsStuck) {
  // The lock is held by another thread of this process when the child is forked: the child's copy
  // stays locked forever, as an allocator's would.
  std::mutex lock;
  std::mutex released;
  released.lock();
  std::thread holder([&] {
    const std::lock_guard<std::mutex> hold(lock);
    released.lock();  // until the test is done
    released.unlock();
  });
  while (lock.try_lock()) {  // until the holder has it
    lock.unlock();
    std::this_thread::yield();
  }
  const auto start = std::chrono::steady_clock::now();
  const ChildProcessResult result = RunInChildProcess(
      [&]() -> std::string {
        const std::lock_guard<std::mutex> wait(lock);
        return "never";
      },
      /*stall_seconds=*/0.5);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  released.unlock();
  holder.join();
  ASSERT_TRUE(result.started);
  EXPECT_TRUE(result.stuck);
  EXPECT_TRUE(result.output.empty());
  EXPECT_GE(seconds, 0.5);
}

TEST(ChildProcess, AChildThatComputesOrSleepsIsNotTakenForStuck) {
  // Busy for three times the stall time, writing nothing until the end.
  const ChildProcessResult busy = RunInChildProcess(
      [] {
        const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(900);
        volatile unsigned sum = 0;
        while (std::chrono::steady_clock::now() < end) sum = sum + 1;
        return std::string("done");
      },
      /*stall_seconds=*/0.3);
  ASSERT_TRUE(busy.started);
  EXPECT_FALSE(busy.stuck);
  EXPECT_EQ(busy.output, "done");
  EXPECT_TRUE(WIFEXITED(busy.wait_status));

  // Asleep, but not in a wait only another thread could end. Telling the two apart takes
  // /proc/PID/syscall of the child, which a kernel with a strict ptrace scope withholds.
  std::ifstream scope("/proc/sys/kernel/yama/ptrace_scope");
  int ptrace_scope = 0;
  if (scope >> ptrace_scope && ptrace_scope >= 2) GTEST_SKIP() << "ptrace_scope " << ptrace_scope;
  const ChildProcessResult asleep = RunInChildProcess(
      [] {
        std::this_thread::sleep_for(std::chrono::milliseconds(900));
        return std::string("awake");
      },
      /*stall_seconds=*/0.3);
  ASSERT_TRUE(asleep.started);
  EXPECT_FALSE(asleep.stuck);
  EXPECT_EQ(asleep.output, "awake");
}

}  // namespace
}  // namespace silpose
