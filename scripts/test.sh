#!/usr/bin/env bash
# Installs what is needed, builds, and runs every test: the release build, then the asan
# preset (AddressSanitizer + UndefinedBehaviorSanitizer). Exits non-zero on any failure.
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
echo "test.sh: all presets passed in $(( $(date +%s) - start )) s"
