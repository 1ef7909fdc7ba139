// The block matcher's row kernels (block_matcher_kernels.cpp, Google Highway): what the
// matcher (block_matcher.cpp) and its SIMD kernels share. The scalar reference of a row is
// block_matcher.cpp's scan_row_generic + finish_row; the kernels give the same bits.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::sensor::kernels {

inline constexpr std::uint16_t kMaskedCost = 0xFFFF;

/// The general SIMD scan keeps a row's lanes in registers: up to this many (beyond, the
/// scalar reference runs).
inline constexpr int kMaxSimdLanes = 256;

// The fast row checks pixel x - kLag while it scans pixel x; its ring of box costs holds the
// last kRingSlots pixels (> kLag + kFastMaxLrDiff), each slot with kRingGuard masked lanes on
// either side, so that the left-right diagonal (|j| <= lr_max_diff <= kFastMaxLrDiff) and the
// fit's neighbours never leave the slots.
inline constexpr int kLag = 16;
inline constexpr int kFastMaxLrDiff = 8;
inline constexpr int kRingSlots = 32;
inline constexpr int kRingGuard = 16;  // 32 bytes: the slots' lanes stay 32-byte aligned
static_assert(kLag > kFastMaxLrDiff && kRingSlots > kLag + kFastMaxLrDiff &&
              kRingGuard >= kFastMaxLrDiff);
/// uint16 elements of one ring slot of a fast row of `lanes` lanes: kRingGuard masked lanes,
/// the lanes, and masked lanes up to a power of two (kRingGuard at least), so that a slot's
/// address is a shift of its pixel, not a multiplication.
constexpr int fast_ring_slot(int lanes) {
  int slot = 1;
  while (slot < lanes + 2 * kRingGuard) slot *= 2;
  return slot;
}

/// What the fast scan leaves per pixel for the fast finish: one uint16 field array each, all
/// at constant offsets from one base (kFieldStride apart). Costs are stored TAGGED (see
/// ScanRowFast in block_matcher_kernels.cpp).
enum FastField : int {
  kFieldCost,    // the winner's cost
  kFieldMinus,   // the cost at d - 1 (lane best + 1)
  kFieldPlus,    // the cost at d + 1 (lane best - 1)
  kFieldDiag,    // the least cost on the right pixel's diagonal within lr_max_diff
  kFieldSecond,  // the least cost further than 1 lane from the winner (0xFFFF: none)
  kFieldBest,    // the winner's lane (not tagged)
  kFieldCount
};
inline constexpr int kFieldStride = 8192;  // the fast row handles widths up to this

/// The fast row's storage order of the lanes in its column sums, ring and window, for a
/// target whose uint16 vectors hold `vector_lanes` (8: 128 bits, 16: 256 bits). The fast row
/// widens 2 vector_lanes byte costs to two uint16 vectors by interleaving with zeros, which
/// works per 128-bit block: vector 0 gets bytes 0..7 of each block, vector 1 bytes 8..15. So
/// each 128-bit block holds 8 consecutive lanes (all the tagged winner search needs), in an
/// order that is the identity on 128-bit vectors and swaps bits 3 and 4 of the lane on
/// 256-bit ones. For both it is its own inverse: the lane at a position and the position of
/// a lane are the same function.
/// Any other vector_lanes (0 included) gives the identity: the lane order.
constexpr int fast_lane_position(int lane, int vector_lanes) {
  if (vector_lanes != 16) return lane;
  return (lane & ~0x18) | ((lane & 8) << 1) | ((lane & 16) >> 1);
}

// Row-scan outcome per pixel, before the left-right check and the depth range.
enum RowState : std::uint8_t { kCandidate = 0, kUnreachable, kLowTexture, kNotUnique };

/// Everything one row scan reads and writes. Lanes below first(x) = max(lanes - num,
/// d_top - x) are out of range (d >= max_disparity, or d > x: outside the right image).
struct RowScan {
  std::uint16_t* column_sums;  // cols x lanes: slid to this row, or by the scan (left_new)
  const std::uint32_t* texture_columns;
  int width, radius, lanes, num, d_top, uniqueness;
  std::uint32_t texture_min;
  std::uint16_t* volume;      // width x lanes: the box costs of the row (for checks)
  std::uint16_t* right_min;   // width + lanes + 1: best cost of right pixel xr at xr + d_top
  std::int32_t* winner_lane;  // width
  std::uint8_t* state;        // width
  // SAD: the scan slides column x + 2r down one row itself (row in: *_new, row out: *_old)
  // just before using it. Null: the column sums are already slid (census, first row).
  const std::uint8_t* left_new = nullptr;
  const std::uint8_t* left_old = nullptr;
  const std::uint8_t* right_new = nullptr;
  const std::uint8_t* right_old = nullptr;

  [[nodiscard]] int first_lane(int x) const { return std::max(lanes - num, d_top - x); }
};

/// The fast row's buffers and options besides RowScan's.
struct FastRow {
  std::uint16_t* ring;              // kRingSlots slots: tagged box costs of pixel x at x % slots
  std::uint16_t* fields;            // kFieldCount x kFieldStride
  const std::uint16_t* near_masks;  // lanes x lanes: 0xFFFF at the positions of lanes b-1..b+1
  const std::int16_t* position;     // lane -> position in a slot, lanes -kRingGuard..lanes+15
  int lr_max_diff;
  bool subpixel, census;
  float d_min, d_max;
  bool texture;      // texture_min > 0
  bool small_costs;  // every per-pixel cost is below 128 (max_pixel_cost)
};

/// uint16 lanes of a vector of the target the dispatch takes (8 or 16; 1 on Highway's
/// scalar fallback, where no kernel applies and the matcher runs the scalar reference).
int vector_lanes();
/// The general scan (lanes a multiple of 32, at most kMaxSimdLanes): what scan_row_generic
/// leaves, the same bits.
void scan_row(const RowScan& scan);
/// Column sums += 2^bits |l - r| of one SAD row, in the fast row's storage order.
void add_sad_row_fast(std::uint16_t* column_sums, const std::uint8_t* left_row,
                      const std::uint8_t* right_row, int cols, int lanes, int bits);
/// The fast row (32 or 64 lanes, width <= kFieldStride): the scan, then the checks and the
/// fit; the disparities of the row and its counts, as finish_row after scan_row_generic.
void match_row_fast(const RowScan& scan, const FastRow& fast, float* out, MatchStats& stats);
/// Census column sums slid down one row: += scale (the incoming row's Hamming distances -
/// the outgoing row's, kept in `ring_row`, which then holds the incoming ones), the sums in
/// the storage order fast_lane_position(., storage_order) (0: lane order). The same
/// arithmetic on every target (Highway's PopulationCount on uint64 lanes, uint16 updates).
/// Its own translation unit (census_kernels.cpp), compiled for AVX-512 too (AVX3_DL).
/// `lanes` a multiple of 8, at most 1024.
void census_slide_row(std::uint16_t* column_sums, std::uint8_t* ring_row,
                      const std::uint64_t* left_row, const std::uint64_t* right_row, int cols,
                      int lanes, int scale, int storage_order);
/// The scalar reference of census_slide_row: lane by lane, the same bits.
void census_slide_row_reference(std::uint16_t* column_sums, std::uint8_t* ring_row,
                                const std::uint64_t* left_row, const std::uint64_t* right_row,
                                int cols, int lanes, int scale, int storage_order);
/// The targets census_slide_row has for this CPU (AVX3_DL included), best first, and the name
/// of the one its dispatch takes.
std::vector<std::int64_t> census_simd_targets();
const char* census_target_name();
/// Census signatures (the census cost's, BlockMatcherOptions::census_window = 2 cr + 1) of
/// `count` consecutive pixels whose windows lie inside the image: rows[k] (k = 0 .. 2 cr)
/// points at the first pixel's column in image row y - cr + k (clamped). Bit = I(neighbour) <
/// I(centre); the neighbours in raster order (dy, then dx; the centre skipped), the first in
/// the highest bit of the (2 cr + 1)^2 - 1. The SIMD kernel gives census_signatures_reference's
/// bits on every target.
void census_signatures(const std::uint8_t* const* rows, int cr, int count, std::uint64_t* out);
/// The scalar reference of census_signatures (block_matcher.cpp).
void census_signatures_reference(const std::uint8_t* const* rows, int cr, int count,
                                 std::uint64_t* out);
/// The name of the target the dispatch takes.
const char* target_name();

}  // namespace kestrel::sensor::kernels
