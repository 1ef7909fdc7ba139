#!/usr/bin/env bash
# The main job on the embedded default (no download): render a synthetic RGB-D sequence of
# the built-in office scene with Kinect-like sensor noise, run the direct odometry on it, and
# evaluate the trajectory against the rendered ground truth (figures + plots in out/demo/).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release
kestrel=build/release/kestrel
out=out/demo
mkdir -p "$out"
"$kestrel" render --scene office --trajectory handheld --duration 6 --noise kinect --seed 1 \
  --out "$out/sequence"
"$kestrel" odometry "$out/sequence" --camera ros --out "$out/odometry.txt"
"$kestrel" evaluate --gt "$out/sequence/groundtruth.txt" --est "$out/odometry.txt" \
  --plot "$out/plots"
echo "demo: sequence in $out/sequence, trajectory $out/odometry.txt, plots in $out/plots/"
