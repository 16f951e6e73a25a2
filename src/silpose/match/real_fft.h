#pragma once
// A small interface over real-to-complex FFT libraries, so the correlation does not depend on one.
// Default: KissFFT (BSD-3). Opt-in: FFTW3 (GPL; CMake -DSILPOSE_WITH_FFTW=ON).

#include <complex>
#include <memory>
#include <string>
#include <vector>

namespace silpose {

enum class FftBackend : uint8_t {
  kDefault = 0,  ///< FFTW when built with it, else KissFFT
  kKissFft = 1,
  kFftw = 2,
};
const char* ToString(FftBackend backend);
/// Backends compiled into this build.
std::vector<FftBackend> AvailableFftBackends();

/// Unnormalised real FFT of one even length. Not thread-safe: use one object per thread.
class RealFft {
 public:
  virtual ~RealFft() = default;
  /// out[k] = sum_x in[x] exp(-2 pi i k x / n), k = 0..n/2 (n/2 + 1 values).
  virtual void Forward(const float* in, std::complex<float>* out) = 0;
  /// out[x] = sum_{k=0}^{n-1} X[k] exp(+2 pi i k x / n) with X Hermitian, given its first n/2 + 1
  /// values in `in` (not normalised by 1/n).
  virtual void Inverse(const std::complex<float>* in, float* out) = 0;
  int length() const { return length_; }

  /// Creates a transform for `length` (even, >= 2). Throws silpose::Error if the backend is not
  /// compiled in.
  static std::unique_ptr<RealFft> Create(int length, FftBackend backend = FftBackend::kDefault);

 protected:
  explicit RealFft(int length) : length_(length) {}

 private:
  int length_;
};

}  // namespace silpose
