#!/usr/bin/env bash
# Compares the kernel benchmarks of several builds (e.g. the portable `release` and the `native`
# preset, or the same preset before and after a change): interleaved rounds, so that a change of
# load hits every build alike, and the minimum CPU time of each benchmark per build.
#
#   scripts/compare_builds.sh [--rounds N] [--filter REGEX] BUILD_DIR...
#
# Each BUILD_DIR is a CMake build folder holding bench/kestrel_bench_fusion, bench/kestrel_bench
# (geometry) and bench/kestrel_bench_odometry. Prints one line per benchmark: the minimum CPU ns
# of each build, its ratio to the first build's, and the median over the rounds of each round's
# ratio (m=...), the steadier figure on a machine whose speed drifts between rounds. Pin it to
# one core with `taskset -c 0 scripts/compare_builds.sh ...`.
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
  # Odd rounds run the builds in the order given, even rounds in reverse: neither goes first
  # every time.
  order=("${!builds[@]}")
  if [ $((round % 2)) -eq 0 ]; then order=($(printf '%s\n' "${order[@]}" | sort -rn)); fi
  for i in "${order[@]}"; do
    for exe in kestrel_bench_fusion kestrel_bench kestrel_bench_odometry; do
      "${builds[$i]}/bench/$exe" --benchmark_filter="$filter" --benchmark_min_time=0.2 \
        --benchmark_format=csv 2>/dev/null | { grep '^"BM' || true; } |
        awk -F, -v b="$i" -v r="$round" '{print b, $1, $4, r}'
    done >> "$out"
  done
done
echo "minimum CPU ns over $rounds rounds; ratio to ${builds[0]} (m=: median of the rounds' ratios)"
for i in "${!builds[@]}"; do echo "  build $i: ${builds[$i]}"; done
awk -v n="${#builds[@]}" '
  { key = $2; if (!(key in seen)) { seen[key] = 1; order[++k] = key }
    v = $3 + 0; m = key SUBSEP $1; if (!(m in best) || v < best[m]) best[m] = v
    # The time of a build in a round: its minimum over the repetitions of that round.
    rk = m SUBSEP $4; if (!(rk in round_t) || v < round_t[rk]) round_t[rk] = v; rounds[$4] = 1 }
  # Median of the per-round ratios of build i to build 0 (insertion sort: mawk has no asort).
  function median_ratio(key, i,    c, r, a, x, y, t) {
    c = 0
    for (r in rounds) {
      x = key SUBSEP 0 SUBSEP r; y = key SUBSEP i SUBSEP r
      if ((x in round_t) && (y in round_t) && round_t[x] > 0) a[++c] = round_t[y] / round_t[x]
    }
    for (x = 2; x <= c; ++x) { t = a[x]; for (y = x - 1; y >= 1 && a[y] > t; --y) a[y + 1] = a[y]; a[y + 1] = t }
    if (c == 0) return -1
    return c % 2 ? a[(c + 1) / 2] : (a[c / 2] + a[c / 2 + 1]) / 2
  }
  END {
    for (j = 1; j <= k; ++j) {
      key = order[j]; line = sprintf("%-26s", key); gsub(/"/, "", line)
      for (i = 0; i < n; ++i) {
        v = best[key SUBSEP i]; line = line sprintf(" %11.1f", v)
        if (i > 0) line = line sprintf(" (%.3f, m=%.3f)", v / best[key SUBSEP 0], median_ratio(key, i))
      }
      print line
    }
  }' "$out"
