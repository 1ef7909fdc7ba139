// The SGM row kernels (sgm_kernels.hpp) in portable SIMD: Google Highway compiles this file once
// per target (foreach_target.h re-includes it) and each call goes to the best target the CPU
// supports (HWY_DYNAMIC_DISPATCH). SIMD runs over the disparities of one pixel (uint16 lanes),
// as in Spangenberg et al., "Large scale semi-global matching on the CPU" (IV 2014): the path
// recursion is sequential along a path but independent across disparities.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "sgm_kernels.cpp"  // NOLINT: this file, found by its folder
#include "sgm_kernels.hpp"

#include <hwy/cache_control.h>
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>

HWY_BEFORE_NAMESPACE();
namespace kestrel::sensor::sgm::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D16 = hn::ScalableTag<std::uint16_t>;
using DI16 = hn::RebindToSigned<D16>;
using D8 = hn::Rebind<std::uint8_t, DI16>;
using V16 = hn::Vec<D16>;

// Census: one comparison (bit) at a time over N pixels, as 16-bit lanes so that the two halves
// of the signature come out as the uint16 planes the costs read.
void CensusRow(const CensusRowArgs& args) {
  const CensusRowArgs a = args;  // a local copy: see aggregate()
  const D16 d;
  const DI16 di;
  const D8 d8;
  const int n = static_cast<int>(hn::Lanes(d));
  for (int x = 0; x < a.width; x += n) {
    V16 low = hn::Zero(d), high = hn::Zero(d);
    const std::uint8_t* p = a.center + x;
    for (int b = 0; b < a.bits; ++b) {
      const auto va = hn::PromoteTo(di, hn::LoadU(d8, p + a.offset_a[b]));
      const auto vb = hn::PromoteTo(di, hn::LoadU(d8, p + a.offset_b[b]));
      const auto greater = hn::RebindMask(d, hn::Gt(va, vb));
      const auto bit = hn::Set(d, static_cast<std::uint16_t>(1U << (b & 15)));
      if (b < 16) {
        low = hn::Or(low, hn::IfThenElseZero(greater, bit));
      } else {
        high = hn::Or(high, hn::IfThenElseZero(greater, bit));
      }
    }
    hn::StoreU(low, d, a.low + x);
    hn::StoreU(high, d, a.high + x);
  }
}

void CostRow(const CostRowArgs& args) {
  // A local copy, as in aggregate(): through the reference GCC reloaded the pad mask's pointer
  // and the lane count after every store.
  const CostRowArgs a = args;
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  for (int x = 0; x < a.width; ++x) {
    const V16 l_low = hn::Set(d, a.left_low[x]);
    const V16 l_high = hn::Set(d, a.left_high[x]);
    const std::uint16_t* r_low = a.right_rev_low + (a.first - x);
    const std::uint16_t* r_high = a.right_rev_high + (a.first - x);
    std::uint16_t* out = a.cost + static_cast<std::ptrdiff_t>(x) * a.lanes;
    for (int k = 0; k < a.lanes; k += n) {
      const V16 c = hn::Add(hn::PopulationCount(hn::Xor(l_low, hn::LoadU(d, r_low + k))),
                            hn::PopulationCount(hn::Xor(l_high, hn::LoadU(d, r_high + k))));
      hn::StoreU(hn::Or(c, hn::LoadU(d, a.pad_mask + k)), d, out + k);
    }
  }
}

// The least lane of v: halves folded down to 128 bits, whose minimum x86 finds in one
// instruction (phminposuw; Highway's MinOfLanes of wider vectors takes the 32-bit route).
template <class D>
HWY_INLINE std::uint16_t least_lane(D d, hn::Vec<D> v) {
#if HWY_TARGET == HWY_SCALAR
  return hn::GetLane(hn::MinOfLanes(d, v));
#else
  if constexpr (hn::MaxLanes(D()) * sizeof(std::uint16_t) > 16) {
    const hn::Half<D> dh;
    return least_lane(dh, hn::Min(hn::LowerHalf(dh, v), hn::UpperHalf(dh, v)));
  } else {
    return hn::GetLane(hn::MinOfLanes(d, v));
  }
#endif
}

// Eq. 13 on N lanes (uint16 or uint8), given the previous pixel's costs at d, d - 1, d + 1.
template <class V>
HWY_INLINE V path_lanes(V at, V below, V above, V prev_min, V jump, V p1, V cost) {
  const V t = hn::Min(hn::Min(at, hn::SaturatedAdd(hn::Min(below, above), p1)), jump);
  return hn::SaturatedAdd(cost, hn::Sub(t, prev_min));
}

#if HWY_TARGET != HWY_SCALAR
// The 128-bit blocks of v rotated by one block: up (block b <- block b - 1) or down. The
// indices come from Iota, not from an array in memory: a vector load of an array just written
// by scalar stores cannot be forwarded and stalls.
HWY_INLINE V16 rotate_blocks(V16 v, bool up) {
  const D16 d;
  const hn::Repartition<std::uint64_t, D16> d64;
  const hn::RebindToSigned<decltype(d64)> di64;
  const auto n64 = static_cast<std::int64_t>(hn::Lanes(d64));
  const auto idx = hn::And(hn::Iota(di64, up ? n64 - 2 : 2), hn::Set(di64, n64 - 1));
  return hn::BitCast(d, hn::TableLookupLanes(hn::BitCast(d64, v), hn::IndicesFromVec(d64, idx)));
}

// The lanes of `v` moved up by one (lane i <- lane i - 1), lane 0 from the last lane of
// `before`: the costs at d - 1 without an unaligned reload of what was just stored (a load
// that straddles two recent stores cannot be forwarded and waits for them to retire).
HWY_INLINE V16 shift_up(V16 v, V16 before) {
  const D16 d;
  const V16 previous_blocks =
      hn::IfThenElse(hn::FirstN(d, 8), rotate_blocks(before, true), rotate_blocks(v, true));
  return hn::CombineShiftRightBytes<14>(d, v, previous_blocks);
}

// The lanes of `v` moved down by one (lane i <- lane i + 1), the last from lane 0 of `after`.
HWY_INLINE V16 shift_down(V16 v, V16 after) {
  const D16 d;
  const V16 next_blocks = hn::IfThenElse(hn::FirstN(d, hn::Lanes(d) - 8), rotate_blocks(v, false),
                                         rotate_blocks(after, false));
  return hn::CombineShiftRightBytes<2>(d, next_blocks, v);
}
#endif

// The paths of a pass at one pixel: where each comes from and goes, its previous least cost,
// that plus P2, and its new least cost. Pointers and vectors in separate arrays: GCC copies a
// struct that mixes them with a narrow store and a wide reload, which cannot be forwarded.
template <int NP>
struct PixelPaths {
  const std::uint16_t* prev[NP];
  std::uint16_t* out[NP];
  V16 prev_min[NP], jump[NP], least[NP];

  HWY_INLINE void set(int r, const std::uint16_t* from, std::uint16_t from_min, std::uint16_t p2,
                      std::uint16_t* to) {
    const D16 d;
    prev[r] = from;
    out[r] = to;
    prev_min[r] = hn::Set(d, from_min);
    jump[r] = hn::SaturatedAdd(prev_min[r], hn::Set(d, p2));
    least[r] = hn::Set(d, kSgmMaskedCost);
  }
};

// Lanes k.. of a path whose previous costs were stored a row ago: unaligned loads at -1, +1.
template <int NP>
HWY_INLINE V16 vertical_lanes(const PixelPaths<NP>& p, int r, int k, V16 p1, V16 cost) {
  const D16 d;
  const std::uint16_t* prev = p.prev[r] + k;
  return path_lanes(hn::LoadU(d, prev), hn::LoadU(d, prev - 1), hn::LoadU(d, prev + 1),
                    p.prev_min[r], p.jump[r], p1, cost);
}

// Lanes k.. of the horizontal path (r = 0), whose previous costs were stored one pixel ago:
// whole-vector reloads of those stores (forwarded) and the +-1 lane neighbours by shifts in
// registers.
template <int NP>
HWY_INLINE V16 horizontal_lanes(const PixelPaths<NP>& p, int k, int lanes, V16 p1, V16 cost) {
#if HWY_TARGET == HWY_SCALAR
  (void)lanes;
  return vertical_lanes(p, 0, k, p1, cost);
#else
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const V16 masked = hn::Set(d, kSgmMaskedCost);
  const std::uint16_t* prev = p.prev[0] + k;
  const V16 at = hn::LoadU(d, prev);
  const V16 before = k > 0 ? hn::LoadU(d, prev - n) : masked;
  const V16 after = k + n < lanes ? hn::LoadU(d, prev + n) : masked;
  return path_lanes(at, shift_up(at, before), shift_down(at, after), p.prev_min[0], p.jump[0], p1,
                    cost);
#endif
}

// The pass's paths at pixel x: the horizontal one and NV vertical ones (compile time, so that
// their state stays in registers). Returns the horizontal path's least cost.
template <int NV>
HWY_INLINE std::uint16_t pixel_paths(const AggregateRowArgs& a, int x, PixelPaths<NV + 1>& p) {
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const V16 p1 = hn::Set(d, a.p1);
  const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(x) * a.lanes;
  for (int k = 0; k < a.lanes; k += n) {
    const V16 cost = hn::LoadU(d, a.cost + base + k);
    V16 sum = a.add ? hn::LoadU(d, a.add + base + k) : hn::Zero(d);
    for (int r = 0; r <= NV; ++r) {
      const V16 l =
          r == 0 ? horizontal_lanes(p, k, a.lanes, p1, cost) : vertical_lanes(p, r, k, p1, cost);
      hn::StoreU(l, d, p.out[r] + k);
      p.least[r] = hn::Min(p.least[r], l);
      sum = hn::SaturatedAdd(sum, l);
    }
    hn::StoreU(sum, d, a.sum + base + k);
  }
  for (int r = 1; r <= NV; ++r) a.vertical[r - 1].cur_min[x + 1] = least_lane(d, p.least[r]);
  return least_lane(d, p.least[0]);
}

// P2 of each path at every pixel of the row (eq. 16), in a plain loop before the recursion so
// that the per-pixel work there is loads only: row r of `p2` is path r (0: horizontal). The
// borders clamp the neighbour; the loop between them needs no clamp and, the table being
// symmetric, no absolute value (it was ~10 % of the 8-bit recursion's time with both).
HWY_INLINE void penalty_row(const AggregateRowArgs& a, const std::uint8_t* other, int dx,
                            std::uint16_t* p2) {
  const int w = a.width;
  const std::uint8_t* image = a.image;
  const std::uint16_t* lut = a.p2_lut;
  for (const int x : {0, w - 1}) {
    p2[x] = lut[int{image[x]} - int{other[std::clamp(x + dx, 0, w - 1)]}];
  }
  const std::uint8_t* shifted = other + dx;
  for (int x = 1; x + 1 < w; ++x) p2[x] = lut[int{image[x]} - int{shifted[x]}];
}

template <int NV>
HWY_INLINE void row_penalties(const AggregateRowArgs& a, std::uint16_t* p2) {
  penalty_row(a, a.image, -a.step, p2);
  for (int r = 0; r < NV; ++r) {
    penalty_row(a, a.image_prev, a.vertical[r].dx,
                p2 + static_cast<std::ptrdiff_t>(r + 1) * a.width);
  }
}

template <int NV>
void aggregate(const AggregateRowArgs& args) {
  // A local copy: Highway's vector stores may alias anything, so through the reference GCC
  // reloaded the row's pointers and sizes after every store; a local whose address stays
  // here cannot be written by them.
  const AggregateRowArgs a = args;
  const int stride = a.lanes + kSgmGuard;
  const int x0 = a.step > 0 ? 0 : a.width - 1;
  row_penalties<NV>(a, a.p2_scratch);
  const std::uint16_t* h_prev = a.horizontal + kSgmGuard;  // the masked slot
  std::uint16_t h_min = kSgmMaskedCost;
  // Aggregate-initialised ({}), not default-constructed: GCC on AArch64 compiles the implicit
  // constructor of a struct of vectors outside Highway's NEON target pragma and then refuses to
  // inline the vectors' always_inline constructors (Highway issue 834, fixed after 1.0.3).
  PixelPaths<NV + 1> p{};
  for (int i = 0; i < a.width; ++i) {
    const int x = x0 + i * a.step;
    std::uint16_t* h_cur = a.horizontal + (1 + (i & 1)) * stride + kSgmGuard;
    p.set(0, h_prev, h_min, a.p2_scratch[x], h_cur);
    for (int r = 0; r < NV; ++r) {
      const PathRows& v = a.vertical[r];
      const int slot = x + 1 + v.dx;
      p.set(r + 1, v.prev + slot * stride + kSgmGuard, v.prev_min[slot],
            a.p2_scratch[(r + 1) * a.width + x], v.cur + (x + 1) * stride + kSgmGuard);
    }
    h_min = pixel_paths<NV>(a, x, p);
    h_prev = h_cur;
  }
}

void AggregateRow(const AggregateRowArgs& a) {
  if (a.num_vertical == 3) {
    aggregate<3>(a);
  } else {
    aggregate<1>(a);
  }
}

// ---------------------------------------------------------------------------------------------
// The same recursion in uint8 path costs: a vector holds twice the disparities, so the
// recursion takes half the operations; the sums stay uint16 (each path's costs widened once).
// Exact as long as every real path cost stays <= 254 (the caller's condition, sgm_kernels.hpp):
// then min(L(d), L(d +- 1) + P1, min L + P2) is the same whether the two sums saturate at 255
// or not (it is at most L(d) <= 254), and 0xFF marks the masked lanes as 0xFFFF does.

#if HWY_TARGET != HWY_SCALAR
// rotate_blocks / shift_up / shift_down for any lane type and vector width.
template <class D>
HWY_INLINE hn::Vec<D> rotate_blocks_of(D d, hn::Vec<D> v, bool up) {
  const hn::Repartition<std::uint64_t, D> d64;
  const hn::RebindToSigned<decltype(d64)> di64;
  const auto n64 = static_cast<std::int64_t>(hn::Lanes(d64));
  const auto idx = hn::And(hn::Iota(di64, up ? n64 - 2 : 2), hn::Set(di64, n64 - 1));
  return hn::BitCast(d, hn::TableLookupLanes(hn::BitCast(d64, v), hn::IndicesFromVec(d64, idx)));
}

template <class D>
HWY_INLINE hn::Vec<D> shift_up_of(D d, hn::Vec<D> v, hn::Vec<D> before) {
  constexpr int kSize = sizeof(hn::TFromD<D>);
  const auto previous_blocks = hn::IfThenElse(
      hn::FirstN(d, 16 / kSize), rotate_blocks_of(d, before, true), rotate_blocks_of(d, v, true));
  return hn::CombineShiftRightBytes<16 - kSize>(d, v, previous_blocks);
}

template <class D>
HWY_INLINE hn::Vec<D> shift_down_of(D d, hn::Vec<D> v, hn::Vec<D> after) {
  constexpr int kSize = sizeof(hn::TFromD<D>);
  const auto next_blocks =
      hn::IfThenElse(hn::FirstN(d, hn::Lanes(d) - 16 / kSize), rotate_blocks_of(d, v, false),
                     rotate_blocks_of(d, after, false));
  return hn::CombineShiftRightBytes<kSize>(d, next_blocks, v);
}

// The least lane of uint8 lanes: halves folded to 128 bits, then each uint16 lane's two bytes
// (the high byte moved down, zeros above: the low byte keeps min(low, high), the high byte 0),
// whose least is least_lane's one instruction.
template <class D>
HWY_INLINE std::uint16_t least_lane8(D d, hn::Vec<D> v) {
  if constexpr (hn::MaxLanes(D()) > 16) {
    const hn::Half<D> dh;
    return least_lane8(dh, hn::Min(hn::LowerHalf(dh, v), hn::UpperHalf(dh, v)));
  } else {
    const hn::Repartition<std::uint16_t, D> dw;
    const auto pairs =
        hn::BitCast(dw, hn::Min(v, hn::BitCast(d, hn::ShiftRight<8>(hn::BitCast(dw, v)))));
    return least_lane(dw, pairs);
  }
}

// PixelPaths in uint8 lanes.
template <class D8, int NP>
struct PixelPaths8 {
  const std::uint8_t* prev[NP];
  std::uint8_t* out[NP];
  hn::Vec<D8> prev_min[NP], jump[NP], least[NP];

  HWY_INLINE void set(int r, const std::uint8_t* from, std::uint16_t from_min, std::uint16_t p2,
                      std::uint8_t* to) {
    const D8 d;
    prev[r] = from;
    out[r] = to;
    // The low byte: least costs are <= 0xFF, and the masked 0xFFFF of the entry slots -> 0xFF.
    prev_min[r] = hn::Set(d, static_cast<std::uint8_t>(from_min));
    jump[r] = hn::SaturatedAdd(prev_min[r], hn::Set(d, static_cast<std::uint8_t>(p2)));
  }
};

template <class D8, int NV>
HWY_INLINE std::uint16_t pixel_paths8(const AggregateRowArgs& a, int x,
                                      PixelPaths8<D8, NV + 1>& p) {
  const D8 d8;
  const hn::Repartition<std::uint16_t, D8> dw;  // the same bytes as uint16: half the lanes
  const hn::Half<D8> dh;
  using V8 = hn::Vec<D8>;
  const int n = static_cast<int>(hn::Lanes(d8)), nw = n / 2;
  const V8 p1 = hn::Set(d8, static_cast<std::uint8_t>(a.p1));
  const V8 masked = hn::Set(d8, std::uint8_t{0xFF});
  const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(x) * a.lanes;
  for (int k = 0; k < a.lanes; k += n) {
    // The costs' low bytes: real costs are <= 32 and masked 0xFFFF becomes 0xFF.
    const std::uint16_t* c = a.cost + base + k;
    const V8 cost = hn::ConcatEven(d8, hn::BitCast(d8, hn::LoadU(dw, c + nw)),
                                   hn::BitCast(d8, hn::LoadU(dw, c)));
    const std::uint16_t* init = a.add ? a.add + base + k : a.pad_mask + k;
    auto sum_lo = hn::LoadU(dw, init);
    auto sum_hi = hn::LoadU(dw, init + nw);
    for (int r = 0; r <= NV; ++r) {
      const std::uint8_t* prev = p.prev[r] + k;
      const V8 at = hn::LoadU(d8, prev);
      V8 l;
      if (r == 0) {  // the horizontal path: the neighbours shifted in registers (see above)
        const V8 before = k > 0 ? hn::LoadU(d8, prev - n) : masked;
        const V8 after = k + n < a.lanes ? hn::LoadU(d8, prev + n) : masked;
        l = path_lanes(at, shift_up_of(d8, at, before), shift_down_of(d8, at, after), p.prev_min[0],
                       p.jump[0], p1, cost);
      } else {
        l = path_lanes(at, hn::LoadU(d8, prev - 1), hn::LoadU(d8, prev + 1), p.prev_min[r],
                       p.jump[r], p1, cost);
      }
      hn::StoreU(l, d8, p.out[r] + k);
      p.least[r] = k == 0 ? l : hn::Min(p.least[r], l);
      sum_lo = hn::SaturatedAdd(sum_lo, hn::PromoteTo(dw, hn::LowerHalf(dh, l)));
      sum_hi = hn::SaturatedAdd(sum_hi, hn::PromoteTo(dw, hn::UpperHalf(dh, l)));
    }
    if (a.add == nullptr) {
      // The top-down sums are read a whole pass later: past the caches, written around them
      // (no read for ownership). Aligned: the volume is, and lanes and k are multiples of n.
      hn::Stream(sum_lo, dw, a.sum + base + k);
      hn::Stream(sum_hi, dw, a.sum + base + k + nw);
    } else {
      hn::StoreU(sum_lo, dw, a.sum + base + k);
      hn::StoreU(sum_hi, dw, a.sum + base + k + nw);
    }
  }
  for (int r = 1; r <= NV; ++r) a.vertical[r - 1].cur_min[x + 1] = least_lane8(d8, p.least[r]);
  return least_lane8(d8, p.least[0]);
}

template <class D8, int NV>
void aggregate8(const AggregateRowArgs& args) {
  const AggregateRowArgs a = args;  // a local copy, as in aggregate()
  const int stride = a.lanes + kSgmGuard8;
  const int x0 = a.step > 0 ? 0 : a.width - 1;
  row_penalties<NV>(a, a.p2_scratch);
  auto* const horizontal = reinterpret_cast<std::uint8_t*>(a.horizontal);
  const std::uint8_t* h_prev = horizontal + kSgmGuard8;  // the masked slot
  std::uint16_t h_min = 0xFF;
  PixelPaths8<D8, NV + 1> p{};
  for (int i = 0; i < a.width; ++i) {
    const int x = x0 + i * a.step;
    std::uint8_t* h_cur = horizontal + (1 + (i & 1)) * stride + kSgmGuard8;
    p.set(0, h_prev, h_min, a.p2_scratch[x], h_cur);
    for (int r = 0; r < NV; ++r) {
      const PathRows& v = a.vertical[r];
      const int slot = x + 1 + v.dx;
      p.set(r + 1, reinterpret_cast<const std::uint8_t*>(v.prev) + slot * stride + kSgmGuard8,
            v.prev_min[slot], a.p2_scratch[(r + 1) * a.width + x],
            reinterpret_cast<std::uint8_t*>(v.cur) + (x + 1) * stride + kSgmGuard8);
    }
    if (a.add != nullptr) {
      // The top-down sums come from memory (they were streamed past the caches): fetched a
      // few pixels ahead of the pixel that adds them.
      const int ahead = std::clamp(x + 16 * a.step, 0, a.width - 1);
      const std::uint16_t* next = a.add + static_cast<std::ptrdiff_t>(ahead) * a.lanes;
      for (int k = 0; k < a.lanes; k += 32) hwy::Prefetch(next + k);
    }
    h_min = pixel_paths8<D8, NV>(a, x, p);
    h_prev = h_cur;
  }
}

template <class D8>
void aggregate8_paths(const AggregateRowArgs& a) {
  if (a.num_vertical == 3) {
    aggregate8<D8, 3>(a);
  } else {
    aggregate8<D8, 1>(a);
  }
}
#endif

#if HWY_TARGET != HWY_SCALAR
// A template, so that the half-vector branch is only instantiated where it can be taken (a
// discarded `if constexpr` branch outside a template would still be compiled for every target,
// the 64-bit halves of 128-bit ones included).
template <class D8>
void aggregate8_lanes(const AggregateRowArgs& a) {
  if (a.lanes % static_cast<int>(hn::Lanes(D8())) == 0) {
    aggregate8_paths<D8>(a);
  } else if constexpr (hn::MaxLanes(D8()) > kSgmMaxVectorLanes) {
    aggregate8_paths<hn::Half<D8>>(a);  // AVX-512 (64 lanes) with lanes an odd multiple of 32
  } else {
    AggregateRow(a);  // not reached: lanes is a multiple of kSgmMaxVectorLanes
  }
}
#endif

void AggregateRow8(const AggregateRowArgs& a) {
#if HWY_TARGET == HWY_SCALAR
  AggregateRow(a);  // one lane: nothing to halve (the sums are the same)
#else
  aggregate8_lanes<hn::ScalableTag<std::uint8_t>>(a);
#endif
}

// The winner of pixel x: least summed cost and its first lane.
HWY_INLINE void winner(const DecideRowArgs& a, int x) {
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const std::uint16_t* s = a.sum + static_cast<std::ptrdiff_t>(x) * a.lanes;
  V16 least = hn::LoadU(d, s);
  for (int k = n; k < a.lanes; k += n) least = hn::Min(least, hn::LoadU(d, s + k));
  const std::uint16_t best_cost = least_lane(d, least);
  least = hn::Set(d, best_cost);
  int best = 0;
  for (int k = 0; k < a.lanes; k += n) {
    const intptr_t first = hn::FindFirstTrue(d, hn::Eq(hn::LoadU(d, s + k), least));
    if (first >= 0) {
      best = k + static_cast<int>(first);
      break;
    }
  }
  a.best[x] = best;
  a.best_cost[x] = best_cost;
}

// Right to left, the lanes of right_min_rev that pixel x can still reach (W - 1 - x + k) are a
// window in `window` (whole vectors: reloads of what was just stored are forwarded); after
// pixel x its first lane is final, and the window moves one lane.
void DecideRow(const DecideRowArgs& args) {
  const DecideRowArgs a = args;  // a local copy: see CostRow
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const V16 masked = hn::Set(d, kSgmMaskedCost);
  if (a.right_min_rev == nullptr) {
    for (int x = 0; x < a.width; ++x) winner(a, x);
    return;
  }
  std::uint16_t* window = a.right_min_rev + a.width;  // scratch: lanes entries past the row
  for (int k = 0; k < a.lanes; k += n) hn::StoreU(masked, d, window + k);
  for (int x = a.width - 1; x >= 0; --x) {
    winner(a, x);
    const std::uint16_t* s = a.sum + static_cast<std::ptrdiff_t>(x) * a.lanes;
    V16 cur = hn::Min(hn::LoadU(d, window), hn::LoadU(d, s));
    a.right_min_rev[a.width - 1 - x] = hn::GetLane(cur);
    for (int k = 0; k < a.lanes; k += n) {
      const V16 next =
          k + n < a.lanes ? hn::Min(hn::LoadU(d, window + k + n), hn::LoadU(d, s + k + n)) : masked;
#if HWY_TARGET == HWY_SCALAR
      hn::StoreU(next, d, window + k);
#else
      hn::StoreU(shift_down(cur, next), d, window + k);
#endif
      cur = next;
    }
  }
}

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace kestrel::sensor::sgm::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::sensor::sgm {

HWY_EXPORT(CensusRow);
HWY_EXPORT(CostRow);
HWY_EXPORT(AggregateRow);
HWY_EXPORT(AggregateRow8);
HWY_EXPORT(DecideRow);
HWY_EXPORT(TargetName);

namespace {
void census_row(const CensusRowArgs& a) { HWY_DYNAMIC_DISPATCH(CensusRow)(a); }
void cost_row(const CostRowArgs& a) { HWY_DYNAMIC_DISPATCH(CostRow)(a); }
void aggregate_row(const AggregateRowArgs& a) { HWY_DYNAMIC_DISPATCH(AggregateRow)(a); }
void aggregate_row8(const AggregateRowArgs& a) { HWY_DYNAMIC_DISPATCH(AggregateRow8)(a); }
void decide_row(const DecideRowArgs& a) { HWY_DYNAMIC_DISPATCH(DecideRow)(a); }
}  // namespace

const Kernels& simd_kernels() {
  static const Kernels k{census_row, cost_row, aggregate_row, aggregate_row8, decide_row};
  return k;
}

const char* simd_target() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

std::vector<std::int64_t> simd_targets() { return hwy::SupportedAndGeneratedTargets(); }

}  // namespace kestrel::sensor::sgm
#endif  // HWY_ONCE
