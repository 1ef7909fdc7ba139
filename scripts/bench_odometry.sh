#!/usr/bin/env bash
# The odometry peer comparison: kestrel odometry vs OpenCV contrib RgbdOdometry and RgbdICPOdometry
# on one TUM RGB-D sequence, each pinned to one core (taskset) and single-threaded, every
# trajectory evaluated by `kestrel evaluate`. Prints one table.
#
#   scripts/bench_odometry.sh [DATASET_DIR] [BUILD_DIR] [CORE]
#     DATASET_DIR  default ../shared/data/tum/rgbd_dataset_freiburg1_rpy_part1
#     BUILD_DIR    default build/release (needs the targets kestrel and peer_opencv_odometry)
#     CORE         default 0
#
# ms/frame is wall-clock time of the tracking alone per frame (kestrel: SUMMARY mean_ms; peers:
# odometry.compute() and frame preparation). On a machine shared with other jobs wall time is
# inflated by contention; compare the methods within one run, and use the Google Benchmark CPU
# times of kestrel_bench_odometry for kestrel's own kernels.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:-../shared/data/tum/rgbd_dataset_freiburg1_rpy_part1}
build=${2:-build/release}
core=${3:-0}
kestrel="$build/apps/kestrel/kestrel"
[[ -x "$kestrel" ]] || kestrel="$build/kestrel"
peer="$build/bench/peer_opencv_odometry"
for exe in "$kestrel" "$peer"; do
  [[ -x "$exe" ]] || { echo "bench_odometry.sh: missing $exe (build it first)" >&2; exit 1; }
done
gt="$data/groundtruth.txt"
[[ -f "$gt" ]] || { echo "bench_odometry.sh: $gt not found" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_NUM_THREADS=1 OPENCV_FOR_THREADS_NUM=1

# evaluate EST -> "ATE RPE_m_s RPE_deg_s" (from the key=value line of `kestrel evaluate`)
evaluate() {
  "$kestrel" evaluate --gt "$gt" --est "$1" > "$tmp/eval.txt" 2>&1 || { cat "$tmp/eval.txt" >&2; exit 1; }
  local line
  line=$(grep -E '^ate_rmse_m=' "$tmp/eval.txt" | tail -n 1)
  sed -E 's/ate_rmse_m=([^ ]+) rpe_trans_m_s=([^ ]+) rpe_rot_deg_s=([^ ]+).*/\1 \2 \3/' <<< "$line"
}

rows=()
# kestrel_row NAME TAG [kestrel odometry flags...]: one table row (the SUMMARY line is the last
# line on stderr).
kestrel_row() {
  local name=$1 tag=$2 summary
  shift 2
  taskset -c "$core" "$kestrel" odometry "$data" --out "$tmp/$tag.txt" "$@" > "$tmp/$tag.out" \
    2> "$tmp/$tag.err"
  summary=$(tail -n 1 "$tmp/$tag.err")
  rows+=("$name|$(sed -E 's/.*mean_ms=([0-9.]+).*/\1/' <<< "$summary")|$(sed -E \
    's/.*failures=([0-9]+).*/\1/' <<< "$summary")|$(evaluate "$tmp/$tag.txt")")
}
kestrel_row "kestrel odometry (defaults)" kestrel
# The rolling-shutter option at a 20 ms readout (not a default: docs/odometry.md).
printf 'rolling_shutter_readout_s: 0.02\n' > "$tmp/rs.yaml"
kestrel_row "kestrel + rolling shutter 20 ms (opt.)" kestrel_rs --config "$tmp/rs.yaml"

for m in rgbd icp; do
  out=$(taskset -c "$core" "$peer" "$m" "$data" "$tmp/$m.txt")
  ms=$(sed -E 's/.*mean_ms=([0-9.]+).*/\1/' <<< "$out")
  fail=$(sed -E 's/.*failures=([0-9]+).*/\1/' <<< "$out")
  name="OpenCV RgbdOdometry"
  [[ $m == icp ]] && name="OpenCV RgbdICPOdometry"
  rows+=("$name|$ms|$fail|$(evaluate "$tmp/$m.txt")")
done

echo "sequence: $data (core $core, single thread)"
printf '| %-38s | %9s | %8s | %8s | %9s | %9s |\n' method ms/frame failures "ATE m" "RPE m/s" "RPE deg/s"
printf '|%s|%s|%s|%s|%s|%s|\n' "----------------------------------------" -----------  ---------- ---------- ----------- -----------
for r in "${rows[@]}"; do
  IFS='|' read -r name ms fail nums <<< "$r"
  read -r ate rt rr <<< "$nums"
  printf '| %-38s | %9.2f | %8d | %8.4f | %9.4f | %9.3f |\n' "$name" "$ms" "$fail" "$ate" "$rt" "$rr"
done
