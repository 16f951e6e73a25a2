#include "silpose/database/view_database.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>

#include "silpose/util/error.h"
#include "silpose/util/hash.h"

namespace silpose {
namespace {

// A small but complete database with made-up contents (no rendering), for the file format.
ViewDatabase SmallDatabase() {
  ViewDatabase database;
  DatabaseParameters& parameters = database.parameters;
  parameters.view_sphere.num_views = 12;
  parameters.view_sphere.num_bins = 3;
  parameters.signature.length = 32;
  parameters.render.resolution_px = 64;
  parameters.distances_in_radii = {3.0, 10.0};  // two distance shells
  database.sphere = BuildViewSphere(parameters.view_sphere);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> radius(0.5f, 1.5f);
  for (const char* name : {"alpha", "beta"}) {
    ModelViews model;
    model.name = name;
    model.source_path = std::string("/models/") + name + ".obj";
    model.mesh_hash = 0x0123456789abcdefULL;
    model.centre[0] = 1.0;
    model.centre[1] = -2.0;
    model.centre[2] = 3.5;
    model.radius = 4.25;
    model.num_vertices = 100;
    model.num_triangles = 196;
    // A stored tetrahedron.
    model.mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.5f}};
    model.mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
    model.views_per_shell = 12;
    model.views.resize(24);
    model.signatures.resize(24 * 32);
    for (int index = 0; index < 24; ++index) {
      const int v = index % 12;
      const int shell = index / 12;
      ViewRecord& record = model.views[static_cast<size_t>(index)];
      record.status = v == 5 ? SignatureStatus::kTooSmall : SignatureStatus::kOk;
      record.flags = static_cast<uint32_t>(v % 4);
      record.mean_radius_px = 20.0f + static_cast<float>(v) - 5.0f * static_cast<float>(shell);
      record.centroid_x_px = 31.5f;
      record.centroid_y_px = 30.0f;
      record.area_px = 900.0f;
      record.relative_std = 0.1f;
      if (v != 5) {  // radii divided by their mean, as the builder writes them
        double mean = 0.0;
        for (float& r : model.MutableSignature(v, shell)) mean += (r = radius(rng));
        for (float& r : model.MutableSignature(v, shell)) r = static_cast<float>(r / (mean / 32.0));
      }
    }
    database.models.push_back(std::move(model));
  }
  return database;
}

std::string ErrorOf(const std::string& bytes) {
  try {
    ViewDatabase::Deserialize(bytes, "test.db");
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

// SmallDatabase with stored spectra of 3 harmonics made up from the signatures (format 4).
ViewDatabase SmallDatabaseWithSpectra() {
  ViewDatabase database = SmallDatabase();
  for (ModelViews& model : database.models) {
    StoredSpectra& spectra = model.spectra;
    spectra.smoothing_deg = 2.0;
    spectra.harmonics = 3;
    std::vector<uint8_t> kinds(model.views.size());
    std::vector<std::complex<float>> coefficients(model.views.size() * 3);
    std::vector<float> magnitudes(coefficients.size());
    std::vector<float> amplitudes(model.views.size(), 0.0f);
    for (size_t r = 0; r < model.views.size(); ++r) {
      if (model.views[r].status != SignatureStatus::kOk) continue;
      kinds[r] = StoredSpectra::kPresent | StoredSpectra::kHasVariance | StoredSpectra::kUsable;
      amplitudes[r] = 0.25f + 0.01f * static_cast<float>(r);
      for (size_t k = 1; k < 3; ++k) {
        coefficients[r * 3 + k] = {0.1f * model.signatures[r * 32 + k], -0.05f};
        magnitudes[r * 3 + k] = std::abs(coefficients[r * 3 + k]);
      }
    }
    spectra.kinds = std::move(kinds);
    spectra.coefficients = std::move(coefficients);
    spectra.magnitudes = std::move(magnitudes);
    spectra.amplitudes = std::move(amplitudes);
  }
  return database;
}

// Reads bytes as ViewDatabase::Read reads a file (kOnFirstUse), the arrays referring to `bytes`,
// then uses every block and view as a matcher would. Returns the first error, or "".
std::string LazyErrorOf(const std::string& bytes, ViewDatabase* out = nullptr) {
  try {
    const auto keep = std::make_shared<std::string>(bytes);
    ViewDatabase database =
        ViewDatabase::Deserialize(*keep, "test.db", ViewChecks::kOnFirstUse, keep);
    if (out != nullptr) *out = database;
    for (int m = 0; m < static_cast<int>(database.models.size()); ++m) {
      for (int s = 0; s < database.num_shells(); ++s) {
        for (ViewBlock block :
             {ViewBlock::kSignatures, ViewBlock::kCoefficients, ViewBlock::kMagnitudes}) {
          database.CheckBlock(m, s, block);
        }
      }
    }
    database.CheckAllViews();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

void Recompute(std::string* bytes) {
  const uint64_t checksum = HashBytes(bytes->data(), bytes->size() - 8);
  std::memcpy(bytes->data() + bytes->size() - 8, &checksum, 8);
}

TEST(ViewDatabaseFile, RoundTripKeepsEverything) {
  const ViewDatabase original = SmallDatabase();
  const auto path = std::filesystem::temp_directory_path() / "silpose_roundtrip.db";
  original.Write(path);
  const ViewDatabase loaded = ViewDatabase::Read(path);
  std::filesystem::remove(path);
  EXPECT_TRUE(loaded.parameters == original.parameters);
  EXPECT_EQ(loaded.sphere.directions, original.sphere.directions);
  EXPECT_EQ(loaded.sphere.typical_spacing_rad, original.sphere.typical_spacing_rad);
  EXPECT_EQ(loaded.sphere.neighbour_offsets, original.sphere.neighbour_offsets);
  EXPECT_EQ(loaded.sphere.neighbour_indices, original.sphere.neighbour_indices);
  EXPECT_EQ(loaded.sphere.bin_of_view, original.sphere.bin_of_view);
  EXPECT_EQ(loaded.sphere.bin_centres, original.sphere.bin_centres);
  ASSERT_EQ(loaded.models.size(), 2u);
  for (size_t m = 0; m < 2; ++m) {
    const ModelViews& a = original.models[m];
    const ModelViews& b = loaded.models[m];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.source_path, b.source_path);
    EXPECT_EQ(a.mesh_hash, b.mesh_hash);
    EXPECT_EQ(a.radius, b.radius);
    EXPECT_EQ(a.centre[2], b.centre[2]);
    EXPECT_EQ(a.num_triangles, b.num_triangles);
    EXPECT_EQ(a.signatures, b.signatures);
    EXPECT_EQ(a.mesh.vertices, b.mesh.vertices);
    EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
    EXPECT_EQ(b.views_per_shell, 12);
    ASSERT_EQ(b.views.size(), 24u);
    for (size_t v = 0; v < a.views.size(); ++v) {
      EXPECT_EQ(a.views[v].status, b.views[v].status);
      EXPECT_EQ(a.views[v].flags, b.views[v].flags);
      EXPECT_EQ(a.views[v].mean_radius_px, b.views[v].mean_radius_px);
    }
  }
  EXPECT_EQ(loaded.num_shells(), 2);
  EXPECT_EQ(loaded.parameters.distances_in_radii, (std::vector<double>{3.0, 10.0}));
  EXPECT_EQ(loaded.FindModel("beta"), 1);
  EXPECT_EQ(loaded.FindModel("gamma"), -1);
  EXPECT_EQ(loaded.Serialize(), original.Serialize());
}

TEST(ViewDatabaseFile, SymmetriesRoundTripAndVersion2FilesReadWithoutThem) {
  ViewDatabase original = SmallDatabase();
  ObjectSymmetry& symmetry = original.models[1].symmetry;
  symmetry.continuous.push_back(
      {.axis = Eigen::Vector3d(0.0, 1.0, 0.0), .offset = Eigen::Vector3d(1.0, -2.0, 3.5)});
  Rigid3 flip;
  flip.rotation = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  flip.translation = Eigen::Vector3d(0.0, -4.0, 7.0);
  symmetry.discrete.push_back(flip);
  symmetry.mirrors.push_back(
      {.normal = Eigen::Vector3d(0.0, 0.0, 1.0), .offset = Eigen::Vector3d(1.0, -2.0, 3.5)});
  const ViewDatabase loaded = ViewDatabase::Deserialize(original.Serialize(), "test.db");
  EXPECT_FALSE(loaded.models[0].symmetry.HasRotations());
  const ObjectSymmetry& read = loaded.models[1].symmetry;
  ASSERT_EQ(read.continuous.size(), 1u);
  EXPECT_EQ(read.continuous[0].axis, symmetry.continuous[0].axis);
  EXPECT_EQ(read.continuous[0].offset, symmetry.continuous[0].offset);
  ASSERT_EQ(read.discrete.size(), 1u);
  EXPECT_EQ(read.discrete[0].rotation, flip.rotation);
  EXPECT_EQ(read.discrete[0].translation, flip.translation);
  ASSERT_EQ(read.mirrors.size(), 1u);
  EXPECT_EQ(read.mirrors[0].normal, symmetry.mirrors[0].normal);

  // Version 2: everything but the symmetries.
  const std::string old_bytes = original.Serialize(2);
  uint32_t version = 0;
  std::memcpy(&version, old_bytes.data() + 8, 4);
  EXPECT_EQ(version, 2u);
  const ViewDatabase old = ViewDatabase::Deserialize(old_bytes, "old.db");
  EXPECT_FALSE(old.models[1].symmetry.HasRotations());
  EXPECT_TRUE(old.models[1].symmetry.mirrors.empty());
  EXPECT_EQ(old.models[1].signatures, original.models[1].signatures);
  EXPECT_EQ(old.models[1].mesh.vertices, original.models[1].mesh.vertices);
  EXPECT_THROW(original.Serialize(1), Error);
  EXPECT_THROW(original.Serialize(ViewDatabase::kFormatVersion + 1), Error);
}

TEST(ViewDatabaseFile, InvalidSymmetriesAreRefused) {
  ViewDatabase database = SmallDatabase();
  Rigid3 not_a_rotation;
  not_a_rotation.rotation(0, 0) = 2.0;  // a scaling
  database.models[0].symmetry.discrete.push_back(not_a_rotation);
  std::string message = ErrorOf(database.Serialize());
  EXPECT_NE(message.find("model 'alpha' has invalid symmetries"), std::string::npos) << message;
  database = SmallDatabase();
  database.models[1].symmetry.continuous.push_back({.axis = Eigen::Vector3d::Zero()});
  message = ErrorOf(database.Serialize());
  EXPECT_NE(message.find("model 'beta' has invalid symmetries"), std::string::npos) << message;
}

TEST(ViewDatabaseShells, ChoosesTheShellNearestInInverseDistance) {
  const ViewDatabase database = SmallDatabase();
  // View 3: mean radius 23 px at 3 radii, 18 px at 10 radii (made-up records), both shells with
  // the same camera framing, so apparent sizes a_s = r_s / f.
  const double a3 = database.ApparentRadius(0, 3, 0);
  const double a10 = database.ApparentRadius(0, 3, 1);
  ASSERT_GT(a3, 0.0);
  ASSERT_GT(a10, 0.0);
  // A frame exactly as large as a shell's view picks that shell.
  EXPECT_EQ(database.ChooseShell(0, 3, a3), 0);
  EXPECT_EQ(database.ChooseShell(0, 3, a10), 1);
  // Seen three times farther than the near shell: 1/D = 1/9, nearer to 1/10 than to 1/3.
  EXPECT_EQ(database.ChooseShell(0, 3, a3 / 3.0), 1);
  // Twice as large as the near shell's view (1/D = 2/3): the near shell.
  EXPECT_EQ(database.ChooseShell(0, 3, 2.0 * a3), 0);
  // Unknown size: the first shell. An unusable view (5) has no size in either shell.
  EXPECT_EQ(database.ChooseShell(0, 3, 0.0), 0);
  EXPECT_EQ(database.ApparentRadius(0, 5, 1), 0.0);
}

TEST(ViewDatabaseShells, ParametersRefuseBadShells) {
  DatabaseParameters parameters;
  std::string error;
  parameters.distances_in_radii = {};
  EXPECT_FALSE(parameters.Check(&error));
  EXPECT_NE(error.find("shells"), std::string::npos) << error;
  parameters.distances_in_radii = {3.0, 3.0};
  EXPECT_FALSE(parameters.Check(&error));
  EXPECT_NE(error.find("increase"), std::string::npos) << error;
  parameters.distances_in_radii = {0.5};
  EXPECT_FALSE(parameters.Check(&error));
  parameters.distances_in_radii = {3.0, std::numeric_limits<double>::infinity()};
  EXPECT_FALSE(parameters.Check(&error));
  parameters.distances_in_radii = {3.0, 4.5, 7.5, 20.0};
  EXPECT_TRUE(parameters.Check(&error)) << error;
}

TEST(ViewDatabaseFile, EverySingleByteCorruptionIsRefused) {
  const std::string bytes = SmallDatabase().Serialize();
  ASSERT_GT(bytes.size(), 1000u);
  for (size_t i = 0; i < bytes.size(); ++i) {
    for (uint8_t change : {uint8_t{0x01}, uint8_t{0xff}}) {
      std::string corrupt = bytes;
      corrupt[i] = static_cast<char>(corrupt[i] ^ change);
      const std::string message = ErrorOf(corrupt);
      ASSERT_FALSE(message.empty()) << "byte " << i << " changed, file accepted";
      ASSERT_EQ(message.rfind("test.db: ", 0), 0u) << message;
    }
  }
}

TEST(ViewDatabaseFile, Format5StoresSpectraAndMapsTheBulkInsteadOfCopyingIt) {
  const ViewDatabase original = SmallDatabaseWithSpectra();
  const auto path = std::filesystem::temp_directory_path() /
                    ("silpose_mapped_" + std::to_string(::getpid()) + ".db");
  original.Write(path);
  {
    const ViewDatabase loaded = ViewDatabase::Read(path);
    EXPECT_TRUE(loaded.views_unchecked);
    EXPECT_EQ(loaded.source, path.string());
    ASSERT_EQ(loaded.storage.size(), 1u);
    for (size_t m = 0; m < 2; ++m) {
      const ModelViews& a = original.models[m];
      const ModelViews& b = loaded.models[m];
      // The bulk refers to the mapped file, aligned for its element type.
      EXPECT_TRUE(b.signatures.referring());
      EXPECT_TRUE(b.spectra.coefficients.referring());
      EXPECT_EQ(reinterpret_cast<uintptr_t>(b.signatures.data()) % 64, 0u);
      EXPECT_EQ(reinterpret_cast<uintptr_t>(b.spectra.coefficients.data()) % 64, 0u);
      EXPECT_EQ(a.signatures, b.signatures);
      EXPECT_EQ(b.spectra.harmonics, 3u);
      EXPECT_EQ(b.spectra.smoothing_deg, 2.0);
      EXPECT_EQ(a.spectra.kinds, b.spectra.kinds);
      EXPECT_EQ(a.spectra.coefficients, b.spectra.coefficients);
      EXPECT_EQ(a.spectra.amplitudes, b.spectra.amplitudes);
      // Format 5 stores no magnitudes: they are the coefficients' moduli, made by the matcher.
      EXPECT_TRUE(b.spectra.magnitudes.empty());
      EXPECT_EQ(b.signature_hashes.size(), 2u);
      EXPECT_EQ(b.coefficient_hashes.size(), 2u);
      EXPECT_TRUE(b.magnitude_hashes.empty());
      // Format 4, for older silpose builds, stores them.
      const ViewDatabase v4 = ViewDatabase::Deserialize(loaded.Serialize(4), "v4.db");
      const ModelViews& c = v4.models[m];
      EXPECT_EQ(c.signatures, a.signatures);
      EXPECT_EQ(c.spectra.coefficients, a.spectra.coefficients);
      ASSERT_EQ(c.spectra.magnitudes.size(), a.spectra.coefficients.size());
      for (size_t i = 0; i < c.spectra.magnitudes.size(); ++i) {
        EXPECT_EQ(c.spectra.magnitudes[i], std::abs(a.spectra.coefficients[i]));
      }
      EXPECT_TRUE(c.spectra.amplitudes.empty());
      // A database read from a format-4 file is written in format 5 without its spectra (no
      // amplitudes to derive signatures with; they are remade from the signatures when used).
      const ViewDatabase v5 = ViewDatabase::Deserialize(v4.Serialize(), "v5.db");
      EXPECT_TRUE(v5.models[m].spectra.empty());
      EXPECT_EQ(v5.models[m].signatures, a.signatures);
    }
    // A copy shares the mapping and outlives the original; writing to it copies (never the file).
    ViewDatabase copy = loaded;
    EXPECT_EQ(copy.models[0].signatures.data(), loaded.models[0].signatures.data());
    copy.models[0].MutableSignature(0)[0] = 7.0f;
    EXPECT_FALSE(copy.models[0].signatures.referring());
    EXPECT_NE(loaded.models[0].Signature(0)[0], 7.0f);
    EXPECT_EQ(loaded.Serialize(), original.Serialize());
    // Older formats are written and read too.
    for (uint32_t version : {2u, 3u}) {
      const ViewDatabase old = ViewDatabase::Deserialize(loaded.Serialize(version), "old.db");
      EXPECT_TRUE(old.models[1].spectra.empty());
      EXPECT_EQ(old.models[1].signatures, original.models[1].signatures);
    }
  }
  // A model copied out of a database read from a file keeps the mapping alive after the database
  // and the file's name are gone.
  ModelViews survivor;
  {
    const ViewDatabase loaded = ViewDatabase::Read(path);
    survivor = loaded.models[1];
  }
  std::filesystem::remove(path);
  EXPECT_TRUE(survivor.signatures.referring());
  EXPECT_EQ(survivor.signatures, original.models[1].signatures);
  EXPECT_EQ(survivor.spectra.coefficients, original.models[1].spectra.coefficients);
}

// Every single-byte change of `bytes` but the whole file's checksum (the last 8 bytes, only read
// by ViewChecks::kAtOpen) is refused by LazyErrorOf with a message naming the file.
void ExpectEveryByteCorruptionRefusedLazily(const std::string& bytes) {
  for (size_t i = 0; i + 8 < bytes.size(); ++i) {
    std::string corrupt = bytes;
    corrupt[i] = static_cast<char>(corrupt[i] ^ 0x10);
    const std::string message = LazyErrorOf(corrupt);
    ASSERT_FALSE(message.empty()) << "byte " << i << " changed, file accepted";
    ASSERT_EQ(message.rfind("test.db: ", 0), 0u) << message;
  }
}

TEST(ViewDatabaseFile, ReadLazilyEverySingleByteCorruptionIsRefusedAtOpenOrFirstUse) {
  const std::string bytes = SmallDatabaseWithSpectra().Serialize();
  ASSERT_EQ(LazyErrorOf(bytes), "");
  ExpectEveryByteCorruptionRefusedLazily(bytes);
}

// The same for a compact file (signatures not stored, derived from the spectra): its bulk is the
// coefficients alone, its amplitudes part of the structure.
TEST(ViewDatabaseFile, CompactFileEverySingleByteCorruptionIsRefusedAtOpenOrFirstUse) {
  ViewDatabase compact = SmallDatabaseWithSpectra();
  compact.DropSignatures();
  const std::string bytes = compact.Serialize();
  EXPECT_LT(bytes.size(), SmallDatabaseWithSpectra().Serialize().size() / 2);
  ViewDatabase read;
  ASSERT_EQ(LazyErrorOf(bytes, &read), "");
  EXPECT_FALSE(read.models[1].signatures_stored());
  EXPECT_EQ(read.models[1].spectra.amplitudes, compact.models[1].spectra.amplitudes);
  ExpectEveryByteCorruptionRefusedLazily(bytes);
}

TEST(ViewDatabaseFile, ReadLazilyACorruptBlockIsNamedWhenFirstUsedAndOnlyThen) {
  const std::string bytes = SmallDatabaseWithSpectra().Serialize();
  const auto open = [](const std::string& data) {
    const auto keep = std::make_shared<std::string>(data);
    return ViewDatabase::Deserialize(*keep, "test.db", ViewChecks::kOnFirstUse, keep);
  };
  const auto error_of = [](auto&& use) -> std::string {
    try {
      use();
    } catch (const Error& error) {
      return error.what();
    }
    return "";
  };
  // Where model beta's shell-1 signatures and shell-0 magnitudes lie in the file.
  const auto keep = std::make_shared<std::string>(bytes);
  const ViewDatabase good =
      ViewDatabase::Deserialize(*keep, "test.db", ViewChecks::kOnFirstUse, keep);
  const auto offset = [&](const void* p) {
    return static_cast<size_t>(static_cast<const char*>(p) - keep->data());
  };
  const size_t signature = offset(good.models[1].Signature(0, 1).data());
  const size_t coefficient = offset(good.models[1].spectra.coefficients.data());
  struct Case {
    size_t at;
    int shell;
    ViewBlock block;
    const char* name;
  };
  for (const Case& c : {Case{signature + 5, 1, ViewBlock::kSignatures, "signatures"},
                        Case{coefficient + 3, 0, ViewBlock::kCoefficients, "stored spectra"}}) {
    // (Named copies: lambdas cannot capture structured bindings in every compiler.)
    const size_t at = c.at;
    const int shell = c.shell;
    const ViewBlock block = c.block;
    const char* name = c.name;
    std::string corrupt = bytes;
    corrupt[at] = static_cast<char>(corrupt[at] ^ 0x10);
    // Opens (only the structure is checked at once), and every other block is fine.
    const ViewDatabase database = open(corrupt);
    EXPECT_EQ(error_of([&] { database.CheckBlock(0, shell, block); }), "");
    EXPECT_EQ(error_of([&] { database.CheckBlock(1, 1 - shell, block); }), "");
    const std::string message = error_of([&] { database.CheckBlock(1, shell, block); });
    EXPECT_NE(
        message.find("test.db: corrupt database (checksum mismatch in the " + std::string(name) +
                     " of model 'beta', shell " + std::to_string(shell) + ")"),
        std::string::npos)
        << message;
    // Read at once, the whole file's checksum refuses it.
    EXPECT_NE(ErrorOf(corrupt).find("checksum mismatch"), std::string::npos);
  }
  // Impossible values behind valid checksums (a crafted file) are refused when the view is used.
  ViewDatabase crafted = SmallDatabaseWithSpectra();
  crafted.models[0].spectra.coefficients.mutable_data()[3 * 7 + 1] = {
      std::numeric_limits<float>::infinity(), 0.0f};
  const ViewDatabase opened = open(crafted.Serialize());
  EXPECT_EQ(error_of([&] { opened.CheckView(0, 6); }), "");
  EXPECT_NE(error_of([&] { opened.CheckView(0, 7); })
                .find("test.db: corrupt database: model 'alpha' view 7 of shell 0 has an invalid "
                      "stored spectrum value"),
            std::string::npos);
  EXPECT_NE(ErrorOf(crafted.Serialize()).find("invalid stored spectrum value"), std::string::npos);
}

// CheckView tests values in lanes with a scalar tail: a bad value is found at every position, of a
// signature and of a spectrum whose lengths are not multiples of the lanes, and the values at the
// edge of the valid range are judged as one by one.
TEST(ViewDatabaseChecks, AnInvalidValueIsFoundWhereverItIs) {
  constexpr size_t kLength = 37;
  constexpr size_t kHarmonics = 13;
  ViewDatabase database = SmallDatabase();
  database.parameters.signature.length = static_cast<int>(kLength);
  ModelViews& model = database.models[0];
  model.signatures.resize(model.views.size() * kLength);
  std::fill_n(model.signatures.mutable_data(), model.signatures.size(), 1.0f);
  StoredSpectra& spectra = model.spectra;
  spectra.smoothing_deg = 2.0;
  spectra.harmonics = kHarmonics;
  spectra.kinds = std::vector<uint8_t>(model.views.size(), StoredSpectra::kPresent);
  spectra.coefficients = std::vector<std::complex<float>>(model.views.size() * kHarmonics,
                                                          std::complex<float>(0.3f, -0.2f));
  spectra.magnitudes = std::vector<float>(model.views.size() * kHarmonics, 0.36f);
  const size_t record = 14;  // view 2 of shell 1
  const auto error = [&] {
    try {
      database.CheckView(0, record);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  ASSERT_EQ(error(), "");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();

  float* radii = model.signatures.mutable_data() + record * kLength;
  for (size_t i = 0; i < kLength; ++i) {
    for (const float bad : {nan, inf, -inf, -0.5f}) {
      radii[i] = bad;
      EXPECT_NE(error().find("view 2 of shell 1 has an invalid signature value"), std::string::npos)
          << "radius " << i << " = " << bad << ": " << error();
    }
    radii[i] = 1.0f + 0.03f;  // the mean moves by 0.03 / 37 < 1e-3
    EXPECT_EQ(error(), "") << i;
    radii[i] = 1.0f + 0.05f;  // by 0.05 / 37 > 1e-3
    EXPECT_NE(error().find("not normalised"), std::string::npos) << i;
    radii[i] = 1.0f;
  }

  std::complex<float>* coefficients = spectra.coefficients.mutable_data() + record * kHarmonics;
  float* magnitudes = spectra.magnitudes.mutable_data() + record * kHarmonics;
  for (size_t k = 0; k < kHarmonics; ++k) {
    for (const std::complex<float> bad :
         {std::complex<float>(nan, 0.0f), std::complex<float>(0.0f, inf),
          std::complex<float>(-inf, 0.0f), std::complex<float>(1.001f, 0.0f),
          std::complex<float>(0.0f, -0.72f * 1.42f)}) {
      coefficients[k] = bad;
      EXPECT_NE(error().find("invalid stored spectrum value"), std::string::npos)
          << "coefficient " << k << " = " << bad.real() << ", " << bad.imag();
    }
    // Near |c| = 1 the values are judged exactly: 0.9999 is valid, and (0.6, 0.8) as its float
    // modulus says.
    coefficients[k] = {0.9999f, 0.0f};
    EXPECT_EQ(error(), "") << k;
    coefficients[k] = {0.6f, 0.8f};
    EXPECT_EQ(error().empty(), std::abs(coefficients[k]) <= 1.0f) << k;
    coefficients[k] = {0.3f, -0.2f};
    for (const float bad : {nan, inf, -0.1f, 1.5f}) {
      magnitudes[k] = bad;
      EXPECT_NE(error().find("invalid stored spectrum value"), std::string::npos)
          << "magnitude " << k << " = " << bad;
    }
    magnitudes[k] = 1.0f;
    EXPECT_EQ(error(), "") << k;
    magnitudes[k] = 0.36f;
  }
}

TEST(ViewDatabaseFile, EveryTruncationIsRefused) {
  const std::string bytes = SmallDatabase().Serialize();
  for (size_t length = 0; length < bytes.size(); ++length) {
    const std::string message = ErrorOf(bytes.substr(0, length));
    ASSERT_FALSE(message.empty()) << "truncated to " << length << " bytes, file accepted";
    if (length >= 20) {
      EXPECT_NE(message.find("truncated"), std::string::npos) << message;
    }
  }
  // Appending is refused too.
  EXPECT_FALSE(ErrorOf(bytes + "x").empty());
}

TEST(ViewDatabaseFile, ForeignAndOtherVersionFilesAreNamedAsSuch) {
  EXPECT_NE(ErrorOf("P6\n640 480\n255\nthis is a picture, not a database").find("not a silpose"),
            std::string::npos);
  EXPECT_NE(ErrorOf("").find("not a silpose"), std::string::npos);
  std::string bytes = SmallDatabase().Serialize();
  const uint32_t version = 7;
  std::memcpy(bytes.data() + 8, &version, 4);
  const std::string message = ErrorOf(bytes);
  EXPECT_NE(message.find("version 7"), std::string::npos) << message;
  EXPECT_NE(message.find("rebuild"), std::string::npos) << message;
}

TEST(ViewDatabaseFile, InconsistentContentBehindAValidChecksumIsRefused) {
  const std::string bytes = SmallDatabase().Serialize();
  // Offsets of fields in the payload (see Serialize): after the 20-byte header come the sampling
  // method (4), roll reference (4) and view count (4).
  std::string wrong_views = bytes;
  const uint32_t views = 13;
  std::memcpy(wrong_views.data() + 28, &views, 4);
  Recompute(&wrong_views);
  EXPECT_NE(ErrorOf(wrong_views).find("corrupt"), std::string::npos);

  // A NaN in the last signature value (format 3 ends with the signatures).
  std::string nan_signature = SmallDatabase().Serialize(3);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(nan_signature.data() + nan_signature.size() - 12, &nan, 4);
  Recompute(&nan_signature);
  EXPECT_NE(ErrorOf(nan_signature).find("invalid signature value"), std::string::npos)
      << ErrorOf(nan_signature);
}

TEST(ViewDatabaseFile, NonFiniteCentresAndModelsWithoutAUsableViewAreRefused) {
  // Behind a recomputed checksum, as a hand-edited file would be.
  ViewDatabase infinite = SmallDatabase();
  infinite.models[1].centre[2] = std::numeric_limits<double>::infinity();
  std::string bytes = infinite.Serialize();
  EXPECT_NE(ErrorOf(bytes).find("model 'beta' has a non-finite centre"), std::string::npos)
      << ErrorOf(bytes);

  // A model none of whose views has a silhouette (what a degenerate mesh gives).
  ViewDatabase empty = SmallDatabase();
  for (ViewRecord& view : empty.models[0].views) view.status = SignatureStatus::kEmpty;
  const std::span<float> radii = empty.models[0].signatures.mutable_span();
  std::fill(radii.begin(), radii.end(), 0.0f);
  bytes = empty.Serialize();
  EXPECT_NE(ErrorOf(bytes).find("model 'alpha' has no view with a usable silhouette"),
            std::string::npos)
      << ErrorOf(bytes);
}

TEST(ViewDatabaseFile, WriteRefusesToReplaceNonRegularFiles) {
  const auto directory =
      std::filesystem::temp_directory_path() / ("silpose_db_write_" + std::to_string(::getpid()));
  std::filesystem::create_directories(directory);
  const auto target = directory / "real.db";
  std::ofstream(target) << "not replaced";
  const auto link = directory / "link.db";
  std::filesystem::create_symlink(target, link);
  try {
    SmallDatabase().Write(link);
    ADD_FAILURE() << "a symbolic link was replaced";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("symbolic link"), std::string::npos) << error.what();
  }
  EXPECT_TRUE(std::filesystem::is_symlink(link));
  // A stale temporary file of a killed build does not matter, and stays.
  std::ofstream(directory / "new.db.tmp") << "stale";
  SmallDatabase().Write(directory / "new.db");
  EXPECT_EQ(ViewDatabase::Read(directory / "new.db").models.size(), 2u);
  EXPECT_TRUE(std::filesystem::exists(directory / "new.db.tmp"));
  std::filesystem::remove_all(directory);
}

TEST(ViewDatabaseFile, MissingFilesAndDirectoriesNameThePath) {
  try {
    ViewDatabase::Read("/nonexistent/dir/models.db");
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/dir/models.db: no such file"),
              std::string::npos);
  }
  EXPECT_THROW(ViewDatabase::Read(std::filesystem::temp_directory_path()), Error);
  EXPECT_THROW(SmallDatabase().Write("/nonexistent/dir/models.db"), Error);
}

}  // namespace
}  // namespace silpose
