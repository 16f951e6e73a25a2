#!/usr/bin/env bash
# Quick start (b): installs the dependencies (Debian 12 packages), builds silpose and runs the whole
# test suite with CTest, then the sanitizer stages (scripts/run-sanitizers.sh, docs/fuzzing.md):
# the suite again under AddressSanitizer + UndefinedBehaviorSanitizer, every fuzzer briefly, and
# the multi-threaded tests under ThreadSanitizer.
# Extra arguments go to ctest (e.g. -R Database) and then skip the sanitizer stages; so does
# SILPOSE_SKIP_SANITIZERS=1.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release
start=$(date +%s)
ctest --preset release "$@"
echo "== run-tests.sh: release tests took $(($(date +%s) - start)) s"
if [ $# -eq 0 ] && [ "${SILPOSE_SKIP_SANITIZERS:-0}" != 1 ]; then
  bash scripts/run-sanitizers.sh
fi
