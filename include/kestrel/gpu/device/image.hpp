// Image pyramids and gradients per output pixel, as the CUDA kernels run them
// (src/gpu/cuda/image_kernels.cu) and the CPU tests emulate them: the arithmetic of
// image::downsample_intensity / downsample_depth / central_gradients (src/image).
#pragma once

#include "kestrel/gpu/device/hd.hpp"

namespace kestrel::gpu::device {

/// Output pixel (x, y) of the 2x2 mean (image::downsample_intensity, box filter).
KESTREL_HD float mean_2x2_at(const float* in, int pitch, int x, int y) {
  const float* r0 = in + static_cast<std::ptrdiff_t>(2 * y) * pitch;
  const float* r1 = r0 + pitch;
  return 0.25F * ((r0[2 * x] + r0[2 * x + 1]) + (r1[2 * x] + r1[2 * x + 1]));
}

/// Output pixel (x, y) of image::downsample_depth: the mean of the valid depths of the 2x2
/// block within max_relative_spread of its nearest one; 0 when none is valid.
KESTREL_HD float depth_2x2_at(const float* in, int pitch, int x, int y, float max_relative_spread) {
  const float* r0 = in + static_cast<std::ptrdiff_t>(2 * y) * pitch;
  const float* r1 = r0 + pitch;
  const float d[4] = {r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]};
  const float inf = infinity_f();
  float z_min = inf;
  for (float v : d) z_min = (v > 0.0F && v < inf && v < z_min) ? v : z_min;  // rejects NaN too
  const float limit = z_min * (1.0F + max_relative_spread);
  float sum = 0.0F;
  float n = 0.0F;
  for (float v : d) {
    const bool use = v > 0.0F && v <= limit && v < inf;
    sum += use ? v : 0.0F;
    n += use ? 1.0F : 0.0F;
  }
  return n > 0.0F ? sum / n : 0.0F;
}

/// OpenCV's BORDER_REFLECT_101 index (gfedcb|abcdefgh|gfedcba).
KESTREL_HD int reflect101(int i, int n) {
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * n - 2 - i;  // cv::borderInterpolate
  return i;
}

/// The 5-tap Gaussian (k[0] centre, k[1], k[2] the sides) along a row at (x, y), in the
/// order of OpenCV's symmetric row filter: c k0 + (l1 + r1) k1 + (l2 + r2) k2.
KESTREL_HD float gaussian5_row_at(const float* in, int pitch, int w, int x, int y, const float* k) {
  const float* row = in + static_cast<std::ptrdiff_t>(y) * pitch;
  return row[x] * k[0] + (row[reflect101(x - 1, w)] + row[reflect101(x + 1, w)]) * k[1] +
         (row[reflect101(x - 2, w)] + row[reflect101(x + 2, w)]) * k[2];
}

/// The same along a column (OpenCV's symmetric column filter: k0 c, then += k1 (u1 + d1),
/// then += k2 (u2 + d2)).
KESTREL_HD float gaussian5_column_at(const float* in, int pitch, int h, int x, int y,
                                     const float* k) {
  const auto at = [&](int yy) {
    return in[static_cast<std::ptrdiff_t>(reflect101(yy, h)) * pitch + x];
  };
  float s = k[0] * at(y);
  s += k[1] * (at(y - 1) + at(y + 1));
  s += k[2] * (at(y - 2) + at(y + 2));
  return s;
}

/// Output pixel (x, y) of the Gaussian pyramid step: the 2x2 mean of the column-filtered values
/// of the row-filtered image `rows` (full resolution, height h).
KESTREL_HD float gaussian_mean_2x2_at(const float* rows, int pitch, int h, int x, int y,
                                      const float* k) {
  const float a = gaussian5_column_at(rows, pitch, h, 2 * x, 2 * y, k);
  const float b = gaussian5_column_at(rows, pitch, h, 2 * x + 1, 2 * y, k);
  const float c = gaussian5_column_at(rows, pitch, h, 2 * x, 2 * y + 1, k);
  const float d = gaussian5_column_at(rows, pitch, h, 2 * x + 1, 2 * y + 1, k);
  return 0.25F * ((a + b) + (c + d));
}

/// Central differences (I(x+1) - I(x-1)) / 2 and (I(y+1) - I(y-1)) / 2; 0 on the border.
KESTREL_HD void central_gradient_at(const float* in, int pitch, int w, int h, int x, int y,
                                    float& gx, float& gy) {
  if (x < 1 || y < 1 || x >= w - 1 || y >= h - 1) {
    gx = 0.0F;
    gy = 0.0F;
    return;
  }
  const float* mid = in + static_cast<std::ptrdiff_t>(y) * pitch;
  gx = 0.5F * (mid[x + 1] - mid[x - 1]);
  gy = 0.5F * (mid[x + pitch] - mid[x - pitch]);
}

}  // namespace kestrel::gpu::device
