#!/usr/bin/env bash
# Checks that need no build: every C++ file is formatted as .clang-format says, and no function
# of the odometry is longer than 80 lines (issue 26: clang-tidy's readability-function-size on a
# compile database configured apart, without the unity build, so that each source is its own
# translation unit), and no hand-written x86 or NEON intrinsic in src/ or include/ (issue 33: the
# SIMD code is Highway's, one source for every target). Exits non-zero on any finding;
# `clang-format -i FILE` fixes the first kind.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t sources < <(git ls-files '*.cpp' '*.hpp' '*.h' '*.cu' '*.cuh')
echo "lint: clang-format on ${#sources[@]} files"
clang-format --dry-run --Werror "${sources[@]}"

echo "lint: no x86 or NEON intrinsics in src/ and include/"
if git grep -nE '\b_mm(256|512)?_[a-z]|[a-z]*mmintrin\.h|arm_neon\.h' -- src include; then
  echo "lint: the intrinsics above: write them with Highway (docs/onboard.md)" >&2
  exit 1
fi

cdb=$(mktemp -d)
trap 'rm -rf "$cdb"' EXIT
cmake -S . -B "$cdb" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
  -DCMAKE_UNITY_BUILD=OFF -DKESTREL_BUILD_TESTS=OFF -DKESTREL_BUILD_BENCH=OFF >"$cdb/configure.log" 2>&1 ||
  { cat "$cdb/configure.log" >&2; exit 1; }
mapfile -t odometry < <(git ls-files 'src/odometry/*.cpp')
echo "lint: functions of at most 80 lines in ${#odometry[@]} odometry sources"
clang-tidy -p "$cdb" --quiet -checks='-*,readability-function-size' --warnings-as-errors='*' \
  -config='{CheckOptions: [{key: readability-function-size.LineThreshold, value: 80}]}' \
  "${odometry[@]}" 2>/dev/null
echo "lint: passed"
