#include "silpose/util/error.h"

#include <cstdio>
#include <cstdlib>

namespace silpose::internal {

void AssertionFailed(const char* expression, const char* file, int line) {
  std::fprintf(stderr, "silpose: internal error: assertion '%s' failed at %s:%d\n", expression,
               file, line);
  std::abort();
}

}  // namespace silpose::internal
