// Rolling-shutter rectification maps for a rotating camera (see rolling_shutter.hpp).
#include "kestrel/image/rolling_shutter.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "kestrel/geometry/so3.hpp"
#include "kestrel/image/row_kernels.hpp"

namespace kestrel::image {

RollingShutterRectifier::RollingShutterRectifier(const PinholeCamera& camera, double readout_s,
                                                 Interpolation interpolation)
    : camera_(camera), readout_s_(readout_s), interpolation_(interpolation) {
  if (!std::isfinite(readout_s) || readout_s <= 0.0) {
    throw std::invalid_argument("RollingShutterRectifier: readout time must be finite and > 0");
  }
  set_rotation_rate(Eigen::Vector3d::Zero());
}

void RollingShutterRectifier::set_rotation_rate(const Eigen::Vector3d& omega_rad_s) {
  const Eigen::Vector3d w = omega_rad_s.allFinite() ? omega_rad_s : Eigen::Vector3d::Zero();
  const int W = camera_.width(), H = camera_.height();
  map_x_.create(H, W, CV_32FC1);
  map_y_.create(H, W, CV_32FC1);
  const double v_mid = 0.5 * (H - 1);
  const double fx = camera_.fx(), fy = camera_.fy(), cx = camera_.cx(), cy = camera_.cy();
  const RadTanDistortion& d = camera_.distortion();
  const kernels::DistortedPinhole cam{
      static_cast<float>(fx),   static_cast<float>(fy),   static_cast<float>(cx),
      static_cast<float>(cy),   static_cast<float>(d.k1), static_cast<float>(d.k2),
      static_cast<float>(d.k3), static_cast<float>(d.p1), static_cast<float>(d.p2)};
  for (int v = 0; v < H; ++v) {
    const double s = readout_s_ * (v - v_mid) / H;
    // The source ray of (u, v) is M (xn(u), yn, 1) with M = exp(w s)^T: linear in xn, so a
    // row is the ray at u = 0 plus u times a constant step; then the lens distortion (thesis
    // 2.2, PinholeCamera::distort), in float.
    const Eigen::Matrix3d M = SO3::exp(w * s).matrix().transpose();
    const double yn = (v - cy) / fy;
    const Eigen::Vector3d r0 = M.col(0) * (-cx / fx) + M.col(1) * yn + M.col(2);
    const Eigen::Vector3d dr = M.col(0) / fx;
    const kernels::RayRow ray{static_cast<float>(r0.x()), static_cast<float>(r0.y()),
                              static_cast<float>(r0.z()), static_cast<float>(dr.x()),
                              static_cast<float>(dr.y()), static_cast<float>(dr.z())};
    kernels::distorted_ray_row(ray, cam, map_x_.ptr<float>(v), map_y_.ptr<float>(v), W);
  }
}

void RollingShutterRectifier::rectify_intensity(const cv::Mat& raw, cv::Mat& out) const {
  const int method = interpolation_ == Interpolation::kBicubic ? cv::INTER_CUBIC : cv::INTER_LINEAR;
  cv::remap(raw, out, map_x_, map_y_, method, cv::BORDER_REPLICATE);
}

void RollingShutterRectifier::rectify_depth(const cv::Mat& raw, cv::Mat& out) const {
  cv::remap(raw, out, map_x_, map_y_, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
}

}  // namespace kestrel::image
