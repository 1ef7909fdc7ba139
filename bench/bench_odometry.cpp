// Microbenchmarks of the image kernels and of the direct tracker on a 640x480 rendered pair.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <vector>

#include "kestrel/image/gradient.hpp"
#include "kestrel/image/intensity.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/image/undistortion.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "../tests/odometry/synthetic_rgbd.hpp"

namespace {

using namespace kestrel;

const PinholeCamera& fr1() {
  static const PinholeCamera cam({517.3, 516.5, 318.6, 255.3, 640, 480},
                                 {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  return cam;
}

cv::Mat random_bgr() {
  cv::Mat m(480, 640, CV_8UC3);
  cv::randu(m, 0, 255);
  return m;
}

void BM_ToIntensity(benchmark::State& s) {
  const cv::Mat bgr = random_bgr();
  cv::Mat out;
  for (auto _ : s) image::to_intensity(bgr, out);
}
BENCHMARK(BM_ToIntensity);

void BM_UndistortIntensity(benchmark::State& s) {
  image::Undistorter u(fr1());
  cv::Mat in(480, 640, CV_32FC1), out;
  cv::randu(in, 0.0F, 1.0F);
  for (auto _ : s) u.undistort_intensity(in, out);
}
BENCHMARK(BM_UndistortIntensity);

void BM_UndistortDepth(benchmark::State& s) {
  image::Undistorter u(fr1());
  cv::Mat in(480, 640, CV_32FC1), out;
  cv::randu(in, 0.5F, 4.0F);
  for (auto _ : s) u.undistort_depth(in, out);
}
BENCHMARK(BM_UndistortDepth);

void BM_IntensityPyramid(benchmark::State& s) {
  cv::Mat in(480, 640, CV_32FC1);
  cv::randu(in, 0.0F, 1.0F);
  image::IntensityPyramid pyr;
  const auto filter = s.range(0) == 0 ? image::PyramidFilter::kBox : image::PyramidFilter::kGaussian;
  for (auto _ : s) pyr.build(in, 5, filter);
}
BENCHMARK(BM_IntensityPyramid)->Arg(0)->Arg(1);

void BM_DepthPyramid(benchmark::State& s) {
  cv::Mat in(480, 640, CV_32FC1);
  cv::randu(in, 0.5F, 4.0F);
  image::DepthPyramid pyr;
  for (auto _ : s) pyr.build(in, 5);
}
BENCHMARK(BM_DepthPyramid);

void BM_Gradients(benchmark::State& s) {
  cv::Mat in(480, 640, CV_32FC1), gx, gy;
  cv::randu(in, 0.0F, 1.0F);
  for (auto _ : s) image::central_gradients(in, gx, gy);
}
BENCHMARK(BM_Gradients);

struct Pair {
  odometry::RgbdFrame ref, cur;
};
const Pair& rendered_pair() {
  static const Pair p = [] {
    const PinholeCamera cam({525.0, 525.0, 319.5, 239.5, 640, 480});
    const auto room = test::make_room();
    Vector6d xi;
    xi << 0.01, 0.005, 0.01, 0.01, 0.02, 0.015;
    return Pair{test::render(room, cam, SE3()), test::render(room, cam, SE3::exp(xi), 33'000'000)};
  }();
  return p;
}

// Whole two-frame alignment (preparation of both frames, reference precomputation, IC-LK).
void BM_AlignPair(benchmark::State& s) {
  const Pair& p = rendered_pair();
  odometry::DirectTrackerOptions o;
  o.max_points_per_level = static_cast<int>(s.range(0));
  odometry::DirectTracker tracker(PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480}), o);
  int iterations = 0;
  for (auto _ : s) iterations = tracker.align_pair(p.ref, p.cur).iterations;
  s.counters["gn_iterations"] = iterations;
}
BENCHMARK(BM_AlignPair)->Arg(2000)->Arg(6000)->Arg(20000)->Unit(benchmark::kMillisecond);

// Tracking a frame against an existing keyframe: what a sequence pays per frame.
void BM_TrackAgainstKeyframe(benchmark::State& s) {
  const Pair& p = rendered_pair();
  odometry::DirectTrackerOptions o;
  o.max_points_per_level = static_cast<int>(s.range(0));
  o.keyframe_min_overlap = 0.0;
  o.keyframe_max_rotation_deg = 180.0;
  o.keyframe_max_translation_rel = 100.0;
  o.constant_velocity_prior = false;
  odometry::DirectTracker tracker(PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480}), o);
  tracker.track(p.ref);
  odometry::RgbdFrame cur = p.cur;
  for (auto _ : s) {
    cur.t_ns += 33'000'000;
    benchmark::DoNotOptimize(tracker.track(cur));
  }
}
BENCHMARK(BM_TrackAgainstKeyframe)->Arg(2000)->Arg(6000)->Arg(20000)->Unit(benchmark::kMillisecond);

// The same with the geometric (point-to-plane) residual: a depth pyramid per frame and a second
// warp per iteration.
void BM_TrackAgainstKeyframeWithDepthResidual(benchmark::State& s) {
  const Pair& p = rendered_pair();
  odometry::DirectTrackerOptions o;
  o.max_points_per_level = static_cast<int>(s.range(0));
  o.use_depth_residual = true;
  o.keyframe_min_overlap = 0.0;
  o.keyframe_max_rotation_deg = 180.0;
  o.keyframe_max_translation_rel = 100.0;
  o.constant_velocity_prior = false;
  odometry::DirectTracker tracker(PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480}), o);
  tracker.track(p.ref);
  odometry::RgbdFrame cur = p.cur;
  for (auto _ : s) {
    cur.t_ns += 33'000'000;
    benchmark::DoNotOptimize(tracker.track(cur));
  }
}
BENCHMARK(BM_TrackAgainstKeyframeWithDepthResidual)->Arg(6000)->Unit(benchmark::kMillisecond);

// The real sequence of issue 3 (fr1/rpy part 1, 250 frames, fast rotation, motion blur), decoded
// once into memory: one iteration tracks all of it with a fresh tracker, so the CPU time per
// frame includes undistortion, keyframe switches, failures and fallbacks in their real
// proportions. Arg 0: the default options; 1: without the geometric fallback.
struct RealSequence {
  std::vector<odometry::RgbdFrame> frames;
  std::string error;
};
const RealSequence& fr1_rpy() {
  static const RealSequence seq = [] {
    RealSequence out;
    const char* env = std::getenv("KESTREL_DATA_DIR");
    const std::filesystem::path data =
        (env != nullptr && *env != '\0') ? std::filesystem::path(env)
                                          : std::filesystem::path(KESTREL_DEFAULT_DATA_DIR);
    const auto folder = data / "tum/rgbd_dataset_freiburg1_rpy_part1";
    if (!std::filesystem::exists(folder)) {
      out.error = "shared data not found: " + folder.string();
      return out;
    }
    const io::TumRgbdSequence tum(folder);
    for (std::size_t i = 0; i < tum.size(); ++i) {
      const io::RgbdImages im = tum.load(i);
      out.frames.push_back({im.t_ns, im.bgr, im.depth_m, im.depth_t_ns});
    }
    return out;
  }();
  return seq;
}

void BM_TrackRealSequence(benchmark::State& s) {
  const RealSequence& seq = fr1_rpy();
  if (!seq.error.empty()) {
    s.SkipWithError(seq.error.c_str());
    return;
  }
  odometry::DirectTrackerOptions o;
  if (s.range(0) == 1) o.geometric_fallback = false;
  const PinholeCamera cam = *io::camera_preset("fr1");
  int failures = 0, fallbacks = 0, keyframes = 0;
  long iterations = 0;
  for (auto _ : s) {
    odometry::DirectTracker tracker(cam, o);
    failures = fallbacks = keyframes = 0;
    iterations = 0;
    for (const auto& f : seq.frames) {
      const odometry::TrackResult r = tracker.track(f);
      failures += r.ok() ? 0 : 1;
      fallbacks += r.geometric_fallback ? 1 : 0;
      keyframes += r.new_keyframe ? 1 : 0;
      iterations += r.iterations;
    }
  }
  const auto n = static_cast<double>(seq.frames.size());
  // CPU seconds per frame (printed with an SI prefix: "8.1m" = 8.1 ms).
  s.counters["per_frame"] = benchmark::Counter(n, benchmark::Counter::kIsIterationInvariantRate |
                                                     benchmark::Counter::kInvert);
  s.counters["failures"] = failures;
  s.counters["fallbacks"] = fallbacks;
  s.counters["keyframes"] = keyframes;
  s.counters["iters_per_frame"] = static_cast<double>(iterations) / n;
}
BENCHMARK(BM_TrackRealSequence)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
