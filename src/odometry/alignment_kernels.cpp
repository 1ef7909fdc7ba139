// The alignment kernels (alignment_kernels.hpp) in portable SIMD: Google Highway compiles this
// file once per target (foreach_target.h re-includes it), and each public function calls the
// best target the CPU supports (HWY_DYNAMIC_DISPATCH). The points that do not fill a vector go
// to the scalar references as the baseline build compiles them (alignment_kernels_reference.hpp);
// the public *_scalar references run on the kernels' target (alignment_kernels_reference-inl.h).
// The bilinear sample is written with gathers: GCC does not vectorise it on its own ("control
// flow in loop").
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "alignment_kernels.cpp"  // NOLINT: this file, found by its folder
#include "kestrel/odometry/alignment_kernels.hpp"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include "alignment_kernels_reference-inl.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::odometry::kernels::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// At most kLanes floats per vector, so that the padding of the per-point arrays is a multiple
// of every target's vector.
using DF = hn::CappedTag<float, kLanes>;
using DI = hn::RebindToSigned<DF>;
using DU8 = hn::Rebind<std::uint8_t, DF>;
using VF = hn::Vec<DF>;
using VI = hn::Vec<DI>;
using MF = hn::Mask<DF>;

// valid[i..i+N) as a float mask (true where non-zero).
HWY_INLINE MF load_valid(const std::uint8_t* valid) {
  const DF df;
  const DI di;
  const VI v = hn::PromoteTo(di, hn::LoadU(DU8(), valid));
  return hn::RebindMask(df, hn::Gt(v, hn::Zero(di)));
}

// A float mask as 0/1 bytes at valid[i..i+N).
HWY_INLINE void store_valid(MF m, std::uint8_t* valid) {
  const DI di;
  const VI ones = hn::IfThenElseZero(hn::RebindMask(di, m), hn::Set(di, 1));
  hn::StoreU(hn::DemoteTo(DU8(), ones), DU8(), valid);
}

// N points moved by T_cur_ref and projected with a level's pinhole model, as both warps need
// them: `inside` = Z > 1 mm and (u, v) in [0, w-1) x [0, h-1) (ordered comparisons: false for
// NaN, as in the scalar references); outside lanes are moved to pixel (0, 0), so that every
// gather stays in bounds. x0, y0 are the sample cell's corner and ax, ay the position in it.
struct Projected {
  VF u, v, ax, ay;
  VI x0, y0;
  MF inside;
};

struct Projector {
  const FloatPose& T;
  const LevelImage& level;

  HWY_INLINE Projected operator()(const float* x, const float* y, const float* z) const {
    const DF df;
    const DI di;
    const VF px = hn::LoadU(df, x), py = hn::LoadU(df, y), pz = hn::LoadU(df, z);
    const auto row = [&](float a, float b, float c, float t) {
      return hn::MulAdd(
          hn::Set(df, a), px,
          hn::MulAdd(hn::Set(df, b), py, hn::MulAdd(hn::Set(df, c), pz, hn::Set(df, t))));
    };
    const VF X = row(T.r00, T.r01, T.r02, T.t0);
    const VF Y = row(T.r10, T.r11, T.r12, T.t1);
    const VF Z = row(T.r20, T.r21, T.r22, T.t2);
    const VF inv_z = hn::Div(hn::Set(df, 1.0F), Z);
    VF u = hn::MulAdd(hn::Mul(hn::Set(df, level.fx), X), inv_z, hn::Set(df, level.cx));
    VF v = hn::MulAdd(hn::Mul(hn::Set(df, level.fy), Y), inv_z, hn::Set(df, level.cy));
    const VF zero = hn::Zero(df);
    const VF umax = hn::Set(df, static_cast<float>(level.width - 1));
    const VF vmax = hn::Set(df, static_cast<float>(level.height - 1));
    MF m = hn::And(hn::Gt(Z, hn::Set(df, 1e-3F)), hn::Ge(u, zero));
    m = hn::And(m, hn::Lt(u, umax));
    m = hn::And(m, hn::Ge(v, zero));
    m = hn::And(m, hn::Lt(v, vmax));
    u = hn::IfThenElseZero(m, u);
    v = hn::IfThenElseZero(m, v);
    const VI x0 = hn::ConvertTo(di, u);  // truncation: u, v >= 0 here
    const VI y0 = hn::ConvertTo(di, v);
    // Aggregate-initialised, never default-constructed: GCC on AArch64 compiles Projected's
    // implicit default constructor without the NEON target's `#pragma GCC target "+crypto"`
    // (Highway 1.0.3), and it then may not inline Vec128's always_inline constructor
    // ("target specific option mismatch").
    return Projected{
        u, v, hn::Sub(u, hn::ConvertTo(df, x0)), hn::Sub(v, hn::ConvertTo(df, y0)), x0, y0, m};
  }
};

// Per lane the two neighbouring elements base[idx] and base[idx + 1]. Where the target has
// 64-bit lanes, each pair is one 8-byte element of a gather by byte offset (half the loads of
// two 32-bit gathers, which is what the samplers spend their time on), split into the two taps
// by ConcatEven / ConcatOdd: the same elements, the same bits. The 8-byte loads are
// unaligned, which gathers by byte offset allow (the emulated targets copy bytes).
struct TapPair {
  VF left, right;
};
HWY_INLINE TapPair gather_pair(const float* base, VI idx) {
  const DF df;
#if HWY_TARGET == HWY_SCALAR
  return {hn::GatherIndex(df, base, idx), hn::GatherIndex(df, base + 1, idx)};
#else
  const hn::Repartition<std::uint64_t, DF> du64;
  const hn::Repartition<std::int64_t, DF> di64;
  const hn::Half<DI> dhalf;
  const auto* pairs = reinterpret_cast<const std::uint64_t*>(base);
  const auto bytes = [&](auto half) { return hn::ShiftLeft<2>(hn::PromoteTo(di64, half)); };
  const VF lo = hn::BitCast(df, hn::GatherOffset(du64, pairs, bytes(hn::LowerHalf(dhalf, idx))));
  const VF hi = hn::BitCast(df, hn::GatherOffset(du64, pairs, bytes(hn::UpperHalf(dhalf, idx))));
  return {hn::ConcatEven(df, hi, lo), hn::ConcatOdd(df, hi, lo)};
#endif
}

// The 2x2 cell at (x0, y0): a pair of taps from each of its two rows.
struct Cell {
  VF p00, p01, p10, p11;
};
HWY_INLINE Cell gather_cell(const LevelImage& img, VI x0, VI y0) {
  const DI di;
  const VI idx = hn::Add(hn::Mul(y0, hn::Set(di, img.stride)), x0);
  const TapPair top = gather_pair(img.data, idx);
  const TapPair bottom = gather_pair(img.data + img.stride, idx);
  return {top.left, top.right, bottom.left, bottom.right};
}

HWY_INLINE VF bilinear(const Cell& c, VF ax, VF ay) {
  const VF top = hn::MulAdd(ax, hn::Sub(c.p01, c.p00), c.p00);
  const VF bottom = hn::MulAdd(ax, hn::Sub(c.p11, c.p10), c.p10);
  return hn::MulAdd(ay, hn::Sub(bottom, top), top);
}

// Catmull-Rom weights of the taps at -1, 0, 1, 2 for a fractional position t (the reference's
// catmull_rom_weights).
struct CatmullRom {
  VF w0, w1, w2, w3;
};
HWY_INLINE CatmullRom catmull_rom_weights(VF t) {
  const DF df;
  const VF half = hn::Set(df, 0.5F);
  const VF t2 = hn::Mul(t, t), t3 = hn::Mul(t2, t);
  const VF two = hn::Set(df, 2.0F), three = hn::Set(df, 3.0F);
  return {hn::Mul(half, hn::Sub(hn::MulSub(two, t2, t), t3)),
          hn::Mul(half, hn::MulAdd(three, t3, hn::NegMulAdd(hn::Set(df, 5.0F), t2, two))),
          hn::Mul(half, hn::NegMulAdd(three, t3, hn::MulAdd(hn::Set(df, 4.0F), t2, t))),
          hn::Mul(half, hn::Sub(t3, t2))};
}

// The bicubic sample: two pairs of taps from each row of the clamped 4x4 neighbourhood. `interior`
// marks the lanes it holds for; the others (within a pixel of the border) take the bilinear sample,
// as the reference's sample_bicubic does.
HWY_INLINE VF bicubic(const LevelImage& cur, VI x0, VI y0, VF ax, VF ay, MF& interior) {
  const DF df;
  const DI di;
  const VI one = hn::Set(di, 1);
  const VI xmax = hn::Set(di, cur.width - 3), ymax = hn::Set(di, cur.height - 3);
  const auto inner = hn::And(hn::And(hn::Gt(x0, hn::Zero(di)), hn::Gt(y0, hn::Zero(di))),
                             hn::Not(hn::Or(hn::Gt(x0, xmax), hn::Gt(y0, ymax))));
  const VI xc = hn::Max(one, hn::Min(x0, xmax));
  const VI yc = hn::Max(one, hn::Min(y0, ymax));
  const VI stride = hn::Set(di, cur.stride);
  VI idx = hn::Add(hn::Mul(hn::Sub(yc, one), stride), hn::Sub(xc, one));
  const CatmullRom wx = catmull_rom_weights(ax);
  const CatmullRom wy = catmull_rom_weights(ay);
  const auto row = [&](VI at) {
    const TapPair left = gather_pair(cur.data, at);
    const TapPair right = gather_pair(cur.data + 2, at);
    VF r = hn::Mul(wx.w0, left.left);
    r = hn::MulAdd(wx.w1, left.right, r);
    r = hn::MulAdd(wx.w2, right.left, r);
    return hn::MulAdd(wx.w3, right.right, r);
  };
  VF out = hn::Mul(wy.w0, row(idx));
  idx = hn::Add(idx, stride);
  out = hn::MulAdd(wy.w1, row(idx), out);
  idx = hn::Add(idx, stride);
  out = hn::MulAdd(wy.w2, row(idx), out);
  idx = hn::Add(idx, stride);
  out = hn::MulAdd(wy.w3, row(idx), out);
  interior = hn::RebindMask(df, inner);
  return out;
}

int WarpResiduals(const PointsView& points, const LevelImage& cur, const FloatPose& T_cur_ref,
                  float alpha, float beta, float* residual, std::uint8_t* valid,
                  Sampling sampling) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const bool use_bicubic = sampling == Sampling::kBicubic && cur.width >= 4 && cur.height >= 4;
  const Projector project{T_cur_ref, cur};
  const VF va = hn::Set(df, alpha), vb = hn::Set(df, beta);
  int inside_count = 0;
  int i = 0;
  for (; i + N <= points.count; i += N) {
    const Projected p = project(points.x + i, points.y + i, points.z + i);
    VF ic;
    if (use_bicubic) {
      // The bilinear gathers only where a lane is within a pixel of the border.
      MF interior;
      ic = bicubic(cur, p.x0, p.y0, p.ax, p.ay, interior);
      if (!hn::AllTrue(df, interior)) {
        ic = hn::IfThenElse(interior, ic, bilinear(gather_cell(cur, p.x0, p.y0), p.ax, p.ay));
      }
    } else {
      ic = bilinear(gather_cell(cur, p.x0, p.y0), p.ax, p.ay);
    }
    const VF r = hn::Sub(hn::MulAdd(va, ic, vb), hn::LoadU(df, points.intensity + i));
    hn::StoreU(hn::IfThenElseZero(p.inside, r), df, residual + i);
    store_valid(p.inside, valid + i);
    inside_count += static_cast<int>(hn::CountTrue(df, p.inside));
  }
  return inside_count + kernels::warp_range_scalar(points, cur, T_cur_ref, alpha, beta, i, residual,
                                                   valid, sampling);
}

// Invalid lanes read pixel (0, 0) and are zeroed at the stores.
int WarpPointToPlane(const PlanePointsView& points, const LevelImage& depth,
                     const FloatPose& T_cur_ref, float max_spread, float* residual,
                     std::uint8_t* valid, float* const* jac) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const FloatPose& T = T_cur_ref;
  const Projector project{T, depth};
  const VF cx = hn::Set(df, depth.cx), cy = hn::Set(df, depth.cy);
  const VF inv_fx = hn::Set(df, 1.0F / depth.fx), inv_fy = hn::Set(df, 1.0F / depth.fy);
  const VF zero = hn::Zero(df), far = hn::Set(df, 1e3F);
  const VF spread = hn::Set(df, 1.0F + max_spread);
  const auto in_range = [&](VF z) { return hn::And(hn::Gt(z, zero), hn::Lt(z, far)); };
  const auto set = [&](float s) { return hn::Set(df, s); };
  int count = 0;
  int i = 0;
  for (; i + N <= points.count; i += N) {
    const Projected p = project(points.x + i, points.y + i, points.z + i);
    MF m = hn::And(p.inside, load_valid(points.has_normal + i));
    const Cell c = gather_cell(depth, p.x0, p.y0);
    m = hn::And(m, hn::And(hn::And(in_range(c.p00), in_range(c.p01)),
                           hn::And(in_range(c.p10), in_range(c.p11))));
    // Interpolated only within one surface (no occlusion boundary in the 2x2 cell).
    const VF zlo = hn::Min(hn::Min(c.p00, c.p01), hn::Min(c.p10, c.p11));
    const VF zhi = hn::Max(hn::Max(c.p00, c.p01), hn::Max(c.p10, c.p11));
    m = hn::And(m, hn::Le(zhi, hn::Mul(spread, zlo)));
    const VF z = bilinear(c, p.ax, p.ay);
    // Q_cur back-projected at (u, v); into the reference frame: R^T (Q_cur - t).
    const VF dx = hn::MulSub(hn::Mul(hn::Sub(p.u, cx), inv_fx), z, set(T.t0));
    const VF dy = hn::MulSub(hn::Mul(hn::Sub(p.v, cy), inv_fy), z, set(T.t1));
    const VF dz = hn::Sub(z, set(T.t2));
    const VF qx = hn::MulAdd(set(T.r00), dx, hn::MulAdd(set(T.r10), dy, hn::Mul(set(T.r20), dz)));
    const VF qy = hn::MulAdd(set(T.r01), dx, hn::MulAdd(set(T.r11), dy, hn::Mul(set(T.r21), dz)));
    const VF qz = hn::MulAdd(set(T.r02), dx, hn::MulAdd(set(T.r12), dy, hn::Mul(set(T.r22), dz)));
    const VF nx = hn::LoadU(df, points.nx + i);
    const VF ny = hn::LoadU(df, points.ny + i);
    const VF nz = hn::LoadU(df, points.nz + i);
    const VF r = hn::Sub(hn::MulAdd(nx, qx, hn::MulAdd(ny, qy, hn::Mul(nz, qz))),
                         hn::LoadU(df, points.n_dot_p + i));
    hn::StoreU(hn::IfThenElseZero(m, r), df, residual + i);
    // J_g = -[n, q x n] (point_to_plane_pose_jacobian).
    hn::StoreU(hn::IfThenElseZero(m, hn::Neg(nx)), df, jac[0] + i);
    hn::StoreU(hn::IfThenElseZero(m, hn::Neg(ny)), df, jac[1] + i);
    hn::StoreU(hn::IfThenElseZero(m, hn::Neg(nz)), df, jac[2] + i);
    hn::StoreU(hn::IfThenElseZero(m, hn::MulSub(qz, ny, hn::Mul(qy, nz))), df, jac[3] + i);
    hn::StoreU(hn::IfThenElseZero(m, hn::MulSub(qx, nz, hn::Mul(qz, nx))), df, jac[4] + i);
    hn::StoreU(hn::IfThenElseZero(m, hn::MulSub(qy, nx, hn::Mul(qx, ny))), df, jac[5] + i);
    store_valid(m, valid + i);
    count += static_cast<int>(hn::CountTrue(df, m));
  }
  return count + kernels::point_to_plane_range_scalar(points, depth, T_cur_ref, max_spread, i,
                                                      residual, valid, jac);
}

// Sums of float lanes kept in double lanes (the robust cost of thousands of points).
#if HWY_TARGET == HWY_SCALAR
struct DoubleSum {  // one lane: no halves to promote
  double acc = 0.0;
  HWY_INLINE void add(VF x) { acc += static_cast<double>(hn::GetLane(x)); }
  [[nodiscard]] double total() const { return acc; }
};
#else
struct DoubleSum {
  using DH = hn::Half<DF>;
  using DD = hn::Rebind<double, DH>;
  hn::Vec<DD> acc;

  // Written out: a compiler-generated constructor would lack the target's attributes.
  HWY_INLINE DoubleSum() : acc(hn::Zero(DD())) {}

  HWY_INLINE void add(VF x) {
    const DH dh;
    const DD dd;
    acc = hn::Add(acc, hn::PromoteTo(dd, hn::LowerHalf(dh, x)));
    acc = hn::Add(acc, hn::PromoteTo(dd, hn::UpperHalf(dh, x)));
  }
  [[nodiscard]] double total() const {
    const DD dd;
    HWY_ALIGN double lanes[kLanes];
    hn::Store(acc, dd, lanes);
    double s = 0.0;
    for (std::size_t k = 0; k < hn::Lanes(dd); ++k) s += lanes[k];
    return s;
  }
};
#endif

// Tukey cost of s^2 (rho_max beyond c, thesis eq. 3.39 integrated) and weight (0 beyond c);
// `in` = s^2 <= 1.
struct TukeyLanes {
  VF k, one;
  [[nodiscard]] HWY_INLINE VF cost(VF s2, MF in) const {
    const VF t = hn::Sub(one, s2);
    const VF t3 = hn::Mul(hn::Mul(t, t), t);
    return hn::IfThenElse(in, hn::Mul(k, hn::Sub(one, t3)), k);
  }
  [[nodiscard]] HWY_INLINE VF weight(VF s2, MF in) const {
    const VF t = hn::Sub(one, s2);
    return hn::IfThenElseZero(in, hn::Mul(t, t));
  }
};

double TukeyCostSum(const float* residual, const std::uint8_t* valid, int count, float inv_sigma,
                    float c) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const TukeyLanes tk{hn::Set(df, c * c / 6.0F), hn::Set(df, 1.0F)};
  const VF scale = hn::Set(df, inv_sigma / c);
  DoubleSum sum;
  int i = 0;
  for (; i + N <= count; i += N) {
    const VF s = hn::Mul(hn::LoadU(df, residual + i), scale);
    const VF s2 = hn::Mul(s, s);
    // Invalid points cost rho_max.
    sum.add(hn::IfThenElse(load_valid(valid + i), tk.cost(s2, hn::Le(s2, tk.one)), tk.k));
  }
  return sum.total() + kernels::tukey_cost_range(residual, valid, i, count, inv_sigma, c);
}

WeightSums TukeyWeights(const float* residual, const std::uint8_t* valid, int count,
                        float inv_sigma, float c, float* weight) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const TukeyLanes tk{hn::Set(df, c * c / 6.0F), hn::Set(df, 1.0F)};
  const VF scale = hn::Set(df, inv_sigma / c);
  const VF w_scale = hn::Set(df, inv_sigma * inv_sigma);
  DoubleSum sum;
  int inliers = 0;
  int i = 0;
  for (; i + N <= count; i += N) {
    const VF s = hn::Mul(hn::LoadU(df, residual + i), scale);
    const VF s2 = hn::Mul(s, s);
    const MF ok = load_valid(valid + i);
    const MF in = hn::Le(s2, tk.one);
    hn::StoreU(hn::IfThenElseZero(ok, hn::Mul(tk.weight(s2, in), w_scale)), df, weight + i);
    sum.add(hn::IfThenElse(ok, tk.cost(s2, in), tk.k));
    inliers += static_cast<int>(hn::CountTrue(df, hn::And(ok, hn::Lt(s2, tk.one))));
  }
  WeightSums out = kernels::tukey_weights_range(residual, valid, i, count, inv_sigma, c, weight);
  out.cost += sum.total();
  out.inliers += inliers;
  return out;
}

// abs_median's pass over its bracket [lo, hi): counts, and packs the values inside.
MedianBracket BracketAbs(const float* residual, const std::uint8_t* valid, int count, float lo,
                         float hi, float* scratch) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const VF vlo = hn::Set(df, lo), vhi = hn::Set(df, hi);
  MedianBracket b;
  int i = 0;
  for (; i + N <= count; i += N) {
    const VF a = hn::Abs(hn::LoadU(df, residual + i));
    const MF ok = load_valid(valid + i);
    b.valid += static_cast<int>(hn::CountTrue(df, ok));
    b.below += static_cast<int>(hn::CountTrue(df, hn::And(ok, hn::Lt(a, vlo))));
    const MF in = hn::And(ok, hn::And(hn::Ge(a, vlo), hn::Lt(a, vhi)));
    // Few lanes are inside (~11 %): a loop over their bits beats a compressing store.
    std::uint8_t bytes[8] = {};
    hn::StoreMaskBits(df, in, bytes);
    std::uint64_t bits = 0;
    std::memcpy(&bits, bytes, sizeof(bits));
    for (; bits != 0; bits &= bits - 1) {
      scratch[b.inside++] = std::fabs(residual[i + std::countr_zero(bits)]);
    }
  }
  kernels::bracket_range(residual, valid, i, count, lo, hi, b, scratch);
  return b;
}

// Row A of the normal equations: sum w J_A J_b for b = A..C-1 and sum w J_A r, each in one
// vector accumulator (C - A + 1 <= 9 of them: they stay in registers, unlike the 44 of all rows
// at once, which spill; docs/odometry.md, "Speed"). Arrays of vectors: not for SVE's sizeless
// vectors, which the build leaves out (HWY_DISABLED_TARGETS).
template <int A, int C>
HWY_INLINE void accumulate_row(const float* const* J, int n, const float* w, const float* r,
                               double* row) {
  constexpr int kTerms = C - A + 1;
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const float* ja = J[A];
  VF acc[kTerms];
  for (int t = 0; t < kTerms; ++t) acc[t] = hn::Zero(df);
  for (int i = 0; i < n; i += N) {
    const VF wa = hn::Mul(hn::LoadU(df, w + i), hn::LoadU(df, ja + i));
    for (int b = A; b < C; ++b) acc[b - A] = hn::MulAdd(wa, hn::LoadU(df, J[b] + i), acc[b - A]);
    acc[kTerms - 1] = hn::MulAdd(wa, hn::LoadU(df, r + i), acc[kTerms - 1]);
  }
  HWY_ALIGN float lanes[kLanes];
  for (int t = 0; t < kTerms; ++t) {
    hn::Store(acc[t], df, lanes);
    double s = 0.0;
    for (int k = 0; k < N; ++k) s += static_cast<double>(lanes[k]);
    row[t] = s;
  }
}

template <int C, int... A>
HWY_INLINE void accumulate_rows(const float* const* J, int n, const float* w, const float* r,
                                Matrix8d& H, Vector8d& g, std::integer_sequence<int, A...>) {
  const auto one_row = [&]<int Row>(std::integral_constant<int, Row>) {
    double row[C - Row + 1];
    accumulate_row<Row, C>(J, n, w, r, row);
    for (int b = Row; b < C; ++b) {
      H(Row, b) += row[b - Row];
      if (b != Row) H(b, Row) += row[b - Row];
    }
    g(Row) += row[C - Row];
  };
  (one_row(std::integral_constant<int, A>{}), ...);
}

void NormalEquations6(const float* const* J, int count, const float* w, const float* r, Matrix8d& H,
                      Vector8d& g) {
  accumulate_rows<6>(J, pad_to_lanes(count), w, r, H, g, std::make_integer_sequence<int, 6>{});
}

void NormalEquations8(const float* const* J, int count, const float* w, const float* r, Matrix8d& H,
                      Vector8d& g) {
  accumulate_rows<8>(J, pad_to_lanes(count), w, r, H, g, std::make_integer_sequence<int, 8>{});
}

// gather_abs_valid: |r| of the valid lanes, packed by a compressing store. The store may write
// a whole vector at out + m; m <= i, so it stays inside out[0, count).
int GatherAbsValid(const float* residual, const std::uint8_t* valid, int count, float* out) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  int m = 0, i = 0;
  for (; i + N <= count; i += N) {
    const VF a = hn::Abs(hn::LoadU(df, residual + i));
    m += static_cast<int>(hn::CompressStore(a, load_valid(valid + i), df, out + m));
  }
  for (; i < count; ++i) {
    out[m] = std::fabs(residual[i]);
    m += valid[i];
  }
  return m;
}

// How many of v[0, n) are below lo and above hi.
struct OutsideCounts {
  int below = 0, above = 0;
};
HWY_INLINE OutsideCounts count_outside(const float* v, int n, float lo, float hi) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const VF vlo = hn::Set(df, lo), vhi = hn::Set(df, hi);
  OutsideCounts c;
  int i = 0;
  for (; i + N <= n; i += N) {
    const VF x = hn::LoadU(df, v + i);
    c.below += static_cast<int>(hn::CountTrue(df, hn::Lt(x, vlo)));
    c.above += static_cast<int>(hn::CountTrue(df, hn::Gt(x, vhi)));
  }
  for (; i < n; ++i) {
    c.below += v[i] < lo ? 1 : 0;
    c.above += v[i] > hi ? 1 : 0;
  }
  return c;
}

// Keeps the values of v[0, n) in [lo, hi], in front, in place; returns how many. The write
// position never passes the read position, so the compressing store (a whole vector) only
// overwrites values already loaded.
HWY_INLINE int keep_inside(float* v, int n, float lo, float hi) {
  const DF df;
  const auto N = static_cast<int>(hn::Lanes(df));
  const VF vlo = hn::Set(df, lo), vhi = hn::Set(df, hi);
  int m = 0, i = 0;
  for (; i + N <= n; i += N) {
    const VF x = hn::LoadU(df, v + i);
    m += static_cast<int>(hn::CompressStore(x, hn::And(hn::Ge(x, vlo), hn::Le(x, vhi)), df, v + m));
  }
  for (; i < n; ++i) {
    if (v[i] >= lo && v[i] <= hi) v[m++] = v[i];
  }
  return m;
}

// select_kth: Floyd-Rivest-like selection with SIMD passes. Each round sorts a small sample,
// brackets the k-th by the samples ranked around k, counts the values below and above the
// bracket (one pass) and keeps the one of the three parts that holds the k-th (a second pass,
// in place). Neither pass branches on the data, unlike nth_element's partition, whose
// comparisons on real residuals mispredict.
float SelectKth(float* v, int n, int k) {
  constexpr int kSmall = 64;    // from this many values down, nth_element is the faster finish
  constexpr int kSamples = 32;  // the sample sorted each round
  constexpr int kSpread = 3;    // sample ranks either side of k's (bracket ~ 1/5 of the values)
  while (n > kSmall) {
    std::array<float, kSamples> s{};
    for (int j = 0; j < kSamples; ++j) {
      s[static_cast<std::size_t>(j)] =
          v[static_cast<std::size_t>((2 * j + 1) * static_cast<std::int64_t>(n) / (2 * kSamples))];
    }
    std::sort(s.begin(), s.end());
    const auto r = static_cast<int>(static_cast<std::int64_t>(k) * kSamples / n);
    const float lo = s[static_cast<std::size_t>(std::max(r - kSpread, 0))];
    const float hi = s[static_cast<std::size_t>(std::min(r + kSpread, kSamples - 1))];
    const OutsideCounts c = count_outside(v, n, lo, hi);
    int kept = 0;
    if (k < c.below) {
      kept = keep_inside(v, n, -std::numeric_limits<float>::infinity(),
                         std::nextafter(lo, -std::numeric_limits<float>::infinity()));
    } else if (k >= n - c.above) {
      k -= n - c.above;
      kept = keep_inside(v, n, std::nextafter(hi, std::numeric_limits<float>::infinity()),
                         std::numeric_limits<float>::infinity());
    } else {
      if (lo == hi) return lo;  // every value in the bracket is the k-th
      k -= c.below;
      kept = keep_inside(v, n, lo, hi);
    }
    if (kept == n) break;  // no progress (the sample spans the values): nth_element finishes
    n = kept;
  }
  std::nth_element(v, v + k, v + n);
  return v[k];
}

// The neighbours' depths valid and within the spread of the centre's (surface_normal_at).
HWY_INLINE MF same_surface(VF z, VF z0, VF limit) {
  const DF df;
  const MF in_range = hn::And(hn::Gt(z, hn::Zero(df)), hn::Lt(z, hn::Set(df, 1e3F)));
  return hn::And(in_range, hn::Not(hn::Gt(hn::Abs(hn::Sub(z, z0)), limit)));
}

// surface_normal_row (alignment_kernels.hpp): the reference's float operations, in its order,
// a vector of pixels at a time.
void SurfaceNormalRow(const NormalRow& r, float* nx, float* ny, std::uint8_t* ok) {
  const DF df;
  const DI di;
  const int n = static_cast<int>(hn::Lanes(df));
  const VF zero = hn::Zero(df);
  const VF cx = hn::Set(df, r.cx), fx = hn::Set(df, r.fx), spread = hn::Set(df, r.max_spread);
  const VF ix = hn::Set(df, 1.0F / r.fx);
  const float yv_s = (static_cast<float>(r.v) - r.cy) / r.fy, iy_s = 1.0F / r.fy;
  const VF yv = hn::Set(df, yv_s), yp = hn::Set(df, yv_s + iy_s), ym = hn::Set(df, yv_s - iy_s);
  const VF fifth = hn::Set(df, 0.2F), step = hn::Set(df, static_cast<float>(n));
  // The column numbers stepped by a vector add (Iota in the loop would go through the stack).
  VF fu = hn::ConvertTo(df, hn::Iota(di, 1));
  int u = 1;
  for (; u + n <= r.width - 1; u += n, fu = hn::Add(fu, step)) {
    const VF z0 = hn::LoadU(df, r.mid + u);
    const VF zl = hn::LoadU(df, r.mid + u - 1), zr = hn::LoadU(df, r.mid + u + 1);
    const VF zu = hn::LoadU(df, r.up + u), zd = hn::LoadU(df, r.down + u);
    const VF limit = hn::Mul(spread, z0);
    MF m = hn::And(hn::And(same_surface(zl, z0, limit), same_surface(zr, z0, limit)),
                   hn::And(same_surface(zu, z0, limit), same_surface(zd, z0, limit)));
    const VF xu = hn::Div(hn::Sub(fu, cx), fx);
    const VF ax = hn::Sub(hn::Mul(hn::Add(xu, ix), zr), hn::Mul(hn::Sub(xu, ix), zl));
    const VF ay = hn::Mul(yv, hn::Sub(zr, zl)), az = hn::Sub(zr, zl);
    const VF bx = hn::Mul(xu, hn::Sub(zd, zu));
    const VF by = hn::Sub(hn::Mul(yp, zd), hn::Mul(ym, zu)), bz = hn::Sub(zd, zu);
    VF n0 = hn::Sub(hn::Mul(ay, bz), hn::Mul(az, by));
    VF n1 = hn::Sub(hn::Mul(az, bx), hn::Mul(ax, bz));
    const VF n2 = hn::Sub(hn::Mul(ax, by), hn::Mul(ay, bx));
    const VF len = hn::Sqrt(hn::Add(hn::Add(hn::Mul(n0, n0), hn::Mul(n1, n1)), hn::Mul(n2, n2)));
    m = hn::And(m, hn::Gt(len, zero));
    const VF px = hn::Mul(xu, z0), py = hn::Mul(yv, z0);
    VF dot = hn::Div(hn::Add(hn::Add(hn::Mul(n0, px), hn::Mul(n1, py)), hn::Mul(n2, z0)), len);
    const MF flip = hn::Gt(dot, zero);
    n0 = hn::IfThenElse(flip, hn::Neg(n0), n0);
    n1 = hn::IfThenElse(flip, hn::Neg(n1), n1);
    dot = hn::IfThenElse(flip, hn::Neg(dot), dot);
    const VF ray = hn::Sqrt(hn::Add(hn::Add(hn::Mul(px, px), hn::Mul(py, py)), hn::Mul(z0, z0)));
    m = hn::And(m, hn::Gt(hn::Neg(dot), hn::Mul(fifth, ray)));
    hn::StoreU(hn::Div(n0, len), df, nx + u);
    hn::StoreU(hn::Div(n1, len), df, ny + u);
    store_valid(m, ok + u);
  }
  surface_normal_columns(r, u, r.width - 1, nx, ny, ok);
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

// The scalar references' entry points, one per target like the kernels' (the public *_scalar
// functions below dispatch to them).
int WarpResidualsScalar(const PointsView& points, const LevelImage& cur, const FloatPose& T_cur_ref,
                        float alpha, float beta, float* residual, std::uint8_t* valid,
                        Sampling sampling) {
  return reference::warp_range(points, cur, T_cur_ref, alpha, beta, 0, residual, valid, sampling);
}
int WarpPointToPlaneScalar(const PlanePointsView& points, const LevelImage& depth,
                           const FloatPose& T_cur_ref, float max_spread, float* residual,
                           std::uint8_t* valid, float* const* jac) {
  return reference::point_to_plane_range(points, depth, T_cur_ref, max_spread, 0, residual, valid,
                                         jac);
}
double TukeyCostSumScalar(const float* residual, const std::uint8_t* valid, int count,
                          float inv_sigma, float c) {
  return reference::tukey_cost_range(residual, valid, 0, count, inv_sigma, c);
}
WeightSums TukeyWeightsScalar(const float* residual, const std::uint8_t* valid, int count,
                              float inv_sigma, float c, float* weight) {
  return reference::tukey_weights_range(residual, valid, 0, count, inv_sigma, c, weight);
}
int GatherAbsValidScalar(const float* residual, const std::uint8_t* valid, int count, float* out) {
  return reference::gather_abs_valid(residual, valid, count, out);
}
float SelectKthScalar(float* v, int n, int k) { return reference::select_kth(v, n, k); }
void NormalEquations6Scalar(const float* const* J, int count, const float* w, const float* r,
                            Matrix8d& H, Vector8d& g) {
  reference::accumulate_normal_equations<6>(J, count, w, r, H, g);
}
void NormalEquations8Scalar(const float* const* J, int count, const float* w, const float* r,
                            Matrix8d& H, Vector8d& g) {
  reference::accumulate_normal_equations<8>(J, count, w, r, H, g);
}

}  // namespace kestrel::odometry::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::odometry::kernels {

HWY_EXPORT(WarpResiduals);
HWY_EXPORT(WarpPointToPlane);
HWY_EXPORT(TukeyCostSum);
HWY_EXPORT(TukeyWeights);
HWY_EXPORT(BracketAbs);
HWY_EXPORT(GatherAbsValid);
HWY_EXPORT(SelectKth);
HWY_EXPORT(NormalEquations6);
HWY_EXPORT(NormalEquations8);
HWY_EXPORT(SurfaceNormalRow);
HWY_EXPORT(TargetName);
HWY_EXPORT(WarpResidualsScalar);
HWY_EXPORT(WarpPointToPlaneScalar);
HWY_EXPORT(TukeyCostSumScalar);
HWY_EXPORT(TukeyWeightsScalar);
HWY_EXPORT(GatherAbsValidScalar);
HWY_EXPORT(SelectKthScalar);
HWY_EXPORT(NormalEquations6Scalar);
HWY_EXPORT(NormalEquations8Scalar);

FloatPose FloatPose::from(const SE3& T) {
  const Eigen::Matrix3f R = T.rotation_matrix().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  return {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2),
          R(2, 0), R(2, 1), R(2, 2), t.x(),   t.y(),   t.z()};
}

int warp_residuals(const PointsView& points, const LevelImage& cur, const FloatPose& T_cur_ref,
                   float alpha, float beta, float* residual, std::uint8_t* valid,
                   Sampling sampling) {
  return HWY_DYNAMIC_DISPATCH(WarpResiduals)(points, cur, T_cur_ref, alpha, beta, residual, valid,
                                             sampling);
}

int warp_point_to_plane(const PlanePointsView& points, const LevelImage& depth,
                        const FloatPose& T_cur_ref, float max_spread, float* residual,
                        std::uint8_t* valid, float* const* jac) {
  return HWY_DYNAMIC_DISPATCH(WarpPointToPlane)(points, depth, T_cur_ref, max_spread, residual,
                                                valid, jac);
}

double tukey_cost_sum(const float* residual, const std::uint8_t* valid, int count, float inv_sigma,
                      float c) {
  return HWY_DYNAMIC_DISPATCH(TukeyCostSum)(residual, valid, count, inv_sigma, c);
}

WeightSums tukey_weights(const float* residual, const std::uint8_t* valid, int count,
                         float inv_sigma, float c, float* weight) {
  return HWY_DYNAMIC_DISPATCH(TukeyWeights)(residual, valid, count, inv_sigma, c, weight);
}

int gather_abs_valid(const float* residual, const std::uint8_t* valid, int count, float* out) {
  return HWY_DYNAMIC_DISPATCH(GatherAbsValid)(residual, valid, count, out);
}

float select_kth(float* v, int n, int k) { return HWY_DYNAMIC_DISPATCH(SelectKth)(v, n, k); }

AbsMedian abs_median(const float* residual, const std::uint8_t* valid, int count, float hint,
                     float* scratch) {
  AbsMedian out;
  if (hint > 0.0F && std::isfinite(hint)) {
    // Half-width 1/8 of the hint: near the optimum sigma moves by far less between iterations,
    // and a bracket this narrow holds ~11 % of Gaussian residuals, so the selection is on a few
    // hundred values instead of thousands.
    const MedianBracket b = HWY_DYNAMIC_DISPATCH(BracketAbs)(residual, valid, count, hint * 0.875F,
                                                             hint * 1.125F, scratch);
    out.valid = b.valid;
    if (b.valid == 0) return out;
    const int k = b.valid / 2;
    if (k >= b.below && k < b.below + b.inside) {
      out.median = select_kth(scratch, b.inside, k - b.below);
      return out;
    }
  }
  const int m = gather_abs_valid(residual, valid, count, scratch);
  out.valid = m;
  if (m > 0) out.median = select_kth(scratch, m, m / 2);
  return out;
}

template <>
void accumulate_normal_equations<6>(const float* const* J, int count, const float* w,
                                    const float* r, Matrix8d& H, Vector8d& g) {
  HWY_DYNAMIC_DISPATCH(NormalEquations6)(J, count, w, r, H, g);
}

template <>
void accumulate_normal_equations<8>(const float* const* J, int count, const float* w,
                                    const float* r, Matrix8d& H, Vector8d& g) {
  HWY_DYNAMIC_DISPATCH(NormalEquations8)(J, count, w, r, H, g);
}

// The scalar references, on the target the kernels run on (hwy::SetSupportedTargetsForTest
// selects both).
int warp_residuals_scalar(const PointsView& points, const LevelImage& cur,
                          const FloatPose& T_cur_ref, float alpha, float beta, float* residual,
                          std::uint8_t* valid, Sampling sampling) {
  return HWY_DYNAMIC_DISPATCH(WarpResidualsScalar)(points, cur, T_cur_ref, alpha, beta, residual,
                                                   valid, sampling);
}

int warp_point_to_plane_scalar(const PlanePointsView& points, const LevelImage& depth,
                               const FloatPose& T_cur_ref, float max_spread, float* residual,
                               std::uint8_t* valid, float* const* jac) {
  return HWY_DYNAMIC_DISPATCH(WarpPointToPlaneScalar)(points, depth, T_cur_ref, max_spread,
                                                      residual, valid, jac);
}

double tukey_cost_sum_scalar(const float* residual, const std::uint8_t* valid, int count,
                             float inv_sigma, float c) {
  return HWY_DYNAMIC_DISPATCH(TukeyCostSumScalar)(residual, valid, count, inv_sigma, c);
}

WeightSums tukey_weights_scalar(const float* residual, const std::uint8_t* valid, int count,
                                float inv_sigma, float c, float* weight) {
  return HWY_DYNAMIC_DISPATCH(TukeyWeightsScalar)(residual, valid, count, inv_sigma, c, weight);
}

int gather_abs_valid_scalar(const float* residual, const std::uint8_t* valid, int count,
                            float* out) {
  return HWY_DYNAMIC_DISPATCH(GatherAbsValidScalar)(residual, valid, count, out);
}

float select_kth_scalar(float* v, int n, int k) {
  return HWY_DYNAMIC_DISPATCH(SelectKthScalar)(v, n, k);
}

template <>
void accumulate_normal_equations_scalar<6>(const float* const* J, int count, const float* w,
                                           const float* r, Matrix8d& H, Vector8d& g) {
  HWY_DYNAMIC_DISPATCH(NormalEquations6Scalar)(J, count, w, r, H, g);
}

template <>
void accumulate_normal_equations_scalar<8>(const float* const* J, int count, const float* w,
                                           const float* r, Matrix8d& H, Vector8d& g) {
  HWY_DYNAMIC_DISPATCH(NormalEquations8Scalar)(J, count, w, r, H, g);
}

void surface_normal_row(const NormalRow& row, float* nx, float* ny, std::uint8_t* ok) {
  HWY_DYNAMIC_DISPATCH(SurfaceNormalRow)(row, nx, ny, ok);
}

const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

std::vector<std::int64_t> simd_targets() { return hwy::SupportedAndGeneratedTargets(); }

}  // namespace kestrel::odometry::kernels
#endif  // HWY_ONCE
