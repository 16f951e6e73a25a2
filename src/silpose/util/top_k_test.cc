#include "silpose/util/top_k.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <functional>
#include <random>
#include <utility>
#include <vector>

namespace silpose {
namespace {

// The values a partial sort would put first, in its order.
std::vector<std::pair<float, int>> LargestBySorting(std::vector<std::pair<float, int>> values,
                                                    size_t k) {
  k = std::min(k, values.size());
  std::partial_sort(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end(),
                    std::greater<>());
  values.resize(k);
  return values;
}

TEST(KeepLargest, KeepsWhatAPartialSortPutsFirst) {
  std::mt19937 random(7);
  // Few distinct values: many ties, broken by the second member as in the callers' (score, view).
  std::uniform_int_distribution<int> level(0, 20);
  for (const size_t k : {size_t{1}, size_t{3}, size_t{8}, size_t{64}, size_t{2000}}) {
    std::vector<std::pair<float, int>> values;
    for (int i = 0; i < 1000; ++i)
      values.emplace_back(0.05f * static_cast<float>(level(random)), i);
    std::shuffle(values.begin(), values.end(), random);
    std::vector<std::pair<float, int>> best;
    for (const auto& value : values) {
      KeepLargest(&best, k, value);
      ASSERT_LE(best.size(), k);
      ASSERT_TRUE(std::is_sorted(best.begin(), best.end(), std::greater<>()));
    }
    EXPECT_EQ(best, LargestBySorting(values, k)) << "k = " << k;
  }
}

// Ordered by key alone: items of equal key compare equal however they arrived.
struct Item {
  int key;
  int arrival;
  bool operator>(const Item& other) const { return key > other.key; }
};

TEST(KeepLargest, EqualValuesKeepTheirOrderOfArrival) {
  std::vector<Item> best;
  int arrival = 0;
  for (const int key : {3, 1, 3, 2, 3, 5, 3}) KeepLargest(&best, 4, Item{key, arrival++});
  // 5 first; then the 3s that came first (the last one did not make the cut: not larger).
  ASSERT_EQ(best.size(), 4u);
  EXPECT_EQ(best[0].key, 5);
  for (size_t i = 1; i < 4; ++i) EXPECT_EQ(best[i].key, 3);
  EXPECT_EQ(best[1].arrival, 0);
  EXPECT_EQ(best[2].arrival, 2);
  EXPECT_EQ(best[3].arrival, 4);
}

TEST(KeepLargest, KeepsNothingForKZero) {
  std::vector<int> best;
  for (const int value : {4, 9, 1}) KeepLargest(&best, 0, value);
  EXPECT_TRUE(best.empty());
}

}  // namespace
}  // namespace silpose
