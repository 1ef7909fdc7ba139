// Scoring a disparity map against ground truth (fill rate, RMS error, bad-pixel share, as the
// Middlebury benchmark counts them), and loading the Middlebury pairs of ../shared/data.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

namespace kestrel::lab {

struct DisparityScore {
  std::size_t scored = 0;     ///< pixels with known truth (in the mask, if any)
  std::size_t filled = 0;     ///< of those, pixels with a disparity
  std::size_t bad = 0;        ///< of those, no disparity or |error| > threshold
  double rms_error_px = 0.0;  ///< over filled pixels
  double bad_threshold_px = 1.0;

  [[nodiscard]] double fill_rate() const { return scored ? double(filled) / double(scored) : 0.0; }
  /// Share of scored pixels that are bad; missing disparities count as bad.
  [[nodiscard]] double bad_rate() const { return scored ? double(bad) / double(scored) : 0.0; }
  /// Share of FILLED pixels off by more than the threshold.
  [[nodiscard]] double bad_rate_of_filled() const;
  [[nodiscard]] std::string describe() const;
};

/// Scores `disparity_px` (CV_32F, non-finite = none) against `truth_px` (CV_32F, 0 or
/// non-finite = unknown). `mask` (CV_8U, optional) restricts the scored pixels. Throws
/// std::invalid_argument for mismatched sizes or types.
DisparityScore score_disparity(const cv::Mat& disparity_px, const cv::Mat& truth_px,
                               double bad_threshold_px = 1.0, const cv::Mat& mask = cv::Mat());

/// A Middlebury pair with its true disparity (CV_32F px, 0 = unknown).
struct MiddleburyPair {
  std::string name;
  cv::Mat left, right;  ///< as stored (colour, CV_8UC3)
  cv::Mat truth_px;
  int max_disparity = 0;  ///< the largest true disparity (README of the data)
};

/// Loads tsukuba (im3/im4, disp3.pgm / 16), venus (im2/im6, disp2.pgm / 8) or teddy
/// (im2/im6, disp2.png / 4) from `folder` (named after the pair). Throws InputError naming
/// the file that is missing or the unknown pair.
MiddleburyPair load_middlebury_pair(const std::filesystem::path& folder);

/// A false-colour image of a disparity map (CV_8UC3, black where none), for figures.
cv::Mat colorize_disparity(const cv::Mat& disparity_px, double max_disparity_px);

}  // namespace kestrel::lab
