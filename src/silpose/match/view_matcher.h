#pragma once
// Single-frame matching against the whole view database (the paper's brute-force baseline,
// section 5.1): the query signature is correlated with every view of every model; the best
// (object, view, roll, score) candidates come back.
//
// The default search is exact but pruned: every view first gets the cheap upper bound of its
// correlation peak (circular_correlator.h); views are then correlated in decreasing order of bound
// until the K-th best score found is at least the next bound, so the result equals the exhaustive
// search. `exhaustive` correlates every view (for checking and benchmarking).

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "silpose/database/view_database.h"
#include "silpose/match/circular_correlator.h"

namespace silpose {

struct MatchOptions {
  /// Number of candidates returned, best first (>= 1).
  int top_k = 5;
  /// Correlate every view instead of pruning by the bound (same result, slower).
  bool exhaustive = false;
  /// Restrict the search to these model indices; empty = all models.
  std::vector<int> models;
  /// Apparent size of the query silhouette (mean radius / focal length in the on-axis virtual
  /// camera, pose/on_axis.h). Each view is matched against the distance shell this size implies
  /// for it (ViewDatabase::ChooseShell); 0 = unknown: the first (nearest) shell.
  double apparent_radius = 0.0;

  bool Check(std::string* error = nullptr) const;
};

struct MatchCandidate {
  int model = -1;
  int view = -1;
  /// Distance shell the view was matched in.
  int shell = 0;
  /// Camera roll in degrees, (-180, 180] (geometry/view_frame.h).
  double roll_deg = 0.0;
  /// Correlation peak in [-1, 1].
  float score = 0.0f;
};

/// Statistics of the last search.
struct MatchStats {
  int views_bounded = 0;
  int views_correlated = 0;
};

/// Holds the spectra of every database view, in every distance shell. A database written with its
/// spectra (StoreViewSpectra, as build-db does) lends them where the file is mapped: nothing is
/// transformed or copied, and a view's spectrum values are checked when it is first used
/// (ViewDatabase::CheckViewSpectrum; its signature where the pose reads it, CheckSignatures).
/// Otherwise a view's spectrum is
/// computed when it is first used (one FFT; thread-safe), so a sequence seen at one distance never
/// pays for the other shells, and a particle filter only for the views its particles visit; or all
/// at once by ComputeAll, for memory that no longer grows while tracking. A spectrum keeps only the
/// harmonics the smoothing leaves non-zero (CircularCorrelator::harmonics(): 151 of 501
/// coefficients at the default 2 degrees and M = 1000, about 1.8 KB a view), which correlate
/// exactly as the full spectrum. Searching is read-only on it but uses per-object scratch space, so
/// use one ViewMatcher per thread (they can share one ViewSpectra). `database` must outlive it.
class ViewSpectra {
 public:
  explicit ViewSpectra(const ViewDatabase& database, const CorrelationOptions& options = {});
  ViewSpectra(const ViewSpectra&) = delete;
  ViewSpectra& operator=(const ViewSpectra&) = delete;
  /// Not for temporaries: the spectra keep a reference to the database.
  ViewSpectra(ViewDatabase&&, const CorrelationOptions& = {}) = delete;

  /// The spectrum of a view (made now if it was not yet). Views whose silhouette could not be
  /// described (ViewRecord::status) have an empty one.
  const SignatureSpectrum& Get(int model, int view, int shell = 0) const {
    const size_t block = Index(model, shell);
    const size_t index = block * static_cast<size_t>(num_views_) + static_cast<size_t>(view);
    // The spectra of one (model, shell) are allocated when the first of them is used (and the
    // block's data checked against its checksums, for a database read with
    // ViewChecks::kOnFirstUse).
    std::call_once(block_once_[block], [&] { OpenBlock(model, shell); });
    std::call_once(once_[index], [&] { Compute(model, view, shell); });
    return blocks_[block][static_cast<size_t>(view)];
  }
  /// The spectrum's magnitudes (SignatureSpectrum::magnitudes) of a usable view, for bounds and
  /// rankings that visit every view: read in place from stored spectra (nothing made, the view's
  /// values not checked: a caller that finds a non-finite or impossible bound from them calls Get,
  /// which checks), else Get(...).magnitudes.
  std::span<const float> Magnitudes(int model, int view, int shell = 0) const {
    if (stored_[static_cast<size_t>(model)] != 0) {
      const size_t block = Index(model, shell);
      std::call_once(magnitudes_once_[block], [&] { OpenMagnitudes(model, shell); });
      const StoredSpectra& stored = database_.models[static_cast<size_t>(model)].spectra;
      const float* magnitudes =
          stored.magnitudes.empty()
              ? magnitudes_[block].get()
              : stored.magnitudes.data() +
                    static_cast<size_t>(shell) * static_cast<size_t>(num_views_) * stored.harmonics;
      return {magnitudes + static_cast<size_t>(view) * stored.harmonics, stored.harmonics};
    }
    return Get(model, view, shell).magnitudes.span();
  }
  /// Harmonics in a bound head (BoundHeads).
  static constexpr size_t kBoundHead = 15;
  /// Floats per view in BoundHeads.
  static constexpr size_t kBoundHeadStride = kBoundHead + 1;
  /// Added to a bound from BoundHeads: the float sums of it and of the exact bound round
  /// differently (by up to about 1e-6 over 151 harmonics).
  static constexpr float kBoundHeadSlack = 1e-5f;
  /// For every view of model `model` in shell `shell`, kBoundHeadStride floats: its first
  /// kBoundHead magnitudes (Magnitudes), then the norm of the others; all 0 for a view that is
  /// not Usable. Made from Magnitudes when first asked for (thread-safe),
  /// so that a search over every view can bound them all from one small contiguous table
  /// instead of reading each view's spectrum.
  std::span<const float> BoundHeads(int model, int shell = 0) const {
    const size_t block = Index(model, shell);
    std::call_once(heads_once_[block], [&] { MakeBoundHeads(model, shell); });
    return {heads_[block].get(), static_cast<size_t>(num_views_) * kBoundHeadStride};
  }
  /// For a database read with ViewChecks::kOnFirstUse: checks the signatures of model `model` in
  /// shell `shell` against their checksum (ViewDatabase::CheckBlock) and each view's signature
  /// values (ViewDatabase::CheckViewSignature), once. When the spectra come from the file the
  /// matcher reads neither (only the spectra, whose blocks and values it checks); code that reads
  /// signatures (the 6-DOF pose) calls this first. Throws silpose::Error naming the file; nothing
  /// for a database checked at open.
  void CheckSignatures(int model, int shell) const {
    if (!database_.views_unchecked) return;
    std::call_once(signatures_once_[Index(model, shell)], [&] {
      // A compact model's signatures are derived from its coefficients: those are checked.
      if (database_.models[static_cast<size_t>(model)].signatures_stored()) {
        database_.CheckBlock(model, shell, ViewBlock::kSignatures);
      } else {
        CheckCoefficients(model, shell);
      }
      const size_t first = static_cast<size_t>(shell) * static_cast<size_t>(num_views_);
      for (size_t r = first; r < first + static_cast<size_t>(num_views_); ++r) {
        database_.CheckViewSignature(model, r);
      }
    });
  }
  /// Makes the spectra of every view of every model and shell not made yet, on `num_threads`
  /// threads (0 = all available cores; util/threads.h). Thread-safe with Get; the spectra are the
  /// ones Get makes. Afterwards Get allocates nothing.
  void ComputeAll(int num_threads = 0) const;
  /// True if the spectra of model `model` come from the database file (StoredSpectra).
  bool Stored(int model) const { return stored_[static_cast<size_t>(model)] != 0; }
  /// Spectra made so far (views whose silhouette was described; see Get).
  size_t num_computed() const { return num_computed_.load(std::memory_order_relaxed); }
  /// Bytes this object holds: its tables (sized at construction), the spectrum slots of every
  /// (model, shell) used so far, the spectra and BoundHeads tables made so far (stored spectra
  /// lent by the database are not counted: they are the mapped file's).
  size_t MemoryBytes() const {
    return table_bytes_ + spectrum_bytes_.load(std::memory_order_relaxed);
  }
  /// False for a view whose silhouette could not be described when the database was built.
  bool Usable(int model, int view, int shell = 0) const {
    return usable_[Index(model, shell) * static_cast<size_t>(num_views_) +
                   static_cast<size_t>(view)] != 0;
  }
  /// ViewDatabase::ChooseShell, from tables made once.
  int ChooseShell(int model, int view, double apparent_radius) const;
  int num_models() const { return num_models_; }
  int num_views() const { return num_views_; }
  int num_shells() const { return num_shells_; }
  int signature_length() const { return signature_length_; }
  const CorrelationOptions& options() const { return options_; }
  const ViewDatabase& database() const { return database_; }

 private:
  size_t Index(int model, int shell) const {
    return static_cast<size_t>(model) * static_cast<size_t>(num_shells_) +
           static_cast<size_t>(shell);
  }
  void Compute(int model, int view, int shell) const;
  void OpenBlock(int model, int shell) const;
  /// A stored-spectra block's magnitudes: checked against their checksum (format 4, read with
  /// ViewChecks::kOnFirstUse), or computed from the coefficients (format 5, which stores none).
  void OpenMagnitudes(int model, int shell) const;
  /// For a database read with ViewChecks::kOnFirstUse: the block's stored coefficients against
  /// their checksum, once.
  void CheckCoefficients(int model, int shell) const {
    if (!database_.views_unchecked) return;
    std::call_once(coefficients_once_[Index(model, shell)],
                   [&] { database_.CheckBlock(model, shell, ViewBlock::kCoefficients); });
  }
  void MakeBoundHeads(int model, int shell) const;

  const ViewDatabase& database_;
  CorrelationOptions options_;
  int num_models_;
  int num_views_;
  int num_shells_;
  int signature_length_;
  /// Per (model, shell): its views' spectra (allocated on first use), each made on first use.
  mutable std::vector<std::unique_ptr<SignatureSpectrum[]>> blocks_;
  std::unique_ptr<std::once_flag[]> block_once_;
  /// Per (model, shell): its stored magnitudes checked (ViewChecks::kOnFirstUse) or computed (in
  /// magnitudes_; format 5), its signatures checked (ViewChecks::kOnFirstUse).
  std::unique_ptr<std::once_flag[]> magnitudes_once_;
  mutable std::vector<std::unique_ptr<float[]>> magnitudes_;
  /// Per (model, shell): its stored coefficients checked (ViewChecks::kOnFirstUse).
  std::unique_ptr<std::once_flag[]> coefficients_once_;
  std::unique_ptr<std::once_flag[]> signatures_once_;
  /// Per (model, shell): BoundHeads, made on first use.
  mutable std::vector<std::unique_ptr<float[]>> heads_;
  std::unique_ptr<std::once_flag[]> heads_once_;
  std::unique_ptr<std::once_flag[]> once_;
  std::vector<uint8_t> usable_;
  /// Per model: whether its spectra are the database's stored ones.
  std::vector<uint8_t> stored_;
  /// Per (model, shell, view): ViewDatabase::ApparentRadius.
  std::vector<float> apparent_;
  /// Bytes of the tables above.
  size_t table_bytes_ = 0;
  /// Spectra made, and the bytes of their coefficients and magnitudes.
  mutable std::atomic<size_t> num_computed_{0};
  mutable std::atomic<size_t> spectrum_bytes_{0};
};

/// Whether a model's stored spectra are missing or lack their amplitudes (read from a file of
/// format 3 or 4): a database with such a model needs StoreViewSpectra before it is written.
inline bool NeedsStoredSpectra(const ModelViews& model) {
  return model.spectra.empty() || model.spectra.amplitudes.size() != model.views.size();
}

/// Computes the spectra of every view of every model (as ViewSpectra would with `options`) into
/// ModelViews::spectra, so that written databases carry them (build-db does this), on
/// `num_threads` threads (0 = all available cores), with the amplitudes that turn them back into
/// the smoothed signatures. Replaces spectra stored before, except those of compact models
/// (ModelViews::DropSignatures), which are kept: they are the only data of such a model (a
/// compact model whose spectra were made with another smoothing is refused, silpose::Error).
void StoreViewSpectra(ViewDatabase* database, const CorrelationOptions& options = {},
                      int num_threads = 0);

class ViewMatcher {
 public:
  /// Correlates with the options the spectra were made with.
  explicit ViewMatcher(const ViewSpectra& spectra);
  /// The matcher keeps a reference to the spectra: a temporary would dangle.
  explicit ViewMatcher(ViewSpectra&&) = delete;

  /// Best candidates for a signature of the database's length (PolarSignature::radii), best first.
  /// Throws silpose::Error for a signature of another length or invalid options.
  std::vector<MatchCandidate> Match(std::span<const float> radii, const MatchOptions& options = {});

  /// Correlation peak of a signature against one view (of shell `shell`).
  CorrelationPeak Score(const SignatureSpectrum& query, int model, int view, int shell = 0);

  CircularCorrelator& correlator() { return correlator_; }
  const MatchStats& last_stats() const { return stats_; }

 private:
  struct BoundedView {
    float bound;
    int model;
    int view;
    int shell;
    /// Whether `bound` is CorrelationUpperBound over every harmonic (else the cheaper, looser
    /// bound from the first harmonics and the rest's energy).
    bool full;
    bool operator<(const BoundedView& other) const { return bound < other.bound; }
  };

  const ViewSpectra& spectra_;
  CircularCorrelator correlator_;
  SignatureSpectrum query_;
  std::vector<BoundedView> bounds_;
  MatchStats stats_;
};

}  // namespace silpose
