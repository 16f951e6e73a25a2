#include "silpose/util/hash.h"

#include <xxhash.h>

#include <fstream>
#include <new>
#include <vector>

#include "silpose/util/error.h"

namespace silpose {

uint64_t HashBytes(const void* data, size_t size, uint64_t seed) { return XXH64(data, size, seed); }

Hasher::Hasher(uint64_t seed) : state_(XXH64_createState()) {
  if (state_ == nullptr) throw std::bad_alloc();
  XXH64_reset(static_cast<XXH64_state_t*>(state_), seed);
}
Hasher::~Hasher() { XXH64_freeState(static_cast<XXH64_state_t*>(state_)); }
void Hasher::Update(const void* data, size_t size) {
  XXH64_update(static_cast<XXH64_state_t*>(state_), data, size);
}
uint64_t Hasher::Digest() const { return XXH64_digest(static_cast<const XXH64_state_t*>(state_)); }

uint64_t HashFile(const std::filesystem::path& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) ThrowError(path.string(), ": cannot open file for reading");
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  std::vector<char> buffer(1 << 16);
  while (stream) {
    stream.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    XXH64_update(state, buffer.data(), static_cast<size_t>(stream.gcount()));
  }
  const bool failed = stream.bad();
  const uint64_t hash = XXH64_digest(state);
  XXH64_freeState(state);
  if (failed) ThrowError(path.string(), ": read error");
  return hash;
}

}  // namespace silpose
