// The per-iteration alignment kernels against direct per-point formulas: the SIMD warp against
// the scalar reference and a linear image (exact under bilinear sampling), the Tukey sums
// against robust_weights.hpp point by point, the normal equations against an Eigen product.
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <vector>

#include "kestrel/odometry/alignment_kernels.hpp"
#include "kestrel/odometry/robust_weights.hpp"
#include "simd_targets.hpp"

namespace kestrel::odometry::kernels {
namespace {

constexpr float kC = 4.6851F;

// Runs `body` on every SIMD target the kernels have for this CPU, best first, naming the target
// in any failure: each target's kernels against the one scalar reference.
template <class Body>
void on_every_simd_target(Body&& body) {
  test::on_every_simd_target(
      simd_targets(), [] { return simd_target(); }, [&](std::int64_t) { body(); });
}

TEST(AlignmentKernels, RunOnTheBestSimdTargetOfTheCpu) {
  const std::vector<std::int64_t> targets = simd_targets();
  ASSERT_FALSE(targets.empty());
  EXPECT_STREQ(simd_target(), hwy::TargetName(targets.front()));
  // The targets the other tests run, in the log (scripts/check_arm64.sh shows this line).
  std::string names;
  for (const std::int64_t t : targets) {
    names += std::string(names.empty() ? "" : " ") + hwy::TargetName(t);
  }
  std::printf("SIMD targets (best first): %s; dispatched: %s\n", names.c_str(), simd_target());
#if defined(__x86_64__)
  EXPECT_GE(targets.size(), 2U) << "x86-64 has at least SSSE3 and the scalar fallback";
#elif defined(__aarch64__)
  // Every AArch64 CPU has NEON (Advanced SIMD), and SVE is not compiled (cmake/KestrelSimd.cmake):
  // NEON is the best target, and the portable fallback comes after it.
  EXPECT_STREQ(simd_target(), "NEON");
  EXPECT_GE(targets.size(), 2U) << "AArch64 has NEON and the scalar fallback";
#endif
}

struct Points {
  std::vector<float> x, y, z, intensity;
  explicit Points(int n)
      : x(static_cast<std::size_t>(pad_to_lanes(n))),
        y(x.size()),
        z(x.size()),
        intensity(x.size()),
        count(n) {}
  int count;
  PointsView view() const { return {x.data(), y.data(), z.data(), intensity.data(), count}; }
};

// I(u, v) = 0.1 + 0.002 u + 0.001 v: bilinear interpolation reproduces it exactly.
cv::Mat ramp_image(int w, int h) {
  cv::Mat m(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) m.at<float>(v, u) = 0.1F + 0.002F * u + 0.001F * v;
  }
  return m;
}

LevelImage level_of(const cv::Mat& m) {
  return {m.ptr<float>(), static_cast<int>(m.step1()), m.cols, m.rows, 300.0F, 300.0F, 80.0F,
          60.0F};
}

// Random points, some behind the camera, outside the image or NaN.
Points random_points(int n, std::mt19937& rng) {
  Points p(n);
  std::uniform_real_distribution<float> u(-20.0F, 180.0F), v(-20.0F, 140.0F), z(0.3F, 5.0F),
      grey(0.0F, 1.0F), pick(0.0F, 1.0F);
  for (int i = 0; i < n; ++i) {
    const auto s = static_cast<std::size_t>(i);
    const float Z = z(rng);
    p.x[s] = (u(rng) - 80.0F) / 300.0F * Z;
    p.y[s] = (v(rng) - 60.0F) / 300.0F * Z;
    p.z[s] = Z;
    p.intensity[s] = grey(rng);
    const float k = pick(rng);
    if (k < 0.03F) p.z[s] = -Z;                                       // behind the camera
    if (k > 0.97F) p.x[s] = std::numeric_limits<float>::quiet_NaN();  // invalid depth
  }
  return p;
}

TEST(AlignmentKernels, WarpMatchesTheScalarReferenceOnEveryPoint) {
  on_every_simd_target([&] {
    std::mt19937 rng(11);
    const cv::Mat image = [] {
      cv::Mat m(120, 160, CV_32FC1);
      cv::randu(m, 0.0F, 1.0F);
      return m;
    }();
    const SE3 T = SE3::exp((Vector6d() << 0.02, -0.01, 0.03, 0.02, -0.03, 0.01).finished());
    for (const Sampling sampling : {Sampling::kBilinear, Sampling::kBicubic})
      for (int n : {0, 1, 7, 8, 9, 15, 16, 17, 33, 1003}) {
        const Points p = random_points(n, rng);
        std::vector<float> r_simd(p.x.size(), -1.0F), r_ref(p.x.size(), -1.0F);
        std::vector<std::uint8_t> v_simd(p.x.size(), 7), v_ref(p.x.size(), 7);
        const int in_simd = warp_residuals(p.view(), level_of(image), FloatPose::from(T), 1.1F,
                                           -0.05F, r_simd.data(), v_simd.data(), sampling);
        const int in_ref =
            warp_residuals_scalar(p.view(), level_of(image), FloatPose::from(T), 1.1F, -0.05F,
                                  r_ref.data(), v_ref.data(), sampling);
        ASSERT_EQ(in_simd, in_ref) << n << " points";
        int valid = 0;
        for (int i = 0; i < n; ++i) {
          const auto s = static_cast<std::size_t>(i);
          ASSERT_EQ(v_simd[s], v_ref[s]) << "point " << i;
          ASSERT_TRUE(v_simd[s] == 0 || v_simd[s] == 1);
          // The random image changes by up to 1 per pixel and u, v round differently by ~1e-5 px.
          EXPECT_NEAR(r_simd[s], r_ref[s], 1e-4F) << "point " << i;
          if (v_simd[s] == 0) {
            EXPECT_EQ(r_simd[s], 0.0F);
          }
          valid += v_simd[s];
        }
        EXPECT_EQ(valid, in_simd);
        if (n > 100) {
          EXPECT_GT(in_simd, n / 2);  // the test exercises both kinds of point
          EXPECT_LT(in_simd, n);
        }
      }
  });
}

// The point-to-plane warp, SIMD against the scalar reference: the random points of the
// photometric test with random unit normals (some without one), on a depth map of two surfaces
// (an occlusion edge the 2x2 test must reject), holes, NaN, and far values.
TEST(AlignmentKernels, PointToPlaneWarpMatchesTheScalarReferenceOnEveryPoint) {
  on_every_simd_target([&] {
    std::mt19937 rng(5);
    cv::Mat depth(120, 160, CV_32FC1);
    cv::randu(depth, 1.5F, 1.6F);
    depth.colRange(100, 160).setTo(3.0F);  // a second surface behind: an edge at u = 100
    std::uniform_int_distribution<int> col(0, 159), row(0, 119);
    for (int k = 0; k < 300; ++k) depth.at<float>(row(rng), col(rng)) = 0.0F;
    for (int k = 0; k < 30; ++k) {
      depth.at<float>(row(rng), col(rng)) = std::numeric_limits<float>::quiet_NaN();
    }
    for (int k = 0; k < 30; ++k) depth.at<float>(row(rng), col(rng)) = 5e3F;
    const SE3 T = SE3::exp((Vector6d() << 0.02, -0.01, 0.03, 0.02, -0.03, 0.01).finished());
    std::normal_distribution<float> n01(0.0F, 1.0F);
    std::uniform_real_distribution<float> pick(0.0F, 1.0F);
    for (int n : {0, 1, 7, 8, 9, 15, 16, 17, 33, 1003}) {
      const Points p = random_points(n, rng);
      const auto size = p.x.size();
      std::vector<float> nx(size), ny(size), nz(size), ndp(size);
      std::vector<std::uint8_t> has(size, 0);
      for (int i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(i);
        const Eigen::Vector3f nrm = Eigen::Vector3f(n01(rng), n01(rng), n01(rng)).normalized();
        nx[s] = nrm.x();
        ny[s] = nrm.y();
        nz[s] = nrm.z();
        ndp[s] = nx[s] * p.x[s] + ny[s] * p.y[s] + nz[s] * p.z[s];
        has[s] = pick(rng) < 0.9F ? 1 : 0;
      }
      const PlanePointsView view{p.x.data(), p.y.data(), p.z.data(), nx.data(), ny.data(),
                                 nz.data(),  ndp.data(), has.data(), n};
      std::vector<float> r_simd(size, -1.0F), r_ref(size, -1.0F);
      std::vector<std::uint8_t> v_simd(size, 7), v_ref(size, 7);
      std::vector<std::vector<float>> j_simd(6, std::vector<float>(size, -1.0F)), j_ref = j_simd;
      float* const js[6] = {j_simd[0].data(), j_simd[1].data(), j_simd[2].data(),
                            j_simd[3].data(), j_simd[4].data(), j_simd[5].data()};
      float* const jr[6] = {j_ref[0].data(), j_ref[1].data(), j_ref[2].data(),
                            j_ref[3].data(), j_ref[4].data(), j_ref[5].data()};
      const int in_simd = warp_point_to_plane(view, level_of(depth), FloatPose::from(T), 0.05F,
                                              r_simd.data(), v_simd.data(), js);
      const int in_ref = warp_point_to_plane_scalar(view, level_of(depth), FloatPose::from(T),
                                                    0.05F, r_ref.data(), v_ref.data(), jr);
      ASSERT_EQ(in_simd, in_ref) << n << " points";
      int valid = 0, without_normal = 0;
      for (int i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(i);
        ASSERT_EQ(v_simd[s], v_ref[s]) << "point " << i;
        ASSERT_TRUE(v_simd[s] == 0 || v_simd[s] == 1);
        if (has[s] == 0) {
          EXPECT_EQ(v_simd[s], 0) << "point " << i;
          ++without_normal;
        }
        // Depths of ~1.5 m interpolated with rounding differences of ~1e-5 px.
        EXPECT_NEAR(r_simd[s], r_ref[s], 1e-5F) << "point " << i;
        for (int k = 0; k < 6; ++k) {
          EXPECT_NEAR(j_simd[static_cast<std::size_t>(k)][s], j_ref[static_cast<std::size_t>(k)][s],
                      1e-5F)
              << "point " << i << ", column " << k;
        }
        if (v_simd[s] == 0) {
          EXPECT_EQ(r_simd[s], 0.0F);
          for (int k = 0; k < 6; ++k) EXPECT_EQ(j_simd[static_cast<std::size_t>(k)][s], 0.0F);
        }
        valid += v_simd[s];
      }
      EXPECT_EQ(valid, in_simd);
      if (n > 100) {
        EXPECT_GT(in_simd, n / 4);  // the test exercises both kinds of point
        EXPECT_LT(in_simd, n - without_normal);
      }
    }
  });
}

// A plane seen by a 160x120 camera: depth z(u, v) = d / (n . ray(u, v)), its normal facing the
// camera. Central differences of back-projected points of a plane lie in the plane, so the
// normal is exact up to float rounding.
cv::Mat plane_depth(const Eigen::Vector3f& n, float d, const NormalRow& cam, int w, int h) {
  cv::Mat depth(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3f ray((static_cast<float>(u) - cam.cx) / cam.fx,
                                (static_cast<float>(v) - cam.cy) / cam.fy, 1.0F);
      depth.at<float>(v, u) = d / n.dot(ray);
    }
  }
  return depth;
}

// A normal row's intrinsics, with the tests' spread (0.06); the rows from row_of.
NormalRow camera_row(float fx, float fy, float cx, float cy) {
  NormalRow cam;
  cam.fx = fx;
  cam.fy = fy;
  cam.cx = cx;
  cam.cy = cy;
  cam.max_spread = 0.06F;
  return cam;
}

// The 160 x 120 camera of the plane and edge tests.
NormalRow small_camera_row() { return camera_row(130.0F, 131.0F, 79.5F, 59.5F); }

NormalRow row_of(const cv::Mat& depth, int v, NormalRow cam) {
  cam.up = depth.ptr<float>(v - 1);
  cam.mid = depth.ptr<float>(v);
  cam.down = depth.ptr<float>(v + 1);
  cam.width = depth.cols;
  cam.v = v;
  return cam;
}

TEST(AlignmentKernels, SurfaceNormalsOfAPlaneAreItsNormal) {
  const NormalRow cam = small_camera_row();
  // Unit normals facing the camera (n . P = d < 0 for the points in front of it).
  const Eigen::Vector3f n = Eigen::Vector3f(0.3F, -0.2F, -1.0F).normalized();
  const cv::Mat depth = plane_depth(n, -2.0F, cam, 160, 120);
  on_every_simd_target([&] {
    std::vector<float> nx(160, 9.0F), ny(160, 9.0F);
    std::vector<std::uint8_t> ok(160, 7);
    for (const int v : {1, 37, 60, 118}) {
      surface_normal_row(row_of(depth, v, cam), nx.data(), ny.data(), ok.data());
      EXPECT_EQ(ok[0], 7) << "column 0 is not written";
      EXPECT_EQ(ok[159], 7) << "the last column is not written";
      for (int u = 1; u < 159; ++u) {
        const auto c = static_cast<std::size_t>(u);
        ASSERT_EQ(ok[c], 1) << "row " << v << ", column " << u;
        EXPECT_NEAR(nx[c], n.x(), 2e-5F) << "row " << v << ", column " << u;
        EXPECT_NEAR(ny[c], n.y(), 2e-5F) << "row " << v << ", column " << u;
      }
    }
  });
}

TEST(AlignmentKernels, SurfaceNormalsRefuseEdgesHolesAndGrazingSurfaces) {
  const NormalRow cam = small_camera_row();
  cv::Mat depth(5, 40, CV_32FC1, cv::Scalar(2.0F));
  depth.at<float>(2, 10) = 0.0F;                                     // a hole: 9 and 11 refused
  depth.at<float>(1, 20) = std::numeric_limits<float>::quiet_NaN();  // above 20: refused
  depth.at<float>(2, 30) = 2.5F;                                     // a step: 29 and 31 refused
  on_every_simd_target([&] {
    std::vector<float> nx(40), ny(40);
    std::vector<std::uint8_t> ok(40, 7);
    surface_normal_row(row_of(depth, 2, cam), nx.data(), ny.data(), ok.data());
    for (int u = 1; u < 39; ++u) {
      const bool refused = (u >= 9 && u <= 11) || u == 20 || (u >= 29 && u <= 31);
      EXPECT_EQ(ok[static_cast<std::size_t>(u)], refused ? 0 : 1) << "column " << u;
    }
    // A plane seen almost edge-on (normal 85 deg from the optical axis at the centre): refused.
    const Eigen::Vector3f grazing =
        Eigen::Vector3f(std::sin(1.4835F), 0.0F, -std::cos(1.4835F)).normalized();
    const cv::Mat edge_on = plane_depth(grazing, -0.2F, cam, 160, 120);
    std::vector<float> gx(160), gy(160);
    std::vector<std::uint8_t> gok(160, 7);
    NormalRow wide = cam;
    wide.max_spread = 1.0F;  // the depth changes fast along the row: the spread is not the test
    surface_normal_row(row_of(edge_on, 60, wide), gx.data(), gy.data(), gok.data());
    EXPECT_EQ(gok[80], 0);
  });
}

TEST(AlignmentKernels, SurfaceNormalsMatchTheScalarReference) {
  const NormalRow cam = camera_row(517.3F, 516.5F, 318.6F, 255.3F);  // fr1's intrinsics
  std::mt19937 rng(9);
  cv::Mat depth(48, 203, CV_32FC1);
  cv::randu(depth, 1.0F, 1.04F);  // rough surfaces near the spread's threshold
  std::uniform_int_distribution<int> col(0, 202), row(0, 47);
  for (int k = 0; k < 200; ++k) depth.at<float>(row(rng), col(rng)) = 0.0F;
  for (int k = 0; k < 20; ++k) {
    depth.at<float>(row(rng), col(rng)) = std::numeric_limits<float>::quiet_NaN();
  }
  on_every_simd_target([&] {
    std::vector<float> nx(203), ny(203), rx(203), ry(203);
    std::vector<std::uint8_t> ok(203), rok(203);
    int both = 0, differ = 0;
    for (int v = 1; v < 47; ++v) {
      surface_normal_row(row_of(depth, v, cam), nx.data(), ny.data(), ok.data());
      surface_normal_row_scalar(row_of(depth, v, cam), rx.data(), ry.data(), rok.data());
      for (std::size_t u = 1; u < 202; ++u) {
        ASSERT_TRUE(ok[u] == 0 || ok[u] == 1);
        // Fused multiply-adds on some targets round differently: a test at its threshold may
        // go the other way, on a few pixels at most.
        if (ok[u] != rok[u]) {
          ++differ;
          continue;
        }
        if (ok[u] == 0) continue;
        ++both;
        EXPECT_NEAR(nx[u], rx[u], 1e-4F) << "row " << v << ", column " << u;
        EXPECT_NEAR(ny[u], ry[u], 1e-4F) << "row " << v << ", column " << u;
      }
    }
    EXPECT_GT(both, 1000);  // the test exercises both outcomes
    EXPECT_LE(differ, 5);
  });
}

TEST(AlignmentKernels, WarpOfALinearImageGivesTheKnownResidual) {
  on_every_simd_target([&] {
    const cv::Mat image = ramp_image(160, 120);
    const SE3 T = SE3::exp((Vector6d() << 0.05, 0.02, -0.1, 0.0, 0.02, 0.01).finished());
    const FloatPose pose = FloatPose::from(T);
    Points p(64);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(20.0F, 140.0F), v(20.0F, 100.0F), z(1.0F, 3.0F);
    for (std::size_t i = 0; i < 64; ++i) {
      const float Z = z(rng);
      p.x[i] = (u(rng) - 80.0F) / 300.0F * Z;
      p.y[i] = (v(rng) - 60.0F) / 300.0F * Z;
      p.z[i] = Z;
      p.intensity[i] = 0.3F;
    }
    std::vector<float> r(p.x.size());
    std::vector<std::uint8_t> valid(p.x.size());
    const int inside =
        warp_residuals(p.view(), level_of(image), pose, 0.9F, 0.02F, r.data(), valid.data());
    int expected_inside = 0;
    for (std::size_t i = 0; i < 64; ++i) {
      const Eigen::Vector3d Q = T * Eigen::Vector3d(p.x[i], p.y[i], p.z[i]);
      const double uq = 300.0 * Q.x() / Q.z() + 80.0;
      const double vq = 300.0 * Q.y() / Q.z() + 60.0;
      const bool in = uq >= 0.0 && uq < 159.0 && vq >= 0.0 && vq < 119.0;
      expected_inside += in ? 1 : 0;
      EXPECT_EQ(valid[i], in ? 1 : 0) << "point " << i << " at " << uq << ", " << vq;
      if (!in) continue;
      const double expected = 0.9 * (0.1 + 0.002 * uq + 0.001 * vq) + 0.02 - 0.3;
      EXPECT_NEAR(r[i], expected, 2e-5) << "point " << i;
    }
    EXPECT_EQ(inside, expected_inside);
    EXPECT_GT(inside, 48);
  });
}

// Catmull-Rom reproduces quadratics exactly; bilinear errs by the curvature times a quarter of a
// pixel squared. Both paths, interior points and points within a pixel of the border (where
// bicubic falls back to bilinear).
TEST(AlignmentKernels, BicubicSamplingReproducesAQuadraticImage) {
  on_every_simd_target([&] {
    const int w = 160, h = 120;
    auto f = [](double u, double v) {
      return 0.1 + 0.002 * u + 0.001 * v + 2e-5 * u * u + 3e-5 * v * v - 1e-5 * u * v;
    };
    cv::Mat image(h, w, CV_32FC1);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) image.at<float>(v, u) = static_cast<float>(f(u, v));
    }
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> ui(1.0F, w - 2.0F), vi(1.0F, h - 2.0F), frac(0.0F, 1.0F);
    const int n = 203;
    Points p(n);
    std::vector<double> us(n), vs(n);
    for (int i = 0; i < n; ++i) {
      const auto s = static_cast<std::size_t>(i);
      // Every 10th point in the border band [0, 1) x rows, the rest inside.
      const float u = i % 10 == 0 ? frac(rng) * 0.999F : ui(rng) * 0.9999F;
      const float v = vi(rng) * 0.9999F;
      us[s] = u;
      vs[s] = v;
      p.x[s] = (u - 80.0F) / 300.0F;  // Z = 1: pixel (u, v) under the identity
      p.y[s] = (v - 60.0F) / 300.0F;
      p.z[s] = 1.0F;
      p.intensity[s] = 0.0F;
    }
    for (const bool simd : {true, false}) {
      std::vector<float> rc(p.x.size()), rl(p.x.size());
      std::vector<std::uint8_t> valid(p.x.size());
      const auto run = [&](Sampling smp, std::vector<float>& r) {
        return simd ? warp_residuals(p.view(), level_of(image), FloatPose::from(SE3()), 1.0F, 0.0F,
                                     r.data(), valid.data(), smp)
                    : warp_residuals_scalar(p.view(), level_of(image), FloatPose::from(SE3()), 1.0F,
                                            0.0F, r.data(), valid.data(), smp);
      };
      ASSERT_EQ(run(Sampling::kBicubic, rc), n);
      ASSERT_EQ(run(Sampling::kBilinear, rl), n);
      double max_bilinear_error = 0.0;
      for (int i = 0; i < n; ++i) {
        const auto s = static_cast<std::size_t>(i);
        const double truth = f(us[s], vs[s]);
        if (i % 10 == 0) {
          EXPECT_EQ(rc[s], rl[s]) << "border point " << i;  // the bilinear fallback
          continue;
        }
        EXPECT_NEAR(rc[s], truth, 2e-6) << "point " << i << (simd ? " (simd)" : " (scalar)");
        max_bilinear_error =
            std::max(max_bilinear_error, std::fabs(static_cast<double>(rl[s]) - truth));
      }
      EXPECT_GT(max_bilinear_error, 5e-6);  // the comparison can tell the two apart
    }
  });
}

// Bilinear sampling reads (u + 1, v + 1): the last column and row are outside, for the 8-wide
// and the scalar tail alike.
TEST(AlignmentKernels, LastColumnAndRowAreOutside) {
  on_every_simd_target([&] {
    const cv::Mat image = ramp_image(160, 120);
    const float us[] = {0.01F, 158.99F, 159.0F, 80.0F, 80.0F, -0.001F, 40.0F, 40.0F, 159.0F};
    const float vs[] = {0.01F, 118.99F, 60.0F, 119.0F, 118.0F, 10.0F, 40.0F, 40.0F, 119.0F};
    const std::uint8_t expected[] = {1, 1, 0, 0, 1, 0, 1, 1, 0};
    Points p(9);
    for (std::size_t i = 0; i < 9; ++i) {
      p.x[i] = (us[i] - 80.0F) / 300.0F * 2.0F;
      p.y[i] = (vs[i] - 60.0F) / 300.0F * 2.0F;
      p.z[i] = 2.0F;
    }
    std::vector<float> r(p.x.size());
    std::vector<std::uint8_t> valid(p.x.size());
    EXPECT_EQ(warp_residuals(p.view(), level_of(image), FloatPose::from(SE3()), 1.0F, 0.0F,
                             r.data(), valid.data()),
              5);
    for (std::size_t i = 0; i < 9; ++i) EXPECT_EQ(valid[i], expected[i]) << "point " << i;
  });
}

TEST(AlignmentKernels, TukeySumsMatchThePerPointFunctions) {
  on_every_simd_target([&] {
    std::mt19937 rng(2);
    std::normal_distribution<float> noise(0.0F, 0.05F);
    std::bernoulli_distribution outside(0.1);
    for (int n : {5, 8, 17, 1001}) {
      std::vector<float> r(static_cast<std::size_t>(n)), w(r.size(), -1.0F);
      std::vector<std::uint8_t> valid(r.size());
      for (std::size_t i = 0; i < r.size(); ++i) {
        r[i] = noise(rng) * (i % 7 == 0 ? 10.0F : 1.0F);  // outliers beyond c sigma
        valid[i] = outside(rng) ? 0 : 1;
      }
      const float inv_sigma = 1.0F / 0.04F;
      double cost = 0.0;
      int inliers = 0;
      for (std::size_t i = 0; i < r.size(); ++i) {
        const float u = r[i] * inv_sigma;
        cost += static_cast<double>(valid[i] ? tukey_cost(u, kC) : kC * kC / 6.0F);
        inliers += (valid[i] && std::fabs(u) < kC) ? 1 : 0;
      }
      EXPECT_NEAR(tukey_cost_sum(r.data(), valid.data(), n, inv_sigma, kC), cost, 1e-4 * cost);
      EXPECT_NEAR(tukey_cost_sum_scalar(r.data(), valid.data(), n, inv_sigma, kC), cost,
                  1e-4 * cost);
      std::vector<float> w_scalar(r.size(), -1.0F);
      const WeightSums sums_scalar =
          tukey_weights_scalar(r.data(), valid.data(), n, inv_sigma, kC, w_scalar.data());
      EXPECT_NEAR(sums_scalar.cost, cost, 1e-4 * cost);
      EXPECT_EQ(sums_scalar.inliers, inliers);
      const WeightSums sums = tukey_weights(r.data(), valid.data(), n, inv_sigma, kC, w.data());
      EXPECT_NEAR(sums.cost, cost, 1e-4 * cost);
      EXPECT_EQ(sums.inliers, inliers);
      for (std::size_t i = 0; i < r.size(); ++i) {
        const float expected =
            valid[i] ? tukey_weight(r[i] * inv_sigma, kC) * inv_sigma * inv_sigma : 0.0F;
        EXPECT_NEAR(w[i], expected, 1e-5F * inv_sigma * inv_sigma) << "point " << i;
        EXPECT_NEAR(w_scalar[i], expected, 1e-5F * inv_sigma * inv_sigma) << "point " << i;
      }
    }
  });
}

TEST(AlignmentKernels, AbsoluteResidualsOfValidPointsArePacked) {
  const std::vector<float> r = {-1.0F, 2.0F, -3.0F, 4.0F, -5.0F};
  const std::vector<std::uint8_t> valid = {1, 0, 1, 0, 1};
  on_every_simd_target([&] {
    std::vector<float> out(r.size());
    ASSERT_EQ(gather_abs_valid(r.data(), valid.data(), 5, out.data()), 3);
    EXPECT_EQ(out[0], 1.0F);
    EXPECT_EQ(out[1], 3.0F);
    EXPECT_EQ(out[2], 5.0F);
  });
}

// The packing against its scalar reference, in order, on counts around the SIMD widths, all or
// none valid, and with the compressing store's whole-vector writes ending at the buffer's end.
TEST(AlignmentKernels, PackingEqualsTheScalarReference) {
  on_every_simd_target([&] {
    std::mt19937 rng(11);
    std::normal_distribution<float> noise(0.0F, 1.0F);
    for (const int n : {0, 1, 15, 16, 17, 31, 33, 100, 6001}) {
      for (const double p_valid : {0.0, 0.3, 1.0}) {
        std::bernoulli_distribution keep(p_valid);
        std::vector<float> r(static_cast<std::size_t>(n));
        std::vector<std::uint8_t> valid(r.size());
        for (std::size_t i = 0; i < r.size(); ++i) {
          r[i] = noise(rng);
          valid[i] = keep(rng) ? 1 : 0;
        }
        std::vector<float> got(r.size()), expected(r.size());
        const int m = gather_abs_valid(r.data(), valid.data(), n, got.data());
        ASSERT_EQ(m, gather_abs_valid_scalar(r.data(), valid.data(), n, expected.data()));
        got.resize(static_cast<std::size_t>(m));
        expected.resize(static_cast<std::size_t>(m));
        EXPECT_EQ(got, expected) << "n " << n << " valid " << p_valid;
      }
    }
  });
}

// select_kth against a sort, for the first, last, middle and random ranks, on shapes that stress
// its sampled brackets: all equal, a few distinct values, values a few ulps apart, half zeros,
// twelve decades of magnitude, negatives, sorted and reversed input, denormals.
TEST(AlignmentKernels, SelectionEqualsTheSortedElement) {
  on_every_simd_target([&] {
    std::mt19937 rng(5);
    std::lognormal_distribution<float> wide(0.0F, 6.0F);
    std::uniform_int_distribution<int> ulps(0, 300), few(0, 3);
    std::bernoulli_distribution coin(0.5);
    for (const int n : {1, 2, 63, 64, 65, 500, 6001, 20000}) {
      for (int shape = 0; shape < 9; ++shape) {
        std::vector<float> v(static_cast<std::size_t>(n));
        for (std::size_t i = 0; i < v.size(); ++i) {
          float& x = v[i];
          if (shape == 0) x = 0.125F;
          if (shape == 1) x = static_cast<float>(few(rng));
          if (shape == 2)
            x = 1.0F + static_cast<float>(ulps(rng)) * std::numeric_limits<float>::epsilon();
          if (shape == 3) x = coin(rng) ? 0.0F : wide(rng);
          if (shape == 4) x = wide(rng);
          if (shape == 5) x = coin(rng) ? -wide(rng) : wide(rng);
          if (shape == 6) x = static_cast<float>(i);
          if (shape == 7) x = -static_cast<float>(i);
          if (shape == 8)
            x = static_cast<float>(ulps(rng)) * std::numeric_limits<float>::denorm_min();
        }
        std::vector<float> sorted = v;
        std::sort(sorted.begin(), sorted.end());
        std::uniform_int_distribution<int> any(0, n - 1);
        for (const int k : {0, n - 1, n / 2, any(rng), any(rng)}) {
          std::vector<float> work = v, ref = v;
          EXPECT_EQ(select_kth(work.data(), n, k), sorted[static_cast<std::size_t>(k)])
              << "n " << n << " shape " << shape << " k " << k;
          EXPECT_EQ(select_kth_scalar(ref.data(), n, k), sorted[static_cast<std::size_t>(k)]);
        }
      }
    }
  });
}

// abs_median against packing + nth_element (what robust_sigma selects) for hints inside the
// bracket, outside it on both sides, none and non-finite, on counts that are not a multiple of
// the SIMD width, with ties and invalid points.
TEST(AlignmentKernels, AbsMedianIsTheUpperMedianWhateverTheHint) {
  on_every_simd_target([&] {
    std::mt19937 rng(7);
    std::normal_distribution<float> noise(0.0F, 0.05F);
    std::bernoulli_distribution keep(0.8);
    for (const int n : {1, 2, 7, 8, 9, 17, 33, 100, 6001}) {
      for (const bool ties : {false, true}) {
        std::vector<float> r(static_cast<std::size_t>(n)), scratch(r.size());
        std::vector<std::uint8_t> valid(r.size());
        for (std::size_t i = 0; i < r.size(); ++i) {
          r[i] =
              ties ? 0.01F * static_cast<float>(static_cast<int>(noise(rng) * 100.0F)) : noise(rng);
          valid[i] = keep(rng) ? 1 : 0;
        }
        std::vector<float> packed(r.size());
        const int m = gather_abs_valid(r.data(), valid.data(), n, packed.data());
        packed.resize(static_cast<std::size_t>(m));
        float expected = 0.0F;
        if (m > 0) {
          std::sort(packed.begin(), packed.end());
          expected = packed[static_cast<std::size_t>(m / 2)];
        }
        for (const float hint :
             {expected, expected * 1.05F, expected * 0.95F, expected * 3.0F, expected * 0.2F, 0.0F,
              -1.0F, std::numeric_limits<float>::quiet_NaN(),
              std::numeric_limits<float>::infinity()}) {
          const AbsMedian got = abs_median(r.data(), valid.data(), n, hint, scratch.data());
          EXPECT_EQ(got.valid, m) << "n " << n << " hint " << hint;
          EXPECT_EQ(got.median, expected) << "n " << n << " ties " << ties << " hint " << hint;
        }
      }
    }
    const std::vector<float> r(5, 1.0F);
    const std::vector<std::uint8_t> invalid(5, 0);
    std::vector<float> scratch(5);
    const AbsMedian none = abs_median(r.data(), invalid.data(), 5, 1.0F, scratch.data());
    EXPECT_EQ(none.valid, 0);
    EXPECT_EQ(none.median, 0.0F);
  });
}

// abs_median on shapes that are hard for a selection (all values equal, values a few ulps
// apart, half zeros, denormals, twelve decades of magnitude), on sizes below and above where it
// hands over to nth_element.
TEST(AlignmentKernels, AbsMedianOnHardShapes) {
  std::mt19937 rng(3);
  std::lognormal_distribution<float> wide(0.0F, 6.0F);
  std::uniform_int_distribution<int> ulps(0, 300);
  std::bernoulli_distribution coin(0.5);
  for (const int n : {31, 33, 500, 6001, 20000}) {
    for (int shape = 0; shape < 5; ++shape) {
      std::vector<float> r(static_cast<std::size_t>(n)), scratch(r.size());
      const std::vector<std::uint8_t> valid(r.size(), 1);
      for (auto& v : r) {
        if (shape == 0) v = -0.125F;  // all equal (and negative: |r| is selected)
        if (shape == 1)
          v = 1.0F + static_cast<float>(ulps(rng)) * std::numeric_limits<float>::epsilon();
        if (shape == 2) v = coin(rng) ? 0.0F : wide(rng);
        if (shape == 3)
          v = static_cast<float>(ulps(rng)) * std::numeric_limits<float>::denorm_min();
        if (shape == 4) v = coin(rng) ? -wide(rng) : wide(rng);
      }
      std::vector<float> sorted(r.size());
      std::transform(r.begin(), r.end(), sorted.begin(), [](float v) { return std::fabs(v); });
      std::sort(sorted.begin(), sorted.end());
      const float expected = sorted[static_cast<std::size_t>(n / 2)];
      for (const float hint : {0.0F, expected}) {
        const AbsMedian got = abs_median(r.data(), valid.data(), n, hint, scratch.data());
        EXPECT_EQ(got.valid, n);
        EXPECT_EQ(got.median, expected) << "n " << n << " shape " << shape << " hint " << hint;
      }
    }
  }
}

TEST(RobustSigma, FromTheMedianEqualsTheSelection) {
  std::vector<float> r = {0.5F, 0.1F, 0.3F, 0.2F, 0.4F, 0.6F, 0.9F, 0.7F, 0.8F, 0.05F};
  const double from_median = robust_sigma_from_median(0.5, static_cast<int>(r.size()), 6);
  EXPECT_DOUBLE_EQ(robust_sigma(r, 6), from_median);
  EXPECT_EQ(robust_sigma_from_median(0.5, 6, 6), 0.0);  // m <= p: no estimate
}

template <int C>
void check_normal_equations(int n, std::mt19937& rng) {
  const int padded = pad_to_lanes(n);
  std::uniform_real_distribution<float> d(-1.0F, 1.0F), pos(0.0F, 2.0F);
  std::vector<std::vector<float>> cols(C,
                                       std::vector<float>(static_cast<std::size_t>(padded), 0.0F));
  std::vector<float> w(static_cast<std::size_t>(padded), 0.0F), r(w.size(), 0.0F);
  Eigen::MatrixXd J(n, C);
  Eigen::VectorXd wv(n), rv(n);
  for (int i = 0; i < n; ++i) {
    const auto s = static_cast<std::size_t>(i);
    for (int c = 0; c < C; ++c) J(i, c) = cols[static_cast<std::size_t>(c)][s] = d(rng);
    wv(i) = w[s] = pos(rng);
    rv(i) = r[s] = d(rng);
  }
  const float* Jp[C];
  for (int c = 0; c < C; ++c) Jp[c] = cols[static_cast<std::size_t>(c)].data();
  Matrix8d H = Matrix8d::Identity();  // the kernel adds to what is there
  Vector8d g = Vector8d::Ones();
  accumulate_normal_equations<C>(Jp, n, w.data(), r.data(), H, g);
  Matrix8d H_scalar = Matrix8d::Identity();
  Vector8d g_scalar = Vector8d::Ones();
  accumulate_normal_equations_scalar<C>(Jp, n, w.data(), r.data(), H_scalar, g_scalar);
  const Eigen::MatrixXd H_ref = J.transpose() * wv.asDiagonal() * J;
  const Eigen::VectorXd g_ref = J.transpose() * (wv.array() * rv.array()).matrix();
  const double tol = 1e-5 * std::max(1, n);
  for (int a = 0; a < 8; ++a) {
    for (int b = 0; b < 8; ++b) {
      const double expected = (a < C && b < C ? H_ref(a, b) : 0.0) + (a == b ? 1.0 : 0.0);
      EXPECT_NEAR(H(a, b), expected, tol) << C << " columns, H(" << a << ", " << b << ")";
      EXPECT_NEAR(H_scalar(a, b), expected, 1e-9 * std::max(1, n)) << "scalar reference";
    }
    EXPECT_NEAR(g(a), (a < C ? g_ref(a) : 0.0) + 1.0, tol) << C << " columns, g(" << a << ")";
    EXPECT_NEAR(g_scalar(a), (a < C ? g_ref(a) : 0.0) + 1.0, 1e-9 * std::max(1, n));
  }
}

TEST(AlignmentKernels, NormalEquationsEqualTheDenseProduct) {
  on_every_simd_target([&] {
    std::mt19937 rng(9);
    for (int n : {1, 8, 13, 16, 31, 777}) {
      check_normal_equations<8>(n, rng);
      check_normal_equations<6>(n, rng);
    }
  });
}

}  // namespace
}  // namespace kestrel::odometry::kernels
