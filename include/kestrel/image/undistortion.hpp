// Undistortion of images from a camera with radial-tangential distortion (TUM fr1, fr2)
// onto the pinhole camera with the same K, by precomputed maps (cv::initUndistortRectifyMap).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/geometry/pinhole_camera.hpp"

namespace kestrel::image {

class Undistorter {
 public:
  /// Precomputes the maps once: for float images, each output pixel's source index and
  /// bilinear weights (the SIMD row kernels of row_kernels.hpp); for other types, cv::remap's
  /// fixed-point maps.
  explicit Undistorter(const PinholeCamera& distorted);

  /// The camera of the undistorted images: same K, no distortion.
  [[nodiscard]] const PinholeCamera& undistorted_camera() const { return undistorted_; }
  [[nodiscard]] bool is_identity() const { return identity_; }

  /// Bilinear remap of an intensity (or any float/8-bit) image; copies when is_identity().
  void undistort_intensity(const cv::Mat& in, cv::Mat& out) const;
  /// Nearest-neighbour remap of a depth map (interpolating depth would invent surfaces
  /// between foreground and background); pixels mapping outside the image get 0.
  void undistort_depth(const cv::Mat& in, cv::Mat& out) const;

 private:
  // Float images of the camera's size go through the tables, others through cv::remap.
  [[nodiscard]] bool by_table(const cv::Mat& in) const;
  // Elements of a source image the tables read from (width x height floats).
  [[nodiscard]] std::int64_t source_count() const {
    return std::int64_t{undistorted_.width()} * undistorted_.height();
  }
  // out's rows from `row_kernel(src, first index of the row, out row, width)`.
  template <class RowKernel>
  void remap_rows(const cv::Mat& in, cv::Mat& out, RowKernel row_kernel) const;

  PinholeCamera undistorted_;
  bool identity_ = true;
  // Float images (every frame of the tracker): per output pixel, the index of the top-left
  // source pixel of its bilinear block and the weights, borders replicated by clamping the
  // block into the image; and the nearest source pixel's index, -1 outside the image.
  std::vector<std::int32_t> bilinear_index_;
  std::vector<float> weight_x_, weight_y_;
  std::vector<std::int32_t> nearest_index_;
  // Other types (8-bit images): cv::remap's fixed-point maps.
  cv::Mat map1_, map2_;  // bilinear (fixed point)
  cv::Mat map_nearest_;  // CV_16SC2 integer map for nearest-neighbour
};

}  // namespace kestrel::image
