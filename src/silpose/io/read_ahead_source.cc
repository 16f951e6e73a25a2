#include "silpose/io/read_ahead_source.h"

#include <system_error>
#include <utility>

#include "silpose/util/error.h"

namespace silpose {

ReadAheadSource::ReadAheadSource(std::unique_ptr<FrameSource> source, int depth, FrameWork work)
    : FrameSource(FrameColor::kAsStored),
      source_(std::move(source)),
      depth_(depth > 0 ? static_cast<size_t>(depth) : 0),
      work_(std::move(work)) {
  if (source_ == nullptr) ThrowError("ReadAheadSource: no source given");
  if (depth < 1) ThrowError("ReadAheadSource: the read-ahead depth must be >= 1, got ", depth);
  num_frames_ = source_->num_frames();
  fps_ = source_->fps();
  size_ = source_->size();
  name_ = source_->name();
  try {
    thread_ = std::thread([this] { Run(); });
  } catch (const std::system_error& error) {
    ThrowError(name_, ": cannot start a thread to read frames ahead (", error.what(), ")");
  }
}

ReadAheadSource::~ReadAheadSource() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void ReadAheadSource::Run() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [this] { return stop_ || queue_.size() < depth_; });
      if (stop_) return;
    }
    Entry entry;
    try {
      cv::Mat frame;
      if (source_->Read(&frame)) {
        // A buffer of its own: the source may decode its next frame into the one it returned.
        entry.frame = frame.clone();
        entry.name = source_->name();
        if (work_) entry.work = work_(entry.frame);
      } else {
        entry.end = true;
      }
    } catch (...) {
      entry.end = true;
      entry.error = std::current_exception();
    }
    const bool end = entry.end;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(std::move(entry));
    }
    changed_.notify_all();
    if (end) return;
  }
}

bool ReadAheadSource::ReadNext(cv::Mat* frame) {
  if (ended_) return false;
  Entry entry;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return !queue_.empty(); });
    entry = std::move(queue_.front());
    queue_.pop_front();
  }
  changed_.notify_all();
  if (entry.end) {
    ended_ = true;
    if (entry.error) std::rethrow_exception(entry.error);
    return false;
  }
  name_ = std::move(entry.name);
  work_result_ = std::move(entry.work);
  if (frame_index() < 0) size_ = entry.frame.size();
  *frame = std::move(entry.frame);
  return true;
}

}  // namespace silpose
