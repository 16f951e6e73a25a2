#pragma once
// A FrameSource that reads another one on a thread of its own, a few frames ahead of the caller:
// the next frames are decoded (and, for masks, put through the mask rule) while the caller works
// on the current one. `silpose track` reads its input so by default (`--read-ahead`,
// docs/tracking.md, "Input").
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "silpose/io/frame_source.h"

namespace silpose {

class ReadAheadSource final : public FrameSource {
 public:
  /// Starts reading `source` (not null) on a new thread, at most `depth` (>= 1) frames ahead of
  /// Read(). The frames, their names and indices, and the Error of a bad frame come out exactly as
  /// `source` gives them, in order: the good frames before a bad one first, then its Error. Each
  /// frame is a buffer of its own (not one Read() reuses). Throws silpose::Error for a depth < 1.
  ReadAheadSource(std::unique_ptr<FrameSource> source, int depth);
  /// Stops the thread after the read it is in (a camera's next frame, at worst) and joins it.
  ~ReadAheadSource() override;

  /// As `source` stated them when this one was made.
  std::optional<int> num_frames() const override { return num_frames_; }
  double fps() const override { return fps_; }
  /// `source`'s size when this one was made; once a frame is read, the first frame's.
  cv::Size size() const override { return size_; }
  /// The name `source` gave the last frame Read() delivered (before the first: its name then).
  std::string name() const override { return name_; }

 protected:
  bool ReadNext(cv::Mat* frame) override;

 private:
  // One entry of the queue: a frame and its name, or the end of the frames (with the error that
  // ended them, if one did).
  struct Entry {
    cv::Mat frame;
    std::string name;
    bool end = false;
    std::exception_ptr error;
  };
  void Run();

  std::unique_ptr<FrameSource> source_;
  const size_t depth_;
  std::optional<int> num_frames_;
  double fps_ = 0.0;
  cv::Size size_;
  std::string name_;

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Entry> queue_;  // guarded by mutex_
  bool stop_ = false;        // guarded by mutex_: the destructor asks the thread to end
  bool ended_ = false;       // reader side only: the end or an error was delivered
  std::thread thread_;
};

}  // namespace silpose
