// Microbenchmarks of the image kernels and of the direct tracker on a 640x480 rendered pair.
#include <benchmark/benchmark.h>
#include <hwy/targets.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "../tests/odometry/synthetic_rgbd.hpp"
#include "kestrel/image/gradient.hpp"
#include "kestrel/image/intensity.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/image/rolling_shutter.hpp"
#include "kestrel/image/undistortion.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/point_selection.hpp"
#include "kestrel/odometry/robust_weights.hpp"

namespace {

using namespace kestrel;
namespace kernels = kestrel::odometry::kernels;

// KESTREL_BENCH_SIMD=<target> (e.g. AVX2) runs the alignment kernels on that SIMD target instead
// of the CPU's best, to compare targets in one binary; the context header names the target.
const bool kSimdTargetChosen = [] {
  if (const char* wanted = std::getenv("KESTREL_BENCH_SIMD")) {
    bool found = false;
    for (const std::int64_t t : kernels::simd_targets()) {
      if (std::string(hwy::TargetName(t)) == wanted) {
        hwy::SetSupportedTargetsForTest(t);
        found = true;
      }
    }
    if (!found) throw std::runtime_error(std::string("KESTREL_BENCH_SIMD: no target ") + wanted);
  }
  benchmark::AddCustomContext("simd_target", kernels::simd_target());
  return true;
}();

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

// Rolling shutter (RollingShutter::readout_s): the maps for one rotation rate (undistortion
// folded in), and the remaps that replace the two above.
void BM_RollingShutterMaps(benchmark::State& s) {
  image::RollingShutterRectifier r(fr1(), 0.02);
  for (auto _ : s) r.set_rotation_rate(Eigen::Vector3d(0.5, 1.0, 0.3));
}
BENCHMARK(BM_RollingShutterMaps);

void BM_RollingShutterRectify(benchmark::State& s) {
  image::RollingShutterRectifier r(fr1(), 0.02);
  r.set_rotation_rate(Eigen::Vector3d(0.5, 1.0, 0.3));
  cv::Mat in(480, 640, CV_32FC1), depth(480, 640, CV_32FC1), out, out_depth;
  cv::randu(in, 0.0F, 1.0F);
  cv::randu(depth, 0.5F, 4.0F);
  for (auto _ : s) {
    r.rectify_intensity(in, out);
    r.rectify_depth(depth, out_depth);
  }
}
BENCHMARK(BM_RollingShutterRectify);

void BM_IntensityPyramid(benchmark::State& s) {
  cv::Mat in(480, 640, CV_32FC1);
  cv::randu(in, 0.0F, 1.0F);
  image::IntensityPyramid pyr;
  const auto filter =
      s.range(0) == 0 ? image::PyramidFilter::kBox : image::PyramidFilter::kGaussian;
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

// The tracker's path: level 0 written in place (the rectified depth), levels 1-4 built from it.
void BM_DepthPyramidFromBase(benchmark::State& s) {
  image::DepthPyramid pyr;
  pyr.base().create(480, 640, CV_32FC1);
  cv::randu(pyr.base(), 0.5F, 4.0F);
  for (auto _ : s) pyr.build_from_base(5);
}
BENCHMARK(BM_DepthPyramidFromBase);

void BM_Gradients(benchmark::State& s) {
  cv::Mat in(480, 640, CV_32FC1), gx, gy;
  cv::randu(in, 0.0F, 1.0F);
  for (auto _ : s) image::central_gradients(in, gx, gy);
}
BENCHMARK(BM_Gradients);

// ---- The per-iteration alignment kernels on 6000 points (the default selection.max_points) of
// a 640x480 level: what one Gauss-Newton iteration of DirectTracker runs.
struct KernelData {
  static constexpr int kPoints = 6000;
  cv::Mat image;
  std::vector<float> x, y, z, intensity, residual, weight, abs_residual;
  std::vector<std::uint8_t> valid;
  std::array<std::vector<float>, 8> jac;
  kernels::PointsView points() const {
    return {x.data(), y.data(), z.data(), intensity.data(), kPoints};
  }
  kernels::LevelImage level() const {
    return {image.ptr<float>(),
            static_cast<int>(image.step1()),
            image.cols,
            image.rows,
            525.0F,
            525.0F,
            319.5F,
            239.5F};
  }
};
const KernelData& kernel_data() {
  static const KernelData d = [] {
    KernelData k;
    k.image = cv::Mat(480, 640, CV_32FC1);
    cv::randu(k.image, 0.0F, 1.0F);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0F, 640.0F), v(0.0F, 480.0F), depth(0.5F, 4.0F),
        grey(0.0F, 1.0F), jac(-1.0F, 1.0F);
    const auto padded = static_cast<std::size_t>(kernels::pad_to_lanes(KernelData::kPoints));
    for (auto* vec : {&k.x, &k.y, &k.z, &k.intensity, &k.residual, &k.weight, &k.abs_residual}) {
      vec->assign(padded, 0.0F);
    }
    k.valid.assign(padded, 0);
    for (auto& col : k.jac) col.assign(padded, 0.0F);
    for (int i = 0; i < KernelData::kPoints; ++i) {
      const auto s = static_cast<std::size_t>(i);
      const float Z = depth(rng);
      k.x[s] = (u(rng) - 319.5F) / 525.0F * Z;
      k.y[s] = (v(rng) - 239.5F) / 525.0F * Z;
      k.z[s] = Z;
      k.intensity[s] = grey(rng);
      for (auto& col : k.jac) col[s] = jac(rng);
    }
    return k;
  }();
  return d;
}
// A small motion: about 3 % of the points leave the image, as between consecutive frames.
const kernels::FloatPose& kernel_pose() {
  static const kernels::FloatPose T = [] {
    Vector6d xi;
    xi << 0.01, 0.005, 0.01, 0.01, 0.02, 0.015;
    return kernels::FloatPose::from(SE3::exp(xi));
  }();
  return T;
}

// Arg 0: the SIMD (AVX2 gather) version the tracker calls, 1: the scalar reference; 2 / 3: the
// same with bicubic sampling (bicubic_finest_level).
void BM_WarpResiduals(benchmark::State& s) {
  KernelData d = kernel_data();
  const bool scalar = s.range(0) % 2 == 1;
  const auto sampling =
      s.range(0) >= 2 ? kernels::Sampling::kBicubic : kernels::Sampling::kBilinear;
  for (auto _ : s) {
    const int inside =
        scalar ? kernels::warp_residuals_scalar(d.points(), d.level(), kernel_pose(), 1.0F, 0.0F,
                                                d.residual.data(), d.valid.data(), sampling)
               : kernels::warp_residuals(d.points(), d.level(), kernel_pose(), 1.0F, 0.0F,
                                         d.residual.data(), d.valid.data(), sampling);
    benchmark::DoNotOptimize(inside);
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_WarpResiduals)->Arg(0)->Arg(1)->Arg(2)->Arg(3);

// The point-to-plane warp (the geometric fallback's residual): the kernel points on a depth map
// of 1.5-1.6 m, every point with a normal facing the camera. Arg 0: the SIMD version the tracker
// calls, 1: the scalar reference.
void BM_WarpPointToPlane(benchmark::State& s) {
  const KernelData& d = kernel_data();
  static const cv::Mat depth = [] {
    cv::Mat m(480, 640, CV_32FC1);
    cv::randu(m, 1.5F, 1.6F);
    return m;
  }();
  const std::vector<float> nx(d.x.size(), 0.0F), ny(d.x.size(), 0.0F), nz(d.x.size(), -1.0F);
  std::vector<float> ndp(d.x.size());
  for (std::size_t i = 0; i < ndp.size(); ++i) ndp[i] = -d.z[i];
  const std::vector<std::uint8_t> has(d.x.size(), 1);
  const kernels::PlanePointsView points{d.x.data(), d.y.data(), d.z.data(),
                                        nx.data(),  ny.data(),  nz.data(),
                                        ndp.data(), has.data(), KernelData::kPoints};
  const kernels::LevelImage level{depth.ptr<float>(),
                                  static_cast<int>(depth.step1()),
                                  depth.cols,
                                  depth.rows,
                                  525.0F,
                                  525.0F,
                                  319.5F,
                                  239.5F};
  std::vector<float> residual(d.x.size());
  std::vector<std::uint8_t> valid(d.x.size());
  std::array<std::vector<float>, 6> jac;
  for (auto& col : jac) col.assign(d.x.size(), 0.0F);
  float* const j[6] = {jac[0].data(), jac[1].data(), jac[2].data(),
                       jac[3].data(), jac[4].data(), jac[5].data()};
  const bool scalar = s.range(0) == 1;
  for (auto _ : s) {
    const int n = scalar ? kernels::warp_point_to_plane_scalar(points, level, kernel_pose(), 0.05F,
                                                               residual.data(), valid.data(), j)
                         : kernels::warp_point_to_plane(points, level, kernel_pose(), 0.05F,
                                                        residual.data(), valid.data(), j);
    benchmark::DoNotOptimize(n);
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_WarpPointToPlane)->Arg(0)->Arg(1);

KernelData warped_kernel_data() {
  KernelData d = kernel_data();
  kernels::warp_residuals(d.points(), d.level(), kernel_pose(), 1.0F, 0.0F, d.residual.data(),
                          d.valid.data());
  return d;
}

void BM_TukeyCost(benchmark::State& s) {
  const KernelData d = warped_kernel_data();
  for (auto _ : s) {
    benchmark::DoNotOptimize(kernels::tukey_cost_sum(d.residual.data(), d.valid.data(),
                                                     KernelData::kPoints, 1.0F / 0.1F, 4.6851F));
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_TukeyCost);

void BM_TukeyWeights(benchmark::State& s) {
  KernelData d = warped_kernel_data();
  for (auto _ : s) {
    benchmark::DoNotOptimize(kernels::tukey_weights(d.residual.data(), d.valid.data(),
                                                    KernelData::kPoints, 1.0F / 0.1F, 4.6851F,
                                                    d.weight.data()));
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_TukeyWeights);

// The MAD sigma of thesis eq. 3.40: packing |r| of the valid points, then the median selection.
void BM_RobustSigma(benchmark::State& s) {
  KernelData d = warped_kernel_data();
  for (auto _ : s) {
    const int m = kernels::gather_abs_valid(d.residual.data(), d.valid.data(), KernelData::kPoints,
                                            d.abs_residual.data());
    benchmark::DoNotOptimize(odometry::robust_sigma(
        std::span<float>(d.abs_residual.data(), static_cast<std::size_t>(m)), 8));
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_RobustSigma);

// The same median found near a hint (kernels::abs_median), as the Gauss-Newton loop calls it
// with the last iteration's median: Arg 0 = no hint (pack + select all), 1 = a hint 5 % off the
// median (inside the bracket), 2 = a hint 50 % off (outside: one counting pass, then all). The
// calls cycle through 32 residual sets of slightly different warps, as the tracker never sees
// the same residuals twice: on one repeated set the branch predictor learns a comparison-based
// selection's every branch and flatters it several-fold.
void BM_AbsMedian(benchmark::State& s) {
  constexpr int kSets = 32;
  const KernelData& d = kernel_data();
  std::vector<std::vector<float>> residuals(kSets, std::vector<float>(d.residual.size()));
  std::vector<std::vector<std::uint8_t>> valids(kSets, std::vector<std::uint8_t>(d.valid.size()));
  std::vector<float> hints(kSets);
  std::vector<float> scratch(d.abs_residual.size());
  std::mt19937 rng(5);
  std::normal_distribution<double> twist(0.0, 0.01);
  for (int k = 0; k < kSets; ++k) {
    const auto i = static_cast<std::size_t>(k);
    Vector6d xi;
    for (int j = 0; j < 6; ++j) xi(j) = twist(rng);
    kernels::warp_residuals(d.points(), d.level(), kernels::FloatPose::from(SE3::exp(xi)), 1.0F,
                            0.0F, residuals[i].data(), valids[i].data());
    const float exact = kernels::abs_median(residuals[i].data(), valids[i].data(),
                                            KernelData::kPoints, 0.0F, scratch.data())
                            .median;
    hints[i] = s.range(0) == 0 ? 0.0F : exact * (s.range(0) == 1 ? 1.05F : 1.5F);
  }
  std::size_t k = 0;
  for (auto _ : s) {
    benchmark::DoNotOptimize(kernels::abs_median(residuals[k].data(), valids[k].data(),
                                                 KernelData::kPoints, hints[k], scratch.data()));
    k = (k + 1) % kSets;
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_AbsMedian)->Arg(0)->Arg(1)->Arg(2);

// The 8-column weighted normal equations (36 terms of J^T W J and 8 of J^T W r per point).
void BM_NormalEquations(benchmark::State& s) {
  KernelData d = warped_kernel_data();
  kernels::tukey_weights(d.residual.data(), d.valid.data(), KernelData::kPoints, 1.0F / 0.1F,
                         4.6851F, d.weight.data());
  const float* J[8];
  for (std::size_t c = 0; c < 8; ++c) J[c] = d.jac[c].data();
  for (auto _ : s) {
    odometry::Matrix8d H = odometry::Matrix8d::Zero();
    odometry::Vector8d g = odometry::Vector8d::Zero();
    kernels::accumulate_normal_equations<8>(J, KernelData::kPoints, d.weight.data(),
                                            d.residual.data(), H, g);
    benchmark::DoNotOptimize(H.data());
    benchmark::DoNotOptimize(g.data());
  }
  s.SetItemsProcessed(s.iterations() * KernelData::kPoints);
}
BENCHMARK(BM_NormalEquations);

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
  o.selection.max_points = static_cast<int>(s.range(0));
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
  o.selection.max_points = static_cast<int>(s.range(0));
  o.keyframes.min_overlap = 0.0;
  o.keyframes.max_rotation_deg = 180.0;
  o.keyframes.max_translation_rel = 100.0;
  o.keyframes.constant_velocity_prior = false;
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
  o.selection.max_points = static_cast<int>(s.range(0));
  o.terms.geometric = odometry::GeometricTerm::kAlways;
  o.keyframes.min_overlap = 0.0;
  o.keyframes.max_rotation_deg = 180.0;
  o.keyframes.max_translation_rel = 100.0;
  o.keyframes.constant_velocity_prior = false;
  odometry::DirectTracker tracker(PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480}), o);
  tracker.track(p.ref);
  odometry::RgbdFrame cur = p.cur;
  for (auto _ : s) {
    cur.t_ns += 33'000'000;
    benchmark::DoNotOptimize(tracker.track(cur));
  }
}
BENCHMARK(BM_TrackAgainstKeyframeWithDepthResidual)->Arg(6000)->Unit(benchmark::kMillisecond);

// The real sequence of docs/odometry.md's targets (fr1/rpy part 1, 250 frames, fast rotation,
// motion blur), decoded once into memory: one iteration tracks all of it with a fresh tracker, so
// the CPU time per frame includes undistortion, keyframe switches, failures and fallbacks in their
// real proportions. Arg 0: the default options (bicubic sampling on the finest level); 1: without
// the geometric fallback; 2: bilinear sampling on every level (bicubic_finest_level: false).
struct RealSequence {
  std::vector<odometry::RgbdFrame> frames;
  std::string error;
};
const RealSequence& fr1_rpy() {
  static const RealSequence seq = [] {
    RealSequence out;
    const char* env = std::getenv("KESTREL_DATA_DIR");
    const std::filesystem::path data = (env != nullptr && *env != '\0')
                                           ? std::filesystem::path(env)
                                           : std::filesystem::path(KESTREL_DEFAULT_DATA_DIR);
    const auto folder = data / "tum/rgbd_dataset_freiburg1_rpy_part1";
    if (!std::filesystem::exists(folder)) {
      out.error = "shared data not found: " + folder.string();
      return out;
    }
    const io::TumRgbdSequence tum(folder);
    for (std::size_t i = 0; i < tum.size(); ++i) {
      const io::RgbdImages im = tum.load(i);
      out.frames.push_back({im.t_ns, im.bgr, im.depth_m});
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
  if (s.range(0) == 1) o.terms.geometric = odometry::GeometricTerm::kOff;
  if (s.range(0) == 2) o.solver.bicubic_finest_level = false;            // bilinear everywhere
  if (s.range(0) == 3) o.fallback.rotation_from_previous_frame = false;  // the keyframe's rotation
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
  s.counters["per_frame"] = benchmark::Counter(
      n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  s.counters["failures"] = failures;
  s.counters["fallbacks"] = fallbacks;
  s.counters["keyframes"] = keyframes;
  s.counters["iters_per_frame"] = static_cast<double>(iterations) / n;
}
BENCHMARK(BM_TrackRealSequence)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);

// The point selection of a keyframe's full-resolution level (select_strongest, 6000 of the
// 640x480 scores) on the first fr1/rpy frame: squared gradients of its intensity where the
// depth is valid and the gradient above the default min_gradient, 0 elsewhere, as the tracker
// scores them.
void BM_SelectStrongest(benchmark::State& s) {
  const RealSequence& seq = fr1_rpy();
  if (!seq.error.empty()) {
    s.SkipWithError(seq.error.c_str());
    return;
  }
  const odometry::DirectTrackerOptions o;
  cv::Mat intensity, gx, gy;
  image::to_intensity(seq.frames.front().image, intensity);
  image::central_gradients(intensity, gx, gy);
  const cv::Mat& depth = seq.frames.front().depth_m;
  const auto g2min = static_cast<float>(o.selection.min_gradient * o.selection.min_gradient);
  const auto zmin = static_cast<float>(o.selection.min_depth_m);
  const auto zmax = static_cast<float>(o.selection.max_depth_m);
  std::vector<float> scores(static_cast<std::size_t>(intensity.total()), 0.0F);
  std::size_t positive = 0;
  for (int y = 1; y + 1 < intensity.rows; ++y) {
    for (int x = 1; x + 1 < intensity.cols; ++x) {
      const float g2 =
          gx.at<float>(y, x) * gx.at<float>(y, x) + gy.at<float>(y, x) * gy.at<float>(y, x);
      const float z = depth.at<float>(y, x);
      const bool ok = z >= zmin && z <= zmax && g2 >= g2min;
      scores[static_cast<std::size_t>(y) * static_cast<std::size_t>(intensity.cols) +
             static_cast<std::size_t>(x)] = ok ? g2 : 0.0F;
      positive += ok && g2 > 0.0F ? 1 : 0;
    }
  }
  std::vector<int> selected;
  odometry::SelectionScratch scratch;
  for (auto _ : s) {
    odometry::select_strongest(scores, static_cast<std::size_t>(o.selection.max_points), selected,
                               scratch);
    benchmark::DoNotOptimize(selected.data());
  }
  s.counters["candidates"] = static_cast<double>(positive);
  s.counters["selected"] = static_cast<double>(selected.size());
  s.SetItemsProcessed(s.iterations() * static_cast<std::int64_t>(scores.size()));
}
BENCHMARK(BM_SelectStrongest);

}  // namespace
