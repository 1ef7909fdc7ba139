// Image pyramids (thesis 3.10): each level half the previous, smoothed before scaling;
// depth pyramids that never average across occlusion boundaries or invalid pixels.
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace kestrel::image {

/// Smoothing before each halving. Both end with a 2x2 mean, so that the pixel centres of
/// level l+1 sit at the centres of 2x2 blocks of level l: c' = (c + 0.5) / 2 - 0.5, which is
/// PinholeCamera::scaled(0.5).
enum class PyramidFilter {
  kBox,       ///< 2x2 mean only (a box filter of the block)
  kGaussian,  ///< 5x5 Gaussian (sigma 1 px) and then the 2x2 mean
};
std::string_view to_string(PyramidFilter filter);
/// "box" or "gaussian"; throws std::invalid_argument otherwise.
PyramidFilter pyramid_filter_from_string(std::string_view name);
/// The options-table hook (io/option_fields.hpp): reads a filter by its name.
inline void parse_option(std::string_view name, PyramidFilter& filter) {
  filter = pyramid_filter_from_string(name);
}

/// Size of the next level: floor(w/2) x floor(h/2) (an odd last row/column is dropped so that
/// every output pixel has a full 2x2 block).
cv::Size half_size(cv::Size size);

/// Halves a CV_32FC1 intensity image into `out` (reused when sized right). `scratch` holds the
/// Gaussian-smoothed image (unused for kBox).
void downsample_intensity(const cv::Mat& in, cv::Mat& out, PyramidFilter filter, cv::Mat& scratch);

/// Halves a CV_32FC1 depth map (metres, 0 = invalid). Among the valid depths of each 2x2
/// block, only those within `max_relative_spread` of the block's nearest depth are averaged
/// (the foreground surface); the rest belong to another surface behind an occlusion boundary
/// and are left out. All-invalid blocks give 0. NaN, inf and negative depths count as invalid.
void downsample_depth(const cv::Mat& in, cv::Mat& out, float max_relative_spread = 0.03F);

/// A pyramid of `levels` images; level 0 is the input (copied into the reused buffer).
/// Buffers are kept across calls: building a pyramid of the same size allocates nothing.
/// Where level 0 is produced anyway (undistortion, colour conversion), it can be written in
/// place: fill base(), then build_from_base(), and the copy is saved.
class IntensityPyramid {
 public:
  void build(const cv::Mat& level0, int levels, PyramidFilter filter);
  /// Level 0's buffer, to be written (CV_32FC1) before build_from_base().
  [[nodiscard]] cv::Mat& base();
  /// Levels 1 .. levels-1 from base().
  void build_from_base(int levels, PyramidFilter filter);
  [[nodiscard]] int levels() const { return static_cast<int>(levels_.size()); }
  [[nodiscard]] const cv::Mat& level(int l) const { return levels_[static_cast<std::size_t>(l)]; }

 private:
  std::vector<cv::Mat> levels_;
  cv::Mat scratch_;
};

class DepthPyramid {
 public:
  void build(const cv::Mat& level0_depth_m, int levels, float max_relative_spread = 0.03F);
  /// Level 0's buffer (CV_32FC1 metres), to be written before build_from_base().
  [[nodiscard]] cv::Mat& base();
  /// Levels 1 .. levels-1 from base().
  void build_from_base(int levels, float max_relative_spread = 0.03F);
  [[nodiscard]] int levels() const { return static_cast<int>(levels_.size()); }
  [[nodiscard]] const cv::Mat& level(int l) const { return levels_[static_cast<std::size_t>(l)]; }

 private:
  /// Levels first .. size-1, each halved from the one before.
  void downsample_from(std::size_t first, float max_relative_spread);

  std::vector<cv::Mat> levels_;
};

}  // namespace kestrel::image
