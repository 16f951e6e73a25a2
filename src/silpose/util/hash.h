#pragma once
// Content hashes (XXH64) for mesh fingerprints and database checksums.

#include <cstddef>
#include <cstdint>
#include <filesystem>

namespace silpose {

/// 64-bit XXH64 hash of a byte range.
uint64_t HashBytes(const void* data, size_t size, uint64_t seed = 0);

/// XXH64 of bytes given in pieces: equal to HashBytes of their concatenation.
class Hasher {
 public:
  explicit Hasher(uint64_t seed = 0);
  ~Hasher();
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;
  void Update(const void* data, size_t size);
  uint64_t Digest() const;

 private:
  void* state_;
};

/// XXH64 hash of a file's bytes. Throws silpose::Error naming the file if it cannot be read.
uint64_t HashFile(const std::filesystem::path& path);

}  // namespace silpose
