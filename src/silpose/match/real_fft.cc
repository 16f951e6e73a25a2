#include "silpose/match/real_fft.h"

#include <kiss_fftr.h>

#include <cstring>

#include "silpose/util/error.h"

#ifdef SILPOSE_WITH_FFTW
#include <fftw3.h>

#include <mutex>
#endif

namespace silpose {
namespace {

static_assert(sizeof(kiss_fft_cpx) == sizeof(std::complex<float>));

class KissRealFft final : public RealFft {
 public:
  explicit KissRealFft(int length)
      : RealFft(length),
        forward_(kiss_fftr_alloc(length, 0, nullptr, nullptr)),
        inverse_(kiss_fftr_alloc(length, 1, nullptr, nullptr)) {
    if (forward_ == nullptr || inverse_ == nullptr)
      ThrowError("KissFFT cannot plan length ", length);
  }
  ~KissRealFft() override {
    kiss_fftr_free(forward_);
    kiss_fftr_free(inverse_);
  }
  KissRealFft(const KissRealFft&) = delete;
  KissRealFft& operator=(const KissRealFft&) = delete;

  void Forward(const float* in, std::complex<float>* out) override {
    kiss_fftr(forward_, in, reinterpret_cast<kiss_fft_cpx*>(out));
  }
  void Inverse(const std::complex<float>* in, float* out) override {
    kiss_fftri(inverse_, reinterpret_cast<const kiss_fft_cpx*>(in), out);
  }

 private:
  kiss_fftr_cfg forward_;
  kiss_fftr_cfg inverse_;
};

#ifdef SILPOSE_WITH_FFTW
// FFTW's planner is not thread-safe; execution with new-array functions is.
std::mutex& FftwPlannerMutex() {
  static std::mutex mutex;
  return mutex;
}

class FftwRealFft final : public RealFft {
 public:
  explicit FftwRealFft(int length) : RealFft(length) {
    real_ = fftwf_alloc_real(static_cast<size_t>(length));
    complex_ = fftwf_alloc_complex(static_cast<size_t>(length / 2 + 1));
    std::lock_guard lock(FftwPlannerMutex());
    forward_ = fftwf_plan_dft_r2c_1d(length, real_, complex_, FFTW_MEASURE);
    inverse_ = fftwf_plan_dft_c2r_1d(length, complex_, real_, FFTW_MEASURE);
    if (forward_ == nullptr || inverse_ == nullptr) ThrowError("FFTW cannot plan length ", length);
  }
  ~FftwRealFft() override {
    std::lock_guard lock(FftwPlannerMutex());
    fftwf_destroy_plan(forward_);
    fftwf_destroy_plan(inverse_);
    fftwf_free(real_);
    fftwf_free(complex_);
  }
  FftwRealFft(const FftwRealFft&) = delete;
  FftwRealFft& operator=(const FftwRealFft&) = delete;

  void Forward(const float* in, std::complex<float>* out) override {
    std::memcpy(real_, in, sizeof(float) * static_cast<size_t>(length()));
    fftwf_execute(forward_);
    std::memcpy(out, complex_, sizeof(fftwf_complex) * static_cast<size_t>(length() / 2 + 1));
  }
  void Inverse(const std::complex<float>* in, float* out) override {
    // c2r destroys its input, so it works on the plan's own buffer.
    std::memcpy(complex_, in, sizeof(fftwf_complex) * static_cast<size_t>(length() / 2 + 1));
    fftwf_execute(inverse_);
    std::memcpy(out, real_, sizeof(float) * static_cast<size_t>(length()));
  }

 private:
  float* real_ = nullptr;
  fftwf_complex* complex_ = nullptr;
  fftwf_plan forward_ = nullptr;
  fftwf_plan inverse_ = nullptr;
};
#endif

}  // namespace

const char* ToString(FftBackend backend) {
  switch (backend) {
    case FftBackend::kDefault:
      return "default";
    case FftBackend::kKissFft:
      return "kissfft";
    case FftBackend::kFftw:
      return "fftw";
  }
  return "unknown";
}

std::vector<FftBackend> AvailableFftBackends() {
#ifdef SILPOSE_WITH_FFTW
  return {FftBackend::kKissFft, FftBackend::kFftw};
#else
  return {FftBackend::kKissFft};
#endif
}

std::unique_ptr<RealFft> RealFft::Create(int length, FftBackend backend) {
  if (length < 2 || length % 2 != 0) ThrowError("FFT length must be even and >= 2, got ", length);
#ifdef SILPOSE_WITH_FFTW
  if (backend == FftBackend::kDefault || backend == FftBackend::kFftw) {
    return std::make_unique<FftwRealFft>(length);
  }
#else
  if (backend == FftBackend::kFftw) {
    ThrowError("this build of silpose has no FFTW backend (configure with -DSILPOSE_WITH_FFTW=ON)");
  }
#endif
  return std::make_unique<KissRealFft>(length);
}

}  // namespace silpose
