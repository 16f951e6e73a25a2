#include "silpose/util/cpu_features.h"

#include <atomic>
#include <cstdlib>
#include <cstring>

namespace silpose {
namespace {

bool ProcessorHasAvx2() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  __builtin_cpu_init();  // in case this runs before the compiler's own start-up code
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

bool TurnedOffByEnvironment() {
  const char* value = std::getenv("SILPOSE_NO_AVX2");
  return value != nullptr && *value != '\0' && std::strcmp(value, "0") != 0;
}

std::atomic<bool>& Enabled() {
  static std::atomic<bool> enabled{ProcessorHasAvx2() && !TurnedOffByEnvironment()};
  return enabled;
}

}  // namespace

bool Avx2Enabled() { return Enabled().load(std::memory_order_relaxed); }

bool SetAvx2Enabled(bool enabled) {
  const bool on = enabled && ProcessorHasAvx2();
  Enabled().store(on, std::memory_order_relaxed);
  return on;
}

}  // namespace silpose
