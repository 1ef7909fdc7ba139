// The census cost's column slide (block_matcher_kernels.hpp: census_slide_row) in its own
// Highway translation unit, so that it is compiled for every target including AVX-512 with
// VPOPCNTDQ (Highway's AVX3_DL, asked for in CMakeLists.txt): the row kernels of
// block_matcher_kernels.cpp stop at AVX2, whose copy of this loop pays one scalar popcnt per
// lane, while the AVX3_DL copy is vectorised with vpopcntq (docs/stereo.md, docs/onboard.md).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "census_kernels.cpp"  // NOLINT: this file, found by its folder
#include <hwy/foreach_target.h>                  // IWYU pragma: keep
#include <hwy/highway.h>

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "block_matcher_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace kestrel::sensor::kernels::HWY_NAMESPACE {

// Plain loops, compiled here once per target so that the popcount and the vectorised updates
// use the target's instructions also in a build without -march=native: the Hamming distances
// first, then the column and ring updates.
void CensusSlideRow(std::uint16_t* column_sums, std::uint8_t* ring_row,
                    const std::uint64_t* left_row, const std::uint64_t* right_row, int cols,
                    int lanes, int scale, int storage_order) {
  const auto lane_stride = static_cast<std::size_t>(lanes);
  std::array<std::uint8_t, 1024> distances{};  // lanes <= 1024 (validate)
  for (int c = 0; c < cols; ++c) {
    std::uint16_t* sums = column_sums + static_cast<std::size_t>(c) * lane_stride;
    std::uint8_t* ring = ring_row + static_cast<std::size_t>(c) * lane_stride;
    const std::uint64_t left = left_row[c];
    for (int i = 0; i < lanes; ++i) {
      distances[static_cast<std::size_t>(i)] =
          static_cast<std::uint8_t>(std::popcount(left ^ right_row[c + i]));
    }
    for (int i0 = 0; i0 < lanes; i0 += 8) {  // the storage order keeps runs of 8 lanes
      std::uint16_t* sum = sums + fast_lane_position(i0, storage_order);
      for (int i = 0; i < 8; ++i) {
        sum[i] = static_cast<std::uint16_t>(
            sum[i] + scale * (distances[static_cast<std::size_t>(i0 + i)] - ring[i0 + i]));
      }
    }
    std::memcpy(ring, distances.data(), lane_stride);
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
