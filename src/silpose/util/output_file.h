#pragma once
// Writing output files safely (docs/limits.md, "Output files"):
//  - CheckOutputPath: before anything is created, whether a path can be written (its folder exists
//    and is writable, it is not a folder, an existing file is writable);
//  - OutputLock: an advisory lock (flock) on `<path>.lock`, so that two silpose processes never
//    write the same output at once; the second is refused with the first one's process id;
//  - WriteFileAtomically: a whole file written to a unique temporary file beside it, then renamed
//    over the target, which must be a regular file or absent (a device, FIFO, symbolic link or
//    folder is refused, never replaced).

#include <filesystem>
#include <string>
#include <string_view>

namespace silpose {

/// Throws silpose::Error naming `path` (and `what`, e.g. "--json") if it cannot be written: a
/// folder, a missing or read-only parent folder, an existing file without write permission.
/// Devices and FIFOs that exist are accepted (writing to /dev/stdout is fine).
void CheckOutputPath(const std::filesystem::path& path, const std::string& what);

/// True if `path` exists and is a regular file or does not exist (symbolic links followed).
bool IsRegularOrAbsent(const std::filesystem::path& path);

/// An exclusive advisory lock on `<path>.lock`, held for the object's lifetime (and released by
/// the system if the process dies; the empty lock file is removed on release). Paths that are not
/// regular files (devices, FIFOs) are not locked.
class OutputLock {
 public:
  OutputLock() = default;
  /// Takes the lock or throws silpose::Error naming `path`, the process id holding it and what to
  /// do. If the lock file cannot be created (a read-only folder), no lock is taken.
  explicit OutputLock(const std::filesystem::path& path);
  ~OutputLock();
  OutputLock(OutputLock&& other) noexcept;
  OutputLock& operator=(OutputLock&& other) noexcept;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

  bool locked() const { return fd_ >= 0; }
  const std::filesystem::path& lock_path() const { return lock_path_; }

 private:
  void Release();
  int fd_ = -1;
  std::filesystem::path lock_path_;
};

/// Throws silpose::Error naming `path` if something other than a regular file is there (a device,
/// FIFO, socket, folder or symbolic link): what WriteFileAtomically refuses to replace.
void CheckReplaceable(const std::filesystem::path& path);

/// Writes `bytes` to `path` through a uniquely named temporary file in the same folder
/// (`<path>.tmp.XXXXXX`) and a rename. Refuses (silpose::Error naming the path) a target that
/// exists and is not a regular file: a device, FIFO, socket, folder or symbolic link. On failure
/// the temporary file is removed and the target is unchanged. A `<path>.tmp` left by an earlier
/// run is never touched.
void WriteFileAtomically(const std::filesystem::path& path, std::string_view bytes);

}  // namespace silpose
