#include "silpose/util/mapped_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "silpose/util/error.h"

namespace silpose {

std::shared_ptr<const MappedFile> MappedFile::Open(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) ThrowError(path.string(), ": no such file");
  if (std::filesystem::is_directory(path, error)) ThrowError(path.string(), ": is a folder");
  std::shared_ptr<MappedFile> file(new MappedFile());
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) ThrowError(path.string(), ": cannot open for reading (", std::strerror(errno), ")");
  struct stat status {};
  if (::fstat(fd, &status) == 0 && S_ISREG(status.st_mode) && status.st_size > 0) {
    // Pages are mapped when first touched: a reader pays only for what it reads (no
    // MAP_POPULATE, which would make every page of a large file resident at once).
    void* address =
        ::mmap(nullptr, static_cast<size_t>(status.st_size), PROT_READ, MAP_SHARED, fd, 0);
    if (address != MAP_FAILED) {
      file->mapped_ = address;
      file->size_ = static_cast<size_t>(status.st_size);
    }
  }
  ::close(fd);
  if (file->mapped_ != nullptr) return file;
  // Not mappable: read it.
  std::ifstream stream(path, std::ios::binary);
  if (!stream) ThrowError(path.string(), ": cannot open for reading");
  std::ostringstream contents;
  contents << stream.rdbuf();
  if (stream.bad()) ThrowError(path.string(), ": read error");
  file->copy_ = std::move(contents).str();
  return file;
}

MappedFile::~MappedFile() {
  if (mapped_ != nullptr) ::munmap(mapped_, size_);
}

}  // namespace silpose
