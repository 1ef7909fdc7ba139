// The per-row loops of the image front end that run on every frame: BGR to intensity (thesis
// eq. 3.22), the 2x2 downsampling of the intensity and depth pyramids (thesis 3.10) and the
// central-difference gradients. Each is written once in portable SIMD (Google Highway, the best
// target of the CPU chosen at run time) and has one scalar reference (*_scalar) that the tests hold
// it equal to, bit for bit.
//
// Why not plain loops: GCC vectorises these strided loops (3 or 2 interleaved inputs) only with
// AVX2 or AVX-512 enabled at compile time, so a build without -march=native ran them 4-11x
// slower (docs/onboard.md, "Portable release build").
#pragma once

#include <cstdint>
#include <vector>

namespace kestrel::image::kernels {

/// out[x] = (b + g + r) / (3 * 255) of the interleaved BGR bytes bgr[3x..3x+2], x in [0, width).
void bgr_to_intensity_row(const std::uint8_t* bgr, float* out, int width);
void bgr_to_intensity_row_scalar(const std::uint8_t* bgr, float* out, int width);

/// out[x] = the mean of the 2x2 block of rows r0, r1 at columns 2x, 2x+1, x in [0, out_width).
void mean_2x2_row(const float* r0, const float* r1, float* out, int out_width);
void mean_2x2_row_scalar(const float* r0, const float* r1, float* out, int out_width);

/// out[x] = the mean of the valid depths (finite, > 0) of the 2x2 block that lie within
/// `max_relative_spread` of the block's nearest valid depth; 0 where the block has none.
void depth_2x2_row(const float* r0, const float* r1, float* out, int out_width,
                   float max_relative_spread);
void depth_2x2_row_scalar(const float* r0, const float* r1, float* out, int out_width,
                          float max_relative_spread);

/// Central differences of row `mid` (rows `up` and `down` above and below it), x in [1, width-1):
/// gx[x] = (mid[x+1] - mid[x-1]) / 2, gy[x] = (down[x] - up[x]) / 2. gx[0], gx[width-1], gy[0]
/// and gy[width-1] are left as they are.
void central_gradient_row(const float* up, const float* mid, const float* down, float* gx,
                          float* gy, int width);
void central_gradient_row_scalar(const float* up, const float* mid, const float* down, float* gx,
                                 float* gy, int width);

/// One row of a rolling-shutter rectification map: for u in [0, width) the ray
/// (r0 + u dr) is projected (x = X/Z, y = Y/Z), distorted with the radial-tangential model
/// (thesis 2.2; k = {k1, k2, k3}, p = {p1, p2}) and mapped to pixels with (f, c). Equal to the
/// scalar reference within float rounding (the two may contract a*b+c into an FMA differently).
struct RayRow {
  float r0x, r0y, r0z, dx, dy, dz;
};
struct DistortedPinhole {
  float fx, fy, cx, cy, k1, k2, k3, p1, p2;
};
void distorted_ray_row(const RayRow& ray, const DistortedPinhole& cam, float* map_x, float* map_y,
                       int width);
void distorted_ray_row_scalar(const RayRow& ray, const DistortedPinhole& cam, float* map_x,
                              float* map_y, int width);

/// One row of a precomputed bilinear remap (undistortion): out[x] blends the 2x2 block of `src`
/// whose top-left element is src[index[x]] (its lower row `stride` elements further) with the
/// weights wx[x], wy[x] in [0, 1]: top = a + wx (b - a), bottom = c + wx (d - c),
/// out = top + wy (bottom - top). Equal to the scalar reference within float rounding (the
/// SIMD version may contract a multiply-add where the reference rounds twice). `src` holds
/// `src_count` elements: the SIMD version reads whole vectors near the taps where they lie close
/// together, never past that count.
void remap_bilinear_row(const float* src, int stride, std::int64_t src_count,
                        const std::int32_t* index, const float* wx, const float* wy, float* out,
                        int width);
void remap_bilinear_row_scalar(const float* src, int stride, const std::int32_t* index,
                               const float* wx, const float* wy, float* out, int width);

/// One row of a precomputed nearest-neighbour remap: out[x] = src[index[x]], or 0 where
/// index[x] < 0 (the source pixel is outside the image). Equal to the reference bit for bit.
/// `src` holds `src_count` elements (as for remap_bilinear_row).
void remap_nearest_row(const float* src, std::int64_t src_count, const std::int32_t* index,
                       float* out, int width);
void remap_nearest_row_scalar(const float* src, const std::int32_t* index, float* out, int width);

/// The SIMD target the row kernels dispatch to on this CPU (e.g. "AVX2", "NEON"), and every
/// target compiled in that the CPU supports, best first (for tests and benchmarks).
const char* simd_target();
std::vector<std::int64_t> simd_targets();

}  // namespace kestrel::image::kernels
