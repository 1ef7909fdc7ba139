// Undistortion maps (cv::initUndistortRectifyMap) built once per camera, applied to float
// images by the remap row kernels.
#include "kestrel/image/undistortion.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "kestrel/image/row_kernels.hpp"

namespace kestrel::image {
namespace {

// The first tap and the weight of a bilinear lookup at s in an axis of n >= 2 samples, the
// border replicated: below 0 both taps are sample 0, from n - 1 on both are sample n - 1.
void bilinear_tap(float s, int n, int& first, float& weight) {
  const float f = std::floor(s);
  if (!(s > 0.0F)) {  // also NaN: the border sample
    first = 0;
    weight = 0.0F;
  } else if (f >= static_cast<float>(n - 1)) {
    first = n - 2;
    weight = 1.0F;
  } else {
    first = static_cast<int>(f);
    weight = s - f;
  }
}

// The source as the kernels need it: continuous (they index rows by the width) and apart from
// the output (an in-place call would overwrite pixels still to be read).
const cv::Mat& readable_source(const cv::Mat& in, const cv::Mat& out, cv::Mat& scratch) {
  if (in.isContinuous() && in.data != out.data) return in;
  in.copyTo(scratch);
  return scratch;
}

}  // namespace

Undistorter::Undistorter(const PinholeCamera& distorted)
    : undistorted_(distorted.without_distortion()), identity_(!distorted.has_distortion()) {
  if (identity_) return;
  const auto& d = distorted.distortion();
  cv::Mat K = (cv::Mat_<double>(3, 3) << distorted.fx(), 0.0, distorted.cx(), 0.0, distorted.fy(),
               distorted.cy(), 0.0, 0.0, 1.0);
  cv::Mat D = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  const cv::Size size(distorted.width(), distorted.height());
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, size, CV_16SC2, map1_, map2_);
  cv::Mat map_float;
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, size, CV_32FC2, map_float, cv::noArray());
  // Nearest-neighbour map: round the float map once, so remap does no interpolation.
  cv::Mat no_map2, unused;
  cv::convertMaps(map_float, no_map2, map_nearest_, unused, CV_16SC2, true);

  const int w = size.width, h = size.height;
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  bilinear_index_.resize(n);
  weight_x_.resize(n);
  weight_y_.resize(n);
  nearest_index_.resize(n);
  for (int v = 0; v < h; ++v) {
    const auto* m = map_float.ptr<cv::Vec2f>(v);
    for (int u = 0; u < w; ++u) {
      const std::size_t i =
          static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u);
      int x0 = 0, y0 = 0;
      bilinear_tap(m[u][0], w, x0, weight_x_[i]);
      bilinear_tap(m[u][1], h, y0, weight_y_[i]);
      bilinear_index_[i] = y0 * w + x0;
      // Round half to even, as cv::convertMaps does for the nearest-neighbour map.
      const long xn = std::lrint(m[u][0]), yn = std::lrint(m[u][1]);
      const bool inside = xn >= 0 && xn < w && yn >= 0 && yn < h;
      nearest_index_[i] = inside ? static_cast<std::int32_t>(yn * w + xn) : -1;
    }
  }
}

bool Undistorter::by_table(const cv::Mat& in) const {
  return in.type() == CV_32FC1 && in.cols == undistorted_.width() &&
         in.rows == undistorted_.height();
}

template <class RowKernel>
void Undistorter::remap_rows(const cv::Mat& in, cv::Mat& out, RowKernel row_kernel) const {
  const int w = undistorted_.width(), h = undistorted_.height();
  cv::Mat scratch;
  const cv::Mat& src = readable_source(in, out, scratch);
  out.create(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    row_kernel(src.ptr<float>(), static_cast<std::size_t>(v) * static_cast<std::size_t>(w),
               out.ptr<float>(v), w);
  }
}

void Undistorter::undistort_intensity(const cv::Mat& in, cv::Mat& out) const {
  if (identity_) {
    in.copyTo(out);
  } else if (!by_table(in)) {
    // Replicated border: a constant one would put false edges where the warp samples.
    cv::remap(in, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  } else {
    remap_rows(in, out, [this](const float* src, std::size_t row, float* dst, int w) {
      kernels::remap_bilinear_row(src, w, source_count(), bilinear_index_.data() + row,
                                  weight_x_.data() + row, weight_y_.data() + row, dst, w);
    });
  }
}

void Undistorter::undistort_depth(const cv::Mat& in, cv::Mat& out) const {
  if (identity_) {
    in.copyTo(out);
  } else if (!by_table(in)) {
    cv::remap(in, out, map_nearest_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
              cv::Scalar(0));
  } else {
    remap_rows(in, out, [this](const float* src, std::size_t row, float* dst, int w) {
      kernels::remap_nearest_row(src, source_count(), nearest_index_.data() + row, dst, w);
    });
  }
}

}  // namespace kestrel::image
