#pragma once
// SharedArray<T>: an array that either owns its elements (a std::vector) or refers to elements
// someone else keeps alive, e.g. a database file mapped into memory (util/mapped_file.h). Reading
// is the same either way; the first write to a referring array copies the elements into storage of
// its own (copy on write), so mapped memory is never written. Copying a referring array copies the
// reference, not the elements, and the owner of the memory if one was given (Refer), which keeps
// it alive for as long as any copy exists; without an owner the memory must outlive every copy.

#include <algorithm>
#include <cstddef>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

namespace silpose {

template <typename T>
class SharedArray {
 public:
  SharedArray() = default;
  SharedArray(std::vector<T> values)  // NOLINT(google-explicit-constructor): a vector is an array
      : owned_(std::move(values)), data_(owned_.data()), size_(owned_.size()) {}
  /// An array referring to `size` elements at `data`, kept alive by `owner` (shared by every
  /// copy); without an owner, `data` must outlive the array and its copies.
  static SharedArray Refer(const T* data, size_t size,
                           std::shared_ptr<const void> owner = nullptr) {
    SharedArray array;
    array.data_ = data;
    array.size_ = size;
    array.referring_ = true;
    array.owner_ = std::move(owner);
    return array;
  }

  SharedArray(const SharedArray& other) { *this = other; }
  SharedArray& operator=(const SharedArray& other) {
    if (this == &other) return *this;
    referring_ = other.referring_;
    owner_ = other.owner_;
    if (referring_) {
      owned_.clear();
      owned_.shrink_to_fit();
      data_ = other.data_;
    } else {
      owned_ = other.owned_;
      data_ = owned_.data();
    }
    size_ = other.size_;
    return *this;
  }
  SharedArray(SharedArray&& other) noexcept { *this = std::move(other); }
  SharedArray& operator=(SharedArray&& other) noexcept {
    if (this == &other) return *this;
    referring_ = other.referring_;
    owner_ = std::move(other.owner_);
    owned_ = std::move(other.owned_);
    data_ = referring_ ? other.data_ : owned_.data();
    size_ = other.size_;
    other.owned_.clear();
    other.data_ = nullptr;
    other.size_ = 0;
    other.referring_ = false;
    return *this;
  }

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  /// True if the elements are someone else's (Refer) and not yet copied.
  bool referring() const { return referring_; }
  /// Bytes of the elements this array owns (0 while it refers).
  size_t owned_bytes() const { return owned_.capacity() * sizeof(T); }

  const T* data() const { return data_; }
  const T& operator[](size_t i) const { return data_[i]; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  std::span<const T> span() const { return {data_, size_}; }

  // Writing: a referring array first copies its elements into its own storage. (Named apart
  // from the reading accessors so that reading a non-const array never copies it.)
  T* mutable_data() { return Own(); }
  std::span<T> mutable_span() { return {Own(), size_}; }
  void resize(size_t size) {
    Change([&] { owned_.resize(size); });
  }
  void assign(size_t size, const T& value) {
    Change([&] { owned_.assign(size, value); });
  }
  template <typename Iterator>
  requires(!std::is_integral_v<Iterator>) void assign(Iterator first, Iterator last) {
    Change([&] { owned_.assign(first, last); });
  }
  void clear() {
    Change([&] { owned_.clear(); });
  }
  std::vector<T> ToVector() const { return {begin(), end()}; }

  friend bool operator==(const SharedArray& a, const SharedArray& b) {
    return a.size_ == b.size_ && std::equal(a.begin(), a.end(), b.begin());
  }

 private:
  T* Own() {
    if (referring_) {
      owned_.assign(data_, data_ + size_);
      referring_ = false;
      owner_.reset();
      data_ = owned_.data();
    }
    return owned_.data();
  }
  template <typename Operation>
  void Change(Operation&& operation) {
    if (referring_) {
      // Only the elements the operation keeps need copying; copy all for simplicity.
      Own();
    }
    operation();
    data_ = owned_.data();
    size_ = owned_.size();
  }

  std::vector<T> owned_;
  const T* data_ = nullptr;
  size_t size_ = 0;
  bool referring_ = false;
  std::shared_ptr<const void> owner_;
};

}  // namespace silpose
