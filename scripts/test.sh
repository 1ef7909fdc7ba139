#!/usr/bin/env bash
# Installs what is needed, checks the formatting and the odometry's function sizes
# (scripts/lint.sh), builds, and runs every test: the release build, then the asan
# preset (AddressSanitizer + UndefinedBehaviorSanitizer), then the install, downstream and
# package checks of the release build (scripts/check_install.sh), then the SIMD kernel tests
# built for aarch64 and run under qemu (scripts/check_arm64.sh --quick; KESTREL_ARM64=full or
# 0), then every fuzz target of fuzz/ for a bounded time (scripts/fuzz.sh:
# KESTREL_FUZZ_SECONDS each, default 60, two at once; 0 skips them). Exits non-zero on any
# failure or fuzzing finding.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
start=$(date +%s)
echo "=== lint: clang-format, function sizes ==="
scripts/lint.sh
for preset in release asan; do
  echo "=== build: $preset ==="
  scripts/build.sh "$preset"
  echo "=== test: $preset ==="
  ctest --preset "$preset" -j "$(nproc)"
done
# What a user gets: install the release build, build examples/downstream against it (CMake and
# pkg-config) and run it on the dev data, import the Python module from the install, build the
# .deb and check that its dependencies resolve (scripts/check_install.sh).
echo "=== install, downstream example, Debian package ==="
scripts/check_install.sh release
# The on-board code on 64-bit ARM: the SIMD kernel tests cross-compiled for aarch64 and run
# under qemu-aarch64, NEON included (scripts/check_arm64.sh; KESTREL_ARM64=full runs the
# odometry, stereo and fusion tests too, 0 skips it).
if [ "${KESTREL_ARM64:-quick}" != 0 ]; then
  echo "=== arm64: ${KESTREL_ARM64:-quick} set under qemu-aarch64 ==="
  arm64_start=$(date +%s)
  scripts/check_arm64.sh "--${KESTREL_ARM64:-quick}"
  echo "arm64: $(( $(date +%s) - arm64_start )) s (sysroot, cross build and tests)"
fi
if [ "${KESTREL_FUZZ_SECONDS:-30}" != 0 ]; then
  echo "=== fuzz: ${KESTREL_FUZZ_SECONDS:-30} s per target ==="
  fuzz_start=$(date +%s)
  scripts/fuzz.sh
  echo "fuzz: $(( $(date +%s) - fuzz_start )) s (build included)"
fi
echo "test.sh: all presets passed in $(( $(date +%s) - start )) s"
