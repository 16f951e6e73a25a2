#pragma once
// Vector instructions for the innermost loops. The correlation's conjugate products and
// band-limited evaluation, the proposal's ranking of views and the mask scans are each compiled
// twice, for the x86-64 baseline (SSE2) and for AVX2, and the AVX2 build runs where the processor
// has it. The two builds perform
// the same floating-point operations in the same order (no fused multiply-add), so they give the
// same results bit for bit; AVX2 only does more of them at once.

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/// Marks a function to be compiled for AVX2 (call it only when Avx2Enabled()).
#define SILPOSE_TARGET_AVX2 __attribute__((target("avx2")))
/// Makes a function's body part of each caller, whatever the caller's instruction set.
#define SILPOSE_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define SILPOSE_TARGET_AVX2
#define SILPOSE_ALWAYS_INLINE inline
#endif

namespace silpose {

/// Whether the AVX2 builds of the innermost loops run: the processor has AVX2 and they have not
/// been turned off (SetAvx2Enabled, or the environment variable SILPOSE_NO_AVX2 set to anything
/// but 0 when the process starts).
bool Avx2Enabled();

/// Turns the AVX2 builds on or off (on only where the processor has AVX2); returns whether they
/// now run. For comparing the two builds, as the tests do; results do not depend on it.
bool SetAvx2Enabled(bool enabled);

}  // namespace silpose
