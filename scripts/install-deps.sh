#!/usr/bin/env bash
# Installs everything silpose needs to build, test and benchmark, from Debian 12 packages only.
# Run as root (or with sudo) on a fresh Debian 12 machine. Safe to run again.
#   --with-fftw   also install FFTW3 (GPL) for the opt-in -DSILPOSE_WITH_FFTW=ON build.
#   --with-video  also install OpenCV videoio (Debian's FFmpeg is GPL) for the opt-in
#                 -DSILPOSE_WITH_VIDEOIO=ON build: mp4 and other FFmpeg formats, live cameras.
set -euo pipefail

with_fftw=0
with_video=0
for arg in "$@"; do
  case "$arg" in
    --with-fftw) with_fftw=1 ;;
    --with-video) with_video=1 ;;
    -h|--help) sed -n '2,7p' "$0"; exit 0 ;;
    *) echo "install-deps.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

packages=(
  build-essential cmake ninja-build pkg-config git
  # image I/O and contours (Apache-2.0); only the modules silpose uses, not the whole of OpenCV
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
  libopencv-video-dev  # background subtraction (MOG2, KNN)
  libopencv-calib3d406 # chessboard calibration, PnP (runtime; headers below)
  libpng-dev libjpeg62-turbo-dev  # PNG and JPEG read and written directly (libpng, IJG/BSD-3)
  libassimp-dev        # mesh import: OBJ, PLY, STL, OFF, glTF (BSD-3)
  libeigen3-dev        # small linear algebra (MPL-2.0)
  libtbb-dev           # multi-threaded database building (Apache-2.0)
  libkissfft-dev       # default FFT for circular correlation (BSD-3)
  libcli11-dev         # command-line parsing (BSD-3)
  nlohmann-json3-dev   # JSON output (MIT)
  libxxhash-dev        # mesh and file checksums (BSD-2)
  libgtest-dev libgmock-dev libbenchmark-dev
  # Python bindings (python/, for /usr/bin/python3): headers, pybind11 (BSD-3), numpy (BSD-3)
  python3-dev pybind11-dev python3-numpy
  # their tests: pytest (MIT); dask.distributed (BSD-3), whose dependencies are BSD, MIT or
  # Apache-2.0 (dask, toolz, zict, partd, cloudpickle, psutil, tornado, msgpack, tblib, ...; only
  # Debian's packaging scripts of some are GPL). Python runs them; nothing links them.
  python3-pytest python3-distributed
  clang-format clang-tidy
  # sanitizer and fuzzing builds (presets asan, tsan, fuzz; Apache-2.0 with LLVM exception):
  # clang 14 (clang++), its sanitizer runtimes and libFuzzer
  clang libclang-rt-14-dev
)
[ "$with_fftw" = 1 ] && packages+=(libfftw3-dev)
[ "$with_video" = 1 ] && packages+=(libopencv-videoio-dev libopencv-calib3d-dev)

# Headers of calib3d and the modules its header includes. Their -dev packages depend on
# libopencv-highgui-dev, which drags Qt and libopencv-videoio (GPL FFmpeg) into every build; the
# runtime libraries above do not. So the default build unpacks only the headers of these three
# Debian packages (same version as the runtime) into $headers_dir, where cmake/FindSilposeOpenCV.cmake
# looks for them. Skipped when the -dev packages themselves are installed (--with-video).
headers_dir=/opt/silpose-deps/include/opencv4
header_debs=(libopencv-flann-dev libopencv-features2d-dev libopencv-calib3d-dev)
install_opencv_headers() {
  if [ -f /usr/include/opencv4/opencv2/calib3d.hpp ] || [ -f "$headers_dir/opencv2/calib3d.hpp" ]; then
    return 0
  fi
  local tmp deb
  tmp="$(mktemp -d)" || return 1
  chmod 755 "$tmp"
  (cd "$tmp" && $SUDO apt-get download -qq "${header_debs[@]}") || { rm -rf "$tmp"; return 1; }
  for deb in "$tmp"/*.deb; do
    dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$tmp" ./usr/include/opencv4 || { rm -rf "$tmp"; return 1; }
  done
  $SUDO mkdir -p "$headers_dir" && $SUDO cp -r "$tmp/usr/include/opencv4/opencv2" "$headers_dir/" ||
    { rm -rf "$tmp"; return 1; }
  rm -rf "$tmp"
  [ -f "$headers_dir/opencv2/calib3d.hpp" ] || return 1
  echo "install-deps.sh: unpacked the headers of ${header_debs[*]} into $headers_dir"
}
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
export DEBIAN_FRONTEND=noninteractive
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps.sh: all ${#packages[@]} packages already installed"
else
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
# (apt-get download needs current package lists: on failure, update them and try again.)
if ! install_opencv_headers; then
  echo "install-deps.sh: updating the package lists and trying again"
  $SUDO apt-get update -qq
  install_opencv_headers || { echo "install-deps.sh: could not unpack the OpenCV calib3d headers" >&2; exit 1; }
fi
