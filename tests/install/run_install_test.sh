#!/usr/bin/env bash
# Installs a silpose build into a temporary prefix, then builds and runs, against that prefix only:
# the project in this folder (find_package(silpose), silpose::silpose, README.md's two library
# examples, every installed header alone) and a program built with pkg-config's flags alone.
# Usage: run_install_test.sh BUILD_DIR [CMAKE_GENERATOR] [CXX_COMPILER] [CHECK_HEADERS=ON|OFF]
set -euo pipefail
build_dir=$1
generator=${2:-Ninja}
cxx=${3:-c++}
check_headers=${4:-ON}
[[ $check_headers == ON || $check_headers == OFF ]] || { echo "CHECK_HEADERS must be ON or OFF" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/silpose-install-test.XXXXXX")
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix
fail() { echo "FAIL: $*" >&2; exit 1; }

echo "== cmake --install $build_dir --prefix $prefix"
cmake --install "$build_dir" --prefix "$prefix" > "$work/install.log"
for file in include/silpose/silpose.h include/silpose/version.h share/doc/silpose/LICENSE \
            bin/silpose; do
  [[ -e $prefix/$file ]] || fail "not installed: $file"
done
pc=$(find "$prefix" -name silpose.pc -path '*/pkgconfig/*' | head -1)
[[ -n $pc ]] || fail "silpose.pc not installed under lib/pkgconfig"
config=$(find "$prefix" -name silposeConfig.cmake | head -1)
[[ -n $config ]] || fail "silposeConfig.cmake not installed"

echo "== configure and build the outside project ($here)"
cmake -S "$here" -B "$work/build" -G "$generator" -DCMAKE_CXX_COMPILER="$cxx" \
      -DCMAKE_PREFIX_PATH="$prefix" -DSILPOSE_CHECK_HEADERS="$check_headers" > "$work/configure.log" ||
  { cat "$work/configure.log"; fail "configure"; }
if [[ $check_headers == ON ]]; then
  grep -q "checking .* installed headers alone" "$work/configure.log" || fail "header check missing"
fi
grep "installed headers alone" "$work/configure.log"
cmake --build "$work/build" -j2 > "$work/build.log" 2>&1 || { tail -60 "$work/build.log"; fail "build"; }

echo "== sample data made with the installed silpose"
silpose=$prefix/bin/silpose
models=$prefix/share/silpose/models
data=$work/data
mkdir -p "$data"
"$silpose" build-db "$models/cow.obj" "$models/bunny.obj" "$models/hand.obj" -o "$data/parts.db" \
  --views 300 --threads 2 > "$work/build-db.log"
"$silpose" synth "$models/cow.obj" -o "$work/seq" --frames 24 --colour --video --camera-noise 2 \
  --seed 5 > "$work/synth.log"
cp "$work/seq/video.avi" "$data/recording.avi"
cp "$work/seq/background.png" "$data/empty.png"
cp "$work/seq/camera.yml" "$data/camera.yml"
cp "$work/seq/masks/000012.png" "$data/frame.png"

echo "== README example: tracking a video"
(cd "$data" && "$work/build/track_example") > "$work/track.out" || fail "track_example failed"
frames=$(grep -c '^frame ' "$work/track.out" || true)
cow=$(grep -c '^frame [0-9]*: cow .*with pose' "$work/track.out" || true)
echo "$frames frames, $cow named cow with a pose"
[[ $frames -eq 24 ]] || fail "track_example printed $frames frames, expected 24"
(( cow * 10 >= frames * 8 )) || { cat "$work/track.out"; fail "cow in only $cow of $frames frames"; }

echo "== README example: matching a single silhouette"
(cd "$data" && "$work/build/match_example") > "$work/match.out" || fail "match_example failed"
cat "$work/match.out"
[[ $(wc -l < "$work/match.out") -eq 5 ]] || fail "match_example: expected 5 candidates"
head -1 "$work/match.out" | grep -q '^cow view ' || fail "match_example: best candidate is not cow"

echo "== formats other than PNG and JPEG: OpenCV's codecs through the installed plugin"
plugin=$(find "$prefix" -name libsilpose_opencv_codecs.so | head -1)
[[ -n $plugin ]] || fail "libsilpose_opencv_codecs.so not installed"
"$silpose" render "$models/cow.obj" --resolution 256 -o "$data/cow.bmp" > "$work/render.log" ||
  fail "render to BMP"
LD_DEBUG=files LD_DEBUG_OUTPUT="$work/loader" "$silpose" match -d "$data/parts.db" "$data/cow.bmp" \
  > "$work/bmp.out" || fail "match of a BMP mask"
grep -q "calling init: $plugin" "$work"/loader.* ||
  fail "the installed silpose did not load the installed plugin $plugin"
grep -q " cow " "$work/bmp.out" || fail "match of the BMP mask did not find the cow"
echo "BMP read through $plugin"

echo "== version macros and deleted overloads"
"$work/build/api_check" | tee "$work/api.out"
grep -q "^silpose [0-9]*\.[0-9]*\.[0-9]* (" "$work/api.out" || fail "api_check output"

echo "== a program built with pkg-config --cflags --libs silpose alone"
export PKG_CONFIG_PATH=$(dirname "$pc")
flags=$(pkg-config --cflags --libs silpose) || fail "pkg-config silpose"
"$cxx" "$here/pkgconfig_example.cc" $flags -o "$work/pkgconfig_example" > "$work/pc-build.log" 2>&1 ||
  { cat "$work/pc-build.log"; fail "pkg-config build: $cxx pkgconfig_example.cc $flags"; }
"$work/pkgconfig_example" | tee "$work/pc.out"
grep -q "signature of 1000 radii" "$work/pc.out" || fail "pkgconfig_example output"
echo "== python3 -c 'import silpose' against the installed package"
module=$(find "$prefix" -name '_silpose*.so' | head -1)
if [[ -n $module ]]; then
  package_dir=$(dirname "$(dirname "$module")")
  relative=${package_dir#"$prefix"/}
  # Where Debian's python3 looks for this relative folder under /usr/local or /usr.
  /usr/bin/python3 -c "import sys; sys.exit(0 if {'/usr/local/$relative', '/usr/$relative'} & set(sys.path) else 1)" ||
    fail "the Python package is installed in $relative, where Debian's python3 does not look"
  # A sanitizer build's module needs the sanitizer runtime preloaded into the interpreter
  # (SILPOSE_SANITIZER_RUNTIME, set by tests/CMakeLists.txt for such builds).
  preload=()
  if [[ -n ${SILPOSE_SANITIZER_RUNTIME:-} ]]; then
    preload=(env "LD_PRELOAD=$SILPOSE_SANITIZER_RUNTIME" "ASAN_OPTIONS=detect_leaks=0")
  fi
  PYTHONPATH=$package_dir "${preload[@]}" /usr/bin/python3 -c "import silpose; print(silpose.__file__)" \
    > "$work/py.out" || fail "import silpose from the installed package"
  grep -q "^$prefix/" "$work/py.out" || fail "import silpose did not load the installed package: $(cat "$work/py.out")"
  echo "import silpose: $(cat "$work/py.out")"
else
  echo "(no Python package in this build)"
fi
echo "PASS in ${SECONDS} s"
