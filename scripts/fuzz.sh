#!/usr/bin/env bash
# Coverage-guided fuzzing (docs/fuzzing.md): builds the libFuzzer targets and runs each for SECONDS
# (default 600), one after the other, starting from the seeds in fuzz/corpus/<target>/; prints a
# table (target, seconds, executions, corpus size, findings) and exits non-zero if any target
# found something (a crash, a sanitizer report, an exception other than silpose::Error, a hang of
# more than 10 s or more than 2048 MB). Reproducers are kept in BUILD/fuzz-out/<target>/.
#   scripts/fuzz.sh [SECONDS] [TARGET...]
# Environment: SILPOSE_FUZZ_PRESET (default fuzz),
#              SILPOSE_FUZZ_JOBS (targets run at the same time, default 1),
#              SILPOSE_FUZZ_NO_BUILD=1 (run the fuzzers already built).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-600}"
shift || true
preset="${SILPOSE_FUZZ_PRESET:-fuzz}"
jobs="${SILPOSE_FUZZ_JOBS:-1}"
all_targets=(database camera_file avi mask mesh bop match)
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
case "$seconds" in '' | *[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, not '$seconds'" >&2; exit 2 ;; esac

build="build/$preset"
# Leaks inside third-party libraries (scripts/lsan.supp, each with its reason) are not findings.
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
if [ "${SILPOSE_FUZZ_NO_BUILD:-0}" = 0 ]; then
  cmake --preset "$preset" >/dev/null
  cmake --build "$build" --target fuzzers --parallel "$(nproc)"
fi
out="$build/fuzz-out"
mkdir -p "$out"

run_target() {
  local t="$1" dir="$out/$1"
  local binary="$build/fuzz/${t}_fuzzer"
  [ -x "$binary" ] || { echo "fuzz.sh: no fuzzer '$t' ($binary)" >&2; return 2; }
  mkdir -p "$dir/corpus" "$dir/artifacts"
  rm -f "$dir/artifacts/"*
  local status=0 start
  start=$(date +%s)
  # New inputs go to $dir/corpus; the seeds in the tree are only read.
  "$binary" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "$dir/corpus" "fuzz/corpus/$t" >"$dir/log.txt" 2>&1 ||
    status=$?
  local execs corpus findings elapsed
  elapsed=$(($(date +%s) - start))
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$dir/log.txt" | grep -o '[0-9]*$' | tail -1)
  corpus=$(find "$dir/corpus" "fuzz/corpus/$t" -type f | wc -l)
  findings=$(find "$dir/artifacts" -type f | wc -l)
  [ "$status" = 0 ] || [ "$findings" -gt 0 ] || findings="exit $status"
  printf '%-12s %8s %12s %8s   %s\n' "$t" "$elapsed" "${execs:-?}" "$corpus" "$findings" >"$dir/result.txt"
}

pids=()
for t in "${targets[@]}"; do
  run_target "$t" &
  pids+=($!)
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do sleep 1; done
done
wait "${pids[@]}" || true

echo
printf '%-12s %8s %12s %8s   %s\n' target seconds executions corpus findings
bad=0
for t in "${targets[@]}"; do
  if [ -f "$out/$t/result.txt" ]; then
    cat "$out/$t/result.txt"
    grep -q ' 0$' "$out/$t/result.txt" || { bad=1; echo "  -> see $out/$t/log.txt and $out/$t/artifacts/"; }
  else
    echo "$t: did not run"; bad=1
  fi
done
exit "$bad"
