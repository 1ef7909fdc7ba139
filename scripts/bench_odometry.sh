#!/usr/bin/env bash
# The odometry peer comparison over every sequence we have: `kestrel odometry` (defaults), OpenCV
# contrib RgbdOdometry and RgbdICPOdometry, and Open3D's RGB-D odometry, each pinned to one core
# (taskset) and single-threaded, every trajectory evaluated by `kestrel evaluate`. Sequences:
# every TUM folder in ../shared/data/tum (camera from the folder: camera_for_folder) and rendered
# ones (`kestrel render`, Kinect-like depth noise). Prints a table per sequence and the totals.
#
#   scripts/bench_odometry.sh [--tum-only] [--repeat N] [BUILD_DIR] [CORE]
#     --repeat N every method runs N times on each sequence, the methods interleaved (A B C, A B
#                C, ...), and ms/frame is the median of the N runs' means, their range printed
#                under the table; default 1. On a shared or virtual machine a single run's time
#                moves by tens of percent with the neighbours' load: N = 3-5 makes the ratio
#                between the methods hold.
#     BUILD_DIR  default build/release (targets kestrel, peer_opencv_odometry and, where Open3D
#                is installed, peer_open3d_odometry; a missing peer is left out with a note)
#     CORE       default 0
#   KESTREL_DATA_DIR overrides ../shared/data.
#
# ms/frame is wall-clock time of the tracking alone per frame (kestrel: SUMMARY mean_ms; peers:
# their compute call and frame preparation). On a machine shared with other jobs wall time is
# inflated by contention: compare the methods within one run, and use the Google Benchmark CPU
# times of kestrel_bench_odometry for kestrel's own kernels.
set -euo pipefail
cd "$(dirname "$0")/.."
tum_only=0
repeat=1
while [[ ${1:-} == --* ]]; do
  case "$1" in
    --tum-only) tum_only=1; shift ;;
    --repeat)
      [[ ${2:-} =~ ^[1-9][0-9]?$ ]] ||
        { echo "bench_odometry.sh: --repeat takes a whole number from 1 to 99" >&2; exit 2; }
      repeat=$2; shift 2 ;;
    *) echo "bench_odometry.sh: unknown option '$1' (options: --tum-only, --repeat N)" >&2; exit 2 ;;
  esac
done
build=${1:-build/release}
core=${2:-0}
data_dir=${KESTREL_DATA_DIR:-../shared/data}
kestrel="$build/kestrel"
opencv_peer="$build/bench/peer_opencv_odometry"
open3d_peer="$build/bench/peer_open3d_odometry"
[[ -x "$kestrel" ]] || { echo "bench_odometry.sh: missing $kestrel (build it first)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export OMP_NUM_THREADS=1 OPENCV_FOR_THREADS_NUM=1

methods=("kestrel odometry (defaults)")
if [[ -x "$opencv_peer" ]]; then
  methods+=("OpenCV RgbdOdometry" "OpenCV RgbdICPOdometry")
else
  echo "note: $opencv_peer not built (needs OpenCV contrib rgbd): OpenCV rows left out" >&2
fi
if [[ -x "$open3d_peer" ]]; then
  methods+=("Open3D RGB-D odometry")
else
  echo "note: $open3d_peer not built (needs libopen3d-dev): Open3D row left out" >&2
fi

# The camera: every method takes the folder's own (its camera.yaml, as `kestrel render` writes,
# else the freiburgN preset its name says: io::camera_for_folder), so all see the same model.
# (Until 2026-12-06 the rendered sequences were run with the fr1 preset, whose lens distortion
# they do not have: docs/odometry.md, "The rendered sequences' camera".)

# evaluate GT EST -> "ATE RPE_m_s RPE_deg_s" (the key=value line of `kestrel evaluate`)
evaluate() {
  "$kestrel" evaluate --gt "$1" --est "$2" > "$tmp/eval.txt" 2>&1 || { cat "$tmp/eval.txt" >&2; exit 1; }
  grep -E '^ate_rmse_m=' "$tmp/eval.txt" | tail -n 1 |
    sed -E 's/ate_rmse_m=([^ ]+) rpe_trans_m_s=([^ ]+) rpe_rot_deg_s=([^ ]+).*/\1 \2 \3/'
}

# run_method METHOD SEQUENCE_DIR OUT -> "frames failures mean_ms"
run_method() {
  local method=$1 seq=$2 out=$3 summary
  case "$method" in
    kestrel*)
      taskset -c "$core" "$kestrel" odometry "$seq" --out "$out" \
        > "$tmp/run.out" 2> "$tmp/run.err" || { cat "$tmp/run.err" >&2; exit 1; }
      summary=$(grep -E '^SUMMARY' "$tmp/run.err" | tail -n 1) ;;
    "OpenCV RgbdOdometry") summary=$(taskset -c "$core" "$opencv_peer" rgbd "$seq" "$out") ;;
    "OpenCV RgbdICPOdometry") summary=$(taskset -c "$core" "$opencv_peer" icp "$seq" "$out") ;;
    "Open3D RGB-D odometry") summary=$(taskset -c "$core" "$open3d_peer" "$seq" "$out") ;;
  esac
  sed -E 's/.*frames=([0-9]+) failures=([0-9]+) mean_ms=([0-9.]+).*/\1 \2 \3/' <<< "$summary"
}

sequences=()
for d in "$data_dir"/tum/rgbd_dataset_*; do
  [[ -f "$d/groundtruth.txt" ]] && sequences+=("$d")
done
if [[ ${#sequences[@]} -eq 0 ]]; then
  echo "bench_odometry.sh: no TUM folder with groundtruth.txt in $data_dir/tum" >&2
  exit 1
fi
if [[ $tum_only -eq 0 ]]; then
  # Rendered: a hand-held office sequence (textured) and the low-texture corridor flown forward,
  # both at 30 Hz with Kinect-like depth noise, on the fr1 camera model.
  for spec in office:handheld corridor:forward; do
    scene=${spec%%:*} trajectory=${spec##*:}
    out="$tmp/rendered_${scene}_${trajectory}"
    "$kestrel" render --scene "$scene" --trajectory "$trajectory" --camera fr1 --noise kinect \
      --frames 120 --out "$out" > /dev/null 2>&1 || { echo "render $spec failed" >&2; exit 1; }
    sequences+=("$out")
  done
fi

declare -A total_frames total_failures total_ms total_ate total_rt total_rr median_ms
for m in "${methods[@]}"; do
  total_frames[$m]=0 total_failures[$m]=0 total_ms[$m]=0 total_ate[$m]=0 total_rt[$m]=0 total_rr[$m]=0
done
row_format='| %-30s | %6s | %8s | %8s | %8s | %8s | %9s |\n'
row_line='|--------------------------------|--------|----------|----------|----------|----------|-----------|'

for seq in "${sequences[@]}"; do
  echo
  camera="its freiburgN name"
  [[ -f "$seq/camera.yaml" ]] && camera="its camera.yaml"
  echo "sequence: $(basename "$seq") (camera from $camera, core $core, single thread)"
  # shellcheck disable=SC2059
  printf "$row_format" method frames failures ms/frame "ATE m" "RPE m/s" "RPE deg/s"
  echo "$row_line"
  # The runs, interleaved: every method once per round. The trajectory evaluated is the first
  # round's (each method is deterministic); the times are every round's.
  declare -A run_ms=() first=()
  for ((r = 1; r <= repeat; r++)); do
    for m in "${methods[@]}"; do
      tag=$(tr -c 'a-zA-Z0-9' _ <<< "$m")
      out="$tmp/$tag.txt"
      [[ $r -gt 1 ]] && out="$tmp/${tag}_again.txt"
      read -r frames failures ms <<< "$(run_method "$m" "$seq" "$out")"
      [[ $r -eq 1 ]] && first[$m]="$frames $failures"
      run_ms[$m]="${run_ms[$m]:-} $ms"
    done
  done
  for m in "${methods[@]}"; do
    tag=$(tr -c 'a-zA-Z0-9' _ <<< "$m")
    read -r frames failures <<< "${first[$m]}"
    ms=$(tr ' ' '\n' <<< "${run_ms[$m]}" | grep . | sort -g |
      awk '{ v[NR] = $1 } END { print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2) }')
    median_ms[$m]=$ms
    read -r ate rt rr <<< "$(evaluate "$seq/groundtruth.txt" "$tmp/$tag.txt")"
    printf '| %-30s | %6d | %8d | %8.2f | %8.4f | %8.4f | %9.3f |\n' "$m" "$frames" "$failures" \
      "$ms" "$ate" "$rt" "$rr"
    total_frames[$m]=$((total_frames[$m] + frames))
    total_failures[$m]=$((total_failures[$m] + failures))
    total_ms[$m]=$(awk -v a="${total_ms[$m]}" -v f="$frames" -v x="$ms" 'BEGIN { print a + f * x }')
    total_ate[$m]=$(awk -v a="${total_ate[$m]}" -v x="$ate" 'BEGIN { print a + x }')
    total_rt[$m]=$(awk -v a="${total_rt[$m]}" -v x="$rt" 'BEGIN { print a + x }')
    total_rr[$m]=$(awk -v a="${total_rr[$m]}" -v x="$rr" 'BEGIN { print a + x }')
  done
  if [[ $repeat -gt 1 ]]; then
    echo "ms/frame: median of $repeat interleaved runs; each method's range:"
    for m in "${methods[@]}"; do
      tr ' ' '\n' <<< "${run_ms[$m]}" | grep . | sort -g |
        awk -v name="$m" 'NR == 1 { lo = $1 } { hi = $1 } END { printf "  %-30s %.2f-%.2f\n", name, lo, hi }'
    done
  fi
  # The issue-26 figure: Kestrel's time against OpenCV RgbdOdometry's, from the same runs.
  if [[ -n ${median_ms["OpenCV RgbdOdometry"]:-} ]]; then
    awk -v k="${median_ms["kestrel odometry (defaults)"]}" -v o="${median_ms["OpenCV RgbdOdometry"]}" \
      'BEGIN { if (o > 0) printf "kestrel / RgbdOdometry time: %.3fx\n", k / o }'
  fi
done

n=${#sequences[@]}
echo
echo "total over $n sequences (ms/frame over all frames; ATE and RPE: mean over the sequences)"
# shellcheck disable=SC2059
printf "$row_format" method frames failures ms/frame "ATE m" "RPE m/s" "RPE deg/s"
echo "$row_line"
for m in "${methods[@]}"; do
  awk -v name="$m" -v f="${total_frames[$m]}" -v fail="${total_failures[$m]}" \
    -v ms="${total_ms[$m]}" -v ate="${total_ate[$m]}" -v rt="${total_rt[$m]}" \
    -v rr="${total_rr[$m]}" -v n="$n" \
    'BEGIN { printf "| %-30s | %6d | %8d | %8.2f | %8.4f | %8.4f | %9.3f |\n",
             name, f, fail, (f > 0 ? ms / f : 0), ate / n, rt / n, rr / n }'
done
if [[ -n ${median_ms["OpenCV RgbdOdometry"]:-} ]]; then
  k="kestrel odometry (defaults)" o="OpenCV RgbdOdometry"
  awk -v k="${total_ms[$k]}" -v o="${total_ms[$o]}" \
    'BEGIN { if (o > 0) printf "kestrel / RgbdOdometry time over all frames: %.3fx\n", k / o }'
fi
