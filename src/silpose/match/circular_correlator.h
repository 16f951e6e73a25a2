#pragma once
// Circular normalised cross-correlation of polar signatures (paper 4.2, equation 3), through FFTs.
//
// Each signature is made zero-mean and unit-norm, so for a query q and a reference d
//   e(n) = sum_x q(x) d(x + n),  n = 0..M-1,
// is Pearson's correlation coefficient of q with d shifted by n bins, in [-1, 1]. The similarity is
// max_n e(n) and the roll is its argmax: a query seen at roll r equals the reference shifted by
// r M / 360 bins (geometry/view_frame.h), so roll_deg = 360 * argmax / M. The argmax is refined
// below one bin by a parabola through the peak and its two neighbours.
//
// Smoothing (an addition to the paper): each signature can be smoothed over angle by a Gaussian
// before it is normalised (CorrelationOptions::smoothing_deg, default 2 deg), a free weighting of
// its spectrum.
// Detail finer than a pixel and rasterisation noise otherwise pull the correlation peak: with it
// the roll of database views matched at other image sizes is right to within 2 bins far more often
// (docs/PERFORMANCE.md). 0 gives the paper's plain normalised cross-correlation.
//
// In the frequency domain e = IDFT(conj(Q) D) / M. A cheap upper bound of max_n e(n), used to
// prune the database search exactly, is sum_k |Q_k| |D_k| / M (triangle inequality).

#include <complex>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "silpose/match/real_fft.h"
#include "silpose/util/shared_array.h"

namespace silpose {

struct CorrelationOptions {
  /// Standard deviation of the Gaussian smoothing of each signature over angle, degrees (>= 0).
  double smoothing_deg = 2.0;
  FftBackend backend = FftBackend::kDefault;

  bool Check(std::string* error = nullptr) const;
};

/// The spectrum of a normalised signature, ready to correlate. Built by CircularCorrelator.
struct SignatureSpectrum {
  /// M/2 + 1 coefficients of the zero-mean, smoothed, unit-norm signature, scaled by 1/sqrt(M).
  /// Smoothing makes the ones from CircularCorrelator::harmonics() on exactly 0: a spectrum may
  /// keep only the first harmonics() (ViewSpectra stores them so) and correlates the same.
  /// A database view's spectrum may refer to the mapped database file (util/shared_array.h).
  SharedArray<std::complex<float>> coefficients;
  /// |coefficients[k]| for the harmonics the smoothing keeps, weighted by how often bin k occurs
  /// in the full spectrum (1 for k = 0 and k = M/2, 2 otherwise) when `weighted` was asked for; the
  /// dot product of a weighted and an unweighted magnitude vector is the upper bound above.
  SharedArray<float> magnitudes;
  /// False if the signature was constant (no variance): every correlation with it is 0.
  bool has_variance = false;
  /// What turns the coefficients back into the smoothed signature r_s (of the radii given to
  /// CircularCorrelator::Transform, whose mean is m): r_s(x) = m + amplitude * sum_k C_k
  /// exp(2 pi i k x / M), summed over the full Hermitian spectrum. 0 without variance.
  float amplitude = 0.0f;
};

struct CorrelationPeak {
  /// max_n e(n), in [-1, 1].
  float score = 0.0f;
  /// argmax_n e(n), refined below one bin, in [0, M).
  float shift_bins = 0.0f;
  /// The roll the shift means, in degrees, in (-180, 180].
  double RollDeg(int length) const;
};

/// Correlates signatures of one length M. Not thread-safe (scratch buffers): one per thread.
class CircularCorrelator {
 public:
  explicit CircularCorrelator(int length, const CorrelationOptions& options = {});

  int length() const { return length_; }
  const CorrelationOptions& options() const { return options_; }
  /// Harmonics the smoothing keeps (M/2 + 1 without smoothing): coefficients from this one on are
  /// exactly 0, and every spectrum has this many magnitudes. Spectra whose coefficients are cut to
  /// any length from harmonics() to M/2 + 1 give the same correlations.
  size_t harmonics() const { return bound_length_; }

  /// Normalises `radii` (M values) and transforms it. `weighted`: see SignatureSpectrum.
  void Transform(std::span<const float> radii, SignatureSpectrum* spectrum, bool weighted = false);
  SignatureSpectrum Transform(std::span<const float> radii, bool weighted = false);

  /// The whole correlation e(n), n = 0..M-1, into `out` (M values).
  void Correlate(const SignatureSpectrum& query, const SignatureSpectrum& reference,
                 std::span<float> out);
  /// max and argmax of e. With smoothing the correlation is band-limited and its maximum is found
  /// over continuous shifts (a short inverse FFT, then Newton steps on the exact band-limited e);
  /// without, over the M integer shifts with a parabola through the peak.
  CorrelationPeak Peak(const SignatureSpectrum& query, const SignatureSpectrum& reference);

  /// Local maxima of e near given shifts (the particle filter's roll tracking, filter/): for each
  /// start shift s (bins, any real value), the local maximum reached by climbing e uphill from s,
  /// searched within [s - max_offset_bins, s + max_offset_bins]. If e still rises at the edge of
  /// that window the result is the best point on the edge side, so a roll never jumps further than
  /// max_offset_bins (a symmetric shape's other, possibly higher, peak is not taken).
  /// peaks[i].shift_bins is in [0, M), peaks[i].score is e there.
  /// Cost: one correlation on a grid (with smoothing the short band-limited inverse FFT of Peak,
  /// every M / L bins; without, every bin), shared by all starts, then per distinct local maximum
  /// reached the refinement Peak does (Newton steps on the exact band-limited e with smoothing, a
  /// parabola through the grid peak without; there the score is the grid sample's). Starts that
  /// climb to the same grid maximum share its refinement, so several particles on one view cost
  /// little more than one.
  void LocalPeaks(const SignatureSpectrum& query, const SignatureSpectrum& reference,
                  std::span<const double> start_shifts_bins, double max_offset_bins,
                  std::span<CorrelationPeak> peaks);

  /// e(n) at one shift, O(M), from the spectra (no FFT). Used to score a known roll.
  float ScoreAtShift(const SignatureSpectrum& query, const SignatureSpectrum& reference,
                     double shift_bins) const;

  /// Reference implementation for tests: e(n) by the definition (no smoothing), O(M^2), in double
  /// precision.
  static std::vector<double> CorrelateDirect(std::span<const float> query,
                                             std::span<const float> reference);

 private:
  /// Whether `spectrum` holds from harmonics() to M/2 + 1 coefficients.
  bool HasHarmonics(const SignatureSpectrum& spectrum) const {
    return spectrum.coefficients.size() >= bound_length_ &&
           spectrum.coefficients.size() <= complex_scratch_.size();
  }
  /// Band-limited products conj(Q_k) D_k into coarse_products_ and the correlation at the
  /// coarse_fft_ length's evenly spaced shifts into coarse_samples_.
  void CoarseCorrelate(const SignatureSpectrum& query, const SignatureSpectrum& reference);
  CorrelationPeak FullPeak(const SignatureSpectrum& query, const SignatureSpectrum& reference);
  CorrelationPeak BandLimitedPeak(const SignatureSpectrum& query,
                                  const SignatureSpectrum& reference);

  int length_;
  CorrelationOptions options_;
  std::unique_ptr<RealFft> fft_;
  /// Gaussian weight of each harmonic (all 1 without smoothing).
  std::vector<float> window_;
  /// Harmonics with a non-zero weight (the length of SignatureSpectrum::magnitudes).
  size_t bound_length_ = 0;
  std::vector<float> real_scratch_;
  std::vector<std::complex<float>> complex_scratch_;
  /// The short transform for band-limited correlations (null without smoothing).
  std::unique_ptr<RealFft> coarse_fft_;
  std::vector<std::complex<float>> coarse_products_;
  std::vector<float> coarse_samples_;
};

/// Upper bound of max_n e(n): dot product of a weighted and an unweighted magnitude vector.
float CorrelationUpperBound(std::span<const float> weighted_magnitudes,
                            std::span<const float> magnitudes);

/// Square root of a spectrum's energy beyond its first `harmonics` harmonics, from its
/// (unweighted) magnitudes: sqrt(max(0, 1 - sum_{k < harmonics} w_k m_k^2)), w_k = 1 for k = 0
/// and k = M/2 (`num_coefficients` = M/2 + 1), else 2; a spectrum of CircularCorrelator has unit
/// energy. For two spectra Q and D,
///   sum_{k < K} w_k |Q_k| |D_k| + TailEnergyRoot(Q, K) TailEnergyRoot(D, K)
/// is an upper bound of max_n e(n) over all harmonics (Cauchy-Schwarz on those from K on), 1 when
/// the magnitudes are equal. The first term alone favours spectra with much energy in the first
/// harmonics; the second credits a match of the energy beyond them (a nearly round outline has
/// little in the first ones). `harmonics` <= magnitudes.size().
float TailEnergyRoot(std::span<const float> magnitudes, size_t harmonics, size_t num_coefficients);

}  // namespace silpose
