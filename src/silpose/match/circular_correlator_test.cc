#include "silpose/match/circular_correlator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "silpose/geometry/view_frame.h"
#include "silpose/util/cpu_features.h"
#include "silpose/util/error.h"

namespace silpose {
namespace {

// A smooth random periodic signature: a few random Fourier terms around 1, sampled at `length`
// points, with its argument shifted by `shift_bins` (may be fractional).
std::vector<float> SmoothSignature(uint32_t seed, int length, double shift_bins = 0.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> amplitude(-0.2, 0.2);
  std::vector<std::pair<double, double>> terms;
  for (int k = 1; k <= 12; ++k) terms.emplace_back(amplitude(rng) / k, amplitude(rng) / k);
  std::vector<float> radii(static_cast<size_t>(length));
  for (int x = 0; x < length; ++x) {
    const double t = 2.0 * std::numbers::pi * (x + shift_bins) / length;
    double r = 1.0;
    for (size_t k = 0; k < terms.size(); ++k) {
      r += terms[k].first * std::cos(static_cast<double>(k + 1) * t) +
           terms[k].second * std::sin(static_cast<double>(k + 1) * t);
    }
    radii[static_cast<size_t>(x)] = static_cast<float>(r);
  }
  return radii;
}

// a - b on a circle of `length` bins, in [-length/2, length/2).
double CircularDifference(double a, double b, int length) {
  return std::fmod(a - b + 1.5 * length, static_cast<double>(length)) - 0.5 * length;
}

// Every property holds for every FFT backend, with and without smoothing.
class CorrelatorTest : public ::testing::TestWithParam<CorrelationOptions> {};

// Circular convolution with a sampled Gaussian of `sigma_deg` (the smoothing, done the slow way).
std::vector<float> SmoothDirect(const std::vector<float>& values, double sigma_deg) {
  if (sigma_deg <= 0.0) return values;
  const int m = static_cast<int>(values.size());
  const double sigma_bins = sigma_deg * m / 360.0;
  std::vector<double> kernel(static_cast<size_t>(m));
  double total = 0.0;
  for (int d = 0; d < m; ++d) {
    const double distance = std::min(d, m - d);
    kernel[static_cast<size_t>(d)] =
        std::exp(-0.5 * distance * distance / (sigma_bins * sigma_bins));
    total += kernel[static_cast<size_t>(d)];
  }
  std::vector<float> out(values.size());
  for (int x = 0; x < m; ++x) {
    double sum = 0.0;
    for (int d = 0; d < m; ++d) {
      sum += kernel[static_cast<size_t>(d)] * values[static_cast<size_t>((x + d) % m)];
    }
    out[static_cast<size_t>(x)] = static_cast<float>(sum / total);
  }
  return out;
}

TEST_P(CorrelatorTest, FftCorrelationEqualsTheDefinition) {
  // The sampled Gaussian of the direct version equals the spectral one once it spans a few bins.
  const std::vector<int> lengths = GetParam().smoothing_deg > 0.0
                                       ? std::vector<int>{1000, 1024}
                                       : std::vector<int>{16, 100, 1000, 1024};
  for (int length : lengths) {
    CircularCorrelator correlator(length, GetParam());
    const std::vector<float> a = SmoothSignature(1, length);
    std::vector<float> b = SmoothSignature(2, length);
    std::mt19937 rng(3);
    std::normal_distribution<float> noise(0.0f, 0.05f);
    for (float& r : b) r += noise(rng);  // not band-limited
    std::vector<float> fast(static_cast<size_t>(length));
    correlator.Correlate(correlator.Transform(a), correlator.Transform(b), fast);
    const std::vector<double> slow = CircularCorrelator::CorrelateDirect(
        SmoothDirect(a, GetParam().smoothing_deg), SmoothDirect(b, GetParam().smoothing_deg));
    for (int n = 0; n < length; ++n) {
      EXPECT_NEAR(fast[static_cast<size_t>(n)], slow[static_cast<size_t>(n)], 2e-5)
          << "length " << length << " shift " << n;
    }
  }
}

TEST_P(CorrelatorTest, ShiftingBySomeBinsMovesThePeakBySoManyBins) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum reference = correlator.Transform(SmoothSignature(5, length));
  for (int shift : {0, 1, 2, 250, 499, 500, 501, 999}) {
    const CorrelationPeak peak =
        correlator.Peak(correlator.Transform(SmoothSignature(5, length, shift)), reference);
    EXPECT_NEAR(peak.score, 1.0f, 1e-5f);
    EXPECT_NEAR(CircularDifference(peak.shift_bins, shift, length), 0.0, 1e-3) << shift;
    EXPECT_NEAR(WrapDegrees(peak.RollDeg(length) - shift * 0.36), 0.0, 1e-3);
  }
}

TEST_P(CorrelatorTest, FractionalShiftsAreRefinedBelowOneBin) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum reference = correlator.Transform(SmoothSignature(9, length));
  for (double shift : {0.25, 10.5, 700.8}) {
    const CorrelationPeak peak =
        correlator.Peak(correlator.Transform(SmoothSignature(9, length, shift)), reference);
    EXPECT_NEAR(CircularDifference(peak.shift_bins, shift, length), 0.0, 0.1) << shift;
    EXPECT_GT(peak.score, 0.999f);
  }
}

TEST_P(CorrelatorTest, ScoreIsInvariantToScaleAndOffsetAndBoundedByOne) {
  const int length = 360;
  CircularCorrelator correlator(length, GetParam());
  const std::vector<float> a = SmoothSignature(11, length);
  std::vector<float> scaled = a;
  for (float& r : scaled) r = 3.5f * r + 2.0f;
  EXPECT_NEAR(correlator.Peak(correlator.Transform(scaled), correlator.Transform(a)).score, 1.0f,
              1e-5f);
  std::vector<float> inverted = a;
  for (float& r : inverted) r = 2.0f - r;
  const float score =
      correlator.Peak(correlator.Transform(inverted), correlator.Transform(a)).score;
  EXPECT_LT(score, 0.9f);
  EXPECT_GE(score, -1.0f);
}

TEST_P(CorrelatorTest, UpperBoundIsNeverBelowThePeak) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  for (uint32_t seed = 0; seed < 50; ++seed) {
    const SignatureSpectrum q = correlator.Transform(SmoothSignature(seed, length), true);
    const SignatureSpectrum d = correlator.Transform(SmoothSignature(seed + 100, length));
    const float peak = correlator.Peak(q, d).score;
    EXPECT_GE(CorrelationUpperBound(q.magnitudes, d.magnitudes) + 1e-5f, peak);
  }
  // Equality for a shifted copy: the bound is tight where it matters.
  const SignatureSpectrum q = correlator.Transform(SmoothSignature(1, length, 77), true);
  const SignatureSpectrum d = correlator.Transform(SmoothSignature(1, length));
  EXPECT_NEAR(CorrelationUpperBound(q.magnitudes, d.magnitudes), 1.0f, 1e-4f);
}

// A nearly round outline: a circle with a ripple of `ripple` bumps, a slight ellipse, shifted.
std::vector<float> RippledCircle(int length, int ripple, double ellipse, double shift_bins) {
  std::vector<float> radii(static_cast<size_t>(length));
  for (int x = 0; x < length; ++x) {
    const double t = 2.0 * std::numbers::pi * (x + shift_bins) / length;
    radii[static_cast<size_t>(x)] =
        static_cast<float>(1.0 + ellipse * std::cos(2.0 * t) + 0.05 * std::cos(ripple * t));
  }
  return radii;
}

TEST_P(CorrelatorTest, TailEnergyBoundIsNeverBelowThePeakAndFindsNearlyRoundOutlines) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const size_t half = length / 2 + 1;
  // Unit energy: nothing is left beyond the last harmonic.
  const SignatureSpectrum own = correlator.Transform(RippledCircle(length, 40, 0.01, 0.0));
  EXPECT_NEAR(TailEnergyRoot(own.magnitudes, own.magnitudes.size(), half), 0.0f, 2e-3f);
  EXPECT_NEAR(TailEnergyRoot(own.magnitudes, 0, half), 1.0f, 1e-6f);
  // The first K harmonics' bound plus the tails' product is never below the peak.
  const auto bound = [&](const SignatureSpectrum& q_weighted, const SignatureSpectrum& d,
                         size_t k) {
    float sum = 0.0f;
    for (size_t i = 0; i < k; ++i) sum += q_weighted.magnitudes[i] * d.magnitudes[i];
    std::vector<float> q(k);
    for (size_t i = 0; i < k; ++i) q[i] = std::abs(q_weighted.coefficients[i]);
    return sum + TailEnergyRoot(q, k, half) * TailEnergyRoot(d.magnitudes, k, half);
  };
  for (uint32_t seed = 0; seed < 30; ++seed) {
    std::vector<float> a = SmoothSignature(seed, length);
    const std::vector<float> ripple = RippledCircle(length, 30 + static_cast<int>(seed), 0.0, seed);
    for (size_t i = 0; i < a.size(); ++i) a[i] += 0.5f * (ripple[i] - 1.0f);
    const SignatureSpectrum q = correlator.Transform(a, true);
    const SignatureSpectrum d = correlator.Transform(SmoothSignature(seed + 100, length));
    const SignatureSpectrum r = correlator.Transform(RippledCircle(length, 45, 0.02, 3.0 * seed));
    for (const size_t k : {size_t{4}, size_t{8}, size_t{32}}) {
      EXPECT_GE(bound(q, d, k) + 1e-5f, correlator.Peak(q, d).score) << seed << " " << k;
      EXPECT_GE(bound(q, r, k) + 1e-5f, correlator.Peak(q, r).score) << seed << " " << k;
    }
  }
  // A nearly round frame: its shifted copy reaches the bound, 1. On the first 32 harmonics alone
  // an elongated outline outranks it; with the tails it does not.
  const SignatureSpectrum frame = correlator.Transform(RippledCircle(length, 40, 0.01, 17.0), true);
  const SignatureSpectrum same = correlator.Transform(RippledCircle(length, 40, 0.01, 0.0));
  const SignatureSpectrum elongated = correlator.Transform(RippledCircle(length, 40, 0.3, 0.0));
  EXPECT_NEAR(correlator.Peak(frame, same).score, 1.0f, 1e-4f);
  EXPECT_NEAR(bound(frame, same, 32), 1.0f, 1e-3f);
  EXPECT_LT(bound(frame, elongated, 32), 0.9f);
  const auto truncated = [&](const SignatureSpectrum& d) {
    return CorrelationUpperBound(std::span<const float>(frame.magnitudes).first(32),
                                 std::span<const float>(d.magnitudes).first(32));
  };
  EXPECT_GT(truncated(elongated), truncated(same));
}

TEST_P(CorrelatorTest, ScoreAtShiftAgreesWithTheCorrelationAtIntegerShifts) {
  const int length = 200;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum q = correlator.Transform(SmoothSignature(21, length));
  const SignatureSpectrum d = correlator.Transform(SmoothSignature(22, length));
  std::vector<float> e(static_cast<size_t>(length));
  correlator.Correlate(q, d, e);
  for (int n = 0; n < length; n += 7) {
    EXPECT_NEAR(correlator.ScoreAtShift(q, d, n), e[static_cast<size_t>(n)], 1e-5) << n;
  }
}

TEST_P(CorrelatorTest, LocalPeakNearTheTruePeakEqualsTheGlobalPeak) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum reference = correlator.Transform(SmoothSignature(31, length));
  for (double shift : {0.0, 3.3, 500.0, 998.6}) {
    const SignatureSpectrum query = correlator.Transform(SmoothSignature(31, length, shift));
    const CorrelationPeak global = correlator.Peak(query, reference);
    // Starts on both sides of the peak, also across the wrap-around at 0.
    const std::vector<double> starts = {shift - 8.0, shift - 1.0, shift, shift + 2.5,
                                        shift + 8.0 + length};
    std::vector<CorrelationPeak> local(starts.size());
    correlator.LocalPeaks(query, reference, starts, 15.0, local);
    for (size_t i = 0; i < starts.size(); ++i) {
      EXPECT_NEAR(CircularDifference(local[i].shift_bins, global.shift_bins, length), 0.0, 0.05)
          << "shift " << shift << " start " << starts[i];
      EXPECT_NEAR(local[i].score, global.score, 1e-4) << "shift " << shift;
      EXPECT_GE(local[i].shift_bins, 0.0f);
      EXPECT_LT(local[i].shift_bins, static_cast<float>(length));
    }
  }
}

// A signature with a two-fold symmetry has two equal peaks half a turn apart: the local search
// keeps the one near its start, where the global search may take either.
TEST_P(CorrelatorTest, LocalPeakStaysOnTheNearPeakOfASymmetricShape) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  std::vector<float> symmetric = SmoothSignature(41, length);
  for (int x = 0; x < length / 2; ++x) {
    symmetric[static_cast<size_t>(x + length / 2)] = symmetric[static_cast<size_t>(x)];
  }
  // The two halves are identical, so e has period M/2.
  const SignatureSpectrum reference = correlator.Transform(symmetric);
  std::vector<float> rotated(symmetric.size());
  for (int x = 0; x < length; ++x) {
    rotated[static_cast<size_t>(x)] = symmetric[static_cast<size_t>((x + 120) % length)];
  }
  const SignatureSpectrum query = correlator.Transform(rotated);
  const std::vector<double> starts = {115.0, 126.0, 617.0, 622.0};
  std::vector<CorrelationPeak> local(starts.size());
  correlator.LocalPeaks(query, reference, starts, 20.0, local);
  EXPECT_NEAR(CircularDifference(local[0].shift_bins, 120.0, length), 0.0, 0.2);
  EXPECT_NEAR(CircularDifference(local[1].shift_bins, 120.0, length), 0.0, 0.2);
  EXPECT_NEAR(CircularDifference(local[2].shift_bins, 620.0, length), 0.0, 0.2);
  EXPECT_NEAR(CircularDifference(local[3].shift_bins, 620.0, length), 0.0, 0.2);
  for (const CorrelationPeak& peak : local) EXPECT_GT(peak.score, 0.999f);
}

TEST_P(CorrelatorTest, LocalPeakIsAMaximumInsideItsWindowOrOnItsEdge) {
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum reference = correlator.Transform(SmoothSignature(51, length));
  const SignatureSpectrum query = correlator.Transform(SmoothSignature(52, length, 300.0));
  std::vector<float> e(static_cast<size_t>(length));
  correlator.Correlate(query, reference, e);
  auto e_at = [&](long bin) { return e[static_cast<size_t>((bin % length + length) % length)]; };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, length);
  std::vector<double> starts(60);
  for (double& start : starts) start = uniform(rng);
  for (double window : {0.0, 0.4, 3.0, 12.0, 40.0}) {
    std::vector<CorrelationPeak> local(starts.size());
    correlator.LocalPeaks(query, reference, starts, window, local);
    for (size_t i = 0; i < starts.size(); ++i) {
      const double shift = local[i].shift_bins;
      const double offset = CircularDifference(shift, starts[i], length);
      EXPECT_LE(std::abs(offset), window + 1e-3) << "start " << starts[i];
      const bool on_edge = std::abs(offset) >= window - 1e-3;
      const double exact = correlator.ScoreAtShift(query, reference, shift);
      if (std::abs(local[i].score - exact) <= 2e-5) {
        // Refined on the band-limited correlation: a local maximum there, unless on the edge.
        if (!on_edge) {
          EXPECT_GE(local[i].score + 2e-5, correlator.ScoreAtShift(query, reference, shift - 0.3));
          EXPECT_GE(local[i].score + 2e-5, correlator.ScoreAtShift(query, reference, shift + 0.3));
        }
      } else {
        // Refined by a parabola: the score is a correlation sample next to the shift, a grid
        // maximum unless on the edge.
        const long bin = std::lround(shift);
        const long near = local[i].score == e_at(bin) ? bin : std::lround(shift + 0.5) - 1;
        ASSERT_TRUE(local[i].score == e_at(bin) || local[i].score == e_at(bin - 1) ||
                    local[i].score == e_at(bin + 1))
            << local[i].score << " at " << shift;
        if (!on_edge && local[i].score == e_at(near)) {
          EXPECT_GE(local[i].score, e_at(near - 1));
          EXPECT_GE(local[i].score, e_at(near + 1));
        }
      }
    }
    // Starting one at a time gives the same as all at once (the shared refinements).
    for (size_t i = 0; i < starts.size(); i += 7) {
      CorrelationPeak alone;
      correlator.LocalPeaks(query, reference, std::span<const double>(&starts[i], 1), window,
                            std::span<CorrelationPeak>(&alone, 1));
      EXPECT_NEAR(alone.score, local[i].score, 1e-6);
      EXPECT_NEAR(CircularDifference(alone.shift_bins, local[i].shift_bins, length), 0.0, 0.05);
    }
  }
}

TEST_P(CorrelatorTest, ConstantSignaturesCorrelateToZero) {
  const int length = 100;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum flat = correlator.Transform(std::vector<float>(100, 1.0f));
  EXPECT_FALSE(flat.has_variance);
  const CorrelationPeak peak = correlator.Peak(flat, correlator.Transform(SmoothSignature(1, 100)));
  EXPECT_EQ(peak.score, 0.0f);
}

TEST_P(CorrelatorTest, TheAvx2AndBaselineBuildsCorrelateAlike) {
  // The conjugate products and the band-limited evaluation have an AVX2 build
  // (util/cpu_features.h): the correlation, the global peak and the local peaks must be the
  // baseline's bit for bit.
  const bool had_avx2 = Avx2Enabled();
  if (!SetAvx2Enabled(true)) GTEST_SKIP() << "this processor has no AVX2";
  const int length = 1000;
  CircularCorrelator correlator(length, GetParam());
  const SignatureSpectrum reference = correlator.Transform(SmoothSignature(41, length));
  const SignatureSpectrum query = correlator.Transform(SmoothSignature(42, length, 123.4));
  const std::vector<double> starts = {0.0, 120.0, 333.3, 990.0};
  auto run = [&](bool avx2, std::vector<float>* correlation, CorrelationPeak* peak,
                 std::vector<CorrelationPeak>* local) {
    SetAvx2Enabled(avx2);
    correlation->resize(static_cast<size_t>(length));
    correlator.Correlate(query, reference, *correlation);
    *peak = correlator.Peak(query, reference);
    local->resize(starts.size());
    correlator.LocalPeaks(query, reference, starts, 20.0, *local);
  };
  std::vector<float> vector_correlation;
  std::vector<float> baseline_correlation;
  CorrelationPeak vector_peak;
  CorrelationPeak baseline_peak;
  std::vector<CorrelationPeak> vector_local;
  std::vector<CorrelationPeak> baseline_local;
  run(true, &vector_correlation, &vector_peak, &vector_local);
  run(false, &baseline_correlation, &baseline_peak, &baseline_local);
  SetAvx2Enabled(had_avx2);
  EXPECT_EQ(vector_correlation, baseline_correlation);
  EXPECT_EQ(vector_peak.score, baseline_peak.score);
  EXPECT_EQ(vector_peak.shift_bins, baseline_peak.shift_bins);
  for (size_t i = 0; i < starts.size(); ++i) {
    EXPECT_EQ(vector_local[i].score, baseline_local[i].score) << "start " << starts[i];
    EXPECT_EQ(vector_local[i].shift_bins, baseline_local[i].shift_bins) << "start " << starts[i];
  }
  // Not a trivial case: the correlation varies and the peak lies between bins.
  EXPECT_GT(vector_peak.score, 0.0f);
  EXPECT_NE(vector_peak.shift_bins, std::round(vector_peak.shift_bins));
}

TEST_P(CorrelatorTest, WrongLengthIsAnError) {
  CircularCorrelator correlator(100, GetParam());
  EXPECT_THROW(correlator.Transform(std::vector<float>(99, 1.0f)), Error);
}

std::vector<CorrelationOptions> Variants() {
  std::vector<CorrelationOptions> variants;
  for (FftBackend backend : AvailableFftBackends()) {
    for (double smoothing : {0.0, 1.0, 2.0, 3.0}) variants.push_back({smoothing, backend});
  }
  return variants;
}

INSTANTIATE_TEST_SUITE_P(Variants, CorrelatorTest, ::testing::ValuesIn(Variants()),
                         [](const auto& test_info) {
                           return std::string(ToString(test_info.param.backend)) + "_smoothing" +
                                  std::to_string(static_cast<int>(test_info.param.smoothing_deg));
                         });

TEST(CorrelationOptions, NegativeOrHugeSmoothingIsAnError) {
  EXPECT_THROW(CircularCorrelator(100, {.smoothing_deg = -1.0}), Error);
  EXPECT_THROW(CircularCorrelator(100, {.smoothing_deg = 400.0}), Error);
}

TEST(RealFft, OddLengthIsAnError) { EXPECT_THROW(RealFft::Create(999), Error); }

}  // namespace
}  // namespace silpose
