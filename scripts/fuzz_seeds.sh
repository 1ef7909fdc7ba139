#!/usr/bin/env bash
# Builds the seed corpora of the fuzz targets (fuzz/) from small pieces of the real recorded data
# in ../shared/data (or $KESTREL_DATA_DIR) and the repository's own config files:
#   scripts/fuzz_seeds.sh OUT_DIR    -> OUT_DIR/<target>/<seed files>
# Each seed is at most ~4 KB (the head of a file, cut at a line end, or a crop of an image), so
# that the fuzzers start from real formats without copying the data sets anywhere.
set -eu  # no pipefail: `head` closing a pipe early is how the seeds are cut
cd "$(dirname "$0")/.."
out="${1:?usage: scripts/fuzz_seeds.sh OUT_DIR}"
data="${KESTREL_DATA_DIR:-$PWD/../shared/data}"
[ -d "$data" ] || { echo "fuzz_seeds: no data folder at $data" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out"

# head_lines SRC DST [LINES]: the first lines of SRC (default 30), at most 4 KB, whole lines.
head_lines() {
  head -n "${3:-30}" "$1" | head -c 4096 > "$2.tmp"
  # Drop a last line cut by the 4 KB limit.
  if [ "$(tail -c 1 "$2.tmp" | od -An -c | tr -d ' ')" != '\n' ]; then sed -i '$d' "$2.tmp"; fi
  mv "$2.tmp" "$2"
}
seed() { mkdir -p "$out/$1"; head_lines "$2" "$out/$1/$3" "${4:-30}"; }

tum="$data/tum"
euroc="$data/euroc/V1_01_easy_part1/mav0"
euroc2="$data/euroc/V1_02_medium_imu_groundtruth/mav0"

for s in rgbd_dataset_freiburg1_rpy_part1 rgbd_dataset_freiburg3_teddy_part1; do
  seed tum_file_list "$tum/$s/rgb.txt" "$s-rgb.txt"
  seed tum_file_list "$tum/$s/depth.txt" "$s-depth.txt"
  seed trajectory "$tum/$s/groundtruth.txt" "$s-groundtruth.txt"
done
seed trajectory "$tum/reference_trajectories/freiburg1_xyz-rgbdslam.txt" rgbdslam.txt
seed trajectory "$euroc/groundtruth_cam0/data.csv" euroc-groundtruth_cam0.csv
seed trajectory "$euroc2/gt0/data.csv" euroc-gt0.csv 10
seed euroc_imu_csv "$euroc/imu0/data.csv" V1_01-imu0.csv
seed euroc_imu_csv "$euroc2/imu0/data.csv" V1_02-imu0.csv
seed euroc_camera_csv "$euroc/cam0/data.csv" cam0.csv
seed euroc_camera_csv "$euroc/cam1/data.csv" cam1.csv
seed euroc_groundtruth "$euroc2/gt0/data.csv" gt0.csv 10
seed euroc_groundtruth "$euroc/groundtruth_cam0/data.csv" groundtruth_cam0.csv 10
for f in cam0/sensor.yaml cam1/sensor.yaml imu0/sensor.yaml body.yaml; do
  seed sensor_yaml "$euroc/$f" "${f//\//-}" 200
done
seed sensor_yaml "$euroc2/gt0/sensor.yaml" gt0-sensor.yaml 200
for f in config/*.yaml; do seed options_yaml "$f" "$(basename "$f")" 400; done
seed sensor_yaml config/imu_default.yaml imu_default.yaml 200

# PFM: an 8x4 crop of the top-left corner of Middlebury disparity maps (rows run bottom up, so
# the crop is the first 4 rows of data with the header's size rewritten).
mkdir -p "$out/pfm"
for scene in Teddy Playroom; do
  src="$data/middlebury2014/$scene/disp0GT.pfm"
  [ -f "$src" ] || continue
  header_bytes=$(head -n 3 "$src" | wc -c)
  width=$(sed -n 2p "$src" | cut -d' ' -f1)
  scale=$(sed -n 3p "$src")
  {
    printf 'Pf\n8 4\n%s\n' "$scale"
    for row in 0 1 2 3; do
      tail -c +$((header_bytes + 1 + row * width * 4)) "$src" | head -c 32
    done
  } > "$out/pfm/$scene-8x4.pfm"
done

# odometry --frames log: the header with its 21 covariance columns and two rows (the format of
# src/io/odometry_frame_log.cpp; the values are those of tests/io/test_odometry_frame_log.cpp).
mkdir -p "$out/odometry_frame_log"
{
  header="frame,t_ns,ref_t_ns,ok,failure,new_keyframe"
  for r in 0 1 2 3 4 5; do for c in $(seq "$r" 5); do header+=",cov_$r$c"; done; done
  echo "# written by kestrel odometry"
  echo "$header"
  for frame in 0 1; do
    line="$frame,$((1403715524922140000 + frame * 50000000)),1403715524922140000,1,,$((1 - frame))"
    for r in 0 1 2 3 4 5; do for c in $(seq "$r" 5); do
      if [ "$r" = "$c" ]; then line+=",1e-06"; else line+=",0"; fi
    done; done
    echo "$line"
  done
} > "$out/odometry_frame_log/frames.csv"

# Stereo decoder: 5 control bytes (width, height, left byte, phase/demosaic/view, stride; see
# fuzz/stereo_frame_decoder.cpp) then the bytes of a real EuRoC frame as the packed samples.
mkdir -p "$out/stereo_frame_decoder"
png=$(find "$euroc/cam0/data" -name '*.png' | sort | head -n 1)
printf '\x10\x08\x00\x00\x00' > "$out/stereo_frame_decoder/16x8-grey.bin"
tail -c 4096 "$png" | head -c 256 >> "$out/stereo_frame_decoder/16x8-grey.bin"
printf '\x20\x10\x01\x15\x08' > "$out/stereo_frame_decoder/32x16-colour-padded.bin"
tail -c 4096 "$png" | head -c 1152 >> "$out/stereo_frame_decoder/32x16-colour-padded.bin"

echo "fuzz_seeds: $(find "$out" -type f | wc -l) seeds, $(du -sk "$out" | cut -f1) KB in $out"
