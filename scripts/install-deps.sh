#!/usr/bin/env bash
# Installs everything silpose needs to build, test and benchmark, from Debian 12 packages only.
# Run as root (or with sudo) on a fresh Debian 12 machine. Safe to run again.
#   --with-fftw   also install FFTW3 (GPL) for the opt-in -DSILPOSE_WITH_FFTW=ON build.
set -euo pipefail

with_fftw=0
for arg in "$@"; do
  case "$arg" in
    --with-fftw) with_fftw=1 ;;
    -h|--help) sed -n '2,5p' "$0"; exit 0 ;;
    *) echo "install-deps.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

packages=(
  build-essential cmake ninja-build pkg-config git
  # image I/O and contours (Apache-2.0); only the modules silpose uses, not the whole of OpenCV
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
  libassimp-dev        # mesh import: OBJ, PLY, STL, OFF, glTF (BSD-3)
  libeigen3-dev        # small linear algebra (MPL-2.0)
  libtbb-dev           # multi-threaded database building (Apache-2.0)
  libkissfft-dev       # default FFT for circular correlation (BSD-3)
  libcli11-dev         # command-line parsing (BSD-3)
  nlohmann-json3-dev   # JSON output (MIT)
  libxxhash-dev        # mesh and file checksums (BSD-2)
  libgtest-dev libgmock-dev libbenchmark-dev
  clang-format clang-tidy
)
[ "$with_fftw" = 1 ] && packages+=(libfftw3-dev)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps.sh: all ${#packages[@]} packages already installed"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
