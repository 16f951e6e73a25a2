#include "silpose/database/view_database.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <complex>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <opencv2/core.hpp>
#include <set>
#include <sstream>
#include <type_traits>

#include "silpose/util/error.h"
#include "silpose/util/hash.h"
#include "silpose/util/mapped_file.h"
#include "silpose/util/output_file.h"

namespace silpose {
namespace {

// The file is little-endian; this code writes the host's representation directly.
static_assert(std::endian::native == std::endian::little,
              "the database reader/writer assumes a little-endian host");

constexpr char kMagic[8] = {'S', 'I', 'L', 'P', 'O', 'S', 'D', 'B'};
// magic, version (u32), payload size (u64)
constexpr size_t kHeaderSize = 8 + 4 + 8;
constexpr size_t kChecksumSize = 8;
constexpr uint32_t kSamplingFibonacci = 1;
constexpr uint32_t kRollReferenceZUp = 1;
// Signatures and stored spectra start at file offsets that are multiples of this (format 4 on),
// so that they can be used where the file is mapped.
constexpr size_t kArrayAlignment = 64;

class Writer {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <typename T>
  void PutArray(std::span<const T> values) {
    bytes_.append(reinterpret_cast<const char*>(values.data()), values.size_bytes());
  }
  void PutString(const std::string& text) {
    Put<uint32_t>(static_cast<uint32_t>(text.size()));
    bytes_.append(text);
  }
  /// Zero bytes up to the next file offset that is a multiple of kArrayAlignment.
  void Align() {
    bytes_.append((kArrayAlignment - bytes_.size() % kArrayAlignment) % kArrayAlignment, '\0');
  }
  /// An array left out of the structure checksum (it has checksums of its own).
  template <typename T>
  void PutBulk(std::span<const T> values) {
    bulk_.push_back({bytes_.size(), values.size_bytes()});
    PutArray<T>(values);
  }
  std::string& bytes() { return bytes_; }
  const std::vector<std::pair<size_t, size_t>>& bulk() const { return bulk_; }

 private:
  std::string bytes_;
  /// (offset, size) of the arrays written by PutBulk.
  std::vector<std::pair<size_t, size_t>> bulk_;
};

/// XXH64 of bytes [0, end) except the bulk ranges (increasing, inside [0, end)).
uint64_t StructureHash(std::string_view bytes, size_t end,
                       const std::vector<std::pair<size_t, size_t>>& bulk) {
  Hasher hasher;
  size_t position = 0;
  for (const auto& [offset, size] : bulk) {
    hasher.Update(bytes.data() + position, offset - position);
    position = offset + size;
  }
  hasher.Update(bytes.data() + position, end - position);
  return hasher.Digest();
}

/// XXH64 of each of `shells` equal consecutive blocks of `values`.
template <typename T>
std::vector<uint64_t> BlockHashes(std::span<const T> values, size_t shells) {
  std::vector<uint64_t> hashes;
  const size_t per_block = values.size() / shells;
  for (size_t s = 0; s < shells; ++s) {
    hashes.push_back(HashBytes(values.data() + s * per_block, per_block * sizeof(T)));
  }
  return hashes;
}

void PutVector(const Eigen::Vector3d& v, Writer* out) {
  for (int r = 0; r < 3; ++r) out->Put<double>(v[r]);
}

void WriteSymmetry(const ObjectSymmetry& symmetry, Writer* out) {
  out->Put<uint32_t>(static_cast<uint32_t>(symmetry.discrete.size()));
  for (const Rigid3& d : symmetry.discrete) {
    for (int r = 0; r < 3; ++r) PutVector(d.rotation.row(r).transpose(), out);  // row-major
    PutVector(d.translation, out);
  }
  out->Put<uint32_t>(static_cast<uint32_t>(symmetry.continuous.size()));
  for (const ContinuousSymmetry& c : symmetry.continuous) {
    PutVector(c.axis, out);
    PutVector(c.offset, out);
  }
  out->Put<uint32_t>(static_cast<uint32_t>(symmetry.mirrors.size()));
  for (const MirrorSymmetry& m : symmetry.mirrors) {
    PutVector(m.normal, out);
    PutVector(m.offset, out);
  }
}

class Reader {
 public:
  /// `bytes` start at file offset `offset`; with `storage` (which keeps `bytes` alive), arrays
  /// refer to `bytes` instead of copying them, and keep `storage` alive.
  Reader(std::string_view bytes, const std::string& source, size_t offset,
         std::shared_ptr<const void> storage)
      : bytes_(bytes), source_(source), offset_(offset), storage_(std::move(storage)) {}

  template <typename T>
  T Get(const char* what) {
    static_assert(std::is_trivially_copyable_v<T>);
    Need(sizeof(T), what);
    T value;
    std::memcpy(&value, bytes_.data() + position_, sizeof(T));
    position_ += sizeof(T);
    return value;
  }
  template <typename T>
  void GetArray(std::span<T> values, const char* what) {
    Need(values.size_bytes(), what);
    if (values.empty()) return;  // memcpy must not get the null data() of an empty vector
    std::memcpy(values.data(), bytes_.data() + position_, values.size_bytes());
    position_ += values.size_bytes();
  }
  /// `count` values of type T: referring to the bytes when the reader refers and they are aligned,
  /// else copied.
  template <typename T>
  SharedArray<T> GetShared(size_t count, const char* what, bool bulk = false) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (count > remaining() / sizeof(T)) Fail(what, " run past the end of the data");
    const char* data = bytes_.data() + position_;
    if (bulk) bulk_.push_back({offset_ + position_, count * sizeof(T)});
    position_ += count * sizeof(T);
    if (storage_ && reinterpret_cast<uintptr_t>(data) % alignof(T) == 0) {
      return SharedArray<T>::Refer(reinterpret_cast<const T*>(data), count, storage_);
    }
    std::vector<T> values(count);
    if (count > 0) std::memcpy(values.data(), data, count * sizeof(T));
    return SharedArray<T>(std::move(values));
  }
  /// Skips the zero bytes up to the next file offset that is a multiple of kArrayAlignment.
  void Align(const char* what) {
    const size_t padding =
        (kArrayAlignment - (offset_ + position_) % kArrayAlignment) % kArrayAlignment;
    Need(padding, what);
    for (size_t i = 0; i < padding; ++i) {
      if (bytes_[position_ + i] != '\0') Fail("non-zero padding before the ", what);
    }
    position_ += padding;
  }
  std::string GetString(const char* what, size_t max_length) {
    const auto length = Get<uint32_t>(what);
    if (length > max_length) Fail(what, " is ", length, " bytes long (at most ", max_length, ")");
    Need(length, what);
    std::string text(bytes_.substr(position_, length));
    position_ += length;
    return text;
  }
  size_t remaining() const { return bytes_.size() - position_; }
  /// (file offset, size) of the arrays read by GetShared(..., bulk = true).
  const std::vector<std::pair<size_t, size_t>>& bulk() const { return bulk_; }

  template <typename... Parts>
  [[noreturn]] void Fail(const Parts&... parts) const {
    ThrowError(source_, ": corrupt database: ", parts...);
  }

 private:
  void Need(size_t size, const char* what) const {
    if (size > remaining()) Fail(what, " runs past the end of the data");
  }

  std::string_view bytes_;
  const std::string& source_;
  size_t offset_;
  std::shared_ptr<const void> storage_;
  size_t position_ = 0;
  std::vector<std::pair<size_t, size_t>> bulk_;
};

// What a model without stored spectra has.
const StoredSpectra kNoSpectra{};

// Counts read from the file are checked against this before anything is allocated.
constexpr uint32_t kMaxViews = 1'000'000;
constexpr uint32_t kMaxModels = 100'000;
constexpr size_t kMaxShells = 16;

}  // namespace

bool DatabaseParameters::Check(std::string* error) const {
  std::string detail;
  if (!view_sphere.Check(&detail)) {
    if (error != nullptr) *error = "view sphere: " + detail;
    return false;
  }
  if (!render.Check(&detail)) {
    if (error != nullptr) *error = "rendering: " + detail;
    return false;
  }
  if (!signature.Check(&detail)) {
    if (error != nullptr) *error = "signature: " + detail;
    return false;
  }
  std::ostringstream message;
  if (distances_in_radii.empty() || distances_in_radii.size() > kMaxShells) {
    message << "shells: 1 to " << kMaxShells << " distances needed, got "
            << distances_in_radii.size();
  } else {
    for (size_t s = 0; s < distances_in_radii.size(); ++s) {
      const double d = distances_in_radii[s];
      if (!std::isfinite(d) || !(d > 1.0) || d > 1e6) {
        message << "shell distance must be finite, > 1 and <= 1e6 object radii, got " << d;
        break;
      }
      if (s > 0 && !(d > distances_in_radii[s - 1])) {
        message << "shell distances must increase strictly, got " << distances_in_radii[s - 1]
                << " then " << d;
        break;
      }
    }
  }
  if (!message.str().empty()) {
    if (error != nullptr) *error = message.str();
    return false;
  }
  return true;
}

ViewRenderOptions DatabaseParameters::ShellRender(int shell) const {
  SILPOSE_ASSERT(shell >= 0 && shell < num_shells());
  ViewRenderOptions options = render;
  options.distance_in_radii = distances_in_radii[static_cast<size_t>(shell)];
  return options;
}

bool DatabaseParameters::operator==(const DatabaseParameters& other) const {
  const auto& a = *this;
  const auto& b = other;
  return a.view_sphere.num_views == b.view_sphere.num_views &&
         a.view_sphere.neighbour_radius_factor == b.view_sphere.neighbour_radius_factor &&
         a.view_sphere.num_bins == b.view_sphere.num_bins &&
         a.view_sphere.kmeans_seed == b.view_sphere.kmeans_seed &&
         a.view_sphere.kmeans_max_iterations == b.view_sphere.kmeans_max_iterations &&
         a.render.resolution_px == b.render.resolution_px &&
         a.distances_in_radii == b.distances_in_radii &&
         a.render.fill_fraction == b.render.fill_fraction &&
         a.signature.length == b.signature.length &&
         a.signature.min_area_px == b.signature.min_area_px &&
         a.signature.circular_threshold == b.signature.circular_threshold;
}

int ModelViews::num_shells(int num_views_per_shell) const {
  return num_views_per_shell > 0 ? static_cast<int>(views.size()) / num_views_per_shell : 0;
}

namespace {
size_t RecordIndex(const ModelViews& model, int view, int shell) {
  const size_t per_shell =
      model.views_per_shell > 0 ? static_cast<size_t>(model.views_per_shell) : model.views.size();
  SILPOSE_ASSERT(view >= 0 && static_cast<size_t>(view) < per_shell && shell >= 0);
  const size_t index = static_cast<size_t>(shell) * per_shell + static_cast<size_t>(view);
  SILPOSE_ASSERT(index < model.views.size());
  return index;
}
}  // namespace

// The signatures of a compact model, derived from its stored spectra as they are asked for: one
// block of M floats per record, allocated (not touched) per shell on first use.
// The spectra they are derived from are held here (their arrays share the data, or the mapped
// file, with the model's): a copy of the model whose `spectra` are later replaced still derives
// from the spectra its cache was made for.
struct ModelViews::DerivedSignatures {
  DerivedSignatures(const StoredSpectra& from, size_t records, size_t shells, size_t radii)
      : spectra(from),
        length(radii),
        records_per_shell(records / shells),
        blocks(shells),
        block_once(std::make_unique<std::once_flag[]>(shells)),
        view_once(std::make_unique<std::once_flag[]>(records)) {}
  StoredSpectra spectra;
  size_t length;
  size_t records_per_shell;
  std::vector<std::unique_ptr<float[]>> blocks;
  std::unique_ptr<std::once_flag[]> block_once;
  std::unique_ptr<std::once_flag[]> view_once;
};

namespace {

// The smoothed signature of one view from its stored spectrum (StoredSpectra): radii
// 1 + a * sum_k C_k exp(2 pi i k x / M) over the full Hermitian spectrum, of which the H stored
// harmonics are the non-zero ones (SignatureSpectrum::amplitude). All 0 for a view without one.
void DeriveSignature(const StoredSpectra& spectra, size_t record, std::span<float> out) {
  const size_t length = out.size();
  const float amplitude = spectra.amplitudes[record];
  if ((spectra.kinds[record] & StoredSpectra::kPresent) == 0) {
    std::fill(out.begin(), out.end(), 0.0f);
    return;
  }
  // OpenCV's packed layout of a real signal's spectrum (CCS): Re C_0, Re C_1, Im C_1, ...,
  // Re C_{M/2}; its inverse without DFT_SCALE is the unnormalised sum above.
  cv::Mat packed(1, static_cast<int>(length), CV_32F, cv::Scalar(0));
  auto* p = packed.ptr<float>();
  const std::complex<float>* c = spectra.coefficients.data() + record * spectra.harmonics;
  const size_t h = std::min<size_t>(spectra.harmonics, length / 2 + 1);
  // C_0 is 0 (the spectrum of a zero-mean signature): the radii keep mean 1 whatever is stored.
  for (size_t k = 1; k < h; ++k) {
    if (k == length / 2) {
      p[length - 1] = c[k].real();
    } else {
      p[2 * k - 1] = c[k].real();
      p[2 * k] = c[k].imag();
    }
  }
  cv::Mat signal(1, static_cast<int>(length), CV_32F, out.data());
  cv::dft(packed, signal, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT);
  // A radius is never negative; the band-limited sum can dip a rounding error below 0.
  for (float& r : out) r = std::max(0.0f, 1.0f + amplitude * r);
}

}  // namespace

std::span<const float> ModelViews::Signature(int view, int shell) const {
  const size_t record = RecordIndex(*this, view, shell);
  if (derived_signatures_ == nullptr) {
    const size_t length = signatures.size() / views.size();
    return {signatures.data() + record * length, length};
  }
  DerivedSignatures& derived = *derived_signatures_;
  const size_t s = record / derived.records_per_shell;
  std::call_once(derived.block_once[s], [&] {
    derived.blocks[s] =
        std::make_unique_for_overwrite<float[]>(derived.records_per_shell * derived.length);
  });
  const std::span<float> out(
      derived.blocks[s].get() + (record % derived.records_per_shell) * derived.length,
      derived.length);
  std::call_once(derived.view_once[record], [&] { DeriveSignature(derived.spectra, record, out); });
  return out;
}

std::span<float> ModelViews::MutableSignature(int view, int shell) {
  if (derived_signatures_ != nullptr) {
    ThrowError("model '", name, "' has no stored signatures to change (a compact database)");
  }
  const size_t length = signatures.size() / views.size();
  return {signatures.mutable_data() + RecordIndex(*this, view, shell) * length, length};
}

void ModelViews::DropSignatures(int signature_length) {
  if (derived_signatures_ != nullptr) return;
  const size_t records = views.size();
  // views_per_shell 0: one shell (databases made by hand).
  const size_t per_shell =
      views_per_shell > 0 ? static_cast<size_t>(views_per_shell) : std::max<size_t>(records, 1);
  if (records == 0 || records % per_shell != 0)
    ThrowError("model '", name, "': cannot drop the signatures of a model without view records");
  if (signature_length < 2 || signature_length % 2 != 0)
    ThrowError("model '", name, "': signature length ", signature_length, " is not even");
  if (spectra.empty() || spectra.amplitudes.size() != records || spectra.kinds.size() != records ||
      spectra.coefficients.size() != records * spectra.harmonics)
    ThrowError("model '", name,
               "': its signatures can only be dropped with stored spectra and amplitudes "
               "(StoreViewSpectra)");
  derived_signatures_ = std::make_shared<DerivedSignatures>(spectra, records, records / per_shell,
                                                            static_cast<size_t>(signature_length));
  signatures = SharedArray<float>();
  signature_hashes.clear();
}

const ViewRecord& ModelViews::Record(int view, int shell) const {
  return views[RecordIndex(*this, view, shell)];
}

double ViewDatabase::ApparentRadius(int model, int view, int shell) const {
  const ViewRecord& record = models[static_cast<size_t>(model)].Record(view, shell);
  if (record.status != SignatureStatus::kOk) return 0.0;
  return record.mean_radius_px / ViewCamera(parameters.ShellRender(shell)).focal_x_px;
}

int ViewDatabase::ChooseShell(int model, int view, double apparent_radius) const {
  return NearestShell(apparent_radius, parameters.distances_in_radii,
                      [&](int shell) { return ApparentRadius(model, view, shell); });
}

int ModelViews::signature_length() const {
  if (derived_signatures_ != nullptr) return static_cast<int>(derived_signatures_->length);
  return views.empty() ? 0 : static_cast<int>(signatures.size() / views.size());
}

void ViewDatabase::DropSignatures() {
  for (ModelViews& model : models) model.DropSignatures(signature_length());
}

int ViewDatabase::FindModel(const std::string& name) const {
  for (size_t i = 0; i < models.size(); ++i) {
    if (models[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::string ViewDatabase::Serialize(uint32_t format_version) const {
  if (format_version < kOldestReadableVersion || format_version > kFormatVersion)
    ThrowError("cannot write database format version ", format_version, " (",
               kOldestReadableVersion, " to ", kFormatVersion, ")");
  for (const ModelViews& model : models) {
    if (format_version < 5 && !model.signatures_stored()) {
      ThrowError("cannot write database format version ", format_version, ": model '", model.name,
                 "' has no stored signatures (a compact database; format 5 on)");
    }
    if (!model.signatures_stored() &&
        (model.spectra.empty() || model.spectra.amplitudes.size() != model.views.size())) {
      ThrowError("cannot write model '", model.name,
                 "': its signatures are not stored and its spectra are missing or incomplete");
    }
  }
  std::string error;
  if (!parameters.Check(&error)) ThrowError("cannot write database: ", error);
  const auto num_views = static_cast<uint32_t>(sphere.num_views());
  const auto length = static_cast<uint32_t>(parameters.signature.length);
  SILPOSE_ASSERT(num_views == static_cast<uint32_t>(parameters.view_sphere.num_views));

  Writer out;
  out.bytes().append(kMagic, sizeof(kMagic));
  out.Put<uint32_t>(format_version);
  out.Put<uint64_t>(0);  // payload size, patched below

  // Generation parameters.
  out.Put<uint32_t>(kSamplingFibonacci);
  out.Put<uint32_t>(kRollReferenceZUp);
  out.Put<uint32_t>(num_views);
  out.Put<double>(parameters.view_sphere.neighbour_radius_factor);
  out.Put<uint32_t>(static_cast<uint32_t>(parameters.view_sphere.num_bins));
  out.Put<uint64_t>(parameters.view_sphere.kmeans_seed);
  out.Put<uint32_t>(static_cast<uint32_t>(parameters.view_sphere.kmeans_max_iterations));
  out.Put<uint32_t>(static_cast<uint32_t>(parameters.render.resolution_px));
  out.Put<uint32_t>(static_cast<uint32_t>(parameters.num_shells()));
  for (double d : parameters.distances_in_radii) out.Put<double>(d);
  out.Put<double>(parameters.render.fill_fraction);
  out.Put<uint32_t>(length);
  out.Put<double>(parameters.signature.min_area_px);
  out.Put<double>(parameters.signature.circular_threshold);

  // View sphere.
  out.Put<double>(sphere.typical_spacing_rad);
  for (const auto& d : sphere.directions) {
    out.Put<double>(d.x());
    out.Put<double>(d.y());
    out.Put<double>(d.z());
  }
  out.Put<uint32_t>(static_cast<uint32_t>(sphere.neighbour_indices.size()));
  out.PutArray<uint32_t>(sphere.neighbour_offsets);
  out.PutArray<uint32_t>(sphere.neighbour_indices);
  out.Put<uint32_t>(static_cast<uint32_t>(sphere.num_bins()));
  for (const auto& c : sphere.bin_centres) {
    out.Put<double>(c.x());
    out.Put<double>(c.y());
    out.Put<double>(c.z());
  }
  out.PutArray<uint32_t>(sphere.bin_of_view);

  // Models.
  out.Put<uint32_t>(static_cast<uint32_t>(models.size()));
  for (const ModelViews& model : models) {
    const size_t records = static_cast<size_t>(num_views) * parameters.distances_in_radii.size();
    SILPOSE_ASSERT(model.views.size() == records);
    SILPOSE_ASSERT(!model.signatures_stored() || model.signatures.size() == records * length);
    SILPOSE_ASSERT(model.signature_length() == static_cast<int>(length));
    out.PutString(model.name);
    out.PutString(model.source_path);
    out.Put<uint64_t>(model.mesh_hash);
    for (double c : model.centre) out.Put<double>(c);
    out.Put<double>(model.radius);
    out.Put<uint32_t>(model.num_vertices);
    out.Put<uint32_t>(model.num_triangles);
    // Stored geometry (may be empty).
    out.Put<uint32_t>(static_cast<uint32_t>(model.mesh.vertices.size()));
    out.Put<uint32_t>(static_cast<uint32_t>(model.mesh.triangles.size()));
    for (const auto& p : model.mesh.vertices) {
      for (int i = 0; i < 3; ++i) out.Put<float>(p[i]);
    }
    for (const auto& t : model.mesh.triangles) {
      for (uint32_t index : t) out.Put<uint32_t>(index);
    }
    if (format_version >= 3) WriteSymmetry(model.symmetry, &out);
    for (const ViewRecord& view : model.views) {
      out.Put<uint8_t>(static_cast<uint8_t>(view.status));
      out.Put<uint32_t>(view.flags);
      out.Put<float>(view.mean_radius_px);
      out.Put<float>(view.centroid_x_px);
      out.Put<float>(view.centroid_y_px);
      out.Put<float>(view.area_px);
      out.Put<float>(view.relative_std);
    }
    if (format_version < 4) {
      out.PutArray<float>(model.signatures);
      continue;
    }
    const size_t shells = parameters.distances_in_radii.size();
    // Spectra without amplitudes (read from a format-4 file) are not written in format 5: the
    // model keeps its signatures, from which a matcher makes the spectra when first used (and
    // StoreViewSpectra, as merge-db does, stores them again with their amplitudes).
    const bool incomplete =
        format_version >= 5 && !model.spectra.empty() && model.spectra.amplitudes.size() != records;
    const StoredSpectra& spectra = incomplete ? kNoSpectra : model.spectra;
    // Format 5: whether the signatures follow (else they are derived from the spectra).
    if (format_version >= 5) out.Put<uint8_t>(model.signatures_stored() ? 1 : 0);
    if (model.signatures_stored()) {
      for (uint64_t hash : BlockHashes<float>(model.signatures, shells)) out.Put<uint64_t>(hash);
      out.Align();
      out.PutBulk<float>(model.signatures);
    }
    out.Put<double>(spectra.empty() ? 0.0 : spectra.smoothing_deg);
    out.Put<uint32_t>(spectra.harmonics);
    if (!spectra.empty()) {
      SILPOSE_ASSERT(spectra.kinds.size() == records);
      SILPOSE_ASSERT(spectra.coefficients.size() == records * spectra.harmonics);
      out.PutArray<uint8_t>(spectra.kinds);
      if (format_version >= 5) out.PutArray<float>(spectra.amplitudes);
      for (uint64_t hash : BlockHashes<std::complex<float>>(spectra.coefficients, shells))
        out.Put<uint64_t>(hash);
      // Format 4 stores the magnitudes too: the moduli of the coefficients.
      SharedArray<float> magnitudes = spectra.magnitudes;
      if (format_version == 4 && magnitudes.size() != records * spectra.harmonics) {
        std::vector<float> moduli(spectra.coefficients.size());
        for (size_t i = 0; i < moduli.size(); ++i) moduli[i] = std::abs(spectra.coefficients[i]);
        magnitudes = std::move(moduli);
      }
      if (format_version == 4) {
        for (uint64_t hash : BlockHashes<float>(magnitudes, shells)) out.Put<uint64_t>(hash);
      }
      out.Align();
      out.PutBulk<std::complex<float>>(spectra.coefficients);
      if (format_version == 4) out.PutBulk<float>(magnitudes);
    }
  }

  std::string& bytes = out.bytes();
  // Format 4: the payload ends with the checksum of everything before it but the bulk arrays.
  const size_t structure_checksum = format_version >= 4 ? sizeof(uint64_t) : 0;
  const uint64_t payload_size = bytes.size() + structure_checksum - kHeaderSize;
  std::memcpy(bytes.data() + 12, &payload_size, sizeof(payload_size));
  if (format_version >= 4) out.Put<uint64_t>(StructureHash(bytes, bytes.size(), out.bulk()));
  const uint64_t checksum = HashBytes(bytes.data(), bytes.size());
  out.Put<uint64_t>(checksum);
  return std::move(bytes);
}

void ViewDatabase::Write(const std::filesystem::path& path) const {
  // A unique temporary file, then a rename: a killed build never leaves a half-written database
  // under the name, and a device, FIFO or symbolic link at the path is refused, not replaced.
  WriteFileAtomically(path, Serialize());
}

ViewDatabase ViewDatabase::Read(const std::filesystem::path& path, ViewChecks checks) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) ThrowError(path.string(), ": no such file");
  if (std::filesystem::is_directory(path, error)) {
    ThrowError(path.string(), ": is a directory, not a database file");
  }
  const std::shared_ptr<const MappedFile> file = MappedFile::Open(path);
  return Deserialize(file->bytes(), path.string(), checks, file);
}

namespace {

// Independent partial results per lane, so that the compiler vectorises the loops below without
// reordering any floating-point sum.
constexpr size_t kCheckLanes = 8;

// Whether all `count` values are finite and >= 0 (a NaN or an infinity makes the sum non-finite);
// their sum in *sum.
bool FiniteNonNegative(const float* values, size_t count, double* sum) {
  std::array<double, kCheckLanes> sums{};
  std::array<float, kCheckLanes> lowest;
  lowest.fill(std::numeric_limits<float>::max());
  size_t i = 0;
  for (; i + kCheckLanes <= count; i += kCheckLanes) {
    for (size_t j = 0; j < kCheckLanes; ++j) {
      const float v = values[i + j];
      sums[j] += v;
      lowest[j] = v < lowest[j] ? v : lowest[j];
    }
  }
  double total = 0.0;
  float low = std::numeric_limits<float>::max();
  for (; i < count; ++i) {
    total += values[i];
    low = values[i] < low ? values[i] : low;
  }
  for (size_t j = 0; j < kCheckLanes; ++j) {
    total += sums[j];
    low = lowest[j] < low ? lowest[j] : low;
  }
  *sum = total;
  return std::isfinite(total) && low >= 0.0f;
}

// Whether a stored spectrum's values are surely valid (finite, magnitudes in [0, 1], |c| clearly
// below 1): a quick test that vectorises; values it does not pass are checked one by one.
// `magnitudes` is null when they are not stored (format 5).
bool SpectrumSurelyValid(const std::complex<float>* coefficients, const float* magnitudes,
                         size_t count) {
  const float* parts = reinterpret_cast<const float*>(coefficients);
  std::array<float, kCheckLanes> sums{}, largest_norm{};
  for (size_t i = 0; i + kCheckLanes <= 2 * count; i += kCheckLanes) {
    for (size_t j = 0; j < kCheckLanes; j += 2) {
      const float re = parts[i + j];
      const float im = parts[i + j + 1];
      const float norm = re * re + im * im;
      sums[j] += re + im;
      largest_norm[j] = norm > largest_norm[j] ? norm : largest_norm[j];
    }
  }
  double total = 0.0;
  float norm = 0.0f;
  for (size_t k = 2 * count / kCheckLanes * kCheckLanes / 2; k < count; ++k) {
    total += coefficients[k].real() + coefficients[k].imag();
    norm = std::max(norm, std::norm(coefficients[k]));
  }
  for (size_t j = 0; j < kCheckLanes; ++j) {
    total += sums[j];
    norm = std::max(norm, largest_norm[j]);
  }
  // A NaN in a coefficient makes the total NaN and fails the test.
  if (magnitudes == nullptr) return std::isfinite(total) && norm <= 0.999f;
  double magnitude_sum = 0.0;
  if (!FiniteNonNegative(magnitudes, count, &magnitude_sum)) return false;
  float largest_magnitude = 0.0f;
  for (size_t k = 0; k < count; ++k) {
    largest_magnitude = magnitudes[k] > largest_magnitude ? magnitudes[k] : largest_magnitude;
  }
  // A NaN in a coefficient makes the total NaN and fails the test.
  return std::isfinite(total) && norm <= 0.999f && largest_magnitude <= 1.0f;
}

}  // namespace

void ViewDatabase::CheckView(int model_index, size_t record) const {
  // A compact model's signature is its spectrum (CheckViewSignature checks that).
  if (models[static_cast<size_t>(model_index)].signatures_stored()) {
    CheckViewSignature(model_index, record);
  }
  CheckViewSpectrum(model_index, record);
}

void ViewDatabase::CheckViewSignature(int model_index, size_t record) const {
  const ModelViews& model = models[static_cast<size_t>(model_index)];
  const size_t per_shell = static_cast<size_t>(sphere.num_views());
  const auto fail = [&](const char* problem) {
    ThrowError(source.empty() ? std::string("database") : source, ": corrupt database: model '",
               model.name, "' view ", record % per_shell, " of shell ", record / per_shell, " has ",
               problem);
  };
  if (!model.signatures_stored()) {
    // Derived from the stored spectrum (ModelViews::Signature): its values are what is checked.
    CheckViewSpectrum(model_index, record);
    return;
  }
  const size_t length = static_cast<size_t>(signature_length());
  const float* radii = model.signatures.data() + record * length;
  double sum = 0.0;
  if (!FiniteNonNegative(radii, length, &sum)) fail("an invalid signature value");
  const bool described = model.views[record].status == SignatureStatus::kOk;
  // A described view's radii are divided by their mean: their mean is 1.
  if (described && std::abs(sum / static_cast<double>(length) - 1.0) > 1e-3) {
    fail("a signature that is not normalised");
  }
}

void ViewDatabase::CheckViewSpectrum(int model_index, size_t record) const {
  const ModelViews& model = models[static_cast<size_t>(model_index)];
  const StoredSpectra& spectra = model.spectra;
  if (spectra.empty()) return;
  const size_t h = spectra.harmonics;
  const std::complex<float>* coefficients = spectra.coefficients.data() + record * h;
  // Format 5 stores no magnitudes (the matcher computes them from the coefficients).
  const float* magnitudes =
      spectra.magnitudes.empty() ? nullptr : spectra.magnitudes.data() + record * h;
  if (SpectrumSurelyValid(coefficients, magnitudes, h)) return;
  bool valid = true;
  for (size_t k = 0; k < h; ++k) {
    valid = valid && std::isfinite(coefficients[k].real()) &&
            std::isfinite(coefficients[k].imag()) && std::abs(coefficients[k]) <= 1.0f;
    if (magnitudes != nullptr) {
      valid =
          valid && std::isfinite(magnitudes[k]) && magnitudes[k] >= 0.0f && magnitudes[k] <= 1.0f;
    }
  }
  if (!valid) {
    const size_t per_shell = static_cast<size_t>(sphere.num_views());
    ThrowError(source.empty() ? std::string("database") : source, ": corrupt database: model '",
               model.name, "' view ", record % per_shell, " of shell ", record / per_shell,
               " has an invalid stored spectrum value");
  }
}

void ViewDatabase::CheckBlock(int model_index, int shell, ViewBlock block) const {
  const ModelViews& model = models[static_cast<size_t>(model_index)];
  const auto s = static_cast<size_t>(shell);
  const size_t views = static_cast<size_t>(sphere.num_views());
  const char* name = "signatures";
  const void* data = nullptr;
  size_t size = 0;
  uint64_t expected = 0;
  if (block == ViewBlock::kSignatures && !model.signatures_stored()) {
    // Derived from the stored coefficients: those are the block to check.
    block = ViewBlock::kCoefficients;
  }
  if (block == ViewBlock::kSignatures) {
    if (model.signature_hashes.size() <= s) return;
    const size_t values = views * static_cast<size_t>(signature_length());
    data = model.signatures.data() + s * values;
    size = values * sizeof(float);
    expected = model.signature_hashes[s];
  } else {
    const std::vector<uint64_t>& hashes =
        block == ViewBlock::kCoefficients ? model.coefficient_hashes : model.magnitude_hashes;
    if (hashes.size() <= s) return;
    const size_t values = views * model.spectra.harmonics;
    if (block == ViewBlock::kCoefficients) {
      name = "stored spectra";
      data = model.spectra.coefficients.data() + s * values;
      size = values * sizeof(std::complex<float>);
    } else {
      name = "stored spectrum magnitudes";
      data = model.spectra.magnitudes.data() + s * values;
      size = values * sizeof(float);
    }
    expected = hashes[s];
  }
  if (HashBytes(data, size) != expected) {
    ThrowError(source.empty() ? std::string("database") : source,
               ": corrupt database (checksum mismatch in the ", name, " of model '", model.name,
               "', shell ", shell, ")");
  }
}

void ViewDatabase::CheckAllViews() const {
  for (size_t m = 0; m < models.size(); ++m) {
    for (size_t r = 0; r < models[m].views.size(); ++r) CheckView(static_cast<int>(m), r);
  }
}

ViewDatabase ViewDatabase::Deserialize(std::string_view bytes, const std::string& source,
                                       ViewChecks checks, std::shared_ptr<const void> storage) {
  const size_t magic_bytes = std::min(bytes.size(), sizeof(kMagic));
  if (bytes.empty() || std::memcmp(bytes.data(), kMagic, magic_bytes) != 0) {
    ThrowError(source, ": not a silpose view database (no SILPOSDB magic number)");
  }
  if (bytes.size() < kHeaderSize + kChecksumSize) {
    ThrowError(source, ": truncated database (", bytes.size(), " bytes, header alone needs ",
               kHeaderSize + kChecksumSize, ")");
  }
  uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, sizeof(version));
  if (version < kOldestReadableVersion || version > kFormatVersion) {
    ThrowError(source, ": database format version ", version, ", this silpose reads versions ",
               kOldestReadableVersion, " to ", kFormatVersion,
               "; rebuild it with 'silpose build-db'");
  }
  uint64_t payload_size = 0;
  std::memcpy(&payload_size, bytes.data() + 12, sizeof(payload_size));
  const uint64_t available = bytes.size() - kHeaderSize - kChecksumSize;
  if (payload_size > available) {
    ThrowError(source, ": truncated database (", bytes.size(), " bytes, its header announces ",
               payload_size + kHeaderSize + kChecksumSize, ")");
  }
  if (payload_size < available) {
    ThrowError(source, ": corrupt database (", available - payload_size,
               " bytes more than its header announces)");
  }
  // Format 4 or 5 read with ViewChecks::kOnFirstUse: the structure checksum below instead of the
  // whole file's; the bulk is checked block by block when used (CheckBlock).
  const bool lazy = version >= 4 && checks == ViewChecks::kOnFirstUse;
  if (!lazy) {
    uint64_t stored_checksum = 0;
    std::memcpy(&stored_checksum, bytes.data() + bytes.size() - kChecksumSize, kChecksumSize);
    if (HashBytes(bytes.data(), bytes.size() - kChecksumSize) != stored_checksum) {
      ThrowError(source, ": corrupt database (checksum mismatch)");
    }
  }
  const size_t structure_checksum = version >= 4 ? sizeof(uint64_t) : 0;
  if (payload_size < structure_checksum) ThrowError(source, ": truncated database (no payload)");

  Reader in(bytes.substr(kHeaderSize, payload_size - structure_checksum), source, kHeaderSize,
            storage);
  ViewDatabase database;
  DatabaseParameters& parameters = database.parameters;
  if (in.Get<uint32_t>("sampling method") != kSamplingFibonacci) in.Fail("unknown sampling method");
  if (in.Get<uint32_t>("roll reference") != kRollReferenceZUp) in.Fail("unknown roll reference");
  const auto num_views = in.Get<uint32_t>("view count");
  if (num_views < 4 || num_views > kMaxViews) in.Fail("view count ", num_views, " out of range");
  parameters.view_sphere.num_views = static_cast<int>(num_views);
  parameters.view_sphere.neighbour_radius_factor = in.Get<double>("neighbour radius");
  parameters.view_sphere.num_bins = static_cast<int>(in.Get<uint32_t>("bin count"));
  parameters.view_sphere.kmeans_seed = in.Get<uint64_t>("k-means seed");
  parameters.view_sphere.kmeans_max_iterations =
      static_cast<int>(in.Get<uint32_t>("k-means iterations"));
  parameters.render.resolution_px = static_cast<int>(in.Get<uint32_t>("resolution"));
  const auto num_shells = in.Get<uint32_t>("shell count");
  if (num_shells < 1 || num_shells > kMaxShells)
    in.Fail("shell count ", num_shells, " out of range");
  parameters.distances_in_radii.resize(num_shells);
  for (double& d : parameters.distances_in_radii) d = in.Get<double>("shell distance");
  parameters.render.distance_in_radii = parameters.distances_in_radii.front();
  parameters.render.fill_fraction = in.Get<double>("fill fraction");
  const auto length = in.Get<uint32_t>("signature length");
  parameters.signature.length = static_cast<int>(std::min<uint32_t>(length, 1u << 30));
  parameters.signature.min_area_px = in.Get<double>("minimum area");
  parameters.signature.circular_threshold = in.Get<double>("circularity threshold");
  std::string error;
  if (!parameters.Check(&error)) in.Fail("invalid parameters: ", error);

  ViewSphere& sphere = database.sphere;
  sphere.typical_spacing_rad = in.Get<double>("view spacing");
  if (!(sphere.typical_spacing_rad > 0.0) || !std::isfinite(sphere.typical_spacing_rad)) {
    in.Fail("view spacing ", sphere.typical_spacing_rad, " is not positive");
  }
  auto need = [&in](uint64_t count, uint64_t element_size, const char* what) {
    if (count * element_size > in.remaining()) in.Fail(what, " run past the end of the data");
  };
  need(num_views, 3 * sizeof(double), "view directions");
  sphere.directions.resize(num_views);
  for (auto& d : sphere.directions) {
    d.x() = in.Get<double>("view directions");
    d.y() = in.Get<double>("view directions");
    d.z() = in.Get<double>("view directions");
    if (!d.allFinite() || std::abs(d.norm() - 1.0) > 1e-6)
      in.Fail("a view direction is not a unit vector");
  }
  const auto num_edges = in.Get<uint32_t>("neighbour count");
  if (num_edges > static_cast<uint64_t>(num_views) * ViewSphereOptions::kMaxMeanNeighbours)
    in.Fail("neighbour count ", num_edges, " out of range");
  need(static_cast<uint64_t>(num_views) + 1 + num_edges, sizeof(uint32_t), "neighbour lists");
  sphere.neighbour_offsets.resize(num_views + 1);
  sphere.neighbour_indices.resize(num_edges);
  in.GetArray<uint32_t>(sphere.neighbour_offsets, "neighbour offsets");
  in.GetArray<uint32_t>(sphere.neighbour_indices, "neighbour indices");
  if (sphere.neighbour_offsets.front() != 0 || sphere.neighbour_offsets.back() != num_edges) {
    in.Fail("neighbour offsets do not span the neighbour list");
  }
  for (uint32_t v = 0; v < num_views; ++v) {
    if (sphere.neighbour_offsets[v] > sphere.neighbour_offsets[v + 1])
      in.Fail("neighbour offsets decrease");
  }
  for (uint32_t i : sphere.neighbour_indices) {
    if (i >= num_views) in.Fail("neighbour index ", i, " out of range");
  }
  const auto num_bins = in.Get<uint32_t>("bin count");
  if (static_cast<int>(num_bins) != parameters.view_sphere.num_bins) in.Fail("bin count mismatch");
  need(num_bins, 3 * sizeof(double), "bin centres");
  sphere.bin_centres.resize(num_bins);
  for (auto& c : sphere.bin_centres) {
    c.x() = in.Get<double>("bin centres");
    c.y() = in.Get<double>("bin centres");
    c.z() = in.Get<double>("bin centres");
    if (!c.allFinite()) in.Fail("a bin centre is not finite");
  }
  sphere.bin_of_view.resize(num_views);
  in.GetArray<uint32_t>(sphere.bin_of_view, "bin labels");
  for (uint32_t b : sphere.bin_of_view) {
    if (b >= num_bins) in.Fail("bin label ", b, " out of range");
  }

  const auto num_models = in.Get<uint32_t>("model count");
  if (num_models > kMaxModels) in.Fail("model count ", num_models, " out of range");
  const size_t num_records = static_cast<size_t>(num_views) * num_shells;
  // At least a record and a signature per view, or (format 5, signatures not stored) a record,
  // a spectrum kind and an amplitude.
  const size_t per_model_bytes =
      num_records * (version >= 5 ? 25 + 1 + 4 : 25 + 4 * static_cast<size_t>(length));
  if (static_cast<size_t>(num_models) * per_model_bytes > in.remaining()) {
    in.Fail(num_models, " models of ", num_views, " views do not fit in the file");
  }
  std::set<std::string> names;
  database.models.resize(num_models);
  for (ModelViews& model : database.models) {
    model.name = in.GetString("model name", 4096);
    if (model.name.empty()) in.Fail("a model has an empty name");
    if (!names.insert(model.name).second) in.Fail("model name '", model.name, "' appears twice");
    model.source_path = in.GetString("model path", 1 << 16);
    model.mesh_hash = in.Get<uint64_t>("mesh hash");
    for (double& c : model.centre) c = in.Get<double>("model centre");
    if (!std::isfinite(model.centre[0]) || !std::isfinite(model.centre[1]) ||
        !std::isfinite(model.centre[2])) {
      in.Fail("model '", model.name, "' has a non-finite centre");
    }
    model.radius = in.Get<double>("model radius");
    if (!(model.radius > 0.0) || !std::isfinite(model.radius))
      in.Fail("model '", model.name, "' has radius ", model.radius);
    model.num_vertices = in.Get<uint32_t>("vertex count");
    model.num_triangles = in.Get<uint32_t>("triangle count");
    const auto stored_vertices = in.Get<uint32_t>("stored vertex count");
    const auto stored_triangles = in.Get<uint32_t>("stored triangle count");
    need(stored_vertices, 3 * sizeof(float), "stored vertices");
    need(stored_triangles, 3 * sizeof(uint32_t), "stored triangles");
    model.mesh.name = model.name;
    model.mesh.vertices.resize(stored_vertices);
    for (auto& p : model.mesh.vertices) {
      for (int i = 0; i < 3; ++i) p[i] = in.Get<float>("stored vertices");
      if (!p.allFinite()) in.Fail("model '", model.name, "' has a non-finite stored vertex");
    }
    model.mesh.triangles.resize(stored_triangles);
    for (auto& t : model.mesh.triangles) {
      for (size_t i = 0; i < 3; ++i) {
        const auto index = in.Get<uint32_t>("stored triangles");
        if (index >= stored_vertices)
          in.Fail("model '", model.name, "' has a triangle index out of range");
        t[i] = index;
      }
    }
    if (version >= 3) {
      ObjectSymmetry& symmetry = model.symmetry;
      // A count of at most kMaxEntries entries of `doubles` values each that fit in what is left.
      const auto count = [&](const char* what, const char* entries, uint64_t doubles) {
        const auto n = in.Get<uint32_t>(what);
        if (n > ObjectSymmetry::kMaxEntries) in.Fail(what, " ", n, " out of range");
        need(n, doubles * sizeof(double), entries);
        return n;
      };
      const auto vector = [&in](const char* what) {
        Eigen::Vector3d v;
        for (int r = 0; r < 3; ++r) v[r] = in.Get<double>(what);
        return v;
      };
      symmetry.discrete.resize(count("discrete symmetry count", "discrete symmetries", 12));
      for (Rigid3& d : symmetry.discrete) {
        for (int r = 0; r < 3; ++r) d.rotation.row(r) = vector("discrete symmetries").transpose();
        d.translation = vector("discrete symmetries");
      }
      symmetry.continuous.resize(count("continuous symmetry count", "continuous symmetries", 6));
      for (ContinuousSymmetry& c : symmetry.continuous) {
        c.axis = vector("continuous symmetries");
        c.offset = vector("continuous symmetries");
      }
      symmetry.mirrors.resize(count("mirror plane count", "mirror planes", 6));
      for (MirrorSymmetry& m : symmetry.mirrors) {
        m.normal = vector("mirror planes");
        m.offset = vector("mirror planes");
      }
      std::string problem;
      if (!symmetry.Check(&problem))
        in.Fail("model '", model.name, "' has invalid symmetries: ", problem);
    }
    model.views_per_shell = static_cast<int>(num_views);
    model.views.resize(num_records);
    for (ViewRecord& view : model.views) {
      const auto status = in.Get<uint8_t>("view status");
      if (status > static_cast<uint8_t>(SignatureStatus::kTooSmall))
        in.Fail("view status ", int{status}, " unknown");
      view.status = static_cast<SignatureStatus>(status);
      view.flags = in.Get<uint32_t>("view flags");
      view.mean_radius_px = in.Get<float>("view radius");
      view.centroid_x_px = in.Get<float>("view centroid");
      view.centroid_y_px = in.Get<float>("view centroid");
      view.area_px = in.Get<float>("view area");
      view.relative_std = in.Get<float>("view deviation");
      if (!std::isfinite(view.mean_radius_px) || !std::isfinite(view.centroid_x_px) ||
          !std::isfinite(view.centroid_y_px) || !std::isfinite(view.area_px) ||
          !std::isfinite(view.relative_std)) {
        in.Fail("model '", model.name, "' has a non-finite view record");
      }
    }
    bool signatures_stored = true;
    if (version >= 5) {
      const auto contents = in.Get<uint8_t>("signature storage");
      if (contents > 1) in.Fail("model '", model.name, "' has signature storage ", int{contents});
      signatures_stored = contents == 1;
    }
    if (signatures_stored) {
      if (version >= 4) {
        for (uint32_t s = 0; s < num_shells; ++s)
          model.signature_hashes.push_back(in.Get<uint64_t>("signature checksums"));
        in.Align("signatures");
      }
      model.signatures = in.GetShared<float>(num_records * length, "signatures", version >= 4);
    }
    if (std::none_of(model.views.begin(), model.views.end(),
                     [](const ViewRecord& view) { return view.status == SignatureStatus::kOk; })) {
      in.Fail("model '", model.name,
              "' has no view with a usable silhouette (built from a degenerate mesh?)");
    }
    if (version >= 4) {
      StoredSpectra& spectra = model.spectra;
      spectra.smoothing_deg = in.Get<double>("spectrum smoothing");
      spectra.harmonics = in.Get<uint32_t>("spectrum harmonics");
      if (!std::isfinite(spectra.smoothing_deg) || spectra.smoothing_deg < 0.0 ||
          spectra.smoothing_deg > 360.0) {
        in.Fail("model '", model.name, "' has spectrum smoothing ", spectra.smoothing_deg);
      }
      if (spectra.harmonics > length / 2 + 1) {
        in.Fail("model '", model.name, "' has ", spectra.harmonics,
                " harmonics per stored spectrum (at most ", length / 2 + 1, ")");
      }
      if (!spectra.empty()) {
        spectra.kinds = in.GetShared<uint8_t>(num_records, "spectrum kinds");
        for (size_t r = 0; r < num_records; ++r) {
          const uint8_t kind = spectra.kinds[r];
          const bool present = (kind & StoredSpectra::kPresent) != 0;
          if ((kind & ~StoredSpectra::kAllBits) != 0 ||
              present != (model.views[r].status == SignatureStatus::kOk) ||
              (!present && kind != 0)) {
            in.Fail("model '", model.name, "' view ", r % num_views, " of shell ", r / num_views,
                    " has spectrum kind ", int{kind}, " that does not fit its record");
          }
        }
        if (version >= 5) {
          spectra.amplitudes = in.GetShared<float>(num_records, "spectrum amplitudes");
          for (size_t r = 0; r < num_records; ++r) {
            const float amplitude = spectra.amplitudes[r];
            // The relative spread of a signature (its radii have mean 1) is far below 1e3.
            // Views without variance (and views not described) have none.
            if (!std::isfinite(amplitude) || amplitude < 0.0f || amplitude > 1e3f ||
                ((spectra.kinds[r] & StoredSpectra::kHasVariance) == 0 && amplitude != 0.0f)) {
              in.Fail("model '", model.name, "' view ", r % num_views, " of shell ", r / num_views,
                      " has spectrum amplitude ", amplitude);
            }
          }
        }
        for (uint32_t s = 0; s < num_shells; ++s)
          model.coefficient_hashes.push_back(in.Get<uint64_t>("spectrum checksums"));
        if (version == 4) {
          for (uint32_t s = 0; s < num_shells; ++s)
            model.magnitude_hashes.push_back(in.Get<uint64_t>("spectrum checksums"));
        }
        in.Align("stored spectra");
        const size_t values = num_records * spectra.harmonics;
        spectra.coefficients = in.GetShared<std::complex<float>>(values, "stored spectra", true);
        if (version == 4)
          spectra.magnitudes = in.GetShared<float>(values, "stored spectrum magnitudes", true);
      }
    }
    if (!signatures_stored) {
      if (model.spectra.empty()) {
        in.Fail("model '", model.name, "' has neither signatures nor stored spectra");
      }
      model.DropSignatures(static_cast<int>(length));
    }
  }
  if (in.remaining() != 0) in.Fail(in.remaining(), " unexpected bytes after the last model");
  if (lazy) {
    const size_t end = kHeaderSize + payload_size - structure_checksum;
    uint64_t stored = 0;
    std::memcpy(&stored, bytes.data() + end, sizeof(stored));
    if (StructureHash(bytes, end, in.bulk()) != stored) {
      ThrowError(source, ": corrupt database (checksum mismatch)");
    }
  }
  database.source = source;
  if (storage) database.storage.push_back(std::move(storage));
  if (checks == ViewChecks::kAtOpen) {
    database.CheckAllViews();
  } else {
    database.views_unchecked = true;
  }
  return database;
}

}  // namespace silpose
