#pragma once
// A file's bytes, mapped read-only into memory (mmap) so that opening a large file costs neither a
// copy nor fresh memory: the pages are the system's file cache, shared by every process that maps
// the same file. Files that cannot be mapped (pipes, devices, empty files) are read into memory
// instead. The file must not be changed in place while it is mapped (silpose replaces files by
// renaming a new one over them, which leaves a mapping of the old one intact).

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace silpose {

class MappedFile {
 public:
  /// Maps (or reads) the file. Throws silpose::Error naming it if it does not exist, is a folder or
  /// cannot be read.
  static std::shared_ptr<const MappedFile> Open(const std::filesystem::path& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::string_view bytes() const {
    return mapped_ != nullptr ? std::string_view(static_cast<const char*>(mapped_), size_)
                              : std::string_view(copy_);
  }
  /// True if the bytes are mapped (false: read into memory).
  bool mapped() const { return mapped_ != nullptr; }

 private:
  MappedFile() = default;
  void* mapped_ = nullptr;
  size_t size_ = 0;
  std::string copy_;
};

}  // namespace silpose
