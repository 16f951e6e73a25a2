#pragma once
// Error handling conventions:
//  - programmer bugs: SILPOSE_ASSERT (aborts with file/line; active in all build types);
//  - bad arguments or bad files at the public API: silpose::Error, whose message names the file or
//    parameter and what is wrong; the command line prints it as one line and exits non-zero;
//  - expected run-time conditions (no silhouette in a frame, ...): statuses in result structs.

#include <sstream>
#include <stdexcept>
#include <string>

namespace silpose {

/// Exception for invalid input at the public API: bad parameters, missing/corrupt/foreign files.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// Builds a message from streamable parts and throws silpose::Error.
template <typename... Parts>
[[noreturn]] void ThrowError(const Parts&... parts) {
  std::ostringstream stream;
  (stream << ... << parts);
  throw Error(stream.str());
}

namespace internal {
[[noreturn]] void AssertionFailed(const char* expression, const char* file, int line);
}  // namespace internal

}  // namespace silpose

#define SILPOSE_ASSERT(expression)     \
  ((expression) ? static_cast<void>(0) \
                : ::silpose::internal::AssertionFailed(#expression, __FILE__, __LINE__))
