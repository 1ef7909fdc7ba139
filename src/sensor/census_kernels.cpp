// The census cost's column slide (block_matcher_kernels.hpp: census_slide_row) in explicit
// Highway ops, in its own translation unit so that it is compiled for every target including
// AVX-512 with VPOPCNTDQ (Highway's AVX3_DL, asked for in CMakeLists.txt): the row kernels of
// block_matcher_kernels.cpp stop at AVX2 (docs/stereo.md v10, v12; docs/onboard.md).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "census_kernels.cpp"  // NOLINT: this file, found by its folder
#include <hwy/foreach_target.h>                  // IWYU pragma: keep
#include <hwy/highway.h>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "block_matcher_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace kestrel::sensor::kernels::HWY_NAMESPACE {

namespace hn = hwy::HWY_NAMESPACE;

// Explicit Highway ops on every target: the Hamming distances a full vector of uint64 lanes at a
// time (PopulationCount: vpopcntq on AVX3_DL, a nibble table on AVX2 and SSE4, cnt + pairwise
// adds on NEON), truncated to bytes; then the column updates a run of 8 uint16 lanes at a time
// (the storage order keeps runs of 8 lanes), in uint16 arithmetic, which wraps as the
// reference's conversion does. (A plain loop here left the updates scalar: the compiler could
// not rule out that the sums alias the ring.)
void CensusSlideRow(std::uint16_t* HWY_RESTRICT column_sums, std::uint8_t* HWY_RESTRICT ring_row,
                    const std::uint64_t* HWY_RESTRICT left_row,
                    const std::uint64_t* HWY_RESTRICT right_row, int cols, int lanes, int scale,
                    int storage_order) {
  const hn::ScalableTag<std::uint64_t> d64;
  const hn::Rebind<std::uint8_t, decltype(d64)> d8q;  // one byte per uint64 lane
  const hn::CappedTag<std::uint16_t, 8> d16;          // (part of) a run of 8 lanes
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const int n64 = static_cast<int>(hn::Lanes(d64));
  const int n16 = static_cast<int>(hn::Lanes(d16));
  const auto lane_stride = static_cast<std::size_t>(lanes);
  const auto vscale = hn::Set(d16, static_cast<std::uint16_t>(scale));
  HWY_ALIGN std::uint8_t distances[1024];  // lanes <= 1024 (validate)
  for (int c = 0; c < cols; ++c) {
    std::uint16_t* sums = column_sums + static_cast<std::size_t>(c) * lane_stride;
    std::uint8_t* ring = ring_row + static_cast<std::size_t>(c) * lane_stride;
    const std::uint64_t* right = right_row + c;
    const auto left = hn::Set(d64, left_row[c]);
    int i = 0;
    for (; i + n64 <= lanes; i += n64) {
      const auto bits = hn::PopulationCount(hn::Xor(left, hn::LoadU(d64, right + i)));
      hn::StoreU(hn::TruncateTo(d8q, bits), d8q, distances + i);
    }
    for (; i < lanes; ++i) {
      distances[i] = static_cast<std::uint8_t>(std::popcount(left_row[c] ^ right[i]));
    }
    for (int i0 = 0; i0 < lanes; i0 += 8) {
      std::uint16_t* sum = sums + fast_lane_position(i0, storage_order);
      for (int j = 0; j < 8; j += n16) {
        const auto in = hn::PromoteTo(d16, hn::LoadU(d8, distances + i0 + j));
        const auto out = hn::PromoteTo(d16, hn::LoadU(d8, ring + i0 + j));
        hn::StoreU(hn::Add(hn::LoadU(d16, sum + j), hn::Mul(hn::Sub(in, out), vscale)), d16,
                   sum + j);
      }
    }
    std::memcpy(ring, distances, lane_stride);
  }
}

const char* CensusTargetName() { return hwy::TargetName(HWY_TARGET); }

}  // namespace kestrel::sensor::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace kestrel::sensor::kernels {

HWY_EXPORT(CensusSlideRow);
HWY_EXPORT(CensusTargetName);

void census_slide_row(std::uint16_t* column_sums, std::uint8_t* ring_row,
                      const std::uint64_t* left_row, const std::uint64_t* right_row, int cols,
                      int lanes, int scale, int storage_order) {
  HWY_DYNAMIC_DISPATCH(CensusSlideRow)
  (column_sums, ring_row, left_row, right_row, cols, lanes, scale, storage_order);
}

void census_slide_row_reference(std::uint16_t* column_sums, std::uint8_t* ring_row,
                                const std::uint64_t* left_row, const std::uint64_t* right_row,
                                int cols, int lanes, int scale, int storage_order) {
  const auto lane_stride = static_cast<std::size_t>(lanes);
  for (int c = 0; c < cols; ++c) {
    for (int i = 0; i < lanes; ++i) {
      const std::size_t at = static_cast<std::size_t>(c) * lane_stride;
      const int distance = std::popcount(left_row[c] ^ right_row[c + i]);
      std::uint16_t& sum =
          column_sums[at + static_cast<std::size_t>(fast_lane_position(i, storage_order))];
      sum = static_cast<std::uint16_t>(sum + scale * (distance - ring_row[at + i]));
      ring_row[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(distance);
    }
  }
}

const char* census_target_name() { return HWY_DYNAMIC_DISPATCH(CensusTargetName)(); }

std::vector<std::int64_t> census_simd_targets() { return hwy::SupportedAndGeneratedTargets(); }

}  // namespace kestrel::sensor::kernels
#endif  // HWY_ONCE
