#!/usr/bin/env bash
# Installs what is needed, builds, and runs every test: the release build, then the asan
# preset (AddressSanitizer + UndefinedBehaviorSanitizer), then every fuzz target of fuzz/ for a
# bounded time (scripts/fuzz.sh: KESTREL_FUZZ_SECONDS each, default 60, two at once; 0 skips
# them). Exits non-zero on any failure or fuzzing finding.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
start=$(date +%s)
for preset in release asan; do
  echo "=== build: $preset ==="
  scripts/build.sh "$preset"
  echo "=== test: $preset ==="
  ctest --preset "$preset" -j "$(nproc)"
done
if [ "${KESTREL_FUZZ_SECONDS:-60}" != 0 ]; then
  echo "=== fuzz: ${KESTREL_FUZZ_SECONDS:-60} s per target ==="
  fuzz_start=$(date +%s)
  scripts/fuzz.sh
  echo "fuzz: $(( $(date +%s) - fuzz_start )) s (build included)"
fi
echo "test.sh: all presets passed in $(( $(date +%s) - start )) s"
