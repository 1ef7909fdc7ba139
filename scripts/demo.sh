#!/usr/bin/env bash
# The main job on the embedded default (no download): a closed-loop flight of the whole
# pipeline in simulation. The quadrotor flies a 2 m square in the built-in office scene on its
# own estimate: rendered active-stereo images -> block matching -> direct odometry -> EKF with
# the IMU -> position controller -> PWM -> flight-controller model -> dynamics. Prints the
# tracking and estimate errors and the paths of the log and plots (out/demo/flight/).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh release
out=out/demo
mkdir -p "$out"
build/release/kestrel fly --scenario square --seed 1 --out "$out/flight"
