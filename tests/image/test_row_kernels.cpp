// The image row kernels on every SIMD target against their scalar references, bit for bit:
// widths that do and do not fill the vectors, and depth rows full of the cases the reference
// treats specially (0, negative, NaN, infinity, blocks at the spread limit).
#include <gtest/gtest.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kestrel/image/row_kernels.hpp"
#include "simd_targets.hpp"

namespace kestrel::image::kernels {
namespace {

// Runs `body` on every SIMD target the kernels have for this CPU, naming it in any failure.
template <class Body>
void on_every_simd_target(Body&& body) {
  test::on_every_simd_target(
      simd_targets(), [] { return simd_target(); }, [&](std::int64_t) { body(); });
}

// Bit patterns, so that NaN == NaN and -0 != +0.
::testing::AssertionResult same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::memcmp(&a[i], &b[i], sizeof(float)) != 0) {
      return ::testing::AssertionFailure() << "column " << i << ": " << a[i] << " vs " << b[i];
    }
  }
  return ::testing::AssertionSuccess();
}

// Widths from 1 to past two AVX-512 vectors of bytes, and camera rows.
const std::vector<int> kWidths = {1,  3,  4,  7,  8,   15,  16,  17, 31,
                                  33, 47, 64, 65, 129, 320, 376, 640};

TEST(ImageRowKernels, BgrToIntensityEqualsTheScalarReference) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      std::vector<std::uint8_t> bgr(3 * static_cast<std::size_t>(w));
      for (auto& b : bgr) b = static_cast<std::uint8_t>(byte(rng));
      if (w > 2) bgr[0] = bgr[1] = bgr[2] = 255;  // the largest sum
      std::vector<float> simd(static_cast<std::size_t>(w), -1.0F), ref(simd);
      bgr_to_intensity_row(bgr.data(), simd.data(), w);
      bgr_to_intensity_row_scalar(bgr.data(), ref.data(), w);
      EXPECT_TRUE(same_bits(simd, ref)) << "width " << w;
      EXPECT_FLOAT_EQ(ref[0], static_cast<float>(bgr[0] + bgr[1] + bgr[2]) / 765.0F);
    }
  });
}

TEST(ImageRowKernels, Mean2x2EqualsTheScalarReference) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> value(0.0F, 1.0F);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      std::vector<float> r0(2 * static_cast<std::size_t>(w)), r1(r0.size());
      for (auto& v : r0) v = value(rng);
      for (auto& v : r1) v = value(rng);
      std::vector<float> simd(static_cast<std::size_t>(w), -1.0F), ref(simd);
      mean_2x2_row(r0.data(), r1.data(), simd.data(), w);
      mean_2x2_row_scalar(r0.data(), r1.data(), ref.data(), w);
      EXPECT_TRUE(same_bits(simd, ref)) << "width " << w;
      EXPECT_NEAR(ref[0], (r0[0] + r0[1] + r1[0] + r1[1]) / 4.0F, 1e-6F);
    }
  });
}

TEST(ImageRowKernels, Depth2x2EqualsTheScalarReferenceOnInvalidAndEdgeDepths) {
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr float kSpread = 0.03F;
  // Depths drawn from the special values and from near/far pairs that straddle the spread.
  const std::vector<float> special = {0.0F,         -1.0F,  kNan, kInf, -kInf, 1.0F,
                                      1.0F * 1.03F, 1.031F, 2.0F, 0.5F, 4.0F};
  std::mt19937 rng(13);
  std::uniform_int_distribution<std::size_t> pick(0, special.size() - 1);
  std::uniform_real_distribution<float> near(0.98F, 1.05F);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      std::vector<float> r0(2 * static_cast<std::size_t>(w)), r1(r0.size());
      for (std::size_t i = 0; i < r0.size(); ++i) {
        r0[i] = (i % 3 == 0) ? near(rng) : special[pick(rng)];
        r1[i] = (i % 2 == 0) ? near(rng) : special[pick(rng)];
      }
      std::vector<float> simd(static_cast<std::size_t>(w), -1.0F), ref(simd);
      depth_2x2_row(r0.data(), r1.data(), simd.data(), w, kSpread);
      depth_2x2_row_scalar(r0.data(), r1.data(), ref.data(), w, kSpread);
      EXPECT_TRUE(same_bits(simd, ref)) << "width " << w;
      for (const float d : ref) EXPECT_TRUE(std::isfinite(d) && d >= 0.0F) << d;
    }
  });
}

TEST(ImageRowKernels, CentralGradientEqualsTheScalarReferenceAndKeepsTheBorder) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> value(0.0F, 1.0F);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      if (w < 3) continue;
      std::vector<float> up(static_cast<std::size_t>(w)), mid(up.size()), down(up.size());
      for (auto* row : {&up, &mid, &down}) {
        for (auto& v : *row) v = value(rng);
      }
      std::vector<float> gx(up.size(), -7.0F), gy(gx), ref_gx(gx), ref_gy(gx);
      central_gradient_row(up.data(), mid.data(), down.data(), gx.data(), gy.data(), w);
      central_gradient_row_scalar(up.data(), mid.data(), down.data(), ref_gx.data(), ref_gy.data(),
                                  w);
      EXPECT_TRUE(same_bits(gx, ref_gx)) << "width " << w;
      EXPECT_TRUE(same_bits(gy, ref_gy)) << "width " << w;
      // The border columns are the caller's: not written.
      EXPECT_EQ(gx.front(), -7.0F);
      EXPECT_EQ(gx.back(), -7.0F);
      EXPECT_EQ(gy.back(), -7.0F);
      EXPECT_FLOAT_EQ(ref_gx[1], 0.5F * (mid[2] - mid[0]));
      EXPECT_FLOAT_EQ(ref_gy[1], 0.5F * (down[1] - up[1]));
    }
  });
}

TEST(ImageRowKernels, DistortedRayRowEqualsTheScalarReferenceWithinFloatRounding) {
  // fr1's Kinect (strong distortion) and rays of a rotated row, as RollingShutterRectifier makes.
  const DistortedPinhole cam{517.3F,   516.5F,  318.6F,   255.3F, 0.2624F,
                             -0.9531F, 1.1633F, -0.0054F, 0.0026F};
  const RayRow ray{-0.62F, -0.45F, 1.01F, 1.0F / 517.3F, 2e-5F, -3e-5F};
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      std::vector<float> mx(static_cast<std::size_t>(w)), my(mx), ref_x(mx), ref_y(mx);
      distorted_ray_row(ray, cam, mx.data(), my.data(), w);
      distorted_ray_row_scalar(ray, cam, ref_x.data(), ref_y.data(), w);
      for (int u = 0; u < w; ++u) {
        // A few float roundings of pixel coordinates of up to ~700: 1e-3 px is ~10 ulp there.
        ASSERT_NEAR(mx[u], ref_x[u], 1e-3F) << "width " << w << " u " << u;
        ASSERT_NEAR(my[u], ref_y[u], 1e-3F) << "width " << w << " u " << u;
      }
    }
    // The centre of the ray at u = 0, checked by hand: undistorted x = -0.62 / 1.01.
    std::vector<float> mx(1), my(1);
    distorted_ray_row_scalar(ray, cam, mx.data(), my.data(), 1);
    const double x = -0.62 / 1.01, y = -0.45 / 1.01, r2 = x * x + y * y;
    const double radial = 1 + r2 * (0.2624 + r2 * (-0.9531 + r2 * 1.1633));
    const double xd = x * radial + 2 * -0.0054 * x * y + 0.0026 * (r2 + 2 * x * x);
    EXPECT_NEAR(mx[0], 517.3 * xd + 318.6, 1e-3);
  });
}

TEST(ImageRowKernels, Depth2x2KnownBlocks) {
  // Near 1.0 and 1.02 averaged; 2.0 beyond 3 % dropped; an all-invalid block gives 0.
  const std::vector<float> r0 = {1.0F, 2.0F, 0.0F, std::nanf("")};
  const std::vector<float> r1 = {1.02F, 0.0F, -1.0F, std::numeric_limits<float>::infinity()};
  std::vector<float> out(2);
  on_every_simd_target([&] {
    depth_2x2_row(r0.data(), r1.data(), out.data(), 2, 0.03F);
    EXPECT_FLOAT_EQ(out[0], (1.0F + 1.02F) / 2.0F);
    EXPECT_EQ(out[1], 0.0F);
  });
}

TEST(ImageRowKernels, RemapBilinearEqualsTheScalarReferenceWithinFloatRounding) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> value(0.0F, 1.0F);
  constexpr int kStride = 80;
  std::vector<float> src(kStride * 20);
  for (auto& v : src) v = value(rng);
  std::uniform_int_distribution<int> col(0, kStride - 2), row(0, 18);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      const auto n = static_cast<std::size_t>(w);
      std::vector<std::int32_t> index(n);
      std::vector<float> wx(n), wy(n);
      for (std::size_t i = 0; i < n; ++i) {
        index[i] = row(rng) * kStride + col(rng);
        wx[i] = value(rng);
        wy[i] = value(rng);
      }
      if (w > 1) {  // the border cases: one tap only
        wx[0] = 0.0F;
        wy[0] = 1.0F;
      }
      std::vector<float> simd(n, -1.0F), ref(simd);
      remap_bilinear_row(src.data(), kStride, std::ssize(src), index.data(), wx.data(), wy.data(),
                         simd.data(), w);
      remap_bilinear_row_scalar(src.data(), kStride, index.data(), wx.data(), wy.data(), ref.data(),
                                w);
      for (std::size_t i = 0; i < n; ++i) ASSERT_NEAR(simd[i], ref[i], 1e-6F) << "column " << i;
      // The reference itself: a blend of the four taps; with weights 0 and 1, the lower-left one.
      if (w > 1) {
        EXPECT_NEAR(ref[0], src[static_cast<std::size_t>(index[0] + kStride)], 1e-6F);
      }
    }
  });
}

TEST(ImageRowKernels, RemapNearestEqualsTheScalarReferenceAndZeroesOutsidePixels) {
  std::mt19937 rng(23);
  std::vector<float> src(200);
  for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<float>(i) + 0.5F;
  src[7] = std::numeric_limits<float>::quiet_NaN();  // copied as it is, not invented
  std::uniform_int_distribution<int> idx(-3, 199);
  on_every_simd_target([&] {
    for (const int w : kWidths) {
      const auto n = static_cast<std::size_t>(w);
      std::vector<std::int32_t> index(n);
      for (auto& i : index) i = idx(rng);
      if (w > 1) {
        index[0] = -1;
        index[1] = 7;
      }
      std::vector<float> simd(n, -1.0F), ref(simd);
      remap_nearest_row(src.data(), std::ssize(src), index.data(), simd.data(), w);
      remap_nearest_row_scalar(src.data(), index.data(), ref.data(), w);
      EXPECT_TRUE(same_bits(simd, ref)) << "width " << w;
      std::vector<float> expected(n);
      for (std::size_t i = 0; i < n; ++i) {
        expected[i] = index[i] < 0 ? 0.0F : src[static_cast<std::size_t>(index[i])];
      }
      EXPECT_TRUE(same_bits(ref, expected)) << "width " << w;
    }
  });
}

// An undistortion map's rows: neighbouring output pixels read neighbouring source pixels of one
// row (the vector kernels' window path), with jumps between rows, a stretch and a squeeze of
// the spacing, and rows at the source's last row (the window's reads near the buffer's end).
std::vector<std::int32_t> neighbouring_taps(int width, int stride, int rows, int start_row,
                                            float spacing) {
  std::vector<std::int32_t> index(static_cast<std::size_t>(width));
  for (int x = 0; x < width; ++x) {
    const int row = std::min(rows - 1, start_row + x / 37);  // a row change every 37 pixels
    const int col = std::clamp(static_cast<int>(std::floor(0.3F + spacing * static_cast<float>(x))),
                               0, stride - 2);
    index[static_cast<std::size_t>(x)] = row * stride + col;
  }
  return index;
}

TEST(ImageRowKernels, RemapOnNeighbouringTapsEqualsTheReference) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> value(0.0F, 1.0F);
  constexpr int kStride = 160, kRows = 6;
  std::vector<float> src(kStride * kRows);
  for (auto& v : src) v = value(rng);
  on_every_simd_target([&] {
    for (const int w : {1, 15, 16, 17, 64, 100, 150}) {
      for (const float spacing : {0.9F, 1.0F, 1.07F}) {
        for (const int start_row : {0, kRows - 2, kRows - 1}) {
          const auto n = static_cast<std::size_t>(w);
          std::vector<float> wx(n), wy(n);
          for (std::size_t i = 0; i < n; ++i) {
            wx[i] = value(rng);
            wy[i] = value(rng);
          }
          // Bilinear blocks need a row below: at most the second-to-last row.
          const auto bilinear = neighbouring_taps(w, kStride, kRows - 1, start_row, spacing);
          std::vector<float> simd(n, -1.0F), ref(simd);
          remap_bilinear_row(src.data(), kStride, std::ssize(src), bilinear.data(), wx.data(),
                             wy.data(), simd.data(), w);
          remap_bilinear_row_scalar(src.data(), kStride, bilinear.data(), wx.data(), wy.data(),
                                    ref.data(), w);
          for (std::size_t i = 0; i < n; ++i) {
            ASSERT_NEAR(simd[i], ref[i], 1e-6F) << "width " << w << " column " << i;
          }
          auto nearest = neighbouring_taps(w, kStride, kRows, start_row, spacing);
          if (w > 20) nearest[5] = -1;  // one outside pixel in a vector of neighbours
          remap_nearest_row(src.data(), std::ssize(src), nearest.data(), simd.data(), w);
          remap_nearest_row_scalar(src.data(), nearest.data(), ref.data(), w);
          EXPECT_TRUE(same_bits(simd, ref)) << "width " << w << " row " << start_row;
        }
      }
    }
  });
}

}  // namespace
}  // namespace kestrel::image::kernels
