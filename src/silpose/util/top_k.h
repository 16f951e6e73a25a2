#pragma once
// Keeping the k largest of a stream of values in one pass: KeepLargest(&best, k, value) holds
// `best` sorted in decreasing order (std::greater) and at most k long. Each value costs one
// comparison when it does not make the cut, which is most of them once `best` is full: cheaper
// than collecting every value and partially sorting them when k is small beside the stream.
// Values that compare equal stay in the order they came.

#include <algorithm>
#include <cstddef>
#include <functional>
#include <vector>

namespace silpose {

namespace top_k_internal {

// KeepLargest's insertion, out of line: the test before it rejects most values.
template <typename T>
[[gnu::noinline]] void Insert(std::vector<T>* best, size_t k, const T& value) {
  if (best->size() >= k) best->pop_back();
  best->insert(std::upper_bound(best->begin(), best->end(), value, std::greater<>()), value);
}

}  // namespace top_k_internal

template <typename T>
inline void KeepLargest(std::vector<T>* best, size_t k, const T& value) {
  if (k == 0 || (best->size() >= k && !(value > best->back()))) return;
  top_k_internal::Insert(best, k, value);
}

}  // namespace silpose
