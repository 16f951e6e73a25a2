#pragma once
// The reference view database (paper 4.1): for every model, the polar signature of its silhouette
// seen from every viewpoint of one view sphere, with the sphere's neighbour graph and K-means bins.
//
// File format (docs/database-format.md): little-endian binary, an 8-byte magic number "SILPOSDB",
// a format version, the payload size, the payload (every generation parameter, per model its name
// and the XXH64 hash of its mesh file, per view its silhouette record, its spectrum and, unless the
// database is compact (the default of build-db), its signature, the graph and bins) and an XXH64
// checksum of everything before it. Reading checks magic, version, size and
// checksum before it parses anything, and every value after; a truncated, corrupt, foreign or
// other-version file is refused with a silpose::Error naming the file and the problem.

#include <cmath>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "silpose/geometry/symmetry.h"
#include "silpose/geometry/view_sphere.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/util/shared_array.h"

namespace silpose {

/// Every parameter that shaped a database; two databases with equal parameters are comparable.
///
/// Distance shells. A silhouette's shape depends on the distance it is seen from (perspective: at
/// 3 object radii the near side of an object looks larger than the far side; far away the outline
/// tends to the orthographic one). The database therefore renders every view from several
/// distances, `distances_in_radii` (the shells), and a frame is matched against, per object and
/// view, the shell nearest to the distance that the frame silhouette's apparent size implies for
/// that view (ViewDatabase::ChooseShell). The perspective change of the outline goes with 1 / D,
/// so the default shells are spaced about evenly in 1 / D from 3 radii to near-orthographic: every
/// distance from 3 radii to infinity is within 0.055 of a shell in 1 / D (the paper's single shell
/// at 3 radii is off by 0.19 at 7 radii and 0.27 at 15). Cost: database size and build time grow
/// with the number of shells (docs/PERFORMANCE.md).
struct DatabaseParameters {
  ViewSphereOptions view_sphere;
  /// Image size and framing of the database renderings. Its distance_in_radii is not used by the
  /// database: each shell renders at its own distance (ShellRender).
  ViewRenderOptions render;
  SignatureOptions signature;
  /// Camera distances of the shells, object radii, strictly increasing, each > 1 (1 to 16 shells).
  /// {3} is the paper's database.
  std::vector<double> distances_in_radii = {3.0, 4.5, 7.5, 20.0};

  int num_shells() const { return static_cast<int>(distances_in_radii.size()); }
  /// `render` with the distance of shell `shell`.
  ViewRenderOptions ShellRender(int shell) const;
  bool Check(std::string* error = nullptr) const;
  bool operator==(const DatabaseParameters& other) const;
};

/// What the silhouette of one database view looked like when the database was built.
struct ViewRecord {
  SignatureStatus status = SignatureStatus::kEmpty;
  /// SilhouetteFlag bits.
  uint32_t flags = 0;
  /// Silhouette measurements in the database image (pixels), for pose recovery from scale and
  /// position: see PolarSignature.
  float mean_radius_px = 0.0f;
  float centroid_x_px = 0.0f;
  float centroid_y_px = 0.0f;
  float area_px = 0.0f;
  float relative_std = 0.0f;
};

/// The spectra of a model's views as the matcher correlates them (match/view_matcher.h: the
/// band-limited spectrum of each view's smoothed, normalised signature), stored in the database so
/// that opening it transforms nothing: the matcher reads them where the file is mapped. Made by
/// StoreViewSpectra (match/view_matcher.h) before a database is written; empty (harmonics 0) in
/// databases of format version 3 and older and in databases made in memory, whose spectra are
/// computed when first used.
struct StoredSpectra {
  /// Bits of `kinds`.
  static constexpr uint8_t kPresent = 1;      ///< the view was described (ViewRecord::status ok)
  static constexpr uint8_t kHasVariance = 2;  ///< SignatureSpectrum::has_variance
  static constexpr uint8_t kUsable = 4;       ///< searched: described and not a perfect circle
  static constexpr uint8_t kAllBits = kPresent | kHasVariance | kUsable;

  /// The CorrelationOptions::smoothing_deg they were made with; used only by a matcher with the
  /// same smoothing and signature length.
  double smoothing_deg = 0.0;
  /// Coefficients (and magnitudes) per view, H: CircularCorrelator::harmonics(). 0 = none stored.
  uint32_t harmonics = 0;
  /// Per record (shell-major, as ModelViews::views): kPresent | kHasVariance | kUsable bits.
  SharedArray<uint8_t> kinds;
  /// Per record, H coefficients (SignatureSpectrum::coefficients; all 0 where not present).
  SharedArray<std::complex<float>> coefficients;
  /// Per record, H unweighted magnitudes (SignatureSpectrum::magnitudes). Not stored from format
  /// 5 on (they are the moduli of the coefficients; the matcher computes them): empty in databases
  /// read from such files.
  SharedArray<float> magnitudes;
  /// Per record, SignatureSpectrum::amplitude: what turns the coefficients back into the view's
  /// smoothed signature (ModelViews::Signature of a database without stored signatures); 0 where
  /// not present. Empty in databases read from files of format 4 and older.
  SharedArray<float> amplitudes;

  bool empty() const { return harmonics == 0; }
};

/// All views of one model, in every distance shell.
struct ModelViews {
  /// The model's name: its mesh file's stem.
  std::string name;
  /// The mesh path as given when the database was built (informative).
  std::string source_path;
  /// XXH64 of the mesh file's bytes.
  uint64_t mesh_hash = 0;
  /// Object centre and radius in model units (mesh/triangle_mesh.h).
  double centre[3] = {0.0, 0.0, 0.0};
  double radius = 0.0;
  uint32_t num_vertices = 0;
  uint32_t num_triangles = 0;
  /// The model's geometry (vertices in model units, triangles), kept so that a database alone
  /// suffices to refine poses against the frame and to draw the model; empty in databases made by
  /// hand (tests).
  TriangleMesh mesh;
  /// The model's symmetries, found by build-db from its surface (mesh/mesh_symmetry.h); none in
  /// databases of format version 2, which did not store them.
  ObjectSymmetry symmetry;
  /// One record per view and shell, shell-major: view v of shell s is views[s * N + v], N views.
  std::vector<ViewRecord> views;
  /// Signatures in the same order, M values each: (shell s, view v) is
  /// signatures[(s * N + v) * M, (s * N + v + 1) * M). Unusable views are all 0. In a database
  /// read from a file they refer to the mapped file, which they keep alive, also in copies of
  /// the model (util/shared_array.h). Empty when the signatures are not stored (a compact
  /// database, DropSignatures): Signature() then derives them from the stored spectra.
  SharedArray<float> signatures;
  /// The views' spectra, if stored (see StoredSpectra).
  StoredSpectra spectra;
  /// As read from a file of format 4 on: the XXH64 of each shell's block of signatures, stored
  /// coefficients and stored magnitudes (one per shell each; empty for what the file does not
  /// store: signatures of a compact model, magnitudes from format 5 on). Checked by
  /// ViewDatabase::CheckBlock. Empty for databases made in memory (writing computes them from the
  /// data).
  std::vector<uint64_t> signature_hashes;
  std::vector<uint64_t> coefficient_hashes;
  std::vector<uint64_t> magnitude_hashes;

  /// Shells held (views.size() / N for N views per shell).
  int num_shells(int num_views_per_shell) const;
  /// `view` of shell `shell`; view indices are per shell (0..N-1). Without stored signatures
  /// (signatures_stored() false) the signature is derived from the view's stored spectrum the
  /// first time it is asked for (one inverse FFT, thread-safe) and kept: it is then the
  /// signature smoothed as the spectra were (StoredSpectra::smoothing_deg, within about 1e-6),
  /// not the raw one.
  std::span<const float> Signature(int view, int shell = 0) const;
  /// Only for a model whose signatures are stored (the database builder's).
  std::span<float> MutableSignature(int view, int shell = 0);
  const ViewRecord& Record(int view, int shell = 0) const;
  int signature_length() const;
  /// False for a compact model: its signatures are derived from its stored spectra.
  bool signatures_stored() const { return derived_signatures_ == nullptr; }
  /// Makes the model compact: frees its signatures, which Signature() then derives from the
  /// stored spectra. Needs stored spectra with amplitudes (StoreViewSpectra, match/view_matcher.h)
  /// and the signature length M; throws silpose::Error otherwise. Copies of the model share the
  /// derived signatures.
  void DropSignatures(int signature_length);
  /// Views per shell (set by the database; records are views.size() / num_shells of them).
  int views_per_shell = 0;

 private:
  struct DerivedSignatures;
  /// Signatures derived from the spectra, for a model whose signatures are not stored.
  std::shared_ptr<DerivedSignatures> derived_signatures_;
};

/// The shell rule of ViewDatabase::ChooseShell for one view: `shell_apparent(s)` gives the view's
/// apparent size in shell s (0 if unusable), `distances_in_radii` the shells' distances. The gap
/// to shell s is |1 / D - 1 / D_s| with D = D_s a_s / a, i.e. |a / a_s - 1| / D_s.
template <typename ShellApparent>
int NearestShell(double apparent_radius, const std::vector<double>& distances_in_radii,
                 ShellApparent&& shell_apparent) {
  const int shells = static_cast<int>(distances_in_radii.size());
  if (shells <= 1 || !(apparent_radius > 0.0) || !std::isfinite(apparent_radius)) return 0;
  int best = 0;
  double best_gap = 0.0;
  bool found = false;
  for (int s = 0; s < shells; ++s) {
    const double a_s = shell_apparent(s);
    if (!(a_s > 0.0)) continue;
    const double gap =
        std::abs(apparent_radius / a_s - 1.0) / distances_in_radii[static_cast<size_t>(s)];
    if (!found || gap < best_gap) {
      best_gap = gap;
      best = s;
      found = true;
    }
  }
  return best;
}

/// When the bulk of a database file (the signatures and stored spectra) is checked on reading:
/// every structural field, count and small value is always checked at once.
enum class ViewChecks {
  /// Everything while reading: the checksum of the whole file, every view's values.
  kAtOpen,
  /// Format 4 and 5 files: the checksum of everything but the bulk at once; each shell's block of
  /// signatures, coefficients or magnitudes against its own checksum (ViewDatabase::CheckBlock)
  /// and each view's values (ViewDatabase::CheckView) when first used: ViewSpectra checks the
  /// blocks and views it reads (with stored spectra only those, not the signatures), and
  /// ViewSpectra::CheckSignatures a signature block and its views' signatures before the pose
  /// reads one; so opening a large database reads little of it. Older formats: the whole file's
  /// checksum at once, the views' values on first use.
  kOnFirstUse,
};

/// The bulk blocks of a database file, one per model and shell each (ViewDatabase::CheckBlock).
enum class ViewBlock { kSignatures, kCoefficients, kMagnitudes };

class ViewDatabase {
 public:
  /// Format version written by this build. Versions 2 (without symmetries), 3 (without stored
  /// spectra) and 4 (signatures always stored, with the spectra's magnitudes) are read too.
  static constexpr uint32_t kFormatVersion = 5;
  static constexpr uint32_t kOldestReadableVersion = 2;

  DatabaseParameters parameters;
  ViewSphere sphere;
  std::vector<ModelViews> models;
  /// The file the database was read from (for messages; empty if made in memory).
  std::string source;
  /// Keeps the mapped files that signatures and spectra refer to alive (empty if they are owned;
  /// several for a merge of databases).
  std::vector<std::shared_ptr<const void>> storage;
  /// Whether views still need CheckView before their values are used (ViewChecks::kOnFirstUse).
  bool views_unchecked = false;

  int num_views() const { return sphere.num_views(); }
  int num_shells() const { return parameters.num_shells(); }
  int signature_length() const { return parameters.signature.length; }
  /// Apparent size of view `view` of `model` in shell `shell`: its silhouette's mean radius in the
  /// database image divided by the database camera's focal length (a tangent; 0 if unusable).
  double ApparentRadius(int model, int view, int shell) const;
  /// The shell to match view `view` of `model` against, for a frame silhouette of apparent size
  /// `apparent_radius` (mean radius / focal length, in the on-axis virtual camera: pose/on_axis.h):
  /// the shell s minimising |1 / D_s - 1 / D|, D = D_s a_s / apparent_radius the distance the
  /// frame's size implies if it is that view at shell s (a_s = ApparentRadius). 0 when
  /// apparent_radius is not positive (unknown size) or there is one shell.
  int ChooseShell(int model, int view, double apparent_radius) const;
  /// Index of the model with this name, or -1.
  int FindModel(const std::string& name) const;
  /// ModelViews::DropSignatures for every model: the database becomes compact (about 1.2 kB per
  /// view and shell on disk instead of 5.2 kB at M = 1000; docs/database-format.md).
  void DropSignatures();

  /// Writes the database atomically: to a uniquely named temporary file beside `path`, renamed
  /// over it. A device, FIFO, symbolic link or folder at `path` is refused, never replaced.
  /// Throws silpose::Error naming the file if it cannot be written.
  void Write(const std::filesystem::path& path) const;
  /// Serialises to bytes (what Write writes): format kFormatVersion, or version 4, 3 or 2 (for
  /// older silpose builds; 3 and 2 without stored spectra, 2 without the symmetries; all only with
  /// every model's signatures stored). Throws silpose::Error for another version.
  std::string Serialize(uint32_t format_version = kFormatVersion) const;

  /// Checks the values of record `record` (shell-major index) of `model`: CheckViewSignature and
  /// CheckViewSpectrum. Throws silpose::Error naming `source`.
  void CheckView(int model, size_t record) const;
  /// The record's signature: finite, non-negative radii with mean 1 if the view was described.
  void CheckViewSignature(int model, size_t record) const;
  /// The record's stored spectrum (if the model has stored spectra): finite values, coefficients
  /// of modulus at most 1, magnitudes in [0, 1].
  void CheckViewSpectrum(int model, size_t record) const;
  /// CheckView for every view of every model.
  void CheckAllViews() const;
  /// Checks one shell's block of `model` against its checksum in the file (nothing to check for
  /// databases made in memory or read from older formats). Throws silpose::Error naming `source`.
  void CheckBlock(int model, int shell, ViewBlock block) const;

  /// Reads and checks a database file. The file is mapped into memory, not copied: signatures and
  /// stored spectra refer to it (opening takes milliseconds whatever the size; processes opening
  /// the same file share its memory). Throws silpose::Error naming the file and the problem.
  static ViewDatabase Read(const std::filesystem::path& path,
                           ViewChecks checks = ViewChecks::kOnFirstUse);
  /// Parses bytes; `source` names them in error messages. With `storage`, the signatures and
  /// spectra refer to `bytes` (which `storage` must keep alive); without, they are copied.
  static ViewDatabase Deserialize(std::string_view bytes, const std::string& source,
                                  ViewChecks checks = ViewChecks::kAtOpen,
                                  std::shared_ptr<const void> storage = nullptr);
};

}  // namespace silpose
