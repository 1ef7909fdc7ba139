// The CUDA kernels of src/gpu/cuda/*.cu as plain host loops: the same device functions
// (include/kestrel/gpu/device) over the same launch decomposition (threads, row chunks,
// grid-stride loops, the warp-shuffle tree of the reduction). The CPU tests compare these with
// the CPU reference implementations, so CI, which has no GPU, checks the arithmetic the GPU runs.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/gpu/device/image.hpp"
#include "kestrel/gpu/device/photometric.hpp"
#include "kestrel/gpu/device/stereo.hpp"
#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::gpu::emulate {

/// stereo_kernels.cu: prefilter, cost, select, finalize. 8-bit grey, continuous images.
inline sensor::MatchStats match(const cv::Mat& left8, const cv::Mat& right8,
                                const device::StereoParams& p, cv::Mat& disparity) {
  CV_Assert(left8.type() == CV_8UC1 && right8.type() == CV_8UC1 && left8.isContinuous() &&
            right8.isContinuous() && left8.cols == p.width && left8.rows == p.height);
  const int w = p.width, h = p.height;
  const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const std::uint8_t* left = left8.ptr<std::uint8_t>();
  const std::uint8_t* right = right8.ptr<std::uint8_t>();
  std::vector<std::uint8_t> pre_l(pixels), pre_r(pixels), gradient(pixels), state(pixels);
  std::vector<std::uint64_t> census_l(p.census ? pixels : 0), census_r(p.census ? pixels : 0);
  // prefilter_kernel
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto i =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      gradient[i] = device::texture_gradient_at(left, w, w, x, y);
      if (p.census) {
        census_l[i] = device::census_at(left, w, w, h, x, y, p.census_radius);
        census_r[i] = device::census_at(right, w, w, h, x, y, p.census_radius);
      } else if (p.xsobel) {
        pre_l[i] = device::xsobel_at(left, w, w, h, x, y, p.prefilter_cap);
        pre_r[i] = device::xsobel_at(right, w, w, h, x, y, p.prefilter_cap);
      } else {
        pre_l[i] = left[i];
        pre_r[i] = right[i];
      }
    }
  }
  // cost_kernel: one thread per (x, di, chunk of kCostRowsPerThread rows)
  std::vector<std::uint16_t> volume(pixels * static_cast<std::size_t>(p.num));
  const int rows = device::kCostRowsPerThread;
  for (int y0 = 0; y0 < h; y0 += rows) {
    for (int di = 0; di < p.num; ++di) {
      for (int x = 0; x < w; ++x) {
        const int y1 = std::min(y0 + rows, h);
        if (p.census) {
          device::cost_column(census_l.data(), census_r.data(), w, p, x, di, y0, y1, volume.data());
        } else {
          device::cost_column(pre_l.data(), pre_r.data(), w, p, x, di, y0, y1, volume.data());
        }
      }
    }
  }
  // select_kernel
  std::vector<std::int16_t> best(pixels);
  std::vector<std::uint16_t> right_min(pixels);
  const auto plane = static_cast<std::size_t>(p.num) * static_cast<std::size_t>(w);
  for (int y = 0; y < h; ++y) {
    const std::uint16_t* vol = volume.data() + static_cast<std::size_t>(y) * plane;
    for (int x = 0; x < w; ++x) {
      const auto i =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      const std::uint32_t tex = device::texture_sum_at(gradient.data(), w, w, h, x, y, p.radius);
      int b = -1;
      state[i] = device::select_pixel(vol, p, x, tex, b);
      best[i] = static_cast<std::int16_t>(b);
      right_min[i] = static_cast<std::uint16_t>(device::right_min_at(vol, p, x));
    }
  }
  // finalize_kernel
  std::array<std::size_t, device::kStateCount> counts{};
  disparity.create(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    const std::uint16_t* vol = volume.data() + static_cast<std::size_t>(y) * plane;
    const std::size_t row = static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    float* out = disparity.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const std::uint8_t s = device::finalize_pixel(
          vol, right_min.data() + row, p, x, state[row + static_cast<std::size_t>(x)],
          best[row + static_cast<std::size_t>(x)], out[x]);
      ++counts[s];
    }
  }
  sensor::MatchStats stats;
  stats.pixels = pixels;
  stats.valid = counts[device::kStateValid];
  stats.unreachable = counts[device::kStateUnreachable];
  stats.rejected_texture = counts[device::kStateLowTexture];
  stats.rejected_uniqueness = counts[device::kStateNotUnique];
  stats.rejected_lr = counts[device::kStateLeftRight];
  stats.rejected_depth = counts[device::kStateDepth];
  return stats;
}

// image_kernels.cu (continuous CV_32FC1 images).
inline void mean_2x2(const cv::Mat& in, cv::Mat& out) {
  out.create(in.rows / 2, in.cols / 2, CV_32FC1);
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x)
      out.at<float>(y, x) = device::mean_2x2_at(in.ptr<float>(), in.cols, x, y);
  }
}

inline void gaussian_downsample(const cv::Mat& in, cv::Mat& out, const float k[3]) {
  cv::Mat rows(in.size(), CV_32FC1);
  for (int y = 0; y < in.rows; ++y) {
    for (int x = 0; x < in.cols; ++x) {
      rows.at<float>(y, x) = device::gaussian5_row_at(in.ptr<float>(), in.cols, in.cols, x, y, k);
    }
  }
  out.create(in.rows / 2, in.cols / 2, CV_32FC1);
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      out.at<float>(y, x) =
          device::gaussian_mean_2x2_at(rows.ptr<float>(), in.cols, in.rows, x, y, k);
    }
  }
}

inline void depth_2x2(const cv::Mat& in, cv::Mat& out, float spread) {
  out.create(in.rows / 2, in.cols / 2, CV_32FC1);
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      out.at<float>(y, x) = device::depth_2x2_at(in.ptr<float>(), in.cols, x, y, spread);
    }
  }
}

inline void central_gradients(const cv::Mat& in, cv::Mat& gx, cv::Mat& gy) {
  gx.create(in.size(), CV_32FC1);
  gy.create(in.size(), CV_32FC1);
  for (int y = 0; y < in.rows; ++y) {
    for (int x = 0; x < in.cols; ++x) {
      device::central_gradient_at(in.ptr<float>(), in.cols, in.cols, in.rows, x, y,
                                  gx.at<float>(y, x), gy.at<float>(y, x));
    }
  }
}

// photometric_kernels.cu
inline int warp_residuals(const device::PointsView& pts, const float* image,
                          const device::WarpParams& p, std::vector<float>& residual,
                          std::vector<std::uint8_t>& valid) {
  residual.assign(static_cast<std::size_t>(pts.count), 0.0F);
  valid.assign(static_cast<std::size_t>(pts.count), 0);
  int inside = 0;
  for (int i = 0; i < pts.count; ++i) {
    float r = 0.0F;
    const bool in =
        device::warp_residual(p, image, pts.x[i], pts.y[i], pts.z[i], pts.intensity[i], r);
    residual[static_cast<std::size_t>(i)] = r;
    valid[static_cast<std::size_t>(i)] = in ? 1 : 0;
    inside += in ? 1 : 0;
  }
  return inside;
}

/// normal_equations_kernel: per thread a grid-stride sum, per warp the __shfl_down tree
/// (offsets 16, 8, 4, 2, 1), per block the warps in order; the host then adds the blocks in
/// double. Returns the kNormalTerms sums.
inline std::array<double, device::kNormalTerms> normal_equations(const device::PointsView& pts,
                                                                 const float* residual,
                                                                 const std::uint8_t* valid,
                                                                 float inv_sigma, float c) {
  constexpr int kT = device::kNormalTerms;
  const int threads = device::kNormalThreads;
  const int blocks = device::normal_equation_blocks(pts.count);
  std::array<double, kT> sums{};
  std::vector<std::array<float, kT>> acc(static_cast<std::size_t>(threads));
  for (int b = 0; b < blocks; ++b) {
    for (int t = 0; t < threads; ++t) {
      auto& a = acc[static_cast<std::size_t>(t)];
      a.fill(0.0F);
      for (int i = b * threads + t; i < pts.count; i += blocks * threads) {
        float jac[8];
        for (int k = 0; k < 8; ++k) jac[k] = pts.jac[k][i];
        device::accumulate_point(jac, residual[i], valid[i] != 0, inv_sigma, c, a.data());
      }
    }
    for (int term = 0; term < kT; ++term) {
      float block_sum = 0.0F;
      for (int warp = 0; warp < threads / 32; ++warp) {
        float v[32];
        for (int lane = 0; lane < 32; ++lane)
          v[lane] = acc[static_cast<std::size_t>(warp * 32 + lane)][static_cast<std::size_t>(term)];
        for (int offset = 16; offset > 0; offset /= 2) {
          for (int lane = 0; lane < 32; ++lane) {  // lanes read the value before this round
            if (lane + offset < 32) v[lane] += v[lane + offset];
          }
        }
        block_sum += v[0];
      }
      sums[static_cast<std::size_t>(term)] += static_cast<double>(block_sum);
    }
  }
  return sums;
}

}  // namespace kestrel::gpu::emulate
