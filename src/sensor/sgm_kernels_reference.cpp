// The scalar reference of the SGM row kernels (sgm_kernels.hpp): the plain loops the SIMD
// kernels must reproduce bit for bit.
#include <algorithm>
#include <bit>
#include <cstdint>

#include "sgm_kernels.hpp"

namespace kestrel::sensor::sgm {
namespace {

void census_row(const CensusRowArgs& a) {
  for (int x = 0; x < a.width; ++x) {
    std::uint32_t signature = 0;
    for (int b = 0; b < a.bits; ++b) {
      const std::uint8_t* p = a.center + x;
      if (p[a.offset_a[b]] > p[a.offset_b[b]]) signature |= std::uint32_t{1} << b;
    }
    a.low[x] = static_cast<std::uint16_t>(signature & 0xFFFFU);
    a.high[x] = static_cast<std::uint16_t>(signature >> 16);
  }
}

void cost_row(const CostRowArgs& a) {
  for (int x = 0; x < a.width; ++x) {
    const std::uint32_t l_low = a.left_low[x], l_high = a.left_high[x];
    for (int k = 0; k < a.lanes; ++k) {
      const int j = a.first - x + k;
      const int distance =
          std::popcount(l_low ^ a.right_rev_low[j]) + std::popcount(l_high ^ a.right_rev_high[j]);
      a.cost[x * a.lanes + k] = static_cast<std::uint16_t>(distance | a.pad_mask[k]);
    }
  }
}

std::uint16_t sat_add(std::uint32_t a, std::uint32_t b) {
  return static_cast<std::uint16_t>(std::min<std::uint32_t>(a + b, kSgmMaskedCost));
}

/// Eq. 13 for one pixel and one path: `prev` is the previous pixel's slot data (lanes -1 and
/// `lanes` readable, masked). Returns the least new path cost.
std::uint16_t update_path(const std::uint16_t* cost, const std::uint16_t* prev,
                          std::uint16_t prev_min, std::uint16_t p1, std::uint16_t p2, int lanes,
                          std::uint16_t* out, std::uint16_t* sum) {
  const std::uint16_t jump = sat_add(prev_min, p2);
  std::uint16_t least = kSgmMaskedCost;
  for (int k = 0; k < lanes; ++k) {
    const std::uint16_t neighbours = sat_add(std::min(prev[k - 1], prev[k + 1]), p1);
    const std::uint16_t t = std::min({prev[k], neighbours, jump});
    const std::uint16_t l = sat_add(cost[k], static_cast<std::uint16_t>(t - prev_min));
    out[k] = l;
    sum[k] = sat_add(sum[k], l);
    least = std::min(least, l);
  }
  return least;
}

void aggregate_row(const AggregateRowArgs& a) {
  const int stride = a.lanes + kSgmGuard;
  const int x0 = a.step > 0 ? 0 : a.width - 1;
  const std::uint16_t* h_prev = a.horizontal + kSgmGuard;  // the masked slot
  std::uint16_t h_min = kSgmMaskedCost;
  for (int i = 0; i < a.width; ++i) {
    const int x = x0 + i * a.step;
    const std::uint16_t* cost = a.cost + static_cast<std::ptrdiff_t>(x) * a.lanes;
    std::uint16_t* sum = a.sum + static_cast<std::ptrdiff_t>(x) * a.lanes;
    for (int k = 0; k < a.lanes; ++k) sum[k] = a.add ? a.add[x * a.lanes + k] : 0;
    const int xh = std::clamp(x - a.step, 0, a.width - 1);
    std::uint16_t* h_cur = a.horizontal + (1 + (i & 1)) * stride + kSgmGuard;
    const int dh = std::abs(int{a.image[x]} - int{a.image[xh]});
    h_min = update_path(cost, h_prev, h_min, a.p1, a.p2_lut[dh], a.lanes, h_cur, sum);
    h_prev = h_cur;
    for (int r = 0; r < a.num_vertical; ++r) {
      const PathRows& v = a.vertical[r];
      const int slot = x + 1 + v.dx;
      const int xv = std::clamp(x + v.dx, 0, a.width - 1);
      const int dv = std::abs(int{a.image[x]} - int{a.image_prev[xv]});
      v.cur_min[x + 1] =
          update_path(cost, v.prev + slot * stride + kSgmGuard, v.prev_min[slot], a.p1,
                      a.p2_lut[dv], a.lanes, v.cur + (x + 1) * stride + kSgmGuard, sum);
    }
  }
}

void decide_row(const DecideRowArgs& a) {
  for (int x = 0; x < a.width; ++x) {
    const std::uint16_t* s = a.sum + static_cast<std::ptrdiff_t>(x) * a.lanes;
    int best = 0;
    for (int k = 1; k < a.lanes; ++k) {
      if (s[k] < s[best]) best = k;
    }
    a.best[x] = best;
    a.best_cost[x] = s[best];
  }
  if (a.right_min_rev == nullptr) return;
  for (int j = 0; j < a.width; ++j) {  // right pixel xr = width - 1 - min_disparity - j
    std::uint16_t least = kSgmMaskedCost;
    for (int k = 0; k < a.lanes && j - k >= 0; ++k) {
      const int x = a.width - 1 - j + k;  // the left pixel whose lane k is that right pixel
      least = std::min(least, a.sum[static_cast<std::ptrdiff_t>(x) * a.lanes + k]);
    }
    a.right_min_rev[j] = least;
  }
}

}  // namespace

const Kernels& reference_kernels() {
  static const Kernels k{census_row, cost_row, aggregate_row, nullptr, decide_row};
  return k;
}

}  // namespace kestrel::sensor::sgm
