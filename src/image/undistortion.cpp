// Undistortion maps (cv::initUndistortRectifyMap) built once per camera.
#include "kestrel/image/undistortion.hpp"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace kestrel::image {

Undistorter::Undistorter(const PinholeCamera& distorted)
    : undistorted_(distorted.without_distortion()), identity_(!distorted.has_distortion()) {
  if (identity_) return;
  const auto& d = distorted.distortion();
  cv::Mat K = (cv::Mat_<double>(3, 3) << distorted.fx(), 0.0, distorted.cx(), 0.0,
               distorted.fy(), distorted.cy(), 0.0, 0.0, 1.0);
  cv::Mat D = (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
  const cv::Size size(distorted.width(), distorted.height());
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, size, CV_16SC2, map1_, map2_);
  cv::Mat map_float;
  cv::initUndistortRectifyMap(K, D, cv::Mat(), K, size, CV_32FC2, map_float, cv::noArray());
  // Nearest-neighbour map: round the float map once, so remap does no interpolation.
  cv::Mat no_map2, unused;
  cv::convertMaps(map_float, no_map2, map_nearest_, unused, CV_16SC2, true);
}

void Undistorter::undistort_intensity(const cv::Mat& in, cv::Mat& out) const {
  if (identity_) {
    in.copyTo(out);
    return;
  }
  // Replicated border: a constant one would put false edges where the warp samples.
  cv::remap(in, out, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
}

void Undistorter::undistort_depth(const cv::Mat& in, cv::Mat& out) const {
  if (identity_) {
    in.copyTo(out);
    return;
  }
  cv::remap(in, out, map_nearest_, cv::noArray(), cv::INTER_NEAREST, cv::BORDER_CONSTANT,
            cv::Scalar(0));
}

}  // namespace kestrel::image
