// Compile-time properties of the installed API: the version macros, and objects that keep a
// reference to a constructor argument refuse temporaries.
#include <silpose/silpose.h>

#include <cstdio>
#include <string_view>
#include <type_traits>

static_assert(SILPOSE_VERSION_MAJOR >= 0 && SILPOSE_VERSION_MINOR >= 0 &&
              SILPOSE_VERSION_PATCH >= 0);
static_assert(!std::is_constructible_v<silpose::Tracker, silpose::ViewDatabase&&,
                                       const silpose::PinholeCamera&>);
static_assert(
    !std::is_constructible_v<silpose::Tracker, silpose::ViewDatabase&&,
                             const silpose::PinholeCamera&, const silpose::TrackerOptions&>);
static_assert(std::is_constructible_v<silpose::Tracker, const silpose::ViewDatabase&,
                                      const silpose::PinholeCamera&>);
static_assert(!std::is_constructible_v<silpose::ViewSpectra, silpose::ViewDatabase&&>);
static_assert(std::is_constructible_v<silpose::ViewSpectra, const silpose::ViewDatabase&>);
static_assert(!std::is_constructible_v<silpose::ViewMatcher, silpose::ViewSpectra&&>);
static_assert(std::is_constructible_v<silpose::ViewMatcher, const silpose::ViewSpectra&>);

int main() {
  std::printf("silpose %s (%d.%d.%d)\n", SILPOSE_VERSION, SILPOSE_VERSION_MAJOR,
              SILPOSE_VERSION_MINOR, SILPOSE_VERSION_PATCH);
  return std::string_view(SILPOSE_VERSION).empty() ? 1 : 0;
}
