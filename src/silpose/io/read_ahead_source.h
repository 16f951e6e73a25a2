#pragma once
// A FrameSource that reads another one on a thread of its own, a few frames ahead of the caller:
// the next frames are decoded (and, for masks, put through the mask rule) while the caller works
// on the current one. `silpose track` reads its input so by default (`--read-ahead`,
// docs/tracking.md, "Input").
#include <any>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "silpose/io/frame_source.h"

namespace silpose {

class ReadAheadSource final : public FrameSource {
 public:
  /// Work done on each frame on the reading thread, in frame order, right after it is read (e.g.
  /// its segmentation, as `silpose track` does). Its result goes with the frame (work_result()).
  using FrameWork = std::function<std::any(const cv::Mat& frame)>;

  /// Starts reading `source` (not null) on a new thread, at most `depth` (>= 1) frames ahead of
  /// Read(). The frames, their names and indices, and the Error of a bad frame come out exactly as
  /// `source` gives them, in order: the good frames before a bad one first, then its Error. Each
  /// frame is a buffer of its own (not one Read() reuses). With `work`, each frame read is also
  /// given to it on that thread; an exception it throws ends the frames there, as a bad frame's
  /// Error does (that frame is not delivered). Throws silpose::Error for a depth < 1.
  ReadAheadSource(std::unique_ptr<FrameSource> source, int depth, FrameWork work = {});
  /// Stops the thread after the read it is in (a camera's next frame, at worst) and joins it.
  ~ReadAheadSource() override;

  /// As `source` stated them when this one was made.
  std::optional<int> num_frames() const override { return num_frames_; }
  double fps() const override { return fps_; }
  /// `source`'s size when this one was made; once a frame is read, the first frame's.
  cv::Size size() const override { return size_; }
  /// The name `source` gave the last frame Read() delivered (before the first: its name then).
  std::string name() const override { return name_; }
  /// What `work` returned for the frame the last Read() delivered (empty without work, or before
  /// the first frame). The caller may move it out.
  std::any& work_result() { return work_result_; }

 protected:
  bool ReadNext(cv::Mat* frame) override;

 private:
  // One entry of the queue: a frame and its name, or the end of the frames (with the error that
  // ended them, if one did).
  struct Entry {
    cv::Mat frame;
    std::string name;
    std::any work;
    bool end = false;
    std::exception_ptr error;
  };
  void Run();

  std::unique_ptr<FrameSource> source_;
  const size_t depth_;
  FrameWork work_;
  std::any work_result_;
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
