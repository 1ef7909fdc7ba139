// The block matcher's row kernels (block_matcher_kernels.hpp) in portable SIMD: Google Highway
// compiles this file once per target (foreach_target.h re-includes it), and each call goes to
// the best target the CPU supports (HWY_DYNAMIC_DISPATCH). Vectors are capped at 256 bits:
// a row's 32 or 64 fast-row lanes are one or two such vectors, the winner search folds them
// to 128 bits anyway, and the fast row's storage order (fast_lane_position) is defined for
// 128- and 256-bit vectors only. Every kernel gives the bits of the scalar reference
// (block_matcher.cpp: scan_row_generic + finish_row).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "block_matcher_kernels.cpp"  // NOLINT: this file, found by its folder
#include "block_matcher_kernels.hpp"

#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

HWY_BEFORE_NAMESPACE();
namespace kestrel::sensor::kernels::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

#if HWY_TARGET == HWY_SCALAR
// One-lane vectors cannot hold the byte pairs the kernels widen: the scalar reference runs
// (vector_lanes() == 1 tells the matcher).
int VectorLanes() { return 1; }
void ScanRow(const RowScan& /*scan*/) {}
void AddSadRowFast(std::uint16_t* /*column_sums*/, const std::uint8_t* /*left_row*/,
                   const std::uint8_t* /*right_row*/, int /*cols*/, int /*lanes*/, int /*bits*/) {}
void MatchRowFast(const RowScan& /*scan*/, const FastRow& /*fast*/, float* /*out*/,
                  MatchStats& /*stats*/) {}
void CensusSignatures(const std::uint8_t* const* rows, int cr, int count, std::uint64_t* out) {
  census_signatures_reference(rows, cr, count, out);
}
#else

using D16 = hn::CappedTag<std::uint16_t, 16>;   // costs
using DI16 = hn::RebindToSigned<D16>;           // lane numbers (signed compares are cheaper)
using D8 = hn::Repartition<std::uint8_t, D16>;  // per-pixel byte costs, as many bytes
using D16x8 = hn::Full128<std::uint16_t>;       // the winner search's 8-lane fold
using V16 = hn::Vec<D16>;
using V8 = hn::Vec<D8>;
constexpr int kV = static_cast<int>(hn::MaxLanes(D16()));  // uint16 lanes per vector: 8 or 16
static_assert(kV == 8 || kV == 16);

int VectorLanes() { return kV; }

HWY_INLINE V8 abs_diff_u8(V8 a, V8 b) {
  return hn::Or(hn::SaturatedSub(a, b), hn::SaturatedSub(b, a));
}

// A vector of costs folded to its 8-lane minimum: on 256 bits, the minimum of the two
// 128-bit blocks (position j of the fold: position j of either block).
template <class V>
HWY_INLINE hn::Vec<D16x8> fold_to_128(V v) {
  if constexpr (hn::MaxLanes(hn::DFromV<V>()) == 16) {
    return hn::Min(hn::LowerHalf(v), hn::UpperHalf(hn::Half<hn::DFromV<V> >(), v));
  } else {
    return v;
  }
}

HWY_INLINE int min_lane(V16 v) { return hn::GetLane(hn::MinOfLanes(D16x8(), fold_to_128(v))); }

// What follows the last lane of `lo` when a row of vectors moves down one lane, as the
// per-128-bit-block CombineShiftRightBytes wants it: on 256 bits the upper block of `lo` and
// the lower one of `next` (the first lane of each block comes from the block after it).
HWY_INLINE V16 next_lanes(V16 lo, V16 next) {
  if constexpr (kV == 16) {
    return hn::ConcatLowerUpper(D16(), next, lo);
  } else {
    return next;
  }
}

// ---------------------------------------------------------------------------------------------
// The general scan: lanes = kLanes in natural order, NV vectors.

// The general scan's state along one row: the box costs, the right view's running minima
// (vector i: right pixels x - d_top + kV i ..) and the window's texture sum, in registers.
template <int kLanes>
struct GeneralScan {
  static constexpr int NV = kLanes / kV;
  explicit GeneralScan(const RowScan& row) : s(row), slide(row.left_new != nullptr) {}
  const RowScan& s;
  bool slide;  // SAD: the scan slides the column sums itself
  V16 box[NV], win[NV];
  std::uint32_t tex = 0;
};

// Column c (slid down one row where the scan slides), in registers and stored back.
template <int kLanes>
inline void general_column(const GeneralScan<kLanes>& t, int c, V16* out) {
  constexpr int NV = GeneralScan<kLanes>::NV;
  const RowScan& s = t.s;
  const D16 d16;
  std::uint16_t* col = s.column_sums + static_cast<std::size_t>(c) * kLanes;
  if (!t.slide) {
    for (int i = 0; i < NV; ++i) out[i] = hn::LoadU(d16, col + kV * i);
    return;
  }
  const D8 d8;
  const hn::Half<D8> dh;
  const V8 left_new = hn::Set(d8, s.left_new[c]), left_old = hn::Set(d8, s.left_old[c]);
  for (int i = 0; i < NV; i += 2) {
    const V8 a_new = abs_diff_u8(left_new, hn::LoadU(d8, s.right_new + c + kV * i));
    const V8 a_old = abs_diff_u8(left_old, hn::LoadU(d8, s.right_old + c + kV * i));
    V16 s0 = hn::Add(hn::LoadU(d16, col + kV * i), hn::PromoteTo(d16, hn::LowerHalf(a_new)));
    V16 s1 =
        hn::Add(hn::LoadU(d16, col + kV * (i + 1)), hn::PromoteTo(d16, hn::UpperHalf(dh, a_new)));
    s0 = hn::Sub(s0, hn::PromoteTo(d16, hn::LowerHalf(a_old)));
    s1 = hn::Sub(s1, hn::PromoteTo(d16, hn::UpperHalf(dh, a_old)));
    hn::StoreU(s0, d16, col + kV * i);
    hn::StoreU(s1, d16, col + kV * (i + 1));
    out[i] = s0;
    out[i + 1] = s1;
  }
}

// The box and texture sum of pixel 0's window (columns 0 .. 2r), the right view's minima
// empty.
template <int kLanes>
inline void general_begin(GeneralScan<kLanes>& t) {
  constexpr int NV = GeneralScan<kLanes>::NV;
  const D16 d16;
  for (int i = 0; i < NV; ++i) {
    t.box[i] = hn::Zero(d16);
    t.win[i] = hn::Set(d16, kMaskedCost);
  }
  for (int c = 0; c <= 2 * t.s.radius; ++c) {
    V16 col[NV];
    general_column(t, c, col);
    for (int i = 0; i < NV; ++i) t.box[i] = hn::Add(t.box[i], col[i]);
    t.tex += t.s.texture_columns[c];
  }
}

// Right view: lane k holds right pixel x - d_top + k; lane 0 is complete after this x. Then
// the window moves down one lane.
template <int kLanes>
inline void general_fold_right(GeneralScan<kLanes>& t, int x, const V16* v) {
  constexpr int NV = GeneralScan<kLanes>::NV;
  const D16 d16;
  for (int i = 0; i < NV; ++i) t.win[i] = hn::Min(t.win[i], v[i]);
  t.s.right_min[x] = hn::GetLane(t.win[0]);
  for (int i = 0; i < NV; ++i) {
    const V16 next = i + 1 < NV ? t.win[i + 1] : hn::Set(d16, kMaskedCost);
    t.win[i] = hn::CombineShiftRightBytes<2>(d16, next_lanes(t.win[i], next), t.win[i]);
  }
}

// The first lane of the least cost (the scalar scan's strict < keeps the first).
template <int kLanes>
inline int general_winner(const V16* v, int c0) {
  const D16 d16;
  const V16 target = hn::Set(d16, static_cast<std::uint16_t>(c0));
  for (int i = 0; i < GeneralScan<kLanes>::NV; ++i) {
    const intptr_t at = hn::FindFirstTrue(d16, hn::Eq(v[i], target));
    if (at >= 0) return kV * i + static_cast<int>(at);
  }
  return 0;
}

// The least cost of the lanes further than 1 from `best` (all masked: 0xFFFF).
template <int kLanes>
inline int general_second(const V16* v, int best) {
  const D16 d16;
  const V16 two = hn::Set(d16, 2), below = hn::Set(d16, static_cast<std::uint16_t>(best - 1));
  V16 m = hn::Set(d16, kMaskedCost);
  for (int i = 0; i < GeneralScan<kLanes>::NV; ++i) {
    // Lanes within 1 of the winner: k - (best - 1) <= 2, unsigned.
    const V16 dist = hn::Sub(hn::Iota(d16, kV * i), below);
    const V16 near = hn::VecFromMask(d16, hn::Eq(hn::Min(dist, two), dist));
    m = hn::Min(m, hn::Or(v[i], near));
  }
  return min_lane(m);
}

// Pixel x: slide the box, store it in the volume, fold it into the right view's minima, and
// the winner and the row scan's checks. kMasked: lanes below first_lane(x) are out of range.
template <bool kMasked, int kLanes>
inline void general_pixel(GeneralScan<kLanes>& t, int x) {
  constexpr int NV = GeneralScan<kLanes>::NV;
  const RowScan& s = t.s;
  const D16 d16;
  const DI16 di16;
  if (x > 0) {
    V16 add[NV];
    general_column(t, x + 2 * s.radius, add);
    const std::uint16_t* sub = s.column_sums + static_cast<std::size_t>(x - 1) * kLanes;
    for (int i = 0; i < NV; ++i) {
      t.box[i] = hn::Sub(hn::Add(t.box[i], add[i]), hn::LoadU(d16, sub + kV * i));
    }
    t.tex += s.texture_columns[x + 2 * s.radius] - s.texture_columns[x - 1];
  }
  std::uint16_t* vol = s.volume + static_cast<std::size_t>(x) * kLanes;
  for (int i = 0; i < NV; ++i) hn::StoreU(t.box[i], d16, vol + kV * i);
  const int first = kMasked ? std::min(s.first_lane(x), kLanes) : 0;
  V16 v[NV];
  for (int i = 0; i < NV; ++i) {
    if constexpr (kMasked) {
      const auto out_of_range =
          hn::Gt(hn::Set(di16, static_cast<std::int16_t>(first)), hn::Iota(di16, kV * i));
      v[i] = hn::Or(t.box[i], hn::VecFromMask(d16, hn::RebindMask(d16, out_of_range)));
    } else {
      v[i] = t.box[i];
    }
  }
  general_fold_right(t, x, v);
  s.winner_lane[x] = -1;
  if (kMasked && first >= kLanes) {
    s.state[x] = kUnreachable;
    return;
  }
  V16 m = v[0];
  for (int i = 1; i < NV; ++i) m = hn::Min(m, v[i]);
  const int c0 = min_lane(m);
  const int best = general_winner<kLanes>(v, c0);
  if (t.tex < s.texture_min) {
    s.state[x] = kLowTexture;
    return;
  }
  if (s.uniqueness > 0) {
    const int second = general_second<kLanes>(v, best);
    if (second * 100 <= c0 * (100 + s.uniqueness)) {
      s.state[x] = kNotUnique;
      return;
    }
  }
  s.state[x] = kCandidate;
  s.winner_lane[x] = best;
}

// The general scan for kLanes lanes: the box costs, the right view's running minima and the
// winner search stay in registers; the right view's window slides down one lane per pixel.
template <int kLanes>
void scan_row_general(const RowScan& s) {
  GeneralScan<kLanes> t(s);
  general_begin(t);
  // Pixels x < x_full have out-of-range lanes (first_lane(x) > 0) that must be masked.
  const int x_full = kLanes > s.num ? s.width : std::min(s.width, std::max(0, s.d_top + 1));
  for (int x = 0; x < x_full; ++x) general_pixel<true>(t, x);
  for (int x = x_full; x < s.width; ++x) general_pixel<false>(t, x);
  // Right pixels not yet emitted: lane k now holds right pixel width - d_top + k.
  for (int i = 0; i < GeneralScan<kLanes>::NV; ++i) {
    hn::StoreU(t.win[i], D16(), s.right_min + s.width + kV * i);
  }
}

template <std::size_t... kGroups>
constexpr auto general_scan_table(std::index_sequence<kGroups...>) {
  return std::array{&scan_row_general<32 * static_cast<int>(kGroups + 1)>...};
}

void ScanRow(const RowScan& scan) {
  static constexpr auto kScans = general_scan_table(std::make_index_sequence<kMaxSimdLanes / 32>{});
  kScans[static_cast<std::size_t>(scan.lanes / 32 - 1)](scan);
}

// ---------------------------------------------------------------------------------------------
// The fast row: 32 or 64 lanes, TAGGED box costs 2^kBits * cost + lane / 8, so that the 8-way
// fold of the lanes (lane = 8 m + j, position j of every 128-bit block) and one horizontal
// minimum give the best cost and the FIRST lane that reaches it: the order of (tagged value,
// j) is the order of (cost, lane). Costs are kept in the storage order of fast_lane_position.

// Column sums += 2^bits |l - r| of one row (the fast row's slide with no outgoing row).
void AddSadRowFast(std::uint16_t* column_sums, const std::uint8_t* left_row,
                   const std::uint8_t* right_row, int cols, int lanes, int bits) {
  const D16 d16;
  const D8 d8;
  const V8 zero = hn::Zero(d8);
  for (int c = 0; c < cols; ++c) {
    std::uint16_t* col =
        column_sums + static_cast<std::size_t>(c) * static_cast<std::size_t>(lanes);
    const V8 l = hn::Set(d8, left_row[c]);
    for (int i = 0; i < lanes; i += 2 * kV) {
      const V8 a = abs_diff_u8(l, hn::LoadU(d8, right_row + c + i));
      const V16 lo = hn::ShiftLeftSame(hn::ZipLower(d16, a, zero), bits);
      const V16 hi = hn::ShiftLeftSame(hn::ZipUpper(d16, a, zero), bits);
      hn::StoreU(hn::Add(hn::LoadU(d16, col + i), lo), d16, col + i);
      hn::StoreU(hn::Add(hn::LoadU(d16, col + i + kV), hi), d16, col + i + kV);
    }
  }
}

// How the fast row gets its column sums: already slid (census, first row), or slid by the
// row itself from the SAD rows, with per-pixel costs below 128 (kSadSmall: the x-Sobel
// prefilter) or up to 255 (kSad).
enum class Slide { kNone, kSadSmall, kSad };

// The fast scan's state along one row. The structs' fields are copied in, as locals: the
// per-pixel stores could alias the structs' fields, which would make the compiler reload them
// for every pixel. kLr: the left-right check off (0), on with lr_max_diff 1 (1, the default) or
// on with another tolerance (2); kUnique: the uniqueness check is on (its second minimum).
// Template arguments, so that a scan without the left-right check keeps no right-view window
// in registers and no scan tests the options per pixel.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
struct FastScan {
  static constexpr int L = kLanes;
  static constexpr int kLrMode = kLr;
  static constexpr int NV = kLanes / kV;
  static constexpr int kBits = kLanes == 32 ? 2 : 3;
  static constexpr int kSlot = fast_ring_slot(L);  // guard lanes, the lanes, guard lanes
  // User-provided, so that it is compiled with the target's attributes: GCC compiles an
  // implicit one without them and then cannot inline the vectors' constructors on NEON.
  FastScan() {}  // NOLINT(modernize-use-equals-default)
  int w, r, num, d_top, lr, lane_floor;
  std::uint16_t* cs;
  std::uint16_t* right_min;
  std::uint16_t* ring;
  std::uint16_t* fields;
  const std::uint16_t* near_masks;
  const std::int16_t* position;
  const std::uint8_t* left_new;
  const std::uint8_t* left_old;
  const std::uint8_t* right_new;
  const std::uint8_t* right_old;
  hn::Vec<DI16> lane_of[NV];  // the lane at each storage position
  V16 box[NV], win[NV];
};

// Position 0 of pixel x's slot. Pixels -lr..-1 and w..w+lr-1 read as masked.
template <class Scan>
HWY_INLINE std::uint16_t* fast_ring_at(const Scan& t, int x) {
  return t.ring + static_cast<std::size_t>(x & (kRingSlots - 1)) * Scan::kSlot + kRingGuard;
}

// 2^kBits (|l - r| of the new row - |l - r| of the old one) for the lanes of a byte vector,
// widened to the storage order by interleaving with zeros (the low and the high uint16
// vector). Costs below 128: the difference fits int8, and shifting it from the high byte
// down scales and sign-extends it in one step.
// (Not a std::pair: its constructors, compiled without the target's attributes, cannot inline
// the vectors' on NEON.)
struct LowHigh {
  V16 lo, hi;
};

template <int kBits, Slide kSlide>
HWY_INLINE LowHigh fast_scaled_change(V8 a_new, V8 a_old) {
  const D16 d16;
  const V8 zero = hn::Zero(D8());
  if constexpr (kSlide == Slide::kSadSmall) {
    const DI16 di16;
    const V8 change = hn::Sub(a_new, a_old);
    const auto lo = hn::ShiftRight<8 - kBits>(hn::BitCast(di16, hn::ZipLower(d16, zero, change)));
    const auto hi = hn::ShiftRight<8 - kBits>(hn::BitCast(di16, hn::ZipUpper(d16, zero, change)));
    return {hn::BitCast(d16, lo), hn::BitCast(d16, hi)};
  } else {
    const V16 lo = hn::Sub(hn::ZipLower(d16, a_new, zero), hn::ZipLower(d16, a_old, zero));
    const V16 hi = hn::Sub(hn::ZipUpper(d16, a_new, zero), hn::ZipUpper(d16, a_old, zero));
    return {hn::ShiftLeft<kBits>(lo), hn::ShiftLeft<kBits>(hi)};
  }
}

// Column c slid down one row (kSlide), in registers and stored back.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_column(const FastScan<kLanes, kSlide, kLr, kUnique>& t, int c, V16* out) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  std::uint16_t* col = t.cs + static_cast<std::size_t>(c) * kLanes;
  if constexpr (kSlide == Slide::kNone) {
    for (int i = 0; i < Scan::NV; ++i) out[i] = hn::LoadU(d16, col + kV * i);
  } else {
    const D8 d8;
    const V8 left_new = hn::Set(d8, t.left_new[c]), left_old = hn::Set(d8, t.left_old[c]);
    for (int i = 0; i < Scan::NV; i += 2) {
      const V8 a_new = abs_diff_u8(left_new, hn::LoadU(d8, t.right_new + c + kV * i));
      const V8 a_old = abs_diff_u8(left_old, hn::LoadU(d8, t.right_old + c + kV * i));
      const auto [lo, hi] = fast_scaled_change<Scan::kBits, kSlide>(a_new, a_old);
      const V16 s0 = hn::Add(hn::LoadU(d16, col + kV * i), lo);
      const V16 s1 = hn::Add(hn::LoadU(d16, col + kV * (i + 1)), hi);
      hn::StoreU(s0, d16, col + kV * i);
      hn::StoreU(s1, d16, col + kV * (i + 1));
      out[i] = s0;
      out[i + 1] = s1;
    }
  }
}

// The row's state from the structs.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_copy_in(FastScan<kLanes, kSlide, kLr, kUnique>& t, const RowScan& s,
                             const FastRow& f) {
  t.w = s.width;
  t.r = s.radius;
  t.num = s.num;
  t.d_top = s.d_top;
  t.lr = f.lr_max_diff;
  t.cs = s.column_sums;
  t.right_min = s.right_min;
  t.ring = f.ring;
  t.fields = f.fields;
  t.near_masks = f.near_masks;
  t.position = f.position;
  t.left_new = s.left_new;
  t.left_old = s.left_old;
  t.right_new = s.right_new;
  t.right_old = s.right_old;
  t.lane_floor = kLanes - t.num;
}

// The row's state, the guard slots of pixels -kFastMaxLrDiff..-1, and the tagged box of pixel
// 0's window (columns 0 .. 2r).
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_begin(FastScan<kLanes, kSlide, kLr, kUnique>& t, const RowScan& s,
                           const FastRow& f) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  const DI16 di16;
  fast_copy_in(t, s, f);
  for (int x = -kFastMaxLrDiff; x < 0; ++x) {
    for (int i = 0; i < Scan::NV; ++i)
      hn::StoreU(hn::Set(d16, kMaskedCost), d16, fast_ring_at(t, x) + kV * i);
  }
  for (int i = 0; i < Scan::NV; ++i) {
    HWY_ALIGN std::int16_t lanes_here[kV];
    for (int k = 0; k < kV; ++k) {
      lanes_here[k] = static_cast<std::int16_t>(fast_lane_position(kV * i + k, kV));
    }
    t.lane_of[i] = hn::Load(di16, lanes_here);
    // The tag lane / 8 in the low bits: the costs themselves are stored times 2^kBits.
    t.box[i] = hn::BitCast(d16, hn::ShiftRight<3>(t.lane_of[i]));
    t.win[i] = hn::Set(d16, kMaskedCost);
  }
  for (int c = 0; c <= 2 * t.r; ++c) {
    V16 col[Scan::NV];
    fast_column(t, c, col);
    for (int i = 0; i < Scan::NV; ++i) t.box[i] = hn::Add(t.box[i], col[i]);
  }
}

// The winner of pixel x: the tagged cost and the first lane from one fold and one horizontal
// minimum.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_store_winner(const FastScan<kLanes, kSlide, kLr, kUnique>& t, int x,
                                  const V16* v) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16x8 d8l;
  V16 m = v[0];
  for (int i = 1; i < Scan::NV; ++i) m = hn::Min(m, v[i]);
  const auto fold = fold_to_128(m);
  const auto least = hn::MinOfLanes(d8l, fold);
  // Some position holds the minimum: no test for none.
  const auto at_least = hn::Eq(fold, least);
#if HWY_ARCH_X86 && HWY_TARGET > HWY_AVX3
  // Masks are vectors here: the compare's byte mask (two bits a lane) needs no pack to 8 bits,
  // nor the zero vector that the pack keeps in a register.
  const hn::Repartition<std::uint8_t, D16x8> d8b;
  const auto j = static_cast<std::uint32_t>(hn::FindKnownFirstTrue(
                     d8b, hn::MaskFromVec(hn::BitCast(d8b, hn::VecFromMask(d8l, at_least))))) >>
                 1;
#else
  const auto j = static_cast<std::uint32_t>(hn::FindKnownFirstTrue(d8l, at_least));
#endif
  const std::uint32_t tagged = hn::GetLane(least);
  t.fields[kFieldCost * kFieldStride + x] = static_cast<std::uint16_t>(tagged);
  t.fields[kFieldBest * kFieldStride + x] =
      static_cast<std::uint16_t>(((tagged & ((1U << Scan::kBits) - 1U)) << 3) | j);
}

// Right view: lane k holds right pixel x - d_top + k; lane 0 (position 0) is complete after
// this x. The window then moves down one lane, in storage order: each block of the low vector
// of a group takes the first lane of the high vector's same block, each block of the high
// vector that of the next block in lane order (next_lanes).
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_fold_right(FastScan<kLanes, kSlide, kLr, kUnique>& t, int x, const V16* v) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  for (int i = 0; i < Scan::NV; ++i) t.win[i] = hn::Min(t.win[i], v[i]);
  t.right_min[x] = hn::GetLane(t.win[0]);
  for (int g = 0; g < Scan::NV / 2; ++g) {
    const V16 a = t.win[2 * g], b = t.win[2 * g + 1];
    const V16 next = 2 * g + 2 < Scan::NV ? t.win[2 * g + 2] : hn::Set(d16, kMaskedCost);
    t.win[2 * g] = hn::CombineShiftRightBytes<2>(d16, b, a);
    t.win[2 * g + 1] = hn::CombineShiftRightBytes<2>(d16, next_lanes(a, next), b);
  }
}

// Stage 1, pixel x: slide its new column, update the box, store the (masked) box costs in the
// ring, find the winner, and fold the costs into the right view's minima.
template <bool kMasked, int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_scan_pixel(FastScan<kLanes, kSlide, kLr, kUnique>& t, int x) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  const DI16 di16;
  if (x > 0) {
    V16 add[Scan::NV];
    fast_column(t, x + 2 * t.r, add);
    const std::uint16_t* sub = t.cs + static_cast<std::size_t>(x - 1) * kLanes;
    for (int i = 0; i < Scan::NV; ++i) {
      t.box[i] = hn::Sub(hn::Add(t.box[i], add[i]), hn::LoadU(d16, sub + kV * i));
    }
  }
  V16 v[Scan::NV];
  if constexpr (kMasked) {  // lanes below first_lane(x) are out of range
    const int lane_floor = t.lane_floor;
    const int first = std::min(std::max(lane_floor, t.d_top - x), kLanes);
    const auto vfirst = hn::Set(di16, static_cast<std::int16_t>(first));
    for (int i = 0; i < Scan::NV; ++i) {
      const auto out_of_range = hn::RebindMask(d16, hn::Gt(vfirst, t.lane_of[i]));
      v[i] = hn::Or(t.box[i], hn::VecFromMask(d16, out_of_range));
    }
  } else {
    for (int i = 0; i < Scan::NV; ++i) v[i] = t.box[i];
  }
  std::uint16_t* slot = fast_ring_at(t, x);
  for (int i = 0; i < Scan::NV; ++i) hn::StoreU(v[i], d16, slot + kV * i);
  fast_store_winner(t, x, v);
  if constexpr (kLr) fast_fold_right(t, x, v);
}

// The least cost on the right pixel q - d's diagonal: pixel q + j at lane best - j, |j| <= lr.
// at_minus, at_plus: the positions of lanes best + 1 and best - 1.
template <class Scan>
HWY_INLINE std::uint16_t fast_diagonal(const Scan& t, int q, int best, std::uint16_t cost,
                                       int at_minus, int at_plus) {
  std::uint16_t diag = cost;
  if constexpr (Scan::kLrMode == 1) {  // the default: the positions are the fit's
    const std::uint16_t left = fast_ring_at(t, q - 1)[at_minus];
    const std::uint16_t right = fast_ring_at(t, q + 1)[at_plus];
    return std::min(diag, std::min(right, left));
  } else {
    for (int j = 1; j <= t.lr; ++j) {
      const std::uint16_t right = fast_ring_at(t, q + j)[t.position[best - j]];
      const std::uint16_t left = fast_ring_at(t, q - j)[t.position[best + j]];
      diag = std::min(diag, std::min(right, left));
    }
    return diag;
  }
}

// Stage 2, pixel q = x - kLag: what the checks and the fit need around the winner, read back
// from the ring and the fields. Kept apart from stage 1 so that its dependency chain (winner
// -> mask -> second minimum) starts from stored inputs and overlaps the next pixels' stage 1,
// and so that its 16-bit loads find the vector ring stores in the cache (a load from a store
// still in flight that it does not match cannot be forwarded and stalls). Masked lanes and
// the guard lanes and slots read as 0xFFFF, above every cost, so the reads need no range
// checks: a minimum ignores them and the fit is not made there.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_check_pixel(const FastScan<kLanes, kSlide, kLr, kUnique>& t, int q) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  const std::uint16_t* slot = fast_ring_at(t, q);
  std::uint16_t* fq = t.fields + q;
  const int best = fq[kFieldBest * kFieldStride];
  const std::uint16_t cost = fq[kFieldCost * kFieldStride];
  // The fit's positions, read once before the stores below (which could alias the table).
  const int at_minus = t.position[best + 1], at_plus = t.position[best - 1];
  if constexpr (kUnique) {
    // The least cost of the lanes further than 1 from the winner (all masked: 0xFFFF).
    const std::uint16_t* near = t.near_masks + static_cast<std::size_t>(best) * kLanes;
    V16 m = hn::Or(hn::LoadU(d16, slot), hn::LoadU(d16, near));
    for (int i = 1; i < Scan::NV; ++i) {
      m = hn::Min(m, hn::Or(hn::LoadU(d16, slot + kV * i), hn::LoadU(d16, near + kV * i)));
    }
    fq[kFieldSecond * kFieldStride] = static_cast<std::uint16_t>(min_lane(m));
  }
  fq[kFieldMinus * kFieldStride] = slot[at_minus];
  fq[kFieldPlus * kFieldStride] = slot[at_plus];
  if constexpr (kLr)
    fq[kFieldDiag * kFieldStride] = fast_diagonal(t, q, best, cost, at_minus, at_plus);
}

// The last kLag pixels' stage 2, then the right view's last minima.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
HWY_INLINE void fast_end(const FastScan<kLanes, kSlide, kLr, kUnique>& t) {
  using Scan = FastScan<kLanes, kSlide, kLr, kUnique>;
  const D16 d16;
  const int w = t.w;
  // The guard slots of pixels w.. overwrite pixels w - kRingSlots.., which only the pixels
  // before q_guard still read.
  const int q_guard = std::max(0, w - kFastMaxLrDiff);
  for (int q = std::max(0, w - kLag); q < q_guard; ++q) fast_check_pixel(t, q);
  for (int x = w; x < w + kFastMaxLrDiff; ++x) {
    for (int i = 0; i < Scan::NV; ++i)
      hn::StoreU(hn::Set(d16, kMaskedCost), d16, fast_ring_at(t, x) + kV * i);
  }
  for (int q = std::max(q_guard, w - kLag); q < w; ++q) fast_check_pixel(t, q);
  if constexpr (kLr) {  // right pixels w - d_top + k, k < L: back to lane order
    HWY_ALIGN std::uint16_t rest[kLanes];
    for (int i = 0; i < Scan::NV; ++i) hn::Store(t.win[i], d16, rest + kV * i);
    for (int k = 0; k < kLanes; ++k) t.right_min[w + k] = rest[t.position[k]];
  }
}

// The scan of one row: per pixel the fields of FastField.
template <int kLanes, Slide kSlide, int kLr, bool kUnique>
void scan_row_fast(const RowScan& s, const FastRow& f) {
  FastScan<kLanes, kSlide, kLr, kUnique> t;
  fast_begin(t, s, f);
  const int w = t.w, num = t.num, d_top = t.d_top;
  const int x_full = kLanes > num ? w : std::min(w, std::max(0, d_top + 1));
  for (int x = 0; x < x_full; ++x) {
    fast_scan_pixel<true>(t, x);
    if (x >= kLag) fast_check_pixel(t, x - kLag);
  }
  // The unmasked pixels (most of the row) in two loops, so that the long one tests nothing.
  const int x_check = std::min(w, std::max(x_full, kLag));
  for (int x = x_full; x < x_check; ++x) {
    fast_scan_pixel<false>(t, x);
    if (x >= kLag) fast_check_pixel(t, x - kLag);
  }
  for (int x = x_check; x < w; ++x) {
    fast_scan_pixel<false>(t, x);
    fast_check_pixel(t, x - kLag);
  }
  fast_end(t);
}

// ---------------------------------------------------------------------------------------------
// The fast finish: the checks and the fit, a vector of pixels at a time in 32-bit lanes.

// Which checks are on, so that each combination is its own loop.
constexpr int kFinishTexture = 1, kFinishUnique = 2, kFinishLr = 4, kFinishSubpixel = 8;

using D32 = hn::CappedTag<std::int32_t, 8>;
using DU32 = hn::RebindToUnsigned<D32>;
using DF32 = hn::Rebind<float, D32>;
using DU16h = hn::Rebind<std::uint16_t, D32>;
using V32 = hn::Vec<D32>;
using M32 = hn::Mask<D32>;

// The finish's inputs, as locals (see FastScan).
struct FastFinish {
  int w, lanes, d_top, lane_floor, min_d, uniqueness, block;
  bool census;
  const std::uint16_t* fields;
  const std::uint16_t* right_min;
  const std::uint32_t* texture_columns;
  std::uint32_t texture_min;
  float d_min, d_max;
};

// The rejections and the valid pixels, a vector of counts each.
struct FastFinishCounts {
  V32 unreach, tex, uniq, lr, depth, valid;
};

// Field `which` of the pixels from p, widened to 32 bits.
HWY_INLINE V32 fast_field(const std::uint16_t* fields, int which, int p) {
  return hn::BitCast(D32(),
                     hn::PromoteTo(DU32(), hn::LoadU(DU16h(), fields + which * kFieldStride + p)));
}

template <int kBits>
HWY_INLINE V32 fast_cost(const std::uint16_t* fields, int which, int p) {
  return hn::ShiftRight<kBits>(fast_field(fields, which, p));
}

// The window sums of texture columns p .. p + 2r for the pixels from p (below 2^31: a signed
// compare).
HWY_INLINE V32 fast_texture(const FastFinish& t, int p) {
  const D32 d32;
  const DU32 du32;
  V32 tex = hn::BitCast(d32, hn::LoadU(du32, t.texture_columns + p));
  for (int c = 1; c < t.block; ++c) {
    tex = hn::Add(tex, hn::BitCast(d32, hn::LoadU(du32, t.texture_columns + p + c)));
  }
  return tex;
}

// Subpixel offsets of the pixels `pix`: both neighbours in range and a nonzero cost, as in
// finish_row.
template <int kBits>
HWY_INLINE hn::Vec<DF32> fast_subpixel(const FastFinish& t, int p, V32 pix, V32 best, V32 c0) {
  const D32 d32;
  const DF32 df;
  const V32 zero = hn::Zero(d32), one = hn::Set(d32, 1);
  const V32 cm = fast_cost<kBits>(t.fields, kFieldMinus, p);
  const V32 cp = fast_cost<kBits>(t.fields, kFieldPlus, p);
  const V32 first = hn::Max(hn::Set(d32, t.lane_floor), hn::Sub(hn::Set(d32, t.d_top), pix));
  M32 fit = hn::And(hn::Gt(c0, zero), hn::Gt(hn::Set(d32, t.lanes - 1), best));
  fit = hn::AndNot(hn::Gt(first, hn::Sub(best, one)), fit);
  const V32 denom =
      t.census ? hn::Sub(hn::Add(cm, cp), hn::Add(c0, c0)) : hn::Sub(hn::Max(cm, cp), c0);
  fit = hn::And(fit, hn::Gt(denom, zero));
  const V32 numer = hn::IfThenElseZero(fit, hn::Sub(cm, cp));
  const V32 den = hn::IfThenElse(fit, hn::Add(denom, denom), one);
  return hn::Div(hn::ConvertTo(df, numer), hn::ConvertTo(df, den));
}

// second * 100 <= c0 * (100 + u), where there is a second.
template <int kBits>
HWY_INLINE M32 fast_not_unique(const FastFinish& t, int p, V32 c0) {
  const D32 d32;
  const V32 second = fast_field(t.fields, kFieldSecond, p);
  const M32 some = hn::Not(hn::Eq(second, hn::Set(d32, 0xFFFF)));
  const V32 lhs = hn::Mul(hn::ShiftRight<kBits>(second), hn::Set(d32, 100));
  const V32 rhs = hn::Mul(c0, hn::Set(d32, 100 + t.uniqueness));
  return hn::AndNot(hn::Gt(lhs, rhs), some);
}

// The diagonal's least cost above the right pixel's best: right_min[p + best] (uint16, read as
// the low half of a 32-bit gather at its byte offset; right_min has one element of slack).
template <int kBits>
HWY_INLINE M32 fast_lr_fails(const FastFinish& t, int p, V32 pix, V32 best) {
  const D32 d32;
  const V32 offsets = hn::ShiftLeft<1>(hn::Add(pix, best));
  const V32 right =
      hn::GatherOffset(d32, reinterpret_cast<const std::int32_t*>(t.right_min), offsets);
  const V32 right_best = hn::ShiftRight<kBits>(hn::And(right, hn::Set(d32, 0xFFFF)));
  return hn::Gt(fast_cost<kBits>(t.fields, kFieldDiag, p), right_best);
}

// Pixels p .. p + Lanes - 1 (`pix`, their column numbers): each counts once, under its first
// failing check; the disparity where none fails.
template <int kBits, int kChecks>
HWY_INLINE void fast_finish_vector(const FastFinish& t, int p, V32 pix, float* out,
                                   FastFinishCounts& n) {
  const D32 d32;
  const DF32 df;
  const V32 best = fast_field(t.fields, kFieldBest, p);
  const V32 c0 = fast_cost<kBits>(t.fields, kFieldCost, p);
  const M32 unreach = hn::Gt(hn::Set(d32, t.min_d), pix);
  M32 open = hn::Not(unreach);
  const M32 none = hn::MaskFromVec(hn::Zero(d32));
  M32 low_tex = none, not_unique = none, lr_fail = none;
  if constexpr ((kChecks & kFinishTexture) != 0) {
    const V32 texture_min =
        hn::Set(d32, static_cast<std::int32_t>(std::min<std::uint32_t>(t.texture_min, 0x7FFFFFFF)));
    low_tex = hn::And(open, hn::Gt(texture_min, fast_texture(t, p)));
    open = hn::AndNot(low_tex, open);
  }
  if constexpr ((kChecks & kFinishUnique) != 0) {
    not_unique = hn::And(open, fast_not_unique<kBits>(t, p, c0));
    open = hn::AndNot(not_unique, open);
  }
  if constexpr ((kChecks & kFinishLr) != 0) {
    lr_fail = hn::And(open, fast_lr_fails<kBits>(t, p, pix, best));
    open = hn::AndNot(lr_fail, open);
  }
  auto delta = hn::Zero(df);
  if constexpr ((kChecks & kFinishSubpixel) != 0) delta = fast_subpixel<kBits>(t, p, pix, best, c0);
  const auto ds = hn::Add(hn::ConvertTo(df, hn::Sub(hn::Set(d32, t.d_top), best)), delta);
  const auto out_of_range =
      hn::Or(hn::Lt(ds, hn::Set(df, t.d_min)), hn::Gt(ds, hn::Set(df, t.d_max)));
  const M32 depth_fail = hn::And(open, hn::RebindMask(d32, out_of_range));
  open = hn::AndNot(depth_fail, open);
  hn::StoreU(hn::IfThenElse(hn::RebindMask(df, open), ds, hn::Set(df, kNoDisparity)), df, out + p);
  n.unreach = hn::Sub(n.unreach, hn::VecFromMask(d32, unreach));
  n.tex = hn::Sub(n.tex, hn::VecFromMask(d32, low_tex));
  n.uniq = hn::Sub(n.uniq, hn::VecFromMask(d32, not_unique));
  n.lr = hn::Sub(n.lr, hn::VecFromMask(d32, lr_fail));
  n.depth = hn::Sub(n.depth, hn::VecFromMask(d32, depth_fail));
  n.valid = hn::Sub(n.valid, hn::VecFromMask(d32, open));
}

inline void add_fast_finish_counts(const FastFinishCounts& n, MatchStats& stats) {
  const auto sum = [](V32 v) {
    return static_cast<std::size_t>(hn::GetLane(hn::SumOfLanes(D32(), v)));
  };
  stats.unreachable += sum(n.unreach);
  stats.rejected_texture += sum(n.tex);
  stats.rejected_uniqueness += sum(n.uniq);
  stats.rejected_lr += sum(n.lr);
  stats.rejected_depth += sum(n.depth);
  stats.valid += sum(n.valid);
}

// The subpixel offset of pixel p alone, with fast_subpixel's arithmetic.
template <int kBits>
inline float fast_subpixel1(const FastFinish& t, int p, int best, int c0) {
  const std::uint16_t* fp = t.fields + p;
  const int lane_floor = t.lane_floor;
  const int first = std::max(lane_floor, t.d_top - p);
  if (c0 <= 0 || best + 1 >= t.lanes || best - 1 < first) return 0.0F;
  const int cm = fp[kFieldMinus * kFieldStride] >> kBits;
  const int cp = fp[kFieldPlus * kFieldStride] >> kBits;
  const int denom = t.census ? cm + cp - 2 * c0 : std::max(cm, cp) - c0;
  return denom > 0 ? static_cast<float>(cm - cp) / static_cast<float>(2 * denom) : 0.0F;
}

// Pixel p alone (the last width % Lanes pixels), with the same checks and arithmetic.
template <int kBits, int kChecks>
inline void fast_finish1(const FastFinish& t, int p, float* out, MatchStats& stats) {
  out[p] = kNoDisparity;
  const std::uint16_t* fp = t.fields + p;
  if (p < t.min_d) {
    ++stats.unreachable;
    return;
  }
  if constexpr ((kChecks & kFinishTexture) != 0) {
    std::uint32_t tex = 0;
    for (int c = 0; c < t.block; ++c) tex += t.texture_columns[p + c];
    if (tex < t.texture_min) {
      ++stats.rejected_texture;
      return;
    }
  }
  const int best = fp[kFieldBest * kFieldStride], c0 = fp[kFieldCost * kFieldStride] >> kBits;
  const int second = fp[kFieldSecond * kFieldStride];
  if (t.uniqueness > 0 && second != 0xFFFF &&
      (second >> kBits) * 100 <= c0 * (100 + t.uniqueness)) {
    ++stats.rejected_uniqueness;
    return;
  }
  if ((kChecks & kFinishLr) != 0 &&
      (fp[kFieldDiag * kFieldStride] >> kBits) > (t.right_min[p + best] >> kBits)) {
    ++stats.rejected_lr;
    return;
  }
  const float delta =
      (kChecks & kFinishSubpixel) != 0 ? fast_subpixel1<kBits>(t, p, best, c0) : 0.0F;
  const float ds = static_cast<float>(t.d_top - best) + delta;
  if (ds < t.d_min || ds > t.d_max) {
    ++stats.rejected_depth;
    return;
  }
  out[p] = ds;
  ++stats.valid;
}

// Disparities of one row from the fields scan_row_fast left: the checks in finish_row's
// order (unreachable, texture, uniqueness, left-right, depth range) and the subpixel fit, with
// finish_row's arithmetic (float division included): the same bits. The texture sum of a
// window is added up here from the column sums.
template <int kBits, int kChecks>
void finish_row_fast(const RowScan& s, const FastRow& f, float* out, MatchStats& stats) {
  const FastFinish t{.w = s.width,
                     .lanes = s.lanes,
                     .d_top = s.d_top,
                     .lane_floor = s.lanes - s.num,
                     .min_d = s.d_top - s.lanes + 1,
                     .uniqueness = (kChecks & kFinishUnique) != 0 ? s.uniqueness : 0,
                     .block = 2 * s.radius + 1,
                     .census = f.census,
                     .fields = f.fields,
                     .right_min = s.right_min,
                     .texture_columns = s.texture_columns,
                     .texture_min = s.texture_min,
                     .d_min = f.d_min,
                     .d_max = f.d_max};
  const D32 d32;
  const V32 zero = hn::Zero(d32);
  FastFinishCounts n{zero, zero, zero, zero, zero, zero};
  const int step = static_cast<int>(hn::Lanes(d32));
  // The column numbers stepped by a vector add: Iota(d32, p) inside the loop writes its lanes
  // to the stack and loads them back as one vector, a store-forwarding stall on every step
  // (29 % of this loop's samples on AVX2, perf annotate).
  const V32 step_v = hn::Set(d32, step);
  V32 pix = hn::Iota(d32, 0);
  int p = 0;
  for (; p + step <= t.w; p += step, pix = hn::Add(pix, step_v)) {
    fast_finish_vector<kBits, kChecks>(t, p, pix, out, n);
  }
  add_fast_finish_counts(n, stats);
  for (; p < t.w; ++p) fast_finish1<kBits, kChecks>(t, p, out, stats);
}

// The scan of one row with the column slide it needs.
template <int kLanes, int kLr, bool kUnique>
void scan_row_fast_slide(const RowScan& scan, const FastRow& fast) {
  if (scan.left_new == nullptr) {
    scan_row_fast<kLanes, Slide::kNone, kLr, kUnique>(scan, fast);
  } else if (fast.small_costs) {
    scan_row_fast<kLanes, Slide::kSadSmall, kLr, kUnique>(scan, fast);
  } else {
    scan_row_fast<kLanes, Slide::kSad, kLr, kUnique>(scan, fast);
  }
}

// ... and with the checks' template arguments.
template <int kLanes, bool kUnique>
void scan_row_fast_checks(const RowScan& scan, const FastRow& fast) {
  if (fast.lr_max_diff == 1) {
    scan_row_fast_slide<kLanes, 1, kUnique>(scan, fast);
  } else if (fast.lr_max_diff >= 0) {
    scan_row_fast_slide<kLanes, 2, kUnique>(scan, fast);
  } else {
    scan_row_fast_slide<kLanes, 0, kUnique>(scan, fast);
  }
}

template <int kBits, std::size_t... kChecks>
constexpr auto finish_row_table(std::index_sequence<kChecks...>) {
  return std::array{&finish_row_fast<kBits, static_cast<int>(kChecks)>...};
}

template <int kLanes>
void match_row_fast_lanes(const RowScan& scan, const FastRow& fast, float* out, MatchStats& stats) {
  constexpr int kBits = FastScan<kLanes, Slide::kNone, 0, false>::kBits;
  static constexpr auto kFinishes = finish_row_table<kBits>(std::make_index_sequence<16>{});
  if (scan.uniqueness > 0) {
    scan_row_fast_checks<kLanes, true>(scan, fast);
  } else {
    scan_row_fast_checks<kLanes, false>(scan, fast);
  }
  const int checks =
      (fast.texture ? kFinishTexture : 0) | (scan.uniqueness > 0 ? kFinishUnique : 0) |
      (fast.lr_max_diff >= 0 ? kFinishLr : 0) | (fast.subpixel ? kFinishSubpixel : 0);
  kFinishes[static_cast<std::size_t>(checks)](scan, fast, out, stats);
}

void MatchRowFast(const RowScan& scan, const FastRow& fast, float* out, MatchStats& stats) {
  if (scan.lanes == 32) {
    match_row_fast_lanes<32>(scan, fast, out, stats);
  } else {
    match_row_fast_lanes<64>(scan, fast, out, stats);
  }
}

// ---------------------------------------------------------------------------------------------
// Census signatures: a vector of uint16 pixels at a time (the bytes widened to int16, whose
// compare every target has), each signature built as up to three 16-bit words by shifting in
// one comparison per neighbour (as the reference shifts its 64-bit signature), then the words
// widened and joined to the 64-bit signatures.

// Word w (bits 16 w .. 16 w + 15) of the signatures of pixels i .. i + Lanes - 1: the
// neighbours j whose bit nb - 1 - j falls in it, the first of them in its highest bit.
HWY_INLINE V16 census_word(const std::uint8_t* const* neighbour, int nb, int w, int i,
                           hn::Vec<DI16> centre) {
  const D16 d16;
  const DI16 di16;
  const hn::Rebind<std::uint8_t, DI16> d8;
  V16 word = hn::Zero(d16);
  for (int j = std::max(0, nb - 16 * (w + 1)); j < nb - 16 * w; ++j) {
    const auto value = hn::PromoteTo(di16, hn::LoadU(d8, neighbour[j] + i));
    // VecFromMask is all ones (-1) where the neighbour is darker: subtracting it adds the bit.
    word = hn::Sub(hn::ShiftLeft<1>(word),
                   hn::BitCast(d16, hn::VecFromMask(di16, hn::Lt(value, centre))));
  }
  return word;
}

void CensusSignatures(const std::uint8_t* const* rows, int cr, int count, std::uint64_t* out) {
  const D16 d16;
  const DI16 di16;
  const hn::Rebind<std::uint8_t, DI16> d8;
  const hn::Half<D16> dh16;
  const hn::Repartition<std::uint32_t, D16> d32;
  const hn::Half<decltype(d32)> dh32;
  const hn::Repartition<std::uint64_t, D16> d64;
  const int side = 2 * cr + 1, nb = side * side - 1;
  std::array<const std::uint8_t*, 48> neighbour{};  // census_window <= 7 (validate): 48 bits
  for (int j = 0, k = 0; k < side * side; ++k) {
    if (k == nb / 2) continue;  // the centre
    neighbour[static_cast<std::size_t>(j++)] = rows[k / side] + (k % side - cr);
  }
  const int n = static_cast<int>(hn::Lanes(d16));
  const int n32 = static_cast<int>(hn::Lanes(d32)), n64 = static_cast<int>(hn::Lanes(d64));
  int i = 0;
  for (; i + n <= count; i += n) {
    const auto centre = hn::PromoteTo(di16, hn::LoadU(d8, rows[cr] + i));
    const V16 w0 = census_word(neighbour.data(), nb, 0, i, centre);
    const V16 w1 = nb > 16 ? census_word(neighbour.data(), nb, 1, i, centre) : hn::Zero(d16);
    const V16 w2 = nb > 32 ? census_word(neighbour.data(), nb, 2, i, centre) : hn::Zero(d16);
    for (int h = 0; h < 2; ++h) {  // the two halves of the pixels: bits 0..31 and 32..47
      const auto half = [&](V16 v) {
        return h == 0 ? hn::LowerHalf(dh16, v) : hn::UpperHalf(dh16, v);
      };
      const auto low =
          hn::Or(hn::PromoteTo(d32, half(w0)), hn::ShiftLeft<16>(hn::PromoteTo(d32, half(w1))));
      const auto high = hn::PromoteTo(d32, half(w2));
      std::uint64_t* o = out + i + h * n32;
      hn::StoreU(hn::Or(hn::PromoteTo(d64, hn::LowerHalf(dh32, low)),
                        hn::ShiftLeft<32>(hn::PromoteTo(d64, hn::LowerHalf(dh32, high)))),
                 d64, o);
      hn::StoreU(hn::Or(hn::PromoteTo(d64, hn::UpperHalf(dh32, low)),
                        hn::ShiftLeft<32>(hn::PromoteTo(d64, hn::UpperHalf(dh32, high)))),
                 d64, o + n64);
    }
  }
  if (i == count) return;
  std::array<const std::uint8_t*, 7> tail{};  // the last count % n pixels: the reference
  for (int k = 0; k < side; ++k) tail[static_cast<std::size_t>(k)] = rows[k] + i;
  census_signatures_reference(tail.data(), cr, count - i, out + i);
}

#endif  // HWY_TARGET == HWY_SCALAR

const char* TargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace kestrel::sensor::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::sensor {
namespace kernels {

HWY_EXPORT(VectorLanes);
HWY_EXPORT(ScanRow);
HWY_EXPORT(AddSadRowFast);
HWY_EXPORT(MatchRowFast);
HWY_EXPORT(CensusSignatures);
HWY_EXPORT(TargetName);

int vector_lanes() { return HWY_DYNAMIC_DISPATCH(VectorLanes)(); }

void scan_row(const RowScan& scan) { HWY_DYNAMIC_DISPATCH(ScanRow)(scan); }

void add_sad_row_fast(std::uint16_t* column_sums, const std::uint8_t* left_row,
                      const std::uint8_t* right_row, int cols, int lanes, int bits) {
  HWY_DYNAMIC_DISPATCH(AddSadRowFast)(column_sums, left_row, right_row, cols, lanes, bits);
}

void match_row_fast(const RowScan& scan, const FastRow& fast, float* out, MatchStats& stats) {
  HWY_DYNAMIC_DISPATCH(MatchRowFast)(scan, fast, out, stats);
}

void census_signatures(const std::uint8_t* const* rows, int cr, int count, std::uint64_t* out) {
  HWY_DYNAMIC_DISPATCH(CensusSignatures)(rows, cr, count, out);
}

const char* target_name() { return HWY_DYNAMIC_DISPATCH(TargetName)(); }

}  // namespace kernels

const char* block_matching_simd_target() { return kernels::target_name(); }

std::vector<std::int64_t> block_matching_simd_targets() {
  return hwy::SupportedAndGeneratedTargets();
}

}  // namespace kestrel::sensor
#endif  // HWY_ONCE
