#pragma once
// A progress bar for long work. It draws on stderr only when stderr is a terminal, so logs, pipes
// and CI stay quiet; it is safe to call Advance() from several threads.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace silpose {

class ProgressBar {
 public:
  /// `label` is shown before the bar; `total` is the number of work items (<= 0: unknown, e.g. a
  /// live camera; then the count and the rate are shown instead of a bar).
  /// `enabled`: draw at all (default: only if stderr is a terminal).
  ProgressBar(std::string label, int64_t total, bool enabled = StderrIsTerminal());
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Marks `count` more items done; redraws at most ~10 times per second.
  void Advance(int64_t count = 1);
  /// Draws the final state and ends the line (called by the destructor if not before).
  void Finish();

  int64_t done() const { return done_.load(); }
  static bool StderrIsTerminal();

 private:
  void Draw(bool final_draw);

  std::string label_;
  int64_t total_;
  bool enabled_;
  bool finished_ = false;
  std::atomic<int64_t> done_{0};
  std::mutex draw_mutex_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace silpose
