#pragma once
// Random numbers for the synthetic generator (internal to the synth layer).
//
// Engines are std::mt19937_64, whose output the C++ standard fixes. The standard distributions
// (std::normal_distribution, ...) are not fixed and differ between standard libraries, so the
// uniform and normal variates are computed here: a sequence generated with a given seed is the
// same with any compiler (up to the last bits of std::log/std::cos).

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace silpose::synth_internal {

/// SplitMix64 finaliser: a bijective mix of 64 bits, used to derive independent seeds.
inline uint64_t Mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Seed of the random stream `stream` of frame `frame` for the user's `seed`. Streams keep the
/// draws of one purpose (e.g. which frames are missed) independent of the options of another.
inline uint64_t FrameSeed(uint64_t seed, uint64_t frame, uint64_t stream) {
  return Mix64(seed ^ Mix64(frame ^ Mix64(stream)));
}

/// Uniform in [0, 1), 53 random bits.
inline double Uniform01(std::mt19937_64& engine) {
  return static_cast<double>(engine() >> 11) * 0x1.0p-53;
}

/// Uniform in [low, high).
inline double Uniform(std::mt19937_64& engine, double low, double high) {
  return low + (high - low) * Uniform01(engine);
}

/// Standard normal variate (Box-Muller, one of the pair).
inline double StandardNormal(std::mt19937_64& engine) {
  const double u1 = 1.0 - Uniform01(engine);  // (0, 1]: the log is finite
  const double u2 = Uniform01(engine);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

}  // namespace silpose::synth_internal
