// The CUDA kernels' arithmetic, run on the CPU: the device functions in the kernels' loops
// (emulation.hpp) against the CPU reference implementations. These run everywhere (CI has no
// GPU); test_cuda_kernels.cpp compares the real kernels when a device is present.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "bitwise_checks.hpp"
#include "emulation.hpp"
#include "kestrel/gpu/image_kernels.hpp"
#include "kestrel/gpu/photometric_step.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"
#include "kestrel/image/gradient.hpp"
#include "kestrel/image/interpolation.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/odometry/alignment_kernels.hpp"
#include "kestrel/odometry/robust_weights.hpp"
#include "photometric_scene.hpp"
#include "stereo_scenes.hpp"
#include "test_data.hpp"

namespace kestrel::gpu {
namespace {

using kestrel::test::differing_bits;
using kestrel::test::expect_same_stats;

cv::Mat random_image(int w, int h, std::uint64_t seed, float lo = 0.0F, float hi = 1.0F) {
  cv::Mat m(h, w, CV_32FC1);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, lo, hi);
  return m;
}

// ---------------------------------------------------------------------------------------------
// Block matching: bit for bit, every option.

TEST(StereoEmulation, EveryOptionMatchesBlockMatcherBitForBit) {
  const int w = 173, h = 101;  // odd sizes, not multiples of any block
  cv::Mat left, right;
  test::synthetic_pair(w, h, 7, left, right);
  for (const test::MatcherCase& c : test::matcher_cases(w, h)) {
    cv::Mat cpu, emu;
    const sensor::MatchStats cpu_stats =
        sensor::BlockMatcher(c.options, c.rig).match(left, right, cpu);
    const sensor::MatchStats emu_stats =
        emulate::match(left, right, stereo_params(c.options, c.rig, w, h), emu);
    EXPECT_EQ(differing_bits(cpu, emu), 0) << c.name;
    expect_same_stats(cpu_stats, emu_stats, c.name);
    // The scene exercises the checks (otherwise equality would prove little).
    if (c.name.rfind("defaults", 0) == 0) {
      EXPECT_GT(cpu_stats.valid, cpu_stats.pixels / 3) << cpu_stats.describe();
      EXPECT_GT(cpu_stats.rejected_texture, 0U) << cpu_stats.describe();
      EXPECT_GT(cpu_stats.rejected_uniqueness, 0U) << cpu_stats.describe();
      EXPECT_GT(cpu_stats.rejected_lr, 0U) << cpu_stats.describe();
    }
    if (c.rig) {
      EXPECT_GT(cpu_stats.rejected_depth, 0U) << c.name << ": " << cpu_stats.describe();
    }
    if (c.options.min_disparity > 0) {
      EXPECT_GT(cpu_stats.unreachable, 0U) << c.name;
    }
  }
}

TEST(StereoEmulation, MiddleburyPairsMatchBlockMatcherBitForBit) {
  KESTREL_REQUIRE_DATA("middlebury/teddy");
  for (const char* name : {"tsukuba", "teddy"}) {
    const lab::MiddleburyPair pair =
        lab::load_middlebury_pair(kestrel::test::shared_data_dir() / "middlebury" / name);
    cv::Mat l, r;
    cv::cvtColor(pair.left, l, cv::COLOR_BGR2GRAY);
    cv::cvtColor(pair.right, r, cv::COLOR_BGR2GRAY);
    for (const sensor::MatchingCost cost :
         {sensor::MatchingCost::kSad, sensor::MatchingCost::kCensus}) {
      sensor::BlockMatcherOptions o;
      o.cost = cost;
      cv::Mat cpu, emu;
      const sensor::MatchStats a = sensor::BlockMatcher(o).match(l, r, cpu);
      const sensor::MatchStats b =
          emulate::match(l, r, stereo_params(o, std::nullopt, l.cols, l.rows), emu);
      EXPECT_EQ(differing_bits(cpu, emu), 0) << name;
      expect_same_stats(a, b, name);
    }
  }
}

TEST(StereoEmulation, CpuBackendIsTheBlockMatcher) {
  cv::Mat left, right;
  test::synthetic_pair(120, 80, 3, left, right);
  StereoMatcher m({}, std::nullopt, Backend::kCpu);
  EXPECT_EQ(m.backend(), Backend::kCpu);
  cv::Mat a, b;
  m.match(left, right, a);
  sensor::BlockMatcher().match(left, right, b);
  EXPECT_EQ(differing_bits(a, b), 0);
  EXPECT_GT(m.last_timing().compute_ms, 0.0);
}

TEST(StereoEmulation, ParamsValidateLikeTheBlockMatcher) {
  sensor::BlockMatcherOptions bad;
  bad.block_size = 4;
  EXPECT_THROW(stereo_params(bad, std::nullopt, 10, 10), std::invalid_argument);
  EXPECT_THROW(StereoMatcher(bad, std::nullopt, Backend::kCpu), std::invalid_argument);
  sensor::BlockMatcherOptions depth;
  depth.max_depth_m = 5.0;  // needs a rig
  EXPECT_THROW(stereo_params(depth, std::nullopt, 10, 10), std::invalid_argument);
  const device::StereoParams p = stereo_params({}, std::nullopt, 640, 480);
  EXPECT_EQ(p.num, 64);
  EXPECT_EQ(p.radius, 4);
  EXPECT_EQ(p.texture_min, 41U);  // ceil(0.25 * 2 * 81)
  EXPECT_TRUE(std::isinf(p.d_max_valid));
}

TEST(StereoEmulation, CensusSignatureAndPrefilterAtTheBorders) {
  // A 3x3 image: the clamped neighbourhoods of a corner, by hand.
  const std::uint8_t img[9] = {10, 20, 30, 40, 50, 60, 70, 80, 90};
  // Corner (0, 0), census 3: neighbours (clamped) row -1 -> row 0: 10 10 20 / 10 20 / 40 40 50;
  // darker than 10: none.
  EXPECT_EQ(device::census_at(img, 3, 3, 3, 0, 0, 1), 0U);
  // Centre (1, 1) = 50: 10 20 30 40 | 60 70 80 90 -> bits 1111 0000.
  EXPECT_EQ(device::census_at(img, 3, 3, 3, 1, 1, 1), 0xF0U);
  // x-Sobel at (1, 1): (30-10) + 2 (60-40) + (90-70) = 80, clamped to cap 31 -> 62.
  EXPECT_EQ(device::xsobel_at(img, 3, 3, 3, 1, 1, 31), 62);
  EXPECT_EQ(device::texture_gradient_at(img, 3, 3, 0, 0), 10);  // |20 - 10|, left clamped
}

// ---------------------------------------------------------------------------------------------
// Pyramids and gradients.

TEST(ImageEmulation, BoxPyramidStepIsBitExact) {
  for (const cv::Size s : {cv::Size(640, 480), cv::Size(161, 123), cv::Size(2, 2)}) {
    const cv::Mat in = random_image(s.width, s.height, 11);
    cv::Mat cpu, emu, scratch;
    image::downsample_intensity(in, cpu, image::PyramidFilter::kBox, scratch);
    emulate::mean_2x2(in, emu);
    EXPECT_EQ(differing_bits(cpu, emu), 0) << s;
  }
}

TEST(ImageEmulation, GaussianPyramidStepWithinOneMillionth) {
  float k[3];
  pyramid_gaussian_taps(k);
  EXPECT_NEAR(k[0] + 2.0F * (k[1] + k[2]), 1.0F, 1e-6F);
  EXPECT_NEAR(k[1] / k[0], std::exp(-0.5F), 1e-6F);
  for (const cv::Size s : {cv::Size(640, 480), cv::Size(161, 123), cv::Size(5, 5)}) {
    const cv::Mat in = random_image(s.width, s.height, 12);
    cv::Mat cpu, emu, scratch;
    image::downsample_intensity(in, cpu, image::PyramidFilter::kGaussian, scratch);
    emulate::gaussian_downsample(in, emu, k);
    double max_diff = 0.0;
    cv::minMaxLoc(cv::abs(cpu - emu), nullptr, &max_diff);
    // OpenCV's vectorised filter may sum in another order (and with FMA): a few ulps.
    EXPECT_LE(max_diff, 1e-6) << s;
    std::cout << "Gaussian step " << s << ": max |emulated - OpenCV| = " << max_diff << "\n";
  }
}

TEST(ImageEmulation, Reflect101IsOpenCvs) {
  for (const int n : {1, 2, 3, 7}) {
    for (int i = -4; i < n + 4; ++i) {
      if (n == 2 && (i < -2 || i > 3)) continue;  // OpenCV loops; so does reflect101
      EXPECT_EQ(device::reflect101(i, n), cv::borderInterpolate(i, n, cv::BORDER_REFLECT_101))
          << i << " " << n;
    }
  }
}

TEST(ImageEmulation, DepthPyramidStepIsBitExactWithInvalidDepths) {
  cv::Mat in = random_image(161, 123, 13, 0.5F, 4.0F);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> ux(0, in.cols - 1), uy(0, in.rows - 1);
  const float specials[] = {0.0F, -1.0F, NAN, INFINITY, -INFINITY, 10.0F, 0.51F};
  for (int k = 0; k < 3000; ++k) in.at<float>(uy(rng), ux(rng)) = specials[k % 7];
  for (const float spread : {0.03F, 0.0F, 0.5F}) {
    cv::Mat cpu, emu;
    image::downsample_depth(in, cpu, spread);
    emulate::depth_2x2(in, emu, spread);
    EXPECT_EQ(differing_bits(cpu, emu), 0) << spread;
  }
}

TEST(ImageEmulation, GradientsAreBitExact) {
  const cv::Mat in = random_image(161, 123, 14);
  cv::Mat gx, gy, ex, ey;
  image::central_gradients(in, gx, gy);
  emulate::central_gradients(in, ex, ey);
  EXPECT_EQ(differing_bits(gx, ex), 0);
  EXPECT_EQ(differing_bits(gy, ey), 0);
}

TEST(ImageEmulation, CpuBackendIsTheImageModule) {
  ImageKernels k(Backend::kCpu);
  const cv::Mat in = random_image(160, 120, 15);
  std::vector<cv::Mat> levels;
  k.intensity_pyramid(in, 4, image::PyramidFilter::kGaussian, levels);
  image::IntensityPyramid ref;
  ref.build(in, 4, image::PyramidFilter::kGaussian);
  ASSERT_EQ(levels.size(), 4U);
  for (int l = 0; l < 4; ++l)
    EXPECT_EQ(differing_bits(levels[static_cast<std::size_t>(l)], ref.level(l)), 0);
  EXPECT_THROW(k.intensity_pyramid(in, 0, image::PyramidFilter::kBox, levels),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// The tracker's inner loop.

TEST(PhotometricEmulation, SamplingAndTukeyAreTheOdometryFunctions) {
  const cv::Mat img = random_image(64, 48, 16);
  std::mt19937 rng(6);
  std::uniform_real_distribution<float> ux(0.0F, 62.999F), uy(0.0F, 46.999F), uu(-8.0F, 8.0F);
  for (int k = 0; k < 20000; ++k) {
    const float x = ux(rng), y = uy(rng);
    const float a = device::sample_bilinear(img.ptr<float>(), img.cols, x, y);
    const float b = image::sample_bilinear_unchecked(img.ptr<float>(), img.cols, x, y);
    ASSERT_EQ(std::memcmp(&a, &b, sizeof(float)), 0) << x << " " << y;
    const float u = uu(rng);
    ASSERT_EQ(device::tukey_weight(u, 4.6851F), odometry::tukey_weight(u, 4.6851F)) << u;
    ASSERT_EQ(device::tukey_cost(u, 4.6851F), odometry::tukey_cost(u, 4.6851F)) << u;
  }
}

device::PointsView view_of(const odometry::ReferenceLevel& L) {
  device::PointsView v;
  v.x = L.x.data();
  v.y = L.y.data();
  v.z = L.z.data();
  v.intensity = L.intensity.data();
  for (std::size_t c = 0; c < 8; ++c) v.jac[c] = L.jac[c].data();
  v.count = L.count;
  return v;
}

device::WarpParams warp_params(const odometry::ReferenceLevel& L, const cv::Mat& img, const SE3& T,
                               float alpha, float beta) {
  device::WarpParams p;
  const Eigen::Matrix3f R = T.rotation_matrix().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) p.r[3 * r + c] = R(r, c);
    p.t[r] = t(r);
  }
  p.fx = L.fx;
  p.fy = L.fy;
  p.cx = L.cx;
  p.cy = L.cy;
  p.width = img.cols;
  p.height = img.rows;
  p.stride = img.cols;
  p.alpha = alpha;
  p.beta = beta;
  return p;
}

// The device warp (emulated on the host) is the tracker's scalar reference bit for bit, as the
// baseline build rounds it: the reference's copy for Highway's portable target (the copies for
// AVX2 and AVX-512 contract a * b + c into FMAs, rounding once). The CPU backend runs the
// tracker's SIMD kernel, equal to float rounding (FMA, another operation order).
TEST(PhotometricEmulation, WarpResidualsAreTheTrackers) {
  const test::PhotometricScene s = test::photometric_scene(320, 240, 6000, 21);
  PhotometricStep cpu(Backend::kCpu);
  cpu.set_reference(s.level);
  cpu.set_image(s.current);
  Vector6d big;
  big << 0.3, 0.0, 0.0, 0.0, 0.1, 0.0;  // many points leave the image
  for (const SE3& T : {s.T_cur_ref, SE3(), SE3::exp(big)}) {
    const int inside = cpu.warp(T, 1.05F, -0.02F);
    std::vector<float> r;
    std::vector<std::uint8_t> v;
    cpu.residuals(r, v);
    std::vector<float> er;
    std::vector<std::uint8_t> ev;
    const int e_inside =
        emulate::warp_residuals(view_of(s.level), s.current.ptr<float>(),
                                warp_params(s.level, s.current, T, 1.05F, -0.02F), er, ev);
    EXPECT_LT(e_inside, s.level.count);  // some points outside

    const auto n = static_cast<std::size_t>(s.level.count);
    std::vector<float> sr(n);
    std::vector<std::uint8_t> sv(n);
    const odometry::kernels::PointsView points{s.level.x.data(), s.level.y.data(), s.level.z.data(),
                                               s.level.intensity.data(), s.level.count};
    const odometry::kernels::LevelImage image{s.current.ptr<float>(),
                                              static_cast<int>(s.current.step1()),
                                              s.current.cols,
                                              s.current.rows,
                                              s.level.fx,
                                              s.level.fy,
                                              s.level.cx,
                                              s.level.cy};
    hwy::SetSupportedTargetsForTest(odometry::kernels::simd_targets().back());
    EXPECT_EQ(odometry::kernels::warp_residuals_scalar(points, image,
                                                       odometry::kernels::FloatPose::from(T), 1.05F,
                                                       -0.02F, sr.data(), sv.data()),
              e_inside);
    hwy::SetSupportedTargetsForTest(0);
    ASSERT_EQ(sr.size(), er.size());
    EXPECT_EQ(std::memcmp(sr.data(), er.data(), sr.size() * sizeof(float)), 0);
    EXPECT_EQ(sv, ev);

    EXPECT_EQ(inside, e_inside);
    ASSERT_EQ(r.size(), er.size());
    EXPECT_EQ(v, ev);
    float max_diff = 0.0F;
    for (std::size_t i = 0; i < n; ++i) max_diff = std::max(max_diff, std::fabs(r[i] - er[i]));
    EXPECT_LT(max_diff, 1e-5F);
  }
}

TEST(PhotometricEmulation, NormalEquationsMatchTheTrackersWithinFloatSummation) {
  for (const int n : {100, 6000, 20000, 100000}) {
    const test::PhotometricScene s = test::photometric_scene(640, 480, n, 22);
    PhotometricStep cpu(Backend::kCpu);
    cpu.set_reference(s.level);
    cpu.set_image(s.current);
    cpu.warp(s.T_cur_ref, 1.0F, 0.0F);
    std::vector<float> absr;
    cpu.valid_abs_residuals(absr);
    const double sigma = odometry::robust_sigma(absr, 8);
    ASSERT_GT(sigma, 0.0);
    const auto inv_sigma = static_cast<float>(1.0 / sigma);
    const float c = 4.6851F;
    const NormalEquations ne = cpu.normal_equations(inv_sigma, c);

    std::vector<float> r;
    std::vector<std::uint8_t> v;
    cpu.residuals(r, v);
    const auto sums = emulate::normal_equations(view_of(s.level), r.data(), v.data(), inv_sigma, c);
    // Max-norm tolerance: float sums in two orders (8 lanes vs per-thread + tree).
    const double h_scale = ne.H.cwiseAbs().maxCoeff();
    int term = 0;
    for (int a = 0; a < 8; ++a) {
      for (int b = a; b < 8; ++b, ++term) {
        EXPECT_NEAR(sums[static_cast<std::size_t>(term)], ne.H(a, b), 2e-5 * h_scale)
            << n << " H " << a << b;
      }
      EXPECT_NEAR(sums[static_cast<std::size_t>(36 + a)], ne.g(a),
                  2e-5 * ne.g.cwiseAbs().maxCoeff())
          << n << " g " << a;
    }
    EXPECT_NEAR(sums[device::kCostTerm], ne.cost, 1e-5 * ne.cost) << n;
    EXPECT_EQ(static_cast<int>(sums[device::kInlierTerm]), ne.inliers) << n;
    EXPECT_GT(ne.inliers, n / 2);
    // The Gauss-Newton step from either agrees.
    odometry::Matrix8d He;
    odometry::Vector8d ge;
    term = 0;
    for (int a = 0; a < 8; ++a) {
      for (int b = a; b < 8; ++b, ++term)
        He(a, b) = He(b, a) = sums[static_cast<std::size_t>(term)];
      ge(a) = sums[static_cast<std::size_t>(36 + a)];
    }
    const odometry::Vector8d d_cpu = ne.H.ldlt().solve(ne.g);
    const odometry::Vector8d d_emu = He.ldlt().solve(ge);
    std::cout << n
              << " points: max |dH| / max |H| = " << (He - ne.H).cwiseAbs().maxCoeff() / h_scale
              << ", max |dg| / max |g| = "
              << (ge - ne.g).cwiseAbs().maxCoeff() / ne.g.cwiseAbs().maxCoeff()
              << ", |d delta| / |delta| = " << (d_cpu - d_emu).norm() / d_cpu.norm() << "\n";
    EXPECT_LE((d_cpu - d_emu).norm(), 1e-3 * d_cpu.norm()) << n;
  }
}

TEST(PhotometricEmulation, CpuBackendChecksItsInput) {
  PhotometricStep step(Backend::kCpu);
  odometry::ReferenceLevel bad;
  bad.count = 5;
  EXPECT_THROW(step.set_reference(bad), std::invalid_argument);
  EXPECT_THROW(step.set_image(cv::Mat(4, 4, CV_8UC1)), std::invalid_argument);
  const test::PhotometricScene s = test::photometric_scene(64, 48, 50, 23);
  step.set_reference(s.level);
  EXPECT_THROW(step.warp(SE3(), 1.0F, 0.0F), std::logic_error);  // no image yet
}

}  // namespace
}  // namespace kestrel::gpu
