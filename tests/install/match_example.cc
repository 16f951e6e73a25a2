// README.md "As a library": matching a single silhouette (kept identical to the README).
#include <silpose/silpose.h>

#include <cstdio>

int main() try {
  const silpose::ViewDatabase database = silpose::ViewDatabase::Read("parts.db");
  const silpose::ViewSpectra spectra(database);  // one FFT per view, shareable across threads
  silpose::ViewMatcher matcher(spectra);         // one per thread
  const silpose::SignatureResult silhouette =
      silpose::ExtractSignature(silpose::ReadMask("frame.png"), database.parameters.signature);
  if (!silhouette.ok()) {
    std::fprintf(stderr, "frame.png: no usable silhouette\n");
    return 1;
  }
  for (const silpose::MatchCandidate& c : matcher.Match(silhouette.signature.radii, {.top_k = 5}))
    std::printf("%s view %d roll %.1f score %.3f\n", database.models[c.model].name.c_str(), c.view,
                c.roll_deg, c.score);
  return 0;
} catch (const silpose::Error& error) {
  std::fprintf(stderr, "error: %s\n", error.what());
  return 1;
}
