#pragma once
// Work in a child process (fork), so that a crash, a runaway allocation or an endless wait in it
// costs that work only, never the calling process.

#include <functional>
#include <string>

namespace silpose {

/// What RunInChildProcess saw of its child.
struct ChildProcessResult {
  /// False: no child could be made (no pipe, or fork failed); the work was not run.
  bool started = false;
  /// The child stopped making progress in a wait that nothing could end, and was killed (see
  /// RunInChildProcess). Its output is then incomplete and wait_status is meaningless.
  bool stuck = false;
  /// waitpid()'s status of the child (WIFEXITED, WIFSIGNALED, ...), when it started and was not
  /// stuck. A child whose work threw ends with exit status 70.
  int wait_status = 0;
  /// Everything the work returned, as far as the child wrote it before it ended.
  std::string output;
};

/// Runs `work` in a child process made with fork() and returns the string it returns, with how
/// the child ended. The child runs only `work` and then _exit()s (no exit handlers, no flushing of
/// the parent's stdio buffers).
///
/// A child forked from a process with several threads holds a copy of every lock those threads
/// held at that moment, still locked, and no thread to release it (an allocator without fork
/// handlers, such as a sanitizer's, is one). A child that takes such a lock waits forever. The
/// parent therefore watches the child while it waits for its output: a child that has been asleep
/// in a futex wait (or, where the kernel does not say which call it sleeps in, asleep at all)
/// without using any CPU time for `stall_seconds` is killed and reported as stuck; the caller can
/// try again (the lock is seldom held at the next fork) or do the work itself. A child that
/// computes, reads a disk or is waiting for a CPU is never taken for stuck.
ChildProcessResult RunInChildProcess(const std::function<std::string()>& work,
                                     double stall_seconds = 2.0);

}  // namespace silpose
