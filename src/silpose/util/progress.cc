#include "silpose/util/progress.h"

#include <unistd.h>

#include <cstdio>

namespace silpose {

ProgressBar::ProgressBar(std::string label, int64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

ProgressBar::~ProgressBar() { Finish(); }

bool ProgressBar::StderrIsTerminal() { return isatty(fileno(stderr)) != 0; }

void ProgressBar::Advance(int64_t count) {
  done_.fetch_add(count);
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  std::unique_lock lock(draw_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  Draw(false);
}

void ProgressBar::Finish() {
  if (finished_) return;
  finished_ = true;
  if (!enabled_) return;
  std::lock_guard lock(draw_mutex_);
  Draw(true);
  std::fputc('\n', stderr);
  std::fflush(stderr);
}

void ProgressBar::Draw(bool final_draw) {
  constexpr int kWidth = 30;
  if (total_ <= 0) {
    // Unknown amount of work (a camera, an unindexed video): count and rate only.
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const int64_t count = done_.load();
    std::fprintf(stderr, "\r%s %lld  %.1fs  %.1f/s   ", label_.c_str(),
                 static_cast<long long>(count), seconds,
                 seconds > 0.0 ? static_cast<double>(count) / seconds : 0.0);
    std::fflush(stderr);
    return;
  }
  const int64_t done = final_draw ? done_.load() : std::min(done_.load(), total_);
  const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  const int filled = static_cast<int>(fraction * kWidth);
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(kWidth - filled), '.');
  if (fraction > 0.0 && fraction < 1.0) {
    const double eta = elapsed * (1.0 - fraction) / fraction;
    std::fprintf(stderr, "\r%s [%s] %3d%% %lld/%lld  %.1fs, ~%.0fs left ", label_.c_str(),
                 bar.c_str(), static_cast<int>(fraction * 100.0), static_cast<long long>(done),
                 static_cast<long long>(total_), elapsed, eta);
  } else {
    std::fprintf(stderr, "\r%s [%s] %3d%% %lld/%lld  %.1fs            ", label_.c_str(),
                 bar.c_str(), static_cast<int>(fraction * 100.0), static_cast<long long>(done),
                 static_cast<long long>(total_), elapsed);
  }
  std::fflush(stderr);
}

}  // namespace silpose
