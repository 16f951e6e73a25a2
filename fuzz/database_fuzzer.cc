// The database reader (ViewDatabase::Deserialize, what ViewDatabase::Read does with a file's
// bytes). Inputs whose first byte is odd are read as they are; the others are the payload only:
// the target wraps them in a valid header and checksum, so that mutations reach the parser behind
// the checksum instead of stopping at it.

#include <cstring>
#include <memory>
#include <string>

#include "fuzz/fuzz_common.h"
#include "silpose/database/view_database.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/hash.h"

namespace {

// What a reader does next with a database it accepted: match its first view against it.
void MatchFirstView(const silpose::ViewDatabase& database) {
  if (database.models.empty()) return;
  const silpose::ViewSpectra spectra(database);
  silpose::ViewMatcher matcher(spectra);
  silpose::MatchOptions options;
  options.top_k = 3;
  options.apparent_radius = database.ApparentRadius(0, 0, 0);
  (void)matcher.Match(database.models[0].Signature(0, 0), options);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using silpose::ViewDatabase;
  if (size == 0) return 0;
  std::string bytes;
  if (data[0] & 1) {
    bytes.assign(reinterpret_cast<const char*>(data) + 1, size - 1);
  } else {
    const uint64_t payload_size = size - 1;
    bytes.append("SILPOSDB", 8);
    const uint32_t version = ViewDatabase::kFormatVersion;
    bytes.append(reinterpret_cast<const char*>(&version), sizeof(version));
    bytes.append(reinterpret_cast<const char*>(&payload_size), sizeof(payload_size));
    bytes.append(reinterpret_cast<const char*>(data) + 1, size - 1);
    const uint64_t checksum = silpose::HashBytes(bytes.data(), bytes.size());
    bytes.append(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  }
  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    const ViewDatabase database = ViewDatabase::Deserialize(bytes, "fuzz.db");
    (void)database.Serialize();  // written back
    MatchFirstView(database);
  });
  silpose::fuzz::ExpectOnlySilposeErrors([&] {
    // As ViewDatabase::Read opens a file: the bulk referred to in place, each block and view
    // checked when the matcher first uses it.
    const auto keep = std::make_shared<const std::string>(bytes);
    const ViewDatabase database =
        ViewDatabase::Deserialize(*keep, "fuzz.db", silpose::ViewChecks::kOnFirstUse, keep);
    MatchFirstView(database);
  });
  return 0;
}
