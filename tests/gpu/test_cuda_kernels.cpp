// The CUDA kernels against the CPU references, within the tolerances of docs/gpu.md. Every
// test skips without a CUDA device (or in a build without CUDA); scripts/gpu_check.sh runs
// them on a machine with one.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "bitwise_checks.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/gpu/image_kernels.hpp"
#include "kestrel/gpu/photometric_step.hpp"
#include "kestrel/gpu/stereo_matcher.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "photometric_scene.hpp"
#include "stereo_scenes.hpp"
#include "test_data.hpp"

#define KESTREL_REQUIRE_CUDA_DEVICE()                                                      \
  do {                                                                                     \
    if (!::kestrel::gpu::cuda_device_info().available()) {                                 \
      GTEST_SKIP() << "no CUDA device: " << ::kestrel::gpu::cuda_device_info().describe(); \
    }                                                                                      \
  } while (0)

namespace kestrel::gpu {
namespace {

using kestrel::test::differing_bits;
using kestrel::test::expect_same_stats;

double max_abs_diff(const cv::Mat& a, const cv::Mat& b) {
  double m = 0.0;
  cv::minMaxLoc(cv::abs(a - b), nullptr, &m);
  return m;
}

// Block matching: integer costs and the same IEEE division: bit for bit.
TEST(CudaStereo, EveryOptionMatchesBlockMatcherBitForBit) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  const int w = 173, h = 101;
  cv::Mat left, right;
  test::synthetic_pair(w, h, 7, left, right);
  for (const test::MatcherCase& c : test::matcher_cases(w, h)) {
    cv::Mat cpu, gpu;
    const sensor::MatchStats a = sensor::BlockMatcher(c.options, c.rig).match(left, right, cpu);
    StereoMatcher m(c.options, c.rig, Backend::kCuda);
    const sensor::MatchStats b = m.match(left, right, gpu);
    EXPECT_EQ(differing_bits(cpu, gpu), 0) << c.name;
    expect_same_stats(a, b, c.name);
  }
}

TEST(CudaStereo, RealPairsMatchBlockMatcherBitForBit) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  KESTREL_REQUIRE_DATA("middlebury/teddy");
  StereoMatcher gpu_matcher({}, std::nullopt, Backend::kCuda);
  for (const char* name : {"tsukuba", "venus", "teddy"}) {
    const lab::MiddleburyPair p =
        lab::load_middlebury_pair(kestrel::test::shared_data_dir() / "middlebury" / name);
    cv::Mat cpu, gpu;  // BGR input: both convert to grey the same way
    const sensor::MatchStats a = sensor::BlockMatcher().match(p.left, p.right, cpu);
    const sensor::MatchStats b = gpu_matcher.match(p.left, p.right, gpu);
    EXPECT_EQ(differing_bits(cpu, gpu), 0) << name;
    expect_same_stats(a, b, name);
  }
}

TEST(CudaStereo, EurocPairMatchesBlockMatcherBitForBit) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const io::EurocSequence seq(kestrel::test::shared_data_dir() / "euroc" / "V1_01_easy_part1");
  const sensor::StereoRectifier rect(sensor::StereoCalibration::from_euroc(seq));
  const io::StereoImages pair = seq.load_stereo(0);
  cv::Mat l, r;
  rect.rectify(pair.left, pair.right, l, r);
  cv::Mat cpu, gpu;
  const sensor::MatchStats a = sensor::BlockMatcher({}, rect.rig()).match(l, r, cpu);
  StereoMatcher m({}, rect.rig(), Backend::kCuda);
  const sensor::MatchStats b = m.match(l, r, gpu);
  EXPECT_EQ(differing_bits(cpu, gpu), 0);
  expect_same_stats(a, b, "euroc");
  EXPECT_GT(m.last_timing().compute_ms, 0.0);
}

TEST(CudaStereo, BadInputIsTheSameError) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  StereoMatcher m({}, std::nullopt, Backend::kCuda);
  cv::Mat d;
  EXPECT_THROW(m.match(cv::Mat(), cv::Mat(10, 10, CV_8U), d), InputError);
  EXPECT_THROW(m.match(cv::Mat(10, 10, CV_8U), cv::Mat(10, 12, CV_8U), d), InputError);
  EXPECT_THROW(m.match(cv::Mat(10, 10, CV_16U), cv::Mat(10, 10, CV_16U), d), InputError);
}

// Pyramids: the box and depth steps and the gradients are exact (no operation nvcc can fuse);
// the Gaussian within 2e-6 (FMA contraction and OpenCV's summation order).
TEST(CudaImage, PyramidsAndGradientsMatchTheImageModule) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  ImageKernels gpu(Backend::kCuda), cpu(Backend::kCpu);
  cv::Mat in(483, 641, CV_32FC1);
  cv::RNG(31).fill(in, cv::RNG::UNIFORM, 0.0, 1.0);
  for (const image::PyramidFilter f :
       {image::PyramidFilter::kBox, image::PyramidFilter::kGaussian}) {
    std::vector<cv::Mat> a, b;
    cpu.intensity_pyramid(in, 5, f, a);
    gpu.intensity_pyramid(in, 5, f, b);
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t l = 0; l < a.size(); ++l) {
      if (f == image::PyramidFilter::kBox) {
        EXPECT_EQ(differing_bits(a[l], b[l]), 0) << "box level " << l;
      } else {
        EXPECT_LE(max_abs_diff(a[l], b[l]), 2e-6) << "gaussian level " << l;
      }
    }
  }
  cv::Mat depth(480, 640, CV_32FC1);
  cv::RNG(32).fill(depth, cv::RNG::UNIFORM, 0.5, 4.0);
  for (int k = 0; k < 5000; ++k)
    depth.at<float>(k * 61 % 480, k * 37 % 640) = (k % 3 == 0) ? 0.0F : (k % 3 == 1 ? NAN : 9.0F);
  std::vector<cv::Mat> da, db;
  cpu.depth_pyramid(depth, 5, 0.03F, da);
  gpu.depth_pyramid(depth, 5, 0.03F, db);
  for (std::size_t l = 0; l < da.size(); ++l)
    EXPECT_EQ(differing_bits(da[l], db[l]), 0) << "depth level " << l;
  cv::Mat gx, gy, hx, hy;
  cpu.central_gradients(in, gx, gy);
  gpu.central_gradients(in, hx, hy);
  EXPECT_EQ(differing_bits(gx, hx), 0);
  EXPECT_EQ(differing_bits(gy, hy), 0);
  EXPECT_GT(gpu.last_timing().compute_ms, 0.0);
}

// The tracker's step: residuals within 1e-5 (FMA in the projection moves u, v by ulps), at
// most 2 points changing side of the image border, H and g within 1e-4 of their largest entry,
// the cost within 1e-5, the inliers within 2.
TEST(CudaPhotometric, StepMatchesTheTrackersLoops) {
  KESTREL_REQUIRE_CUDA_DEVICE();
  for (const int n : {100, 6000, 20000, 100000}) {
    const test::PhotometricScene s = test::photometric_scene(640, 480, n, 41);
    PhotometricStep cpu(Backend::kCpu), gpu(Backend::kCuda);
    for (PhotometricStep* p : {&cpu, &gpu}) {
      p->set_reference(s.level);
      p->set_image(s.current);
    }
    const int in_cpu = cpu.warp(s.T_cur_ref, 1.02F, -0.01F);
    const int in_gpu = gpu.warp(s.T_cur_ref, 1.02F, -0.01F);
    EXPECT_LE(std::abs(in_cpu - in_gpu), 2) << n;
    std::vector<float> ra, rb;
    std::vector<std::uint8_t> va, vb;
    cpu.residuals(ra, va);
    gpu.residuals(rb, vb);
    ASSERT_EQ(ra.size(), rb.size());
    int flips = 0;
    double max_dr = 0.0;
    for (std::size_t i = 0; i < ra.size(); ++i) {
      if (va[i] != vb[i]) {
        ++flips;
        continue;
      }
      max_dr = std::max(max_dr, static_cast<double>(std::fabs(ra[i] - rb[i])));
    }
    EXPECT_LE(flips, 2) << n;
    EXPECT_LE(max_dr, 1e-5) << n;
    const float inv_sigma = 1.0F / 0.02F, c = 4.6851F;
    const NormalEquations a = cpu.normal_equations(inv_sigma, c);
    const NormalEquations b = gpu.normal_equations(inv_sigma, c);
    EXPECT_LE((a.H - b.H).cwiseAbs().maxCoeff(), 1e-4 * a.H.cwiseAbs().maxCoeff()) << n;
    EXPECT_LE((a.g - b.g).cwiseAbs().maxCoeff(), 1e-4 * a.g.cwiseAbs().maxCoeff()) << n;
    EXPECT_NEAR(a.cost, b.cost, 1e-5 * a.cost) << n;
    EXPECT_LE(std::abs(a.inliers - b.inliers), 2) << n;
  }
}

}  // namespace
}  // namespace kestrel::gpu
