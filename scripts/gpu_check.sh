#!/usr/bin/env bash
# On a machine with an NVIDIA GPU: builds the CUDA kernels, runs the GPU tests (the kernels
# against the CPU references) and the GPU benchmark (CPU one thread vs CUDA), and writes
# everything under OUT_DIR (default out/gpu_check). One command:
#   scripts/gpu_check.sh [OUT_DIR] [DATA_DIR]
# Needs what scripts/setup.sh installs, plus nvcc (CUDA 13 here) and a driver. Exits non-zero
# when the build fails, a test fails, or the GPU tests were skipped (no usable device).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/gpu_check}"
data="${2:-../shared/data}"
build=build/gpu-check
mkdir -p "$out"
exec > >(tee "$out/gpu_check.log") 2>&1

echo "=== machine"
date -u +%FT%TZ
git rev-parse HEAD || true
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv || echo "nvidia-smi: not available"
nvcc --version | tail -2 || true
nproc

echo "=== configure ($build, KESTREL_WITH_CUDA=ON)"
cmake --preset release -B "$build" -DKESTREL_WITH_CUDA=ON >"$out/configure.log"
grep "Kestrel CUDA kernels" "$out/configure.log"

echo "=== build"
start=$(date +%s)
cmake --build "$build" --target test_gpu kestrel_bench_gpu kestrel -j "$(nproc)"
echo "build: $(( $(date +%s) - start )) s"

echo "=== GPU tests"
KESTREL_DATA_DIR="$data" "$build/tests/gpu/test_gpu" --gtest_output="xml:$out/test_gpu.xml" \
  | tee "$out/test_gpu.txt"
if grep -q "no CUDA device" "$out/test_gpu.txt"; then
  echo "gpu_check: the CUDA tests were SKIPPED (no usable device): nothing was checked on a GPU"
  exit 2
fi

echo "=== benchmark (CPU rows on one core)"
# taskset keeps the CPU reference on one core; the GPU rows are not affected.
runner=()
command -v taskset >/dev/null && runner=(taskset -c 0)
"${runner[@]}" "$build/bench/kestrel_bench_gpu" "$data" --benchmark_repetitions=5 \
  --benchmark_report_aggregates_only=true --benchmark_out="$out/bench_gpu.json" \
  --benchmark_out_format=json | tee "$out/bench_gpu.txt"

echo "=== kestrel disparity --backend cuda vs cpu"
tsukuba="$data/middlebury/tsukuba"
if [[ -d "$tsukuba" ]]; then
  for b in cpu cuda; do
    "$build/kestrel" disparity --left "$tsukuba/im3.png" --right "$tsukuba/im4.png" \
      --max-disparity 16 --out "$out/tsukuba_$b.pfm" --force --backend "$b"
  done
  cmp "$out/tsukuba_cpu.pfm" "$out/tsukuba_cuda.pfm" && echo "tsukuba: identical PFMs"
fi
echo "gpu_check: done; results in $out"
