// The row kernels of the semi-global matcher (sgm_matcher.hpp): census signatures, census
// matching costs, the path recursion of SGM (Hirschmueller, PAMI 2008, eq. 13) over one image
// row for one pass, and the winner-take-all with the right view's best costs. Each kernel is
// written once in portable SIMD (Google Highway, sgm_kernels.cpp, the best target the CPU has
// chosen at run time) and once as a scalar reference (sgm_kernels_reference.cpp); all integer,
// so the two give the same results bit for bit.
//
// Cost rows hold `lanes` uint16 costs per pixel, lane k <-> disparity min_disparity + k; lanes
// past the searched range hold kSgmMaskedCost. Path costs live in "slots": a slot is
// kSgmGuard guard lanes (kSgmMaskedCost, never written) followed by `lanes` path costs, so that
// the costs at d - 1 and d + 1 of any lane are one unaligned load away and the out-of-range
// neighbours read as masked.
#pragma once

#include <cstdint>
#include <vector>

namespace kestrel::sensor::sgm {

/// A cost no real one reaches: saturating adds keep it, so masked lanes never win a minimum.
inline constexpr std::uint16_t kSgmMaskedCost = 0xFFFF;
/// The most uint16 lanes of a SIMD target (AVX-512); `lanes` is a multiple of it.
inline constexpr int kSgmMaxVectorLanes = 32;
/// Guard lanes in front of each slot (64 bytes: the slots stay on cache-line boundaries).
inline constexpr int kSgmGuard = 32;
/// The 8-bit path recursion (AggregateRowArgs, Kernels::aggregate_row8) keeps the path costs in
/// uint8 lanes, 0xFF masked: exact iff every real path cost stays <= 254, i.e. iff
/// max cost + P2 <= kSgmMax8BitCostPlusP2 (L - min L <= C + P2, eq. 13). Its slots are bytes in
/// the same buffers: kSgmGuard8 guard bytes (64: cache-line boundaries again), then `lanes`.
inline constexpr int kSgmMax8BitCostPlusP2 = 254;
inline constexpr int kSgmGuard8 = 64;

/// Census signatures of one image row: bit b of the signature is I(p + a_b) > I(p + b_b), for
/// the pairs of offsets (a_b, b_b) in a border-replicated 8-bit image (element offsets from the
/// centre pixel). At most 32 bits, kept as two 16-bit halves so that the costs are 16-bit lanes.
struct CensusRowArgs {
  const std::uint8_t* center = nullptr;  ///< the row's first pixel in the padded image
  const std::int32_t* offset_a = nullptr;
  const std::int32_t* offset_b = nullptr;
  int bits = 0;   ///< 1..32
  int width = 0;  ///< pixels; the padded image holds kSgmMaxVectorLanes more to the right
  std::uint16_t* low = nullptr;   ///< bits 0..15, width + kSgmMaxVectorLanes entries
  std::uint16_t* high = nullptr;  ///< bits 16..31
};

/// Hamming distances of one row: cost[x * lanes + k] = popcount(left(x) ^ right(x - d_k)), with
/// the right signatures stored in reverse (right_rev[j] <-> right pixel width - 1 - j + ...):
/// lane k of pixel x reads right_rev[first - x + k]. pad_mask (lanes entries) is ORed in:
/// kSgmMaskedCost on the lanes past the range, 0 elsewhere.
struct CostRowArgs {
  const std::uint16_t* left_low = nullptr;
  const std::uint16_t* left_high = nullptr;
  const std::uint16_t* right_rev_low = nullptr;
  const std::uint16_t* right_rev_high = nullptr;
  const std::uint16_t* pad_mask = nullptr;
  int first = 0;  ///< right_rev index of lane 0 at x = 0
  int width = 0;
  int lanes = 0;
  std::uint16_t* cost = nullptr;  ///< width * lanes
};

/// One path direction's row buffers: width + 2 slots (slot x + 1 <-> pixel x; slots 0 and
/// width + 1 stay masked: a path that enters the image there starts with L = C) and the least
/// path cost of each slot.
struct PathRows {
  const std::uint16_t* prev = nullptr;      ///< the previous row's slots
  const std::uint16_t* prev_min = nullptr;  ///< width + 2
  std::uint16_t* cur = nullptr;
  std::uint16_t* cur_min = nullptr;
  int dx = 0;  ///< the previous pixel on the path is (x + dx) of the previous row
};

/// The paths of one pass over one row, in the order the pass visits the pixels (`step` = +1:
/// left to right, the horizontal path from the left; -1: right to left, from the right).
/// L_r(p, d) = C(p, d) + min(L_r(p-r, d), L_r(p-r, d+-1) + P1, min_k L_r(p-r, k) + P2)
///             - min_k L_r(p-r, k)                                       (PAMI 2008, eq. 13)
/// with P2 = p2_lut[|I(p) - I(p - r)|] (eq. 16: a smaller penalty across intensity edges).
/// sum = (add ? add : 0) + the pass's L_r, saturating.
struct AggregateRowArgs {
  const std::uint16_t* cost = nullptr;  ///< width * lanes
  const std::uint16_t* add = nullptr;   ///< optional width * lanes
  std::uint16_t* sum = nullptr;         ///< width * lanes
  std::uint16_t* horizontal = nullptr;  ///< 3 slots: a masked one, then two in turn
  PathRows vertical[3];
  int num_vertical = 0;                      ///< 1 (4 paths) or 3 (8 paths)
  const std::uint8_t* image = nullptr;       ///< this row of the left image
  const std::uint8_t* image_prev = nullptr;  ///< the previous row on the vertical paths
  /// P2 by intensity difference, each >= p1: p2_lut[-255..255] are readable (symmetric), so
  /// that p2_lut[I(p) - I(q)] needs no absolute value.
  const std::uint16_t* p2_lut = nullptr;
  std::uint16_t* p2_scratch = nullptr;  ///< 4 x width: P2 per path and pixel (scratch)
  /// lanes entries, kSgmMaskedCost past the range: the 8-bit kernel's sums start there when
  /// `add` is null (its masked path costs are 0xFF, not 0xFFFF; the sums stay the same).
  const std::uint16_t* pad_mask = nullptr;
  std::uint16_t p1 = 0;
  int width = 0, lanes = 0;
  int step = 1;
};

/// Winner-take-all over one row of summed costs: best[x] = the FIRST lane of least cost,
/// best_cost[x] its cost; and for the left-right check, the least summed cost of each right
/// pixel over its disparities: right_min_rev[j] = min_k sum(width - 1 - j + k, k), the right
/// pixel width - 1 - min_disparity - j (j < width; right_min_rev has width + lanes entries, the
/// last ones scratch).
struct DecideRowArgs {
  const std::uint16_t* sum = nullptr;
  int width = 0, lanes = 0;
  std::int32_t* best = nullptr;
  std::uint16_t* best_cost = nullptr;
  std::uint16_t* right_min_rev = nullptr;  ///< null: winners only (no left-right check)
};

/// The kernels of one implementation.
struct Kernels {
  void (*census_row)(const CensusRowArgs&);
  void (*cost_row)(const CostRowArgs&);
  void (*aggregate_row)(const AggregateRowArgs&);
  /// The same in uint8 path costs (slots of kSgmGuard8 + lanes bytes in the same buffers;
  /// cur_min/prev_min as before, masked >= 0xFF), for costs and P2 that keep every path cost
  /// <= kSgmMax8BitCostPlusP2; the sums are those of aggregate_row bit for bit. Null where an
  /// implementation has none (the scalar reference: one implementation to check against).
  void (*aggregate_row8)(const AggregateRowArgs&);
  void (*decide_row)(const DecideRowArgs&);
};

/// The SIMD kernels (best target of this CPU, or the one a test selected).
const Kernels& simd_kernels();
/// The scalar reference.
const Kernels& reference_kernels();

/// The target the SIMD kernels run on now (Highway's name).
const char* simd_target();
/// Every SIMD target compiled in that this CPU runs, best first (Highway target bits).
std::vector<std::int64_t> simd_targets();

}  // namespace kestrel::sensor::sgm
