// The image row kernels (row_kernels.hpp) in portable SIMD: Google Highway compiles this file
// once per target (foreach_target.h re-includes it), and each public function calls the best
// target the CPU supports (HWY_DYNAMIC_DISPATCH). The columns that do not fill a vector go to
// the scalar references below. Every vector operation is the scalar reference's operation in
// the same order, so that the results are equal bit for bit (but for the rolling-shutter map,
// whose multiply-adds may round once where the reference rounds twice).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "row_kernels.cpp"  // NOLINT: this file, found by its folder
#include "kestrel/image/row_kernels.hpp"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cmath>

#ifndef KESTREL_IMAGE_ROW_KERNELS_SCALAR
#define KESTREL_IMAGE_ROW_KERNELS_SCALAR
namespace kestrel::image::kernels {

inline constexpr float kIntensityScale = 1.0F / (3.0F * 255.0F);

void bgr_to_intensity_row_scalar(const std::uint8_t* bgr, float* out, int width) {
  for (int x = 0; x < width; ++x) {
    const int sum = bgr[3 * x] + bgr[3 * x + 1] + bgr[3 * x + 2];
    out[x] = static_cast<float>(sum) * kIntensityScale;
  }
}

void mean_2x2_row_scalar(const float* r0, const float* r1, float* out, int out_width) {
  for (int x = 0; x < out_width; ++x) {
    out[x] = 0.25F * ((r0[2 * x] + r0[2 * x + 1]) + (r1[2 * x] + r1[2 * x + 1]));
  }
}

void depth_2x2_row_scalar(const float* r0, const float* r1, float* out, int out_width,
                          float max_relative_spread) {
  for (int x = 0; x < out_width; ++x) {
    const float d[4] = {r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]};
    // The nearest valid depth of the block; !(v > 0) also rejects NaN.
    float z_min = INFINITY;
    for (const float v : d) z_min = (v > 0.0F && v < INFINITY && v < z_min) ? v : z_min;
    const float limit = z_min * (1.0F + max_relative_spread);
    float sum = 0.0F;
    float n = 0.0F;
    for (const float v : d) {
      const bool use = v > 0.0F && v <= limit && v < INFINITY;
      sum += use ? v : 0.0F;
      n += use ? 1.0F : 0.0F;
    }
    out[x] = n > 0.0F ? sum / n : 0.0F;
  }
}

void central_gradient_row_scalar(const float* up, const float* mid, const float* down, float* gx,
                                 float* gy, int width) {
  for (int x = 1; x < width - 1; ++x) {
    gx[x] = 0.5F * (mid[x + 1] - mid[x - 1]);
    gy[x] = 0.5F * (down[x] - up[x]);
  }
}

namespace {

// Columns [from, width) of distorted_ray_row_scalar: the SIMD version's last columns.
void distorted_ray_columns(const RayRow& ray, const DistortedPinhole& cam, float* map_x,
                           float* map_y, int from, int width) {
  for (int u = from; u < width; ++u) {
    const auto fu = static_cast<float>(u);
    const float iz = 1.0F / (ray.r0z + fu * ray.dz);
    const float x = (ray.r0x + fu * ray.dx) * iz, y = (ray.r0y + fu * ray.dy) * iz;
    const float r2 = x * x + y * y;
    const float radial = 1.0F + r2 * (cam.k1 + r2 * (cam.k2 + r2 * cam.k3));
    const float xd = x * radial + 2.0F * cam.p1 * x * y + cam.p2 * (r2 + 2.0F * x * x);
    const float yd = y * radial + cam.p1 * (r2 + 2.0F * y * y) + 2.0F * cam.p2 * x * y;
    map_x[u] = cam.fx * xd + cam.cx;
    map_y[u] = cam.fy * yd + cam.cy;
  }
}

}  // namespace

void distorted_ray_row_scalar(const RayRow& ray, const DistortedPinhole& cam, float* map_x,
                              float* map_y, int width) {
  distorted_ray_columns(ray, cam, map_x, map_y, 0, width);
}

void remap_bilinear_row_scalar(const float* src, int stride, const std::int32_t* index,
                               const float* wx, const float* wy, float* out, int width) {
  for (int x = 0; x < width; ++x) {
    const float* p = src + index[x];
    const float top = p[0] + wx[x] * (p[1] - p[0]);
    const float bottom = p[stride] + wx[x] * (p[stride + 1] - p[stride]);
    out[x] = top + wy[x] * (bottom - top);
  }
}

void remap_nearest_row_scalar(const float* src, const std::int32_t* index, float* out, int width) {
  for (int x = 0; x < width; ++x) out[x] = index[x] >= 0 ? src[index[x]] : 0.0F;
}

}  // namespace kestrel::image::kernels
#endif  // KESTREL_IMAGE_ROW_KERNELS_SCALAR

HWY_BEFORE_NAMESPACE();
namespace kestrel::image::kernels::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DF = hn::ScalableTag<float>;
using DI = hn::RebindToSigned<DF>;
using DU8 = hn::Rebind<std::uint8_t, DF>;
using VF = hn::Vec<DF>;

// Four pixels to each 16-byte block: a lane permutation of 32-bit words (the 12 bytes of a
// block's 4 pixels are 3 whole words) moves them in; two in-block byte lookups give each pixel's
// 32-bit lane the 16-bit pairs (b, g) and (r, 0), whose sum (b + r, g) one widening multiply-add
// by (1, 1) turns into b + g + r. Fewer vector operations than de-interleaving whole vectors
// and widening each channel. The load reads 4 bytes per pixel from 3 x: it stops where that
// would pass the row's end.
#if HWY_TARGET == HWY_SCALAR
HWY_INLINE int BgrToIntensityWords(const std::uint8_t* /*bgr*/, float* /*out*/, int /*width*/) {
  return 0;
}
#else
HWY_INLINE int BgrToIntensityWords(const std::uint8_t* bgr, float* out, int width) {
  const hn::ScalableTag<std::int32_t> d32;
  const hn::Repartition<std::uint8_t, decltype(d32)> d8;
  const hn::Repartition<std::int16_t, decltype(d32)> d16;
  const hn::Rebind<float, decltype(d32)> df;
  const int n = static_cast<int>(hn::Lanes(d32));
  HWY_ALIGN std::int32_t words[HWY_MAX_BYTES / sizeof(std::int32_t)] = {};
  for (int j = 0; j < n; ++j) words[j] = j % 4 == 3 ? 0 : j / 4 * 3 + j % 4;
  const auto to_blocks = hn::SetTableIndices(d32, words);
  constexpr std::uint8_t Z = 0x80;  // a lookup index with its top bit set gives 0
  alignas(16) static constexpr std::uint8_t kBG[16] = {0, Z, 1, Z, 3, Z, 4,  Z,
                                                       6, Z, 7, Z, 9, Z, 10, Z};
  alignas(16) static constexpr std::uint8_t kR[16] = {2, Z, Z, Z, 5,  Z, Z, Z,
                                                      8, Z, Z, Z, 11, Z, Z, Z};
  const auto ibg = hn::LoadDup128(d8, kBG), ir = hn::LoadDup128(d8, kR);
  const auto ones = hn::Set(d16, 1);
  const auto scale = hn::Set(df, kIntensityScale);
  int x = 0;
  for (; 3 * x + 4 * n <= 3 * width; x += n) {
    const auto px = hn::BitCast(
        d8, hn::TableLookupLanes(hn::BitCast(d32, hn::LoadU(d8, bgr + 3 * x)), to_blocks));
    const auto pairs = hn::Add(hn::BitCast(d16, hn::TableLookupBytesOr0(px, ibg)),
                               hn::BitCast(d16, hn::TableLookupBytesOr0(px, ir)));
    auto odd = hn::Zero(d32);
    const auto even = hn::ReorderWidenMulAccumulate(d32, pairs, ones, hn::Zero(d32), odd);
    const auto sum = hn::RearrangeToOddPlusEven(even, odd);
    hn::StoreU(hn::Mul(hn::ConvertTo(df, sum), scale), df, out + x);
  }
  return x;
}
#endif

void BgrToIntensityRow(const std::uint8_t* bgr, float* out, int width) {
  const DF df;
  const DI di;
  const DU8 du8;
  const int n = static_cast<int>(hn::Lanes(df));
  const VF scale = hn::Set(df, kIntensityScale);
  int x = BgrToIntensityWords(bgr, out, width);
  for (; x + n <= width; x += n) {
    hn::Vec<DU8> b, g, r;
    hn::LoadInterleaved3(du8, bgr + 3 * x, b, g, r);
    const auto sum =
        hn::Add(hn::Add(hn::PromoteTo(di, b), hn::PromoteTo(di, g)), hn::PromoteTo(di, r));
    hn::StoreU(hn::Mul(hn::ConvertTo(df, sum), scale), df, out + x);
  }
  bgr_to_intensity_row_scalar(bgr + 3 * x, out + x, width - x);
}

void Mean2x2Row(const float* r0, const float* r1, float* out, int out_width) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  const VF quarter = hn::Set(df, 0.25F);
  int x = 0;
  for (; x + n <= out_width; x += n) {
    VF a0, b0, a1, b1;  // even (a) and odd (b) columns of each row
    hn::LoadInterleaved2(df, r0 + 2 * x, a0, b0);
    hn::LoadInterleaved2(df, r1 + 2 * x, a1, b1);
    hn::StoreU(hn::Mul(quarter, hn::Add(hn::Add(a0, b0), hn::Add(a1, b1))), df, out + x);
  }
  mean_2x2_row_scalar(r0 + 2 * x, r1 + 2 * x, out + x, out_width - x);
}

void Depth2x2Row(const float* r0, const float* r1, float* out, int out_width,
                 float max_relative_spread) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  const VF zero = hn::Zero(df);
  const VF one = hn::Set(df, 1.0F);
  const VF inf = hn::Set(df, INFINITY);
  const VF spread = hn::Set(df, 1.0F + max_relative_spread);
  int x = 0;
  for (; x + n <= out_width; x += n) {
    VF d[4];
    hn::LoadInterleaved2(df, r0 + 2 * x, d[0], d[1]);
    hn::LoadInterleaved2(df, r1 + 2 * x, d[2], d[3]);
    VF z_min = inf;
    for (const VF& v : d) {
      const auto valid = hn::And(hn::And(hn::Gt(v, zero), hn::Lt(v, inf)), hn::Lt(v, z_min));
      z_min = hn::IfThenElse(valid, v, z_min);
    }
    const VF limit = hn::Mul(z_min, spread);
    VF sum = zero;
    VF count = zero;
    for (const VF& v : d) {
      const auto use = hn::And(hn::And(hn::Gt(v, zero), hn::Le(v, limit)), hn::Lt(v, inf));
      sum = hn::Add(sum, hn::IfThenElseZero(use, v));
      count = hn::Add(count, hn::IfThenElseZero(use, one));
    }
    // Divide by 1 where the block has no valid depth: no 0/0 lane, and its sum is 0 anyway.
    const auto any = hn::Gt(count, zero);
    const VF mean = hn::Div(sum, hn::IfThenElse(any, count, one));
    hn::StoreU(hn::IfThenElseZero(any, mean), df, out + x);
  }
  depth_2x2_row_scalar(r0 + 2 * x, r1 + 2 * x, out + x, out_width - x, max_relative_spread);
}

void CentralGradientRow(const float* up, const float* mid, const float* down, float* gx, float* gy,
                        int width) {
  const DF df;
  const int n = static_cast<int>(hn::Lanes(df));
  const VF half = hn::Set(df, 0.5F);
  const auto step = [&](int x) {
    hn::StoreU(hn::Mul(half, hn::Sub(hn::LoadU(df, mid + x + 1), hn::LoadU(df, mid + x - 1))), df,
               gx + x);
    hn::StoreU(hn::Mul(half, hn::Sub(hn::LoadU(df, down + x), hn::LoadU(df, up + x))), df, gy + x);
  };
  int x = 1;
  for (; x + n <= width - 1; x += n) step(x);
  if (x < width - 1 && width - 2 >= n) {
    // The columns left, by one more vector ending at the last interior column: it overlaps
    // columns already written and writes the same values there (the output is a function of
    // the input rows alone), where the scalar loop took up to n - 1 columns a row at a time.
    step(width - 1 - n);
    return;
  }
  // Rows narrower than a vector: the reference from x - 1, whose column x - 1 it does not write.
  const int from = x - 1;
  central_gradient_row_scalar(up + from, mid + from, down + from, gx + from, gy + from,
                              width - from);
}

void DistortedRayRow(const RayRow& ray, const DistortedPinhole& cam, float* map_x, float* map_y,
                     int width) {
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  // Every constant in a register before the loop: the stores to the maps could alias `ray` and
  // `cam` for the compiler, which would reload them on every vector otherwise.
  const VF r0x = hn::Set(df, ray.r0x), r0y = hn::Set(df, ray.r0y), r0z = hn::Set(df, ray.r0z);
  const VF dx = hn::Set(df, ray.dx), dy = hn::Set(df, ray.dy), dz = hn::Set(df, ray.dz);
  const VF k1 = hn::Set(df, cam.k1), k2 = hn::Set(df, cam.k2), k3 = hn::Set(df, cam.k3);
  const VF two_p1 = hn::Set(df, 2.0F * cam.p1), p1 = hn::Set(df, cam.p1);
  const VF two_p2 = hn::Set(df, 2.0F * cam.p2), p2 = hn::Set(df, cam.p2);
  const VF fx = hn::Set(df, cam.fx), fy = hn::Set(df, cam.fy);
  const VF cx = hn::Set(df, cam.cx), cy = hn::Set(df, cam.cy);
  const VF one = hn::Set(df, 1.0F), two = hn::Set(df, 2.0F);
  // The column numbers as floats, stepped by n (exact integers: no rounding drift). Iota in the
  // loop went through a store and a wider load each time, which stalled store forwarding.
  const VF step = hn::Set(df, static_cast<float>(n));
  VF fu = hn::ConvertTo(df, hn::Iota(di, 0));
  int u = 0;
  for (; u + n <= width; u += n, fu = hn::Add(fu, step)) {
    const VF iz = hn::Div(one, hn::MulAdd(fu, dz, r0z));
    const VF x = hn::Mul(hn::MulAdd(fu, dx, r0x), iz);
    const VF y = hn::Mul(hn::MulAdd(fu, dy, r0y), iz);
    const VF r2 = hn::MulAdd(x, x, hn::Mul(y, y));
    const VF radial = hn::MulAdd(r2, hn::MulAdd(r2, hn::MulAdd(r2, k3, k2), k1), one);
    const VF xy = hn::Mul(x, y);
    const VF xd = hn::MulAdd(
        x, radial, hn::MulAdd(two_p1, xy, hn::Mul(p2, hn::MulAdd(two, hn::Mul(x, x), r2))));
    const VF yd = hn::MulAdd(
        y, radial, hn::MulAdd(p1, hn::MulAdd(two, hn::Mul(y, y), r2), hn::Mul(two_p2, xy)));
    hn::StoreU(hn::MulAdd(fx, xd, cx), df, map_x + u);
    hn::StoreU(hn::MulAdd(fy, yd, cy), df, map_y + u);
  }
  distorted_ray_columns(ray, cam, map_x, map_y, u, width);
}

// Neighbouring output pixels of an undistortion map read neighbouring source pixels of one
// row: when a vector's taps all lie within 2N consecutive source elements, two vector loads and
// lane permutes give what four gathers would, for a fraction of the memory operations (the
// gathers' load count; docs/odometry.md, "Remap by window"). The values are
// the gathers' own, so both paths give the same bits.
struct Window {
  VF lo, hi;  // src[first .. first + N), src[first + N .. first + 2N)
};

HWY_INLINE Window LoadWindow(const float* at) {
  const DF df;
  return {hn::LoadU(df, at), hn::LoadU(df, at + hn::Lanes(df))};
}

// Per lane the window's element `offset` (0 <= offset < 2N).
HWY_INLINE VF FromWindow(const Window& w, hn::Vec<DI> offset) {
  const DF df;
  const DI di;
  const auto lanes = hn::Set(di, static_cast<std::int32_t>(hn::Lanes(df)));
  const auto last = hn::Sub(lanes, hn::Set(di, 1));
  // Each lookup's indices kept within its vector; the blend takes the right one.
  const auto upper = hn::RebindMask(df, hn::Gt(offset, last));
  const VF from_lo = hn::TableLookupLanes(w.lo, hn::IndicesFromVec(df, hn::Min(offset, last)));
  const VF from_hi = hn::TableLookupLanes(
      w.hi, hn::IndicesFromVec(df, hn::Max(hn::Sub(offset, lanes), hn::Zero(di))));
  return hn::IfThenElse(upper, from_hi, from_lo);
}

// The smallest index of a vector if its indices, each with the `reach` elements after it, fit
// one window of 2N elements, and that window and the one `below` elements further down lie
// inside the source's `count` elements; -1 otherwise.
HWY_INLINE std::int32_t WindowStart(hn::Vec<DI> index, std::int32_t reach, std::int64_t below,
                                    std::int64_t count) {
  const DI di;
  const auto n = static_cast<std::int32_t>(hn::Lanes(di));
  const std::int32_t first = hn::GetLane(hn::MinOfLanes(di, index));
  const std::int32_t last = hn::GetLane(hn::MaxOfLanes(di, index));
  const bool fits = first >= 0 && last - first + reach < 2 * n &&
                    static_cast<std::int64_t>(first) + below + 2 * n <= count;
  return fits ? first : -1;
}

void RemapBilinearRow(const float* src, int stride, std::int64_t src_count,
                      const std::int32_t* index, const float* wx, const float* wy, float* out,
                      int width) {
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto one = hn::Set(di, 1);
  const auto down = hn::Set(di, stride);
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto i00 = hn::LoadU(di, index + x);
    VF a, b, c, d;
    const std::int32_t first = WindowStart(i00, 1, stride, src_count);
    if (first >= 0) {
      const auto offset = hn::Sub(i00, hn::Set(di, first));
      const auto offset_right = hn::Add(offset, one);
      const Window top = LoadWindow(src + first);
      const Window bottom = LoadWindow(src + first + stride);
      a = FromWindow(top, offset);
      b = FromWindow(top, offset_right);
      c = FromWindow(bottom, offset);
      d = FromWindow(bottom, offset_right);
    } else {
      const auto i10 = hn::Add(i00, down);
      a = hn::GatherIndex(df, src, i00);
      b = hn::GatherIndex(df, src, hn::Add(i00, one));
      c = hn::GatherIndex(df, src, i10);
      d = hn::GatherIndex(df, src, hn::Add(i10, one));
    }
    const VF fx = hn::LoadU(df, wx + x);
    const VF top = hn::MulAdd(fx, hn::Sub(b, a), a);
    const VF bottom = hn::MulAdd(fx, hn::Sub(d, c), c);
    hn::StoreU(hn::MulAdd(hn::LoadU(df, wy + x), hn::Sub(bottom, top), top), df, out + x);
  }
  remap_bilinear_row_scalar(src, stride, index + x, wx + x, wy + x, out + x, width - x);
}

void RemapNearestRow(const float* src, std::int64_t src_count, const std::int32_t* index,
                     float* out, int width) {
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  const auto zero = hn::Zero(di);
  int x = 0;
  for (; x + n <= width; x += n) {
    const auto i = hn::LoadU(di, index + x);
    // A window only where every lane is inside (a negative index fails WindowStart).
    const std::int32_t first = WindowStart(i, 0, 0, src_count);
    if (first >= 0) {
      hn::StoreU(FromWindow(LoadWindow(src + first), hn::Sub(i, hn::Set(di, first))), df, out + x);
      continue;
    }
    const auto outside = hn::RebindMask(df, hn::Lt(i, zero));
    // Outside pixels read src[0] (always valid) and are then zeroed.
    const VF v = hn::GatherIndex(df, src, hn::Max(i, zero));
    hn::StoreU(hn::IfThenZeroElse(outside, v), df, out + x);
  }
  remap_nearest_row_scalar(src, index + x, out + x, width - x);
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace kestrel::image::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::image::kernels {

HWY_EXPORT(BgrToIntensityRow);
HWY_EXPORT(Mean2x2Row);
HWY_EXPORT(Depth2x2Row);
HWY_EXPORT(CentralGradientRow);
HWY_EXPORT(DistortedRayRow);
HWY_EXPORT(RemapBilinearRow);
HWY_EXPORT(RemapNearestRow);
HWY_EXPORT(TargetName);

void bgr_to_intensity_row(const std::uint8_t* bgr, float* out, int width) {
  HWY_DYNAMIC_DISPATCH(BgrToIntensityRow)(bgr, out, width);
}

void mean_2x2_row(const float* r0, const float* r1, float* out, int out_width) {
  HWY_DYNAMIC_DISPATCH(Mean2x2Row)(r0, r1, out, out_width);
}

void depth_2x2_row(const float* r0, const float* r1, float* out, int out_width,
                   float max_relative_spread) {
  HWY_DYNAMIC_DISPATCH(Depth2x2Row)(r0, r1, out, out_width, max_relative_spread);
}

void central_gradient_row(const float* up, const float* mid, const float* down, float* gx,
                          float* gy, int width) {
  HWY_DYNAMIC_DISPATCH(CentralGradientRow)(up, mid, down, gx, gy, width);
}

void distorted_ray_row(const RayRow& ray, const DistortedPinhole& cam, float* map_x, float* map_y,
                       int width) {
  HWY_DYNAMIC_DISPATCH(DistortedRayRow)(ray, cam, map_x, map_y, width);
}

void remap_bilinear_row(const float* src, int stride, std::int64_t src_count,
                        const std::int32_t* index, const float* wx, const float* wy, float* out,
                        int width) {
  HWY_DYNAMIC_DISPATCH(RemapBilinearRow)(src, stride, src_count, index, wx, wy, out, width);
}

void remap_nearest_row(const float* src, std::int64_t src_count, const std::int32_t* index,
                       float* out, int width) {
  HWY_DYNAMIC_DISPATCH(RemapNearestRow)(src, src_count, index, out, width);
}

const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

std::vector<std::int64_t> simd_targets() { return hwy::SupportedAndGeneratedTargets(); }

}  // namespace kestrel::image::kernels
#endif  // HWY_ONCE
