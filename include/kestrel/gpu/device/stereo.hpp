// Block matching per pixel, as the CUDA kernels run it (src/gpu/cuda/stereo_kernels.cu) and the
// CPU tests emulate it: the same costs, winner-take-all and checks as sensor::BlockMatcher
// (src/sensor/block_matcher.cpp), written per output element instead of as sliding registers.
//
// Definitions (identical to the CPU matcher's; tests/gpu checks it bit for bit):
//  - rows and columns outside the image are clamped (the CPU matcher's padded rows);
//  - pixel cost e(y, x, d) = |P_L(y, x) - P_R(y, x - d)| of the prefiltered images (x-Sobel
//    clamped to +-cap and shifted to [0, 2 cap], or raw grey levels), or the Hamming distance
//    of 3/5/7 census signatures;
//  - box cost C(y, x, d) = sum over dy, dx in [-r, r] of e(cy(y + dy), cx(x + dx), cx(x + dx - d))
//    with cy, cx the clamps: exact integers < 65536 (BlockMatcherOptions::validate);
//  - disparities min_d <= d < min_d + num and d <= x; none: the pixel is unreachable;
//  - winner: least C, ties to the LARGER d (the CPU's lowest lane, lanes run d_top - k);
//  - texture: window sum of |I(x + 1) - I(x - 1)| (raw left image, clamped) >= texture_min;
//  - uniqueness: every d further than 1 from the winner must cost > c0 (1 + u / 100);
//  - left-right: the right pixel x - d's least cost over all (x', d') with x' - d' = x - d must
//    be reached by a candidate within lr px of (x, d) along that diagonal;
//  - subpixel: equiangular fit (SAD) or parabola (census) when c0 > 0 and d +- 1 are valid;
//  - depth range: d_min_valid <= d <= d_max_valid.
// The cost volume is stored as volume[(y * num + (d - min_d)) * width + x] (uint16).
#pragma once

#include <cstdint>

#include "kestrel/gpu/device/hd.hpp"

namespace kestrel::gpu::device {

/// Rows of the cost volume one CUDA thread slides over (the kernel and the CPU emulation).
inline constexpr int kCostRowsPerThread = 32;

/// What happened to one pixel; the MatchStats categories.
enum PixelState : std::uint8_t {
  kStateValid = 0,
  kStateUnreachable,
  kStateLowTexture,
  kStateNotUnique,
  kStateLeftRight,
  kStateDepth,
  kStateCandidate,  ///< passed the row checks; left-right, subpixel and depth still to come
  kStateCount,
};

/// BlockMatcherOptions as the kernels read them (gpu::stereo_params builds it).
struct StereoParams {
  int width = 0, height = 0;
  int radius = 4;         ///< block_size / 2
  int min_disparity = 0;  ///< d in [min_disparity, min_disparity + num)
  int num = 64;
  int census = 0;  ///< 0: SAD, 1: census
  int xsobel = 1;  ///< SAD prefilter: 1 x-Sobel, 0 raw grey levels
  int prefilter_cap = 31;
  int census_radius = 2;
  int uniqueness = 10;            ///< percent, 0 = off
  int lr_max_diff = 1;            ///< < 0: off
  std::uint32_t texture_min = 0;  ///< least window sum of |I(x + 1) - I(x - 1)|
  int subpixel = 1;
  float d_min_valid = 0.0F, d_max_valid = 0.0F;  ///< depth range as disparities (max may be inf)
};

// ---------------------------------------------------------------------------------------------
// Prefilter (one thread per pixel).

/// x-Sobel of an 8-bit image at (x, y), clamped to +-cap and shifted to [0, 2 cap].
KESTREL_HD std::uint8_t xsobel_at(const std::uint8_t* img, int pitch, int w, int h, int x, int y,
                                  int cap) {
  const std::uint8_t* r0 = img + static_cast<std::ptrdiff_t>(maxi(y - 1, 0)) * pitch;
  const std::uint8_t* r1 = img + static_cast<std::ptrdiff_t>(y) * pitch;
  const std::uint8_t* r2 = img + static_cast<std::ptrdiff_t>(mini(y + 1, h - 1)) * pitch;
  const int xm = maxi(x - 1, 0), xp = mini(x + 1, w - 1);
  const int g = (r0[xp] - r0[xm]) + 2 * (r1[xp] - r1[xm]) + (r2[xp] - r2[xm]);
  return static_cast<std::uint8_t>(clampi(g, -cap, cap) + cap);
}

/// Census signature: one bit per window neighbour (row-major, centre skipped, first = MSB),
/// set where the neighbour is darker than the centre; coordinates clamped.
KESTREL_HD std::uint64_t census_at(const std::uint8_t* img, int pitch, int w, int h, int x, int y,
                                   int census_radius) {
  const int centre = img[static_cast<std::ptrdiff_t>(y) * pitch + x];
  std::uint64_t bits = 0;
  for (int dy = -census_radius; dy <= census_radius; ++dy) {
    const std::uint8_t* row = img + static_cast<std::ptrdiff_t>(clampi(y + dy, 0, h - 1)) * pitch;
    for (int dx = -census_radius; dx <= census_radius; ++dx) {
      if (dx == 0 && dy == 0) continue;
      bits = (bits << 1) | static_cast<std::uint64_t>(row[clampi(x + dx, 0, w - 1)] < centre);
    }
  }
  return bits;
}

/// |I(x + 1) - I(x - 1)| of the raw left image, columns clamped (the texture measure).
KESTREL_HD std::uint8_t texture_gradient_at(const std::uint8_t* img, int pitch, int w, int x,
                                            int y) {
  const std::uint8_t* row = img + static_cast<std::ptrdiff_t>(y) * pitch;
  return static_cast<std::uint8_t>(absi(int{row[mini(x + 1, w - 1)]} - int{row[maxi(x - 1, 0)]}));
}

/// Window sum of the texture gradient around (x, y), rows and columns clamped.
KESTREL_HD std::uint32_t texture_sum_at(const std::uint8_t* grad, int pitch, int w, int h, int x,
                                        int y, int r) {
  std::uint32_t sum = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const std::uint8_t* row = grad + static_cast<std::ptrdiff_t>(clampi(y + dy, 0, h - 1)) * pitch;
    for (int dx = -r; dx <= r; ++dx) sum += row[clampi(x + dx, 0, w - 1)];
  }
  return sum;
}

// ---------------------------------------------------------------------------------------------
// Cost volume (one thread per column x, disparity d and chunk of rows).

KESTREL_HD int pixel_cost(std::uint8_t a, std::uint8_t b) { return absi(int{a} - int{b}); }
KESTREL_HD int pixel_cost(std::uint64_t a, std::uint64_t b) { return popcount64(a ^ b); }

/// Sum over dx in [-r, r] of e(row, x + dx, d), columns clamped.
template <typename Pixel>
KESTREL_HD int row_cost(const Pixel* left_row, const Pixel* right_row, int w, int r, int x, int d) {
  int sum = 0;
  for (int dx = -r; dx <= r; ++dx) {
    sum += pixel_cost(left_row[clampi(x + dx, 0, w - 1)], right_row[clampi(x + dx - d, 0, w - 1)]);
  }
  return sum;
}

/// Box costs C(y, x, d) of rows [y_begin, y_end) for one column x and disparity index di: the
/// window sum of the first row, then one row in (y + r) and one out (y - r - 1) per step. Exact
/// in int. `pitch` is the prefiltered images' row length in pixels.
template <typename Pixel>
KESTREL_HD void cost_column(const Pixel* left, const Pixel* right, int pitch, const StereoParams& p,
                            int x, int di, int y_begin, int y_end, std::uint16_t* volume) {
  const int w = p.width, h = p.height, r = p.radius;
  const int d = p.min_disparity + di;
  const auto row = [&](const Pixel* img, int y) {
    return img + static_cast<std::ptrdiff_t>(clampi(y, 0, h - 1)) * pitch;
  };
  const auto plane = static_cast<std::ptrdiff_t>(p.num) * w;
  std::uint16_t* out = volume + static_cast<std::ptrdiff_t>(di) * w + x;
  int sum = 0;
  for (int k = y_begin - r; k <= y_begin + r; ++k) {
    sum += row_cost(row(left, k), row(right, k), w, r, x, d);
  }
  out[y_begin * plane] = static_cast<std::uint16_t>(sum);
  for (int y = y_begin + 1; y < y_end; ++y) {
    sum += row_cost(row(left, y + r), row(right, y + r), w, r, x, d) -
           row_cost(row(left, y - r - 1), row(right, y - r - 1), w, r, x, d);
    out[y * plane] = static_cast<std::uint16_t>(sum);
  }
}

// ---------------------------------------------------------------------------------------------
// Selection and checks (one thread per pixel). `vol` points at row y of the volume:
// vol[di * width + x].

/// The largest disparity index valid at column x (d <= x); < 0: the pixel is unreachable.
KESTREL_HD int max_valid_index(const StereoParams& p, int x) {
  return mini(p.num - 1, x - p.min_disparity);
}

/// Winner-take-all, texture and uniqueness for pixel x: kStateCandidate with `best_index`, or
/// the reason it has none (best_index = -1).
KESTREL_HD std::uint8_t select_pixel(const std::uint16_t* vol, const StereoParams& p, int x,
                                     std::uint32_t texture_sum, int& best_index) {
  const int w = p.width;
  const int top = max_valid_index(p, x);
  best_index = -1;
  if (top < 0) return kStateUnreachable;
  int best = 0;
  int c0 = vol[x];
  for (int di = 1; di <= top; ++di) {
    const int c = vol[static_cast<std::ptrdiff_t>(di) * w + x];
    if (c <= c0) {  // ties go to the larger disparity
      c0 = c;
      best = di;
    }
  }
  if (texture_sum < p.texture_min) return kStateLowTexture;
  if (p.uniqueness > 0) {
    int second = 0xFFFF;
    for (int di = 0; di <= top; ++di) {
      if (di < best - 1 || di > best + 1) {
        second = mini(second, vol[static_cast<std::ptrdiff_t>(di) * w + x]);
      }
    }
    if (second * 100 <= c0 * (100 + p.uniqueness)) return kStateNotUnique;
  }
  best_index = best;
  return kStateCandidate;
}

/// The least cost of right pixel xr over every left pixel that sees it: min over valid d of
/// C(y, xr + d, d); 0xFFFF when none.
KESTREL_HD int right_min_at(const std::uint16_t* vol, const StereoParams& p, int xr) {
  const int w = p.width;
  int m = 0xFFFF;
  for (int di = 0; di < p.num; ++di) {
    const int x = xr + p.min_disparity + di;
    if (x >= w) break;
    m = mini(m, vol[static_cast<std::ptrdiff_t>(di) * w + x]);
  }
  return m;
}

/// Left-right check, subpixel refinement and depth range for a pixel in `state` (from
/// select_pixel); writes the disparity (+inf where none) and returns the final state.
KESTREL_HD std::uint8_t finalize_pixel(const std::uint16_t* vol, const std::uint16_t* right_min,
                                       const StereoParams& p, int x, std::uint8_t state,
                                       int best_index, float& disparity) {
  disparity = infinity_f();
  if (state != kStateCandidate) return state;
  const int w = p.width;
  const int d = p.min_disparity + best_index;
  const auto at = [&](int di, int xx) {
    return int{vol[static_cast<std::ptrdiff_t>(di) * w + xx]};
  };
  const int c0 = at(best_index, x);
  if (p.lr_max_diff >= 0) {
    const int right_best = right_min[x - d];
    int diag = c0;
    for (int j = -p.lr_max_diff; j <= p.lr_max_diff; ++j) {
      // Pixel x + j at disparity d + j sees the same right pixel (d + j <= x + j holds).
      const int xj = x + j, dj = best_index + j;
      if (j == 0 || xj < 0 || xj >= w || dj < 0 || dj >= p.num) continue;
      diag = mini(diag, at(dj, xj));
    }
    if (diag > right_best) return kStateLeftRight;
  }
  float delta = 0.0F;
  // A zero cost is an exact match: no fit (an asymmetric cost curve would bias it).
  if (p.subpixel && c0 > 0 && best_index >= 1 && best_index + 1 <= max_valid_index(p, x)) {
    const int cm = at(best_index - 1, x), cp = at(best_index + 1, x);  // d - 1 and d + 1
    const int denom = p.census ? cm + cp - 2 * c0 : maxi(cm, cp) - c0;
    if (denom > 0) delta = static_cast<float>(cm - cp) / static_cast<float>(2 * denom);
  }
  const float ds = static_cast<float>(d) + delta;
  if (ds < p.d_min_valid || ds > p.d_max_valid) return kStateDepth;
  disparity = ds;
  return kStateValid;
}

}  // namespace kestrel::gpu::device
