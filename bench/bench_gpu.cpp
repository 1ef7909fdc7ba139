// The GPU kernels beside their CPU references, one CPU thread (cv::setNumThreads(1)): image
// pyramids, gradients, the tracker's warp + normal equations, block matching. Each kernel has a
// `cpu` row and, with a CUDA device, `cuda_total` (wall clock of the call: upload, kernels,
// download, synchronisation) and `cuda_kernels` (CUDA events around the kernels only) rows.
// Without a device the GPU rows are not registered (one line says why). scripts/gpu_check.sh
// runs it. Usage: kestrel_bench_gpu [DATA_DIR] [benchmark flags]
#include <benchmark/benchmark.h>

#include <filesystem>
#include <functional>
#include <iostream>
#include <opencv2/core.hpp>
#include <string>

#include "../tests/gpu/photometric_scene.hpp"
#include "../tests/gpu/stereo_scenes.hpp"
#include "kestrel/gpu/image_kernels.hpp"
#include "kestrel/gpu/photometric_step.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/sensor/rectification.hpp"

namespace {

using namespace kestrel;
using gpu::Backend;

std::filesystem::path g_data_dir = KESTREL_DEFAULT_DATA_DIR;

cv::Mat random_image(int w, int h, float lo, float hi, std::uint64_t seed) {
  cv::Mat m(h, w, CV_32FC1);
  cv::RNG(seed).fill(m, cv::RNG::UNIFORM, lo, hi);
  return m;
}

// A rectified 752x480 pair: EuRoC V1_01 pair 0 when the shared data is there, else synthetic.
struct StereoInput {
  cv::Mat left, right;
  std::string source;
};
const StereoInput& stereo_input() {
  static const StereoInput in = [] {
    StereoInput s;
    const auto folder = g_data_dir / "euroc" / "V1_01_easy_part1";
    if (std::filesystem::exists(folder)) {
      const io::EurocSequence seq(folder);
      const sensor::StereoRectifier rect(sensor::StereoCalibration::from_euroc(seq));
      const io::StereoImages pair = seq.load_stereo(0);
      rect.rectify(pair.left, pair.right, s.left, s.right);
      s.source = "EuRoC V1_01 pair 0, rectified";
    } else {
      gpu::test::synthetic_pair(752, 480, 1, s.left, s.right);
      s.source = "synthetic (no shared data)";
    }
    return s;
  }();
  return in;
}

enum class Row { kCpu, kCudaTotal, kCudaKernels };

// Runs `call` per iteration; kCudaKernels reports the CUDA-event time of the kernels.
void run(benchmark::State& state, Row row, const std::function<gpu::StageTiming()>& call) {
  double up = 0.0, down = 0.0;
  for (auto _ : state) {
    const gpu::StageTiming t = call();
    if (row == Row::kCudaKernels) state.SetIterationTime(t.compute_ms / 1e3);
    up += t.upload_ms;
    down += t.download_ms;
  }
  if (row != Row::kCpu) {
    const auto n = static_cast<double>(state.iterations());
    state.counters["upload_ms"] = up / n;
    state.counters["download_ms"] = down / n;
  }
}

Backend backend_of(Row row) { return row == Row::kCpu ? Backend::kCpu : Backend::kCuda; }

void BM_IntensityPyramid(benchmark::State& state, Row row, image::PyramidFilter filter) {
  gpu::ImageKernels k(backend_of(row), nullptr);
  const cv::Mat img = random_image(640, 480, 0.0F, 1.0F, 1);
  std::vector<cv::Mat> levels;
  run(state, row, [&] {
    k.intensity_pyramid(img, 5, filter, levels);
    return k.last_timing();
  });
}

void BM_DepthPyramid(benchmark::State& state, Row row) {
  gpu::ImageKernels k(backend_of(row), nullptr);
  const cv::Mat depth = random_image(640, 480, 0.5F, 4.0F, 2);
  std::vector<cv::Mat> levels;
  run(state, row, [&] {
    k.depth_pyramid(depth, 5, 0.03F, levels);
    return k.last_timing();
  });
}

void BM_Gradients(benchmark::State& state, Row row) {
  gpu::ImageKernels k(backend_of(row), nullptr);
  const cv::Mat img = random_image(640, 480, 0.0F, 1.0F, 3);
  cv::Mat gx, gy;
  run(state, row, [&] {
    k.central_gradients(img, gx, gy);
    return k.last_timing();
  });
}

// One Gauss-Newton iteration's kernels: warp + residuals, then weights + normal equations
// (the robust sigma's median stays on the CPU and is not timed here).
void BM_PhotometricStep(benchmark::State& state, Row row, int points) {
  const gpu::test::PhotometricScene s = gpu::test::photometric_scene(640, 480, points, 4);
  gpu::PhotometricStep step(backend_of(row), nullptr);
  step.set_reference(s.level);
  step.set_image(s.current);
  run(state, row, [&] {
    gpu::StageTiming sum;
    step.warp(s.T_cur_ref, 1.0F, 0.0F);
    const gpu::StageTiming a = step.last_timing();
    benchmark::DoNotOptimize(step.normal_equations(50.0F, 4.6851F));
    const gpu::StageTiming b = step.last_timing();
    sum.upload_ms = a.upload_ms + b.upload_ms;
    sum.compute_ms = a.compute_ms + b.compute_ms;
    sum.download_ms = a.download_ms + b.download_ms;
    return sum;
  });
}

void BM_BlockMatching(benchmark::State& state, Row row, sensor::MatchingCost cost) {
  const StereoInput& in = stereo_input();
  sensor::BlockMatcherOptions o;
  o.cost = cost;
  gpu::StereoMatcher m(o, std::nullopt, backend_of(row), nullptr);
  cv::Mat disparity;
  run(state, row, [&] {
    m.match(in.left, in.right, disparity);
    return m.last_timing();
  });
}

void add(const std::string& name, Row row, const std::function<void(benchmark::State&, Row)>& f) {
  static const char* const suffix[] = {"/cpu", "/cuda_total", "/cuda_kernels"};
  auto* b = benchmark::RegisterBenchmark((name + suffix[static_cast<int>(row)]).c_str(),
                                         [f, row](benchmark::State& s) { f(s, row); });
  b->Unit(benchmark::kMillisecond);
  if (row == Row::kCudaKernels) {
    b->UseManualTime();
  } else {
    b->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  // A positional DATA_DIR first (the other bench programs' convention), then benchmark flags.
  if (argc > 1 && argv[1][0] != '-') {
    g_data_dir = argv[1];
    for (int i = 1; i + 1 < argc; ++i) argv[i] = argv[i + 1];
    --argc;
  }
  cv::setNumThreads(1);  // the CPU rows are one core
  const gpu::CudaDeviceInfo& info = gpu::cuda_device_info();
  std::cout << "kestrel_bench_gpu: " << info.describe() << "\n"
            << "kestrel_bench_gpu: block matching input: " << stereo_input().source << "\n";
  std::vector<Row> rows{Row::kCpu};
  if (info.available()) {
    rows.push_back(Row::kCudaTotal);
    rows.push_back(Row::kCudaKernels);
  } else {
    std::cout << "kestrel_bench_gpu: GPU rows skipped (no CUDA device)\n";
  }
  using image::PyramidFilter;
  for (const Row r : rows) {
    add("pyramid_box_640x480_5", r,
        [](benchmark::State& s, Row x) { BM_IntensityPyramid(s, x, PyramidFilter::kBox); });
    add("pyramid_gaussian_640x480_5", r,
        [](benchmark::State& s, Row x) { BM_IntensityPyramid(s, x, PyramidFilter::kGaussian); });
    add("depth_pyramid_640x480_5", r, [](benchmark::State& s, Row x) { BM_DepthPyramid(s, x); });
    add("gradients_640x480", r, [](benchmark::State& s, Row x) { BM_Gradients(s, x); });
    for (const int n : {6000, 20000}) {
      add("photometric_step_" + std::to_string(n), r,
          [n](benchmark::State& s, Row x) { BM_PhotometricStep(s, x, n); });
    }
    add("block_matching_sad_752x480_64", r,
        [](benchmark::State& s, Row x) { BM_BlockMatching(s, x, sensor::MatchingCost::kSad); });
    add("block_matching_census_752x480_64", r,
        [](benchmark::State& s, Row x) { BM_BlockMatching(s, x, sensor::MatchingCost::kCensus); });
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
