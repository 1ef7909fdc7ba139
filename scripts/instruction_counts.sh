#!/usr/bin/env bash
# Instructions per tracked frame and per stereo match, counted exactly by Valgrind's callgrind
# on the release build (portable: no -march=native, whose AVX-512 code Valgrind 3.19 cannot
# run), for each Highway target of interest. SSE4 (128-bit vectors) stands in for AArch64 NEON
# (128-bit) in the on-board cost model of docs/onboard.md; AVX2 is what this machine runs under
# Valgrind (it hides AVX-512); EMU128 is Highway's portable fallback (no SIMD instructions).
#
#   scripts/instruction_counts.sh [BUILD_DIR] [TARGET...]   (default: build/release AVX2 SSE4)
#
# Tracker: BM_TrackRealSequence/0 (250 frames of TUM fr1/rpy, default options, a fresh tracker),
# counting only inside DirectTracker::track, so decoding the images is left out: the mean per
# frame. Matchers: kestrel_bench_stereo --quick --speed --row ROW (one rectified 752x480 EuRoC
# pair, 64 disparities, block 9 unless the row says otherwise, matched 6 times), counting only
# inside BlockMatcher::match and SgmMatcher::match: the mean of the 6 calls (the first also
# sizes the buffers).
# Several minutes per target (Valgrind runs ~50x slower than native).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(AVX2 SSE4)
command -v valgrind >/dev/null || { echo "instruction_counts: valgrind not installed" >&2; exit 1; }
for exe in bench/kestrel_bench_odometry bench/kestrel_bench_stereo; do
  [ -x "$build/$exe" ] || { echo "instruction_counts: $build/$exe not built" >&2; exit 1; }
done
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# Instructions a callgrind profile collected (only inside the toggled functions).
collected() { awk '/^(summary|totals):/ { print $2; exit }' "$1"; }

printf "%-8s %-28s %14s %8s %14s\n" target what instructions calls per_call
for t in "${targets[@]}"; do
  f="$out/track_$t.cg"
  KESTREL_BENCH_SIMD="$t" valgrind --tool=callgrind --callgrind-out-file="$f" \
    --toggle-collect='kestrel::odometry::DirectTracker::track(*' \
    "$build/bench/kestrel_bench_odometry" --benchmark_filter='BM_TrackRealSequence/0$' \
    --benchmark_min_time=0.001 >"$out/track_$t.txt" 2>"$out/track_$t.log"
  [ -s "$f" ] || { cat "$out/track_$t.txt" "$out/track_$t.log" >&2; exit 1; }
  total=$(collected "$f")
  # Frames tracked: the benchmark's CPU time over its per-frame CPU time (one iteration).
  frames=$(awk '/^BM_TrackRealSequence/ { cpu = $4; for (i = 1; i <= NF; ++i)
             if ($i ~ /^per_frame=/) { sub("per_frame=", "", $i); sub("s$", "", $i); pf = $i } }
           END { printf "%.0f", cpu / 1000 / pf }' "$out/track_$t.txt")
  printf "%-8s %-28s %14s %8s %14.0f\n" "$t" "tracker frame (fr1/rpy)" "$total" "$frames" \
    "$(echo "$total / $frames" | bc -l)"

  # One run per speed row of the stereo bench (--row): each matcher is called 6 times, once to
  # size its buffers and 5 timed; collection is on only inside match().
  for row in "kestrel sad" "kestrel sad dense" "kestrel census" "kestrel sad 128 blk 15" \
             "kestrel sgm" "kestrel sgm lr"; do
    f="$out/stereo_$t.cg"
    KESTREL_BENCH_SIMD="$t" valgrind --tool=callgrind --callgrind-out-file="$f" \
      --toggle-collect='*BlockMatcher::match(*cv::Mat&)' \
      --toggle-collect='*SgmMatcher::match(*cv::Mat&)' \
      "$build/bench/kestrel_bench_stereo" --quick --speed --row "$row" >"$out/stereo_$t.txt" \
      2>"$out/stereo_$t.log" || { cat "$out/stereo_$t.txt" "$out/stereo_$t.log" >&2; exit 1; }
    total=$(collected "$f")
    printf "%-8s %-28s %14s %8s %14.0f\n" "$t" "match: ${row#kestrel }" "$total" 6 \
      "$(echo "$total / 6" | bc -l)"
  done
done
