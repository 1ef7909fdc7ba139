#!/usr/bin/env bash
# The on-board code on 64-bit ARM: cross-compiles the libraries and their tests with Debian's
# g++-aarch64-linux-gnu against an arm64 sysroot of Debian packages and runs the tests under
# qemu-aarch64 (user-mode emulation), the Highway kernels' NEON target included (docs/onboard.md).
#
#   scripts/check_arm64.sh [--quick | --full] [--jobs N]
#
#   --quick  the SIMD kernel tests only (test_odometry_kernels, test_image_kernels,
#            test_sensor_kernels, test_fusion_kernels): what CI runs
#   --full   (default) the kernel, image, odometry (RGB-D and stereo), sensor (stereo matching,
#            front end) and fusion tests
#
# Steps, each printed as it starts:
#   1. host tools: g++-aarch64-linux-gnu and qemu-user-static from apt (nothing else of the host
#      changes: no foreign architecture is added to dpkg, no arm64 package is installed);
#   2. the sysroot build/arm64-sysroot (KESTREL_ARM64_SYSROOT): Debian's arm64 packages,
#      downloaded with a private apt state (build/arm64-sysroot-apt) and unpacked with
#      `dpkg -x`: the -dev packages the build needs, then every shared library they need at run
#      time, found by walking the ELF DT_NEEDED entries (the host's dpkg database names the
#      package of each library). Made once; skipped while its stamp matches this script's lists;
#   3. configure build/arm64 with cmake/toolchains/aarch64-linux-gnu.cmake (Release, tests on;
#      bench, CUDA, ROS, fuzzing off), build only the test targets of the chosen set;
#   4. ctest under qemu-aarch64 (the toolchain's CMAKE_CROSSCOMPILING_EMULATOR).
#
# Environment: KESTREL_ARM64_SYSROOT, KESTREL_ARM64_BUILD (build dir, default build/arm64),
# KESTREL_DEBIAN_MIRROR, KESTREL_DEBIAN_SECURITY_MIRROR (default deb.debian.org), KESTREL_DATA_DIR
# (the shared data the odometry tests read; they skip without it).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

mode=full
jobs=2
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) mode=quick ;;
    --full) mode=full ;;
    --jobs) jobs="$2"; shift ;;
    --jobs=*) jobs="${1#--jobs=}" ;;
    -h|--help) sed -n '2,26p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "check_arm64: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done

sysroot="${KESTREL_ARM64_SYSROOT:-$root/build/arm64-sysroot}"
build="${KESTREL_ARM64_BUILD:-$root/build/arm64}"
aptdir="${sysroot%/}-apt"  # apt state and the downloaded .deb files
mirror="${KESTREL_DEBIAN_MIRROR:-http://deb.debian.org/debian}"
security_mirror="${KESTREL_DEBIAN_SECURITY_MIRROR:-http://deb.debian.org/debian-security}"
start=$(date +%s)

step() { echo; echo "=== check_arm64: $* ($(( $(date +%s) - start )) s) ==="; }
die() { echo "check_arm64: error: $*" >&2; exit 1; }
trap 'echo "check_arm64: error: command failed (line $LINENO): $BASH_COMMAND" >&2' ERR

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi

# ---------------------------------------------------------------------------------------------
step "1/4 host tools (g++-aarch64-linux-gnu, qemu-user-static)"
host_packages=(g++-aarch64-linux-gnu binutils-aarch64-linux-gnu qemu-user-static)
missing=()
for p in "${host_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing ${missing[*]}"
  if [ -n "$sudo" ] && ! command -v sudo >/dev/null; then
    die "not root and no sudo: install ${missing[*]}"
  fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
qemu=$(command -v qemu-aarch64-static || command -v qemu-aarch64 || true)
[ -n "$qemu" ] || die "qemu-aarch64(-static) not found after installing qemu-user-static"
gcc_major=$(aarch64-linux-gnu-g++ -dumpversion | cut -d. -f1)
echo "compiler: $(aarch64-linux-gnu-g++ --version | head -1); emulator: $qemu"

# ---------------------------------------------------------------------------------------------
# The sysroot's -dev packages, unpacked without their dependencies (those would pull in Qt, Mesa
# and LLVM through libopencv-dev's module packages): headers, CMake configs, .so links. Every
# OpenCV module's library is unpacked too, because OpenCV's CMake config stops when a file of
# any of its imported targets is missing; only the modules Kestrel links get their libraries'
# dependencies (the DT_NEEDED walk below).
codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")
dev_packages=(
  libc6-dev linux-libc-dev libcrypt-dev "libstdc++-${gcc_major}-dev" "libgcc-${gcc_major}-dev"
  libeigen3-dev libhwy-dev libyaml-cpp-dev libgtest-dev libgmock-dev libcli11-dev
  libopencv-dev
)
# Libraries whose run-time closure is walked: what the on-board modules and tests link.
seed_libraries=(
  libc.so.6 libm.so.6 libstdc++.so.6 libgcc_s.so.1 libhwy.so.1 libyaml-cpp.so.0.7
  libopencv_core.so.406 libopencv_imgproc.so.406 libopencv_imgcodecs.so.406
  libopencv_calib3d.so.406 libopencv_features2d.so.406 libopencv_flann.so.406
)
stamp_text="v1 $codename gcc-$gcc_major ${dev_packages[*]} ${seed_libraries[*]}"

apt_opts=(
  -o "Dir::State=$aptdir/state" -o "Dir::State::status=$aptdir/state/status"
  -o "Dir::Cache=$aptdir/cache" -o "Dir::Etc::SourceList=$aptdir/sources.list"
  -o "Dir::Etc::SourceParts=$aptdir/sources.list.d" -o "Dir::Etc::Preferences=$aptdir/preferences"
  -o "Dir::Etc::PreferencesParts=$aptdir/preferences.d"
  -o APT::Architecture=arm64 -o APT::Architectures::=arm64 -o Debug::NoLocking=1
  -o APT::Get::AllowUnauthenticated=false -o Acquire::Languages=none
)
# Root downloads as root into the build folder (apt's _apt user may not write there).
[ "$(id -u)" -ne 0 ] || apt_opts+=(-o APT::Sandbox::User=root)

# Packages (arm64) download into $aptdir/debs and unpack into the sysroot.
fetch_and_unpack() {
  mkdir -p "$aptdir/debs"
  local want=() p
  for p in "$@"; do
    [ -e "$aptdir/unpacked/$p" ] || want+=("$p")
  done
  [ ${#want[@]} -gt 0 ] || return 0
  echo "downloading ${#want[@]} arm64 packages: ${want[*]}"
  (cd "$aptdir/debs" && apt-get "${apt_opts[@]}" -qq download "${want[@]/%/:arm64}") ||
    die "apt-get download failed for: ${want[*]}"
  mkdir -p "$aptdir/unpacked"
  for p in "${want[@]}"; do
    local deb
    deb=$(ls -t "$aptdir/debs/${p}_"*_arm64.deb "$aptdir/debs/${p}_"*_all.deb 2>/dev/null | head -1 || true)
    [ -n "$deb" ] || die "no .deb downloaded for $p"
    dpkg-deb -x "$deb" "$sysroot"
    touch "$aptdir/unpacked/$p"
  done
  rm -rf "$sysroot/usr/share/doc" "$sysroot/usr/share/man" "$sysroot/usr/share/locale"
}

# The host package that holds x86_64 library $1 (same Debian release: same package names), in
# the multiarch folder or, as a few (libogdi, HDF4) have it, in /usr/lib.
host_package_of() {
  local so=${1//./\\.} list
  list=$(grep -lE "/lib/x86_64-linux-gnu/(.*/)?$so\$" /var/lib/dpkg/info/*.list 2>/dev/null ||
         grep -lE "^/usr/lib/$so\$" /var/lib/dpkg/info/*.list 2>/dev/null || true)
  [ -z "$list" ] || basename "$(echo "$list" | head -1)" .list | sed 's/:amd64$//'
}

# Absolute symlinks (libm.so -> /lib/aarch64-linux-gnu/libm.so.6) made relative, so that they
# resolve inside the sysroot; alternatives (libblas.so.3, liblapack.so.3 live in blas/, lapack/
# and are linked by update-alternatives, which `dpkg -x` does not run) linked by hand.
fix_links() {
  local link target
  while IFS= read -r link; do
    target=$(readlink "$link")
    ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$sysroot$target")" "$link"
  done < <(find "$sysroot" -type l -lname '/*')
  local multiarch="$sysroot/usr/lib/aarch64-linux-gnu" lib
  for lib in "$multiarch"/*/lib*.so.[0-9]*; do
    [ -e "$lib" ] || continue
    [ -e "$multiarch/$(basename "$lib")" ] ||
      ln -s "$(basename "$(dirname "$lib")")/$(basename "$lib")" "$multiarch/$(basename "$lib")"
  done
}

# Prints the sonames of the DT_NEEDED closure of the seed libraries that the sysroot lacks.
missing_libraries() {
  local -A seen=()
  local queue=("${seed_libraries[@]}") so path dep
  while [ ${#queue[@]} -gt 0 ]; do
    so=${queue[0]}; queue=("${queue[@]:1}")
    [ -z "${seen[$so]:-}" ] || continue
    seen[$so]=1
    path=""
    for dir in lib/aarch64-linux-gnu usr/lib/aarch64-linux-gnu lib usr/lib; do
      if [ -e "$sysroot/$dir/$so" ]; then path="$sysroot/$dir/$so"; break; fi
    done
    if [ -z "$path" ]; then echo "$so"; continue; fi
    while read -r dep; do
      queue+=("$dep")
    done < <(aarch64-linux-gnu-readelf -d "$path" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
  done
}

step "2/4 arm64 sysroot $sysroot"
if [ -f "$sysroot/.kestrel-sysroot" ] && [ "$(cat "$sysroot/.kestrel-sysroot")" = "$stamp_text" ]; then
  echo "present (stamp matches): not downloading; delete $sysroot to remake it"
else
  rm -rf "$sysroot" "$aptdir"
  mkdir -p "$sysroot" "$aptdir/state/lists/partial" "$aptdir/cache/archives/partial" \
           "$aptdir/sources.list.d" "$aptdir/preferences.d"
  : > "$aptdir/state/status"
  keyring=/usr/share/keyrings/debian-archive-keyring.gpg
  [ -f "$keyring" ] || die "$keyring missing (Debian package debian-archive-keyring)"
  cat > "$aptdir/sources.list" <<EOF
deb [arch=arm64 signed-by=$keyring] $mirror $codename main
deb [arch=arm64 signed-by=$keyring] $mirror $codename-updates main
deb [arch=arm64 signed-by=$keyring] $security_mirror $codename-security main
EOF
  echo "apt-get update (arm64 indices only, private state in $aptdir)"
  apt-get "${apt_opts[@]}" -qq update || die "apt-get update of the arm64 indices failed"
  # Every OpenCV module library and its -dev package (see above).
  opencv=$(apt-cache "${apt_opts[@]}" pkgnames libopencv |
           grep -E '^libopencv-[a-z0-9-]+(406|-dev)$' | grep -v -e '^libopencv-apps' | sort)
  [ -n "$opencv" ] || die "no libopencv packages in the arm64 index of $codename"
  # shellcheck disable=SC2086
  fetch_and_unpack "${dev_packages[@]}" $opencv libc6 libstdc++6 libgcc-s1 libhwy1 libyaml-cpp0.7
  fix_links
  for round in 1 2 3 4 5 6 7 8 9 10; do
    mapfile -t need < <(missing_libraries | sort -u)
    [ ${#need[@]} -gt 0 ] || break
    echo "round $round: ${#need[@]} shared libraries missing: ${need[*]}"
    packages=()
    for so in "${need[@]}"; do
      p=$(host_package_of "$so")
      [ -n "$p" ] || die "no package known for $so (the host has no x86_64 $so to name it: \
install the host's libraries with scripts/setup.sh first, or add its arm64 package to dev_packages)"
      [ -e "$aptdir/unpacked/$p" ] && die "$so still missing after unpacking $p"
      packages+=("$p")
    done
    mapfile -t packages < <(printf '%s\n' "${packages[@]}" | sort -u)
    fetch_and_unpack "${packages[@]}"
    fix_links
  done
  [ -z "$(missing_libraries)" ] || die "shared libraries still missing: $(missing_libraries | tr '\n' ' ')"
  echo "$stamp_text" > "$sysroot/.kestrel-sysroot"
  echo "sysroot: $(ls "$aptdir/unpacked" | wc -l) packages, $(du -sh "$sysroot" | cut -f1)"
fi

# ---------------------------------------------------------------------------------------------
# What each set builds and runs (CTest labels: one per test executable, tests/CMakeLists.txt).
if [ "$mode" = quick ]; then
  targets=(test_odometry_kernels test_image_kernels test_sensor_kernels test_fusion_kernels)
  labels='^(odometry|image|sensor|fusion)_kernels$'
else
  targets=(test_odometry_kernels test_image_kernels test_sensor_kernels test_fusion_kernels
           test_image test_odometry
           test_sensor test_fusion)
  labels='^(odometry_kernels|image_kernels|sensor_kernels|fusion_kernels|image|odometry|sensor|fusion)$'
fi
# Tests that run the arm64 `kestrel` binary through /bin/sh: the host kernel can start it only
# when binfmt_misc hands aarch64 ELF files to qemu (qemu-user-static registers that on a machine
# with systemd-binfmt; containers usually lack it).
exclude=""
if [ "$(cat /proc/sys/fs/binfmt_misc/qemu-aarch64 2>/dev/null | head -1)" != enabled ]; then
  exclude='^CmdFuse\.'
fi

step "3/4 configure $build and build ${targets[*]} (-j$jobs)"
export CCACHE_BASEDIR="$root" CCACHE_NOHASHDIR=1
export KESTREL_ARM64_SYSROOT="$sysroot"
cmake -S . -B "$build" -G Ninja \
  --toolchain "$root/cmake/toolchains/aarch64-linux-gnu.cmake" \
  -DKESTREL_ARM64_SYSROOT="$sysroot" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_UNITY_BUILD=ON \
  -DKESTREL_BUILD_TESTS=ON -DKESTREL_BUILD_BENCH=OFF -DKESTREL_NATIVE=OFF \
  -DKESTREL_WITH_CUDA=OFF -DKESTREL_WITH_ROS=OFF -DKESTREL_FUZZ=OFF >"$build.configure.log" 2>&1 ||
  { tail -30 "$build.configure.log" >&2; die "configure failed (log: $build.configure.log)"; }
grep -E "^-- (The CXX compiler|Found OpenCV|Found GTest)" "$build.configure.log" || true
nice cmake --build "$build" -j "$jobs" --target "${targets[@]}" ||
  die "cross build failed"
build_done=$(date +%s)

step "4/4 tests under $(basename "$qemu") (labels $labels${exclude:+, excluding $exclude})"
export QEMU_LD_PREFIX="$sysroot"  # for arm64 programs the tests start themselves (binfmt)
ctest_args=(--test-dir "$build" -L "$labels" -j "$jobs" --output-on-failure --timeout 1200)
[ -z "$exclude" ] || ctest_args+=(-E "$exclude")
ctest "${ctest_args[@]}" ||
  die "tests failed under qemu (see above; one test: ctest --test-dir $build -R NAME -V)"
# The kernels ran on NEON: their test names the SIMD targets it ran (printed by the test).
"$qemu" -L "$sysroot" "$build/tests/odometry/test_odometry_kernels" \
  --gtest_filter='AlignmentKernels.RunOnTheBestSimdTargetOfTheCpu' | grep -E "SIMD targets" ||
  die "could not list the kernels' SIMD targets"
echo
echo "check_arm64: $mode set passed under qemu-aarch64 in $(( $(date +%s) - start )) s" \
     "(tests $(( $(date +%s) - build_done )) s)"
