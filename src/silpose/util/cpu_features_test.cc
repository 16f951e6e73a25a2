#include "silpose/util/cpu_features.h"

#include <gtest/gtest.h>

namespace silpose {
namespace {

TEST(CpuFeatures, Avx2RunsOnlyWhereTheProcessorHasItAndCanBeTurnedOff) {
  const bool had = Avx2Enabled();
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  const bool processor = __builtin_cpu_supports("avx2");
#else
  const bool processor = false;
#endif
  EXPECT_EQ(SetAvx2Enabled(true), processor);
  EXPECT_EQ(Avx2Enabled(), processor);
  EXPECT_FALSE(SetAvx2Enabled(false));
  EXPECT_FALSE(Avx2Enabled());
  SetAvx2Enabled(had);
  EXPECT_EQ(Avx2Enabled(), had);
}

}  // namespace
}  // namespace silpose
