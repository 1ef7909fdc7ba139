#!/usr/bin/env bash
# Checks what a user of Kestrel gets from a built preset (default: release), as a user would:
#   1. `cmake --install` into a fresh prefix: the CLI runs, the CMake package and pkg-config
#      file are there, nothing of the simulator, the lab or the tests is;
#   2. examples/downstream builds against it with find_package(Kestrel), and its source again
#      with pkg-config alone;
#   3. on the dev data (../shared/data, or KESTREL_DATA_DIR): both programs track TUM fr1/rpy
#      and give the poses of the installed `kestrel odometry` (skipped, saying so, without it);
#   4. `import kestrel` from the install tree (when the Python module was built);
#   5. `cpack -G DEB`: the package's Depends resolve (`apt-get install --simulate`),
#      `kestrel --help` runs from the unpacked package and examples/downstream builds against it
#      (without the CUDA toolkit, as on a plain Debian machine).
# Work files go to build/<preset>/check_install/ (fixed paths: ccache finds the downstream
# compiles again). Exits non-zero on the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
preset="${1:-release}"
build="$root/build/$preset"
work="$build/check_install"
prefix="$work/prefix"
data="${KESTREL_DATA_DIR:-$root/../shared/data}/tum/rgbd_dataset_freiburg1_rpy_part1"
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1

die() { echo "check_install: FAILED: $*" >&2; exit 1; }
step() { echo "--- check_install: $*"; }
start=$(date +%s)
[ -f "$build/CMakeCache.txt" ] || die "$build is not configured (scripts/build.sh $preset)"
rm -rf "$work"
mkdir -p "$work"

step "1/5 cmake --install $build --prefix $prefix"
t0=$(date +%s)
cmake --install "$build" --prefix "$prefix" >"$work/install.log" ||
  { tail -20 "$work/install.log" >&2; die "install"; }
"$prefix/bin/kestrel" --help >/dev/null || die "installed kestrel --help"
for f in lib/cmake/Kestrel/KestrelConfig.cmake lib/cmake/Kestrel/KestrelConfigVersion.cmake \
         lib/cmake/Kestrel/KestrelTargets.cmake lib/pkgconfig/kestrel.pc \
         include/kestrel/odometry/direct_tracker.hpp lib/libkestrel_odometry.a; do
  [ -e "$prefix/$f" ] || die "$f is not installed"
done
for f in include/kestrel/sim include/kestrel/lab include/kestrel/flight include/kestrel/ros \
         lib/libkestrel_sim.a lib/libkestrel_lab.a lib/libkestrel_flight.a; do
  [ ! -e "$prefix/$f" ] || die "$f is installed (the lab and the simulator stay in the build)"
done
if find "$prefix" -name 'test_*' -o -name '*gtest*' | grep -q .; then
  die "test files are installed: $(find "$prefix" -name 'test_*' -o -name '*gtest*' | head -3)"
fi
echo "installed $(find "$prefix" -type f | wc -l) files, $(du -sh "$prefix" | cut -f1)" \
     "in $(( $(date +%s) - t0 )) s"

step "2/5 examples/downstream: find_package(Kestrel), then pkg-config"
t0=$(date +%s)
launcher=() cxx=(g++)
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache) cxx=(ccache g++)
cmake -S examples/downstream -B "$work/downstream" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" "${launcher[@]}" >"$work/downstream.log" 2>&1 ||
  { tail -30 "$work/downstream.log" >&2; die "configure examples/downstream"; }
cmake --build "$work/downstream" >>"$work/downstream.log" 2>&1 ||
  { tail -30 "$work/downstream.log" >&2; die "build examples/downstream"; }
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
pkg-config --exists kestrel || die "pkg-config does not find kestrel.pc"
# shellcheck disable=SC2046  # the flags are words
"${cxx[@]}" -O2 examples/downstream/track_tum.cpp \
  -o "$work/track_tum_pkgconfig" $(pkg-config --cflags --libs kestrel) \
  >>"$work/downstream.log" 2>&1 ||
  { tail -30 "$work/downstream.log" >&2
    die "build examples/downstream/track_tum.cpp with pkg-config --cflags --libs kestrel"; }
echo "built track_tum (CMake) and track_tum_pkgconfig in $(( $(date +%s) - t0 )) s"

step "3/5 run on the dev data"
if [ -d "$data" ]; then
  t0=$(date +%s)
  "$prefix/bin/kestrel" odometry "$data" --out "$work/cli.txt" >/dev/null 2>"$work/cli.log" ||
    { tail -5 "$work/cli.log" >&2; die "kestrel odometry $data"; }
  for program in "$work/downstream/track_tum" "$work/track_tum_pkgconfig"; do
    "$program" "$data" fr1 >"$work/$(basename "$program").txt" 2>"$work/run.log" ||
      { cat "$work/run.log" >&2; die "$program $data"; }
    # The same library on the same frames: the same poses (to the 9 digits track_tum prints).
    awk 'FNR == NR { if ($1 !~ /^#/) cli[++n] = $0; next }
         { ++m; split(cli[m], c, " ");
           if ($1 != c[1]) { print "line " m ": time " $1 " vs " c[1]; bad = 1; exit }
           for (i = 2; i <= 8; ++i) { d = $i - c[i]; if (d < 0) d = -d;
             if (d > 1e-6 * (1 + (c[i] < 0 ? -c[i] : c[i]))) {
               print "line " m ": " $0 " vs " cli[m]; bad = 1; exit } } }
         END { if (m != n) { print m " poses vs " n; bad = 1 } exit bad }' \
      "$work/cli.txt" "$work/$(basename "$program").txt" ||
      die "$(basename "$program") and kestrel odometry differ on $data"
    echo "$(basename "$program"): $(tail -1 "$work/run.log"), the poses of kestrel odometry"
  done
  echo "ran in $(( $(date +%s) - t0 )) s"
else
  echo "check_install: dev data $data not found: the downstream programs are built but not run"
fi

step "4/5 import kestrel from the install tree"
site="$prefix/lib/python3/dist-packages"
if [ -d "$site/kestrel" ]; then
  python=$(grep -E '^Python_EXECUTABLE:' "$build/CMakeCache.txt" | cut -d= -f2 || true)
  where=$(cd /tmp && PYTHONPATH="$site" "${python:-python3}" -c \
    'import kestrel; kestrel.SE3(); print(kestrel.__file__)') || die "import kestrel from $site"
  case "$where" in "$site"/*) echo "imported $where" ;; *) die "imported $where, not $site" ;; esac
else
  echo "check_install: the Python module was not built (pybind11 missing): not checked"
fi

step "5/5 cpack -G DEB"
t0=$(date +%s)
rm -rf "$build/packages"
(cd "$build" && cpack -G DEB >"$work/cpack.log" 2>&1) ||
  { tail -30 "$work/cpack.log" >&2; die "cpack -G DEB"; }
deb=$(ls "$build"/packages/kestrel_*.deb)
echo "$(basename "$deb"): $(du -h "$deb" | cut -f1) in $(( $(date +%s) - t0 )) s"
dpkg-deb --field "$deb" Depends
apt-get install --simulate "$deb" >"$work/apt.log" 2>&1 ||
  { tail -20 "$work/apt.log" >&2; die "apt-get install --simulate $deb: Depends do not resolve"; }
grep -E "^Inst kestrel " "$work/apt.log" || die "apt-get --simulate would not install kestrel"
dpkg -x "$deb" "$work/deb"
"$work/deb/usr/bin/kestrel" --help >/dev/null || die "kestrel --help from the unpacked package"
# The package's own CMake package (relocatable: found under the unpacked /usr too), as on a
# Debian machine without the CUDA toolkit (CMAKE_DISABLE_FIND_PACKAGE_CUDAToolkit).
cmake -S examples/downstream -B "$work/downstream_deb" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$work/deb/usr" -DCMAKE_DISABLE_FIND_PACKAGE_CUDAToolkit=ON \
  "${launcher[@]}" >"$work/downstream_deb.log" 2>&1 &&
  cmake --build "$work/downstream_deb" >>"$work/downstream_deb.log" 2>&1 ||
  { tail -30 "$work/downstream_deb.log" >&2; die "examples/downstream against the package"; }
grep -q "$work/deb/usr/lib/cmake/Kestrel" "$work/downstream_deb/CMakeCache.txt" ||
  die "examples/downstream did not find the package's KestrelConfig.cmake"
echo "apt-get install --simulate: ok; kestrel --help and examples/downstream from the package: ok"

echo "check_install: passed in $(( $(date +%s) - start )) s"
