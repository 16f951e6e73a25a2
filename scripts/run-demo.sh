#!/usr/bin/env bash
# Quick start (a): installs the dependencies (Debian 12 packages), builds silpose and runs
# 'silpose demo' on the built-in sample models. Extra arguments go to 'silpose demo'.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh release
exec build/release/src/silpose/cli/silpose demo "$@"
