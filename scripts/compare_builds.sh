#!/usr/bin/env bash
# Compares the kernel benchmarks of several builds (e.g. the portable `release` and the `native`
# preset, or the same preset before and after a change): interleaved rounds, so that a change of
# load hits every build alike, and the minimum CPU time of each benchmark per build.
#
#   scripts/compare_builds.sh [--rounds N] [--filter REGEX] BUILD_DIR...
#
# Each BUILD_DIR is a CMake build folder holding bench/kestrel_bench_fusion, bench/kestrel_bench
# (geometry) and bench/kestrel_bench_odometry. Prints one line per benchmark: the minimum CPU ns
# of each build and its ratio to the first build's.
set -euo pipefail
rounds=10
filter='Propagate|UpdateAndClone|Se3Exp|Se3LeftJacobian$|IntensityPyramid|DepthPyramid|Gradients'
builds=()
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds="$2"; shift 2 ;;
    --filter) filter="$2"; shift 2 ;;
    -h|--help) sed -n 2,10p "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) builds+=("$1"); shift ;;
  esac
done
[ ${#builds[@]} -ge 1 ] || { echo "compare_builds: give at least one build folder" >&2; exit 2; }
for b in "${builds[@]}"; do
  for exe in kestrel_bench_fusion kestrel_bench kestrel_bench_odometry; do
    [ -x "$b/bench/$exe" ] || { echo "compare_builds: $b/bench/$exe missing (build it)" >&2; exit 2; }
  done
done
out=$(mktemp)
trap 'rm -f "$out"' EXIT
for round in $(seq 1 "$rounds"); do
  echo "compare_builds: round $round of $rounds" >&2
  for i in "${!builds[@]}"; do
    for exe in kestrel_bench_fusion kestrel_bench kestrel_bench_odometry; do
      "${builds[$i]}/bench/$exe" --benchmark_filter="$filter" --benchmark_min_time=0.2 \
        --benchmark_format=csv 2>/dev/null | { grep '^"BM' || true; } | awk -F, -v b="$i" '{print b, $1, $4}'
    done >> "$out"
  done
done
echo "minimum CPU ns over $rounds rounds; ratio to ${builds[0]}"
for i in "${!builds[@]}"; do echo "  build $i: ${builds[$i]}"; done
awk -v n="${#builds[@]}" '
  { key = $2; if (!(key in seen)) { seen[key] = 1; order[++k] = key }
    v = $3 + 0; m = key SUBSEP $1; if (!(m in best) || v < best[m]) best[m] = v }
  END {
    for (j = 1; j <= k; ++j) {
      key = order[j]; line = sprintf("%-26s", key); gsub(/"/, "", line)
      for (i = 0; i < n; ++i) {
        v = best[key SUBSEP i]; line = line sprintf(" %11.1f", v)
        if (i > 0) line = line sprintf(" (%.3f)", v / best[key SUBSEP 0])
      }
      print line
    }
  }' "$out"
