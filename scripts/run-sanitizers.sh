#!/usr/bin/env bash
# The sanitizer stages of CI (scripts/run-tests.sh runs them after the release tests):
#  1. asan:  clang -O2 -gline-tables-only with AddressSanitizer + UndefinedBehaviorSanitizer; the
#            whole test suite, the Python tests (the sanitizer runtime preloaded into python3) and
#            the 'install' test included;
#  2. fuzz:  the libFuzzer targets, built on their own (the 'fuzz' preset: the libraries with
#            coverage feedback, which would make the tests of stage 1 three times slower), each run
#            for SILPOSE_CI_FUZZ_SECONDS (default 20) seconds from its seed corpus (scripts/fuzz.sh);
#  3. tsan:  clang -O1 -gline-tables-only with ThreadSanitizer; only the tests that run several threads.
# Prints each stage's wall-clock time. Stages can be chosen: scripts/run-sanitizers.sh asan tsan.
# Assumes the dependencies are installed (scripts/install-deps.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
stages=("$@")
[ ${#stages[@]} -gt 0 ] || stages=(asan fuzz tsan)
jobs="$(nproc)"
timings=()
stage() {
  local name="$1" start end
  shift
  start=$(date +%s)
  echo "== run-sanitizers.sh: $name"
  "$@"
  end=$(date +%s)
  timings+=("$(printf '%-28s %5d s' "$name" $((end - start)))")
}
for s in "${stages[@]}"; do
  case "$s" in
    asan)
      stage "asan: configure and build" bash -c "cmake --preset asan >/dev/null && cmake --build --preset asan --parallel $jobs"
      stage "asan: tests" ctest --preset asan ;;
    fuzz)
      stage "fuzz: configure and build" bash -c "cmake --preset fuzz >/dev/null && cmake --build --preset fuzz --parallel $jobs"
      stage "fuzz: ${SILPOSE_CI_FUZZ_SECONDS:-20} s per target" env SILPOSE_FUZZ_PRESET=fuzz SILPOSE_FUZZ_JOBS="$jobs" \
        SILPOSE_FUZZ_NO_BUILD=1 bash scripts/fuzz.sh "${SILPOSE_CI_FUZZ_SECONDS:-20}" ;;
    tsan)
      stage "tsan: configure and build" bash -c "cmake --preset tsan >/dev/null && cmake --build --preset tsan --parallel $jobs"
      stage "tsan: threaded tests" ctest --preset tsan ;;
    *) echo "run-sanitizers.sh: unknown stage '$s' (asan, fuzz, tsan)" >&2; exit 2 ;;
  esac
done
echo "== run-sanitizers.sh: times"
printf '%s\n' "${timings[@]}"
