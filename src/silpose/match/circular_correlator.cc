#include "silpose/match/circular_correlator.h"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// e(s) = sum_k w_k Re(P_k exp(i omega k s)) (w_0 = 1, else 2) and its first two derivatives in s,
// for the band-limited products P_k = conj(Q_k) D_k.
struct BandLimitedValue {
  double value = 0.0;
  double slope = 0.0;
  double bend = 0.0;
};

// The phases exp(i omega k s) advance in kLanes independent chains (k = j, j + kLanes, ...), each
// rotated by exp(i omega kLanes s) per step: the same sums as one chain over k, without its
// multiplication-latency bound (this is the filter's innermost loop). Eight lanes fill two AVX2
// registers, or four SSE2 ones; each lane sums in the same order in either build.
SILPOSE_ALWAYS_INLINE BandLimitedValue
EvaluateBandLimitedBody(std::span<const std::complex<float>> products, double omega, double shift) {
  constexpr size_t kLanes = 8;
  // Lane j starts at exp(i j angle) and steps by exp(i kLanes angle): powers of one rotation.
  const double angle = omega * shift;
  const double rotation_re = std::cos(angle);
  const double rotation_im = std::sin(angle);
  std::array<double, kLanes> phase_re{};
  std::array<double, kLanes> phase_im{};
  phase_re[0] = 1.0;
  for (size_t j = 1; j < kLanes; ++j) {
    phase_re[j] = phase_re[j - 1] * rotation_re - phase_im[j - 1] * rotation_im;
    phase_im[j] = phase_re[j - 1] * rotation_im + phase_im[j - 1] * rotation_re;
  }
  const double step_re = phase_re[kLanes - 1] * rotation_re - phase_im[kLanes - 1] * rotation_im;
  const double step_im = phase_re[kLanes - 1] * rotation_im + phase_im[kLanes - 1] * rotation_re;
  // Per lane: sum of Re(term), k Im(term), k^2 Re(term), every k weighted 2 (k = 0 fixed below).
  std::array<double, kLanes> value{};
  std::array<double, kLanes> slope{};
  std::array<double, kLanes> bend{};
  const size_t size = products.size();
  // Whole blocks of kLanes harmonics without a bounds test (the compiler keeps the lanes in
  // vector registers), then the remainder; each lane sums in the same order either way.
  const size_t whole = size - size % kLanes;
  std::array<double, kLanes> kd{};
  for (size_t j = 0; j < kLanes; ++j) kd[j] = static_cast<double>(j);
  // Harmonic k = kd[j] on lane j.
  const auto add = [&](size_t j, const std::complex<float>& product) {
    const double a = product.real();
    const double b = product.imag();
    const double re = a * phase_re[j] - b * phase_im[j];
    const double im = a * phase_im[j] + b * phase_re[j];
    value[j] += re;
    slope[j] += kd[j] * im;
    bend[j] += kd[j] * kd[j] * re;
  };
  for (size_t base = 0; base < whole; base += kLanes) {
    for (size_t j = 0; j < kLanes; ++j) {
      add(j, products[base + j]);
      const double next_re = phase_re[j] * step_re - phase_im[j] * step_im;
      phase_im[j] = phase_re[j] * step_im + phase_im[j] * step_re;
      phase_re[j] = next_re;
      kd[j] += static_cast<double>(kLanes);
    }
  }
  for (size_t j = 0; whole + j < size; ++j) add(j, products[whole + j]);
  BandLimitedValue out;
  double value_sum = 0.0;
  double slope_sum = 0.0;
  double bend_sum = 0.0;
  for (size_t j = 0; j < kLanes; ++j) {
    value_sum += value[j];
    slope_sum += slope[j];
    bend_sum += bend[j];
  }
  // Weights: 2 for every k but k = 0 (1), whose term is the real product P_0.
  const double first = size > 0 ? static_cast<double>(products[0].real()) : 0.0;
  out.value = 2.0 * value_sum - first;
  out.slope = -2.0 * omega * slope_sum;
  out.bend = -2.0 * omega * omega * bend_sum;
  return out;
}

BandLimitedValue EvaluateBandLimitedBaseline(std::span<const std::complex<float>> products,
                                             double omega, double shift) {
  return EvaluateBandLimitedBody(products, omega, shift);
}

SILPOSE_TARGET_AVX2 BandLimitedValue
EvaluateBandLimitedAvx2(std::span<const std::complex<float>> products, double omega, double shift) {
  return EvaluateBandLimitedBody(products, omega, shift);
}

// products[k] = conj(q[k]) d[k] for k < n, written out: std::complex's product checks every
// result for NaN and does not vectorise.
SILPOSE_ALWAYS_INLINE void ConjugateProductsBody(const std::complex<float>* q,
                                                 const std::complex<float>* d, size_t n,
                                                 std::complex<float>* products) {
  for (size_t k = 0; k < n; ++k) {
    const float qr = q[k].real();
    const float qi = q[k].imag();
    const float dr = d[k].real();
    const float di = d[k].imag();
    products[k] = {qr * dr + qi * di, qr * di - qi * dr};
  }
}

void ConjugateProductsBaseline(const std::complex<float>* q, const std::complex<float>* d, size_t n,
                               std::complex<float>* products) {
  ConjugateProductsBody(q, d, n, products);
}

SILPOSE_TARGET_AVX2 void ConjugateProductsAvx2(const std::complex<float>* q,
                                               const std::complex<float>* d, size_t n,
                                               std::complex<float>* products) {
  ConjugateProductsBody(q, d, n, products);
}

void ConjugateProducts(const std::complex<float>* q, const std::complex<float>* d, size_t n,
                       std::complex<float>* products) {
  if (Avx2Enabled()) {
    ConjugateProductsAvx2(q, d, n, products);
  } else {
    ConjugateProductsBaseline(q, d, n, products);
  }
}

BandLimitedValue EvaluateBandLimited(std::span<const std::complex<float>> products, double omega,
                                     double shift) {
  return Avx2Enabled() ? EvaluateBandLimitedAvx2(products, omega, shift)
                       : EvaluateBandLimitedBaseline(products, omega, shift);
}

}  // namespace

double CorrelationPeak::RollDeg(int length) const {
  double roll = 360.0 * static_cast<double>(shift_bins) / static_cast<double>(length);
  if (roll > 180.0) roll -= 360.0;
  return roll;
}

bool CorrelationOptions::Check(std::string* error) const {
  if (!(smoothing_deg >= 0.0) || !std::isfinite(smoothing_deg) || smoothing_deg > 90.0) {
    if (error != nullptr) {
      *error =
          "signature smoothing must be in [0, 90] degrees, got " + std::to_string(smoothing_deg);
    }
    return false;
  }
  return true;
}

CircularCorrelator::CircularCorrelator(int length, const CorrelationOptions& options)
    : length_(length),
      options_(options),
      fft_(RealFft::Create(length, options.backend)),
      window_(static_cast<size_t>(length / 2 + 1), 1.0f),
      real_scratch_(static_cast<size_t>(length)),
      complex_scratch_(static_cast<size_t>(length / 2 + 1)) {
  std::string error;
  if (!options.Check(&error)) ThrowError("invalid correlation options: ", error);
  // Gaussian of standard deviation s (radians) over angle = Gaussian exp(-(k s)^2 / 2) over the
  // harmonic number k.
  const double sigma_rad = options.smoothing_deg * std::numbers::pi / 180.0;
  for (size_t k = 0; k < window_.size(); ++k) {
    const double ks = static_cast<double>(k) * sigma_rad;
    // Exactly 0 where negligible: tiny weights would make denormal floats, which are very slow.
    const double weight = std::exp(-0.5 * ks * ks);
    window_[k] = weight < 1e-6 ? 0.0f : static_cast<float>(weight);
    if (window_[k] > 0.0f) bound_length_ = k + 1;
  }
  // Smoothed signatures are band-limited to bound_length_ harmonics, and so is their correlation:
  // L >= 2 * bound_length_ samples of it carry all of it. The peak is then searched on those and
  // refined on the exact band-limited correlation (Peak), which is much cheaper than M samples.
  int coarse = 2 * static_cast<int>(bound_length_) + 2;
  auto smooth_number = [](int n) {  // only factors 2, 3, 5: fast for every FFT backend
    for (int f : {2, 3, 5}) {
      while (n % f == 0) n /= f;
    }
    return n == 1;
  };
  while (coarse % 2 != 0 || !smooth_number(coarse)) ++coarse;
  if (coarse < length_ / 2) {
    coarse_fft_ = RealFft::Create(coarse, options.backend);
    coarse_products_.assign(static_cast<size_t>(coarse / 2 + 1), {0.0f, 0.0f});
    coarse_samples_.resize(static_cast<size_t>(coarse));
  }
}

void CircularCorrelator::Transform(std::span<const float> radii, SignatureSpectrum* spectrum,
                                   bool weighted) {
  if (static_cast<int>(radii.size()) != length_) {
    ThrowError("signature has ", radii.size(), " values, the correlator expects ", length_);
  }
  double mean = 0.0;
  for (float r : radii) mean += r;
  mean /= length_;
  double sum_squares = 0.0;
  for (float r : radii) sum_squares += (r - mean) * (r - mean);
  const size_t half = static_cast<size_t>(length_ / 2 + 1);
  spectrum->coefficients.assign(half, {0.0f, 0.0f});
  // Every spectrum of this correlator has bound_length_ magnitudes, flat ones included (all 0).
  spectrum->magnitudes.assign(bound_length_, 0.0f);
  // A signature whose variance is at float rounding level has no shape to correlate.
  spectrum->has_variance = sum_squares > 1e-10 * (mean * mean + 1e-30) * length_;
  spectrum->amplitude = 0.0f;
  if (!spectrum->has_variance) return;
  // Unit norm and the 1/sqrt(M) of the inverse transform, folded into one scale.
  const double scale = 1.0 / std::sqrt(sum_squares * length_);
  // The inverse of the scale below (and of the renormalisation after smoothing), with the 1/M of
  // the inverse transform: C = scale * renormalise * window * DFT(r - m).
  double amplitude = 1.0 / (scale * length_);
  for (size_t x = 0; x < radii.size(); ++x) {
    real_scratch_[x] = static_cast<float>((radii[x] - mean) * scale);
  }
  const std::span<std::complex<float>> coefficients = spectrum->coefficients.mutable_span();
  fft_->Forward(real_scratch_.data(), coefficients.data());
  coefficients[0] = {0.0f, 0.0f};  // exactly zero mean
  if (options_.smoothing_deg > 0.0) {
    // Smoothing changes the norm: restore unit norm through Parseval (e(0) of the signature with
    // itself is the weighted sum of its squared coefficients).
    double energy = 0.0;
    for (size_t k = 1; k < half; ++k) {
      coefficients[k] *= window_[k];
      energy += ((k == half - 1) ? 1.0 : 2.0) * std::norm(coefficients[k]);
    }
    if (!(energy > 1e-20)) {
      spectrum->has_variance = false;
      std::fill(coefficients.begin(), coefficients.end(), std::complex<float>(0.0f, 0.0f));
      return;
    }
    const auto renormalise = static_cast<float>(1.0 / std::sqrt(energy));
    for (auto& c : coefficients) c *= renormalise;
    amplitude /= static_cast<double>(renormalise);
  }
  spectrum->amplitude = static_cast<float>(amplitude);
  // Harmonics the smoothing removed contribute nothing to the bound: they are left out of it.
  float* magnitudes = spectrum->magnitudes.mutable_data();
  for (size_t k = 0; k < bound_length_; ++k) {
    const float weight = (!weighted || k == 0 || k == half - 1) ? 1.0f : 2.0f;
    magnitudes[k] = weight * std::abs(coefficients[k]);
  }
}

SignatureSpectrum CircularCorrelator::Transform(std::span<const float> radii, bool weighted) {
  SignatureSpectrum spectrum;
  Transform(radii, &spectrum, weighted);
  return spectrum;
}

void CircularCorrelator::Correlate(const SignatureSpectrum& query,
                                   const SignatureSpectrum& reference, std::span<float> out) {
  SILPOSE_ASSERT(static_cast<int>(out.size()) == length_);
  SILPOSE_ASSERT(HasHarmonics(query) && HasHarmonics(reference));
  // Coefficients a spectrum leaves out are 0, and so are their products.
  const size_t kept = std::min(query.coefficients.size(), reference.coefficients.size());
  ConjugateProducts(query.coefficients.data(), reference.coefficients.data(), kept,
                    complex_scratch_.data());
  std::fill(complex_scratch_.begin() + static_cast<std::ptrdiff_t>(kept), complex_scratch_.end(),
            std::complex<float>(0.0f, 0.0f));
  fft_->Inverse(complex_scratch_.data(), out.data());
}

CorrelationPeak CircularCorrelator::Peak(const SignatureSpectrum& query,
                                         const SignatureSpectrum& reference) {
  return coarse_fft_ ? BandLimitedPeak(query, reference) : FullPeak(query, reference);
}

CorrelationPeak CircularCorrelator::FullPeak(const SignatureSpectrum& query,
                                             const SignatureSpectrum& reference) {
  Correlate(query, reference, real_scratch_);
  const float* e = real_scratch_.data();
  int best = 0;
  for (int n = 1; n < length_; ++n) {
    if (e[n] > e[best]) best = n;
  }
  const float before = e[(best + length_ - 1) % length_];
  const float after = e[(best + 1) % length_];
  const float peak = e[best];
  const float curvature = before - 2.0f * peak + after;
  float offset = 0.0f;
  if (curvature < 0.0f) offset = std::clamp(0.5f * (before - after) / curvature, -0.5f, 0.5f);
  float shift = static_cast<float>(best) + offset;
  if (shift < 0.0f) shift += static_cast<float>(length_);
  if (shift >= static_cast<float>(length_)) shift -= static_cast<float>(length_);
  return {std::min(peak, 1.0f), shift};
}

void CircularCorrelator::CoarseCorrelate(const SignatureSpectrum& query,
                                         const SignatureSpectrum& reference) {
  const size_t harmonics = bound_length_;
  SILPOSE_ASSERT(HasHarmonics(query) && HasHarmonics(reference));
  ConjugateProducts(query.coefficients.data(), reference.coefficients.data(), harmonics,
                    coarse_products_.data());
  // The correlation at L evenly spaced shifts (s = j M / L), all of it for a band-limited signal.
  coarse_fft_->Inverse(coarse_products_.data(), coarse_samples_.data());
}

CorrelationPeak CircularCorrelator::BandLimitedPeak(const SignatureSpectrum& query,
                                                    const SignatureSpectrum& reference) {
  CoarseCorrelate(query, reference);
  const int coarse = coarse_fft_->length();
  int best = 0;
  for (int j = 1; j < coarse; ++j) {
    if (coarse_samples_[static_cast<size_t>(j)] > coarse_samples_[static_cast<size_t>(best)]) {
      best = j;
    }
  }
  const double before = coarse_samples_[static_cast<size_t>((best + coarse - 1) % coarse)];
  const double after = coarse_samples_[static_cast<size_t>((best + 1) % coarse)];
  const double peak = coarse_samples_[static_cast<size_t>(best)];
  const double curvature = before - 2.0 * peak + after;
  double offset = 0.0;
  if (curvature < 0.0) offset = std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5);
  const double step = static_cast<double>(length_) / coarse;  // bins per coarse sample
  double shift = (best + offset) * step;
  // A Newton step on e(s) = sum_k w_k Re(P_k exp(i w k s)), w = 2 pi / M, with its exact
  // derivatives.
  const double omega = 2.0 * std::numbers::pi / length_;
  const std::span<const std::complex<float>> products(coarse_products_.data(), bound_length_);
  double score = peak;
  for (int iteration = 0; iteration < 2; ++iteration) {
    const BandLimitedValue e = EvaluateBandLimited(products, omega, shift);
    score = e.value;
    if (iteration == 1 || !(e.bend < 0.0)) break;
    shift -= std::clamp(e.slope / e.bend, -step, step);
  }
  if (score < peak) {  // the step went downhill (two lobes close together): keep the sample
    score = peak;
    shift = best * step;
  }
  shift = std::fmod(shift, static_cast<double>(length_));
  if (shift < 0.0) shift += length_;
  auto shift_bins = static_cast<float>(shift);
  if (shift_bins >= static_cast<float>(length_)) shift_bins = 0.0f;  // -tiny rounds up to M
  return {static_cast<float>(std::min(score, 1.0)), shift_bins};
}

void CircularCorrelator::LocalPeaks(const SignatureSpectrum& query,
                                    const SignatureSpectrum& reference,
                                    std::span<const double> start_shifts_bins,
                                    double max_offset_bins, std::span<CorrelationPeak> peaks) {
  SILPOSE_ASSERT(peaks.size() == start_shifts_bins.size());
  SILPOSE_ASSERT(max_offset_bins >= 0.0 && std::isfinite(max_offset_bins));
  if (start_shifts_bins.empty()) return;
  const auto length = static_cast<double>(length_);
  const bool band_limited = coarse_fft_ != nullptr;
  const size_t harmonics = bound_length_;
  // e on a regular grid, once for all starts.
  const float* samples = nullptr;
  int64_t count = 0;
  if (band_limited) {
    CoarseCorrelate(query, reference);
    samples = coarse_samples_.data();
    count = coarse_fft_->length();
  } else {
    Correlate(query, reference, real_scratch_);
    samples = real_scratch_.data();
    count = length_;
  }
  const double step = length / static_cast<double>(count);  // bins per grid sample
  auto wrap_index = [count](int64_t j) { return ((j % count) + count) % count; };
  auto sample = [&](int64_t j) { return static_cast<double>(samples[wrap_index(j)]); };
  auto wrap_shift = [length](double shift) {
    double wrapped = std::fmod(shift, length);
    if (wrapped < 0.0) wrapped += length;
    return wrapped >= length ? 0.0 : wrapped;
  };
  const std::span<const std::complex<float>> products(coarse_products_.data(), harmonics);
  const double omega = 2.0 * std::numbers::pi / length;

  // Refined interior maxima found so far, by wrapped grid index, shared by later starts. A small
  // fixed table: the starts on one view seldom reach more than a couple of maxima.
  struct Refined {
    int64_t grid_index;
    double shift;  // in [0, M)
    double score;
  };
  std::array<Refined, 8> refined{};
  size_t num_refined = 0;

  for (size_t i = 0; i < start_shifts_bins.size(); ++i) {
    SILPOSE_ASSERT(std::isfinite(start_shifts_bins[i]));
    const double start = wrap_shift(start_shifts_bins[i]);
    const double lo = start - max_offset_bins;
    const double hi = start + max_offset_bins;
    const auto first = static_cast<int64_t>(std::ceil(lo / step));
    const auto last = static_cast<int64_t>(std::floor(hi / step));
    // The climb starts at the higher of the two grid samples around the start: e rises from the
    // start towards it (or peaks between them).
    const auto below = static_cast<int64_t>(std::floor(start / step));
    int64_t grid = sample(below + 1) > sample(below) ? below + 1 : below;
    double shift = start;  // where the refinement starts
    double score = sample(grid);
    bool grid_maximum = false;  // the climb ended on a grid maximum inside the window
    if (grid < first || grid > last) {
      // Uphill lies outside the window (or no grid sample is inside): refine from the edge.
      shift = grid < first ? lo : hi;
      grid = std::clamp(static_cast<int64_t>(std::llround(shift / step)), first,
                        std::max(first, last));
      score = sample(grid);
    } else {
      for (;;) {  // climb the grid uphill, within the window
        const double here = sample(grid);
        const double left = grid > first ? sample(grid - 1) : -2.0;
        const double right = grid < last ? sample(grid + 1) : -2.0;
        if (right > here && right >= left) {
          ++grid;
        } else if (left > here) {
          --grid;
        } else {
          break;
        }
      }
      const double before = sample(grid - 1);
      const double after = sample(grid + 1);
      const double peak = sample(grid);
      score = peak;
      if (peak >= before && peak >= after) {
        grid_maximum = true;
        // Parabola through the grid maximum and its neighbours.
        const double curvature = before - 2.0 * peak + after;
        double offset = 0.0;
        if (curvature < 0.0) offset = std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5);
        shift = (static_cast<double>(grid) + offset) * step;
      } else {
        // The climb stopped at the window's edge: e rises beyond it.
        shift = after > peak ? hi : lo;
      }
      shift = std::clamp(shift, lo, hi);
    }
    bool interior = false;  // converged on a local maximum strictly inside the window
    bool reused = false;
    if (grid_maximum) {
      for (size_t r = 0; r < num_refined; ++r) {
        if (refined[r].grid_index != wrap_index(grid)) continue;
        double offset = std::fmod(refined[r].shift - start, length);
        if (offset < -0.5 * length) offset += length;
        if (offset >= 0.5 * length) offset -= length;
        if (std::abs(offset) <= max_offset_bins) {
          shift = refined[r].shift;
          score = refined[r].score;
          reused = true;
        }
        break;
      }
    }
    if (!reused && band_limited) {
      // Safeguarded Newton ascent on the exact band-limited e, inside the window: Newton steps
      // where e is concave, half-grid steps uphill where it is not, halving back on overshoot.
      constexpr int kMaxEvaluations = 6;
      double best_shift = shift;
      double best_score = -std::numeric_limits<double>::infinity();
      for (int evaluation = 0; evaluation < kMaxEvaluations; ++evaluation) {
        const BandLimitedValue e = EvaluateBandLimited(products, omega, shift);
        if (e.value < best_score) {
          shift = 0.5 * (shift + best_shift);
          continue;
        }
        best_shift = shift;
        best_score = e.value;
        double move = 0.0;
        if (e.bend < 0.0) {
          move = std::clamp(-e.slope / e.bend, -step, step);
        } else if (e.slope != 0.0) {
          move = e.slope > 0.0 ? 0.5 * step : -0.5 * step;
        }
        const double next = std::clamp(shift + move, lo, hi);
        // Converged: 0.01 bin from the maximum, e is below its peak by ~1e-9.
        if (std::abs(next - shift) < 1e-2) {
          interior = e.bend < 0.0 && next > lo && next < hi;
          break;
        }
        shift = next;
      }
      shift = best_shift;
      score = best_score;
    } else if (!reused) {
      interior = grid_maximum && shift > lo && shift < hi;
    }
    shift = wrap_shift(shift);
    if (interior && grid_maximum && num_refined < refined.size()) {
      refined[num_refined++] = {wrap_index(grid), shift, score};
    }
    auto shift_bins = static_cast<float>(shift);
    if (shift_bins >= static_cast<float>(length_)) shift_bins = 0.0f;  // rounding up to M
    peaks[i] = {static_cast<float>(std::min(score, 1.0)), shift_bins};
  }
}

float CircularCorrelator::ScoreAtShift(const SignatureSpectrum& query,
                                       const SignatureSpectrum& reference,
                                       double shift_bins) const {
  // e(s) = sum_k w_k Re(conj(Q_k) D_k exp(2 pi i k s / M)) for real s (band-limited interpolation).
  SILPOSE_ASSERT(HasHarmonics(query) && HasHarmonics(reference));
  const size_t half = static_cast<size_t>(length_ / 2 + 1);
  // Coefficients a spectrum leaves out are 0: their terms add nothing.
  const size_t kept = std::min(query.coefficients.size(), reference.coefficients.size());
  const double step = 2.0 * std::numbers::pi * shift_bins / length_;
  double sum = 0.0;
  for (size_t k = 0; k < kept; ++k) {
    const double weight = (k == 0 || k == half - 1) ? 1.0 : 2.0;
    const std::complex<double> product = std::conj(std::complex<double>(query.coefficients[k])) *
                                         std::complex<double>(reference.coefficients[k]);
    const std::complex<double> phase = std::polar(1.0, step * static_cast<double>(k));
    sum += weight * (product * phase).real();
  }
  return static_cast<float>(sum);
}

std::vector<double> CircularCorrelator::CorrelateDirect(std::span<const float> query,
                                                        std::span<const float> reference) {
  SILPOSE_ASSERT(query.size() == reference.size() && !query.empty());
  const size_t m = query.size();
  auto normalise = [m](std::span<const float> values) {
    double mean = 0.0;
    for (float v : values) mean += v;
    mean /= static_cast<double>(m);
    std::vector<double> out(m);
    double norm = 0.0;
    for (size_t i = 0; i < m; ++i) {
      out[i] = values[i] - mean;
      norm += out[i] * out[i];
    }
    norm = std::sqrt(norm);
    for (double& v : out) v = norm > 0.0 ? v / norm : 0.0;
    return out;
  };
  const std::vector<double> q = normalise(query);
  const std::vector<double> d = normalise(reference);
  std::vector<double> e(m, 0.0);
  for (size_t n = 0; n < m; ++n) {
    double sum = 0.0;
    for (size_t x = 0; x < m; ++x) sum += q[x] * d[(x + n) % m];
    e[n] = sum;
  }
  return e;
}

float CorrelationUpperBound(std::span<const float> weighted_magnitudes,
                            std::span<const float> magnitudes) {
  SILPOSE_ASSERT(weighted_magnitudes.size() == magnitudes.size());
  const auto size = static_cast<Eigen::Index>(magnitudes.size());
  return Eigen::Map<const Eigen::VectorXf>(weighted_magnitudes.data(), size)
      .dot(Eigen::Map<const Eigen::VectorXf>(magnitudes.data(), size));
}

float TailEnergyRoot(std::span<const float> magnitudes, size_t harmonics, size_t num_coefficients) {
  SILPOSE_ASSERT(harmonics <= magnitudes.size());
  double energy = 0.0;
  for (size_t k = 0; k < harmonics; ++k) {
    const double weight = k == 0 || k + 1 == num_coefficients ? 1.0 : 2.0;
    energy += weight * static_cast<double>(magnitudes[k]) * static_cast<double>(magnitudes[k]);
  }
  return static_cast<float>(std::sqrt(std::max(0.0, 1.0 - energy)));
}

}  // namespace silpose
