#!/usr/bin/env bash
# Quick start (b): installs the dependencies (Debian 12 packages), builds silpose and runs the whole
# test suite with CTest. Extra arguments go to ctest (e.g. -R Database).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release
ctest --preset release "$@"
