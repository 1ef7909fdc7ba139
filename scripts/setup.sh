#!/usr/bin/env bash
# Installs the Debian packages Kestrel needs. Idempotent: installs only what is missing, and
# uses sudo when not run as root. Debian 12 (bookworm) or later.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  ccache                   # compile cache (CI builds a fresh clone on the same machine)
  libeigen3-dev            # geometry, estimators
  libhwy-dev               # Google Highway: portable SIMD kernels with run-time dispatch
  libopencv-dev            # images, calibration, rectification, peer odometry (contrib rgbd)
  libyaml-cpp-dev          # option and calibration files
  libcli11-dev             # the kestrel command line
  libgtest-dev libgmock-dev  # tests
  libbenchmark-dev         # bench/
  clang-14 libclang-rt-14-dev llvm-14  # fuzz/: libFuzzer, ASan/UBSan runtimes, llvm-symbolizer
  clang-format clang-tidy  # scripts/lint.sh: formatting and the odometry's function sizes
  libopen3d-dev            # bench/: Open3D's RGB-D odometry, a peer in scripts/bench_odometry.sh
  # the Python module (python/): pybind11, the interpreter's headers, numpy, pytest (its tests)
  pybind11-dev python3-dev python3-pybind11 python3-numpy python3-pytest
  doxygen                  # the API reference and its no-warnings test (docs/api.md)
  # ROS 1 node (src/ros, optional): roscpp, rosbag, messages, tf2_ros, cv_bridge,
  # image_transport, and rosmaster for the tests' loopback master (~120 packages, ~45 s)
  libroscpp-dev librosbag-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
  libtf2-ros-dev libcv-bridge-dev libimage-transport-dev python3-rosmaster
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: not root and no sudo; install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
