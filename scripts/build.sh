#!/usr/bin/env bash
# Configures and builds silpose with the given CMake preset (default: release) on all cores.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" --parallel "$(nproc)"
