// Pinhole projection and radial-tangential distortion (thesis 2.2).
#include "kestrel/geometry/pinhole_camera.hpp"

#include <Eigen/LU>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace kestrel {

PinholeCamera::PinholeCamera(const PinholeIntrinsics& k, const RadTanDistortion& d) : k_(k), d_(d) {
  if (!(k.fx > 0.0) || !(k.fy > 0.0) || !std::isfinite(k.fx) || !std::isfinite(k.fy)) {
    throw std::invalid_argument("PinholeCamera: focal lengths must be positive and finite");
  }
  if (k.width <= 0 || k.height <= 0) {
    throw std::invalid_argument("PinholeCamera: image width and height must be positive");
  }
  if (!std::isfinite(k.cx) || !std::isfinite(k.cy)) {
    throw std::invalid_argument("PinholeCamera: principal point must be finite");
  }
  // A NaN coefficient (a bad calibration file) would otherwise surface as NaN pixels later.
  for (const double c : {d.k1, d.k2, d.p1, d.p2, d.k3}) {
    if (!std::isfinite(c)) {
      throw std::invalid_argument("PinholeCamera: distortion coefficients must be finite");
    }
  }
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d K;
  K << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1;
  return K;
}

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& xn) const {
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (d_.k1 + r2 * (d_.k2 + r2 * d_.k3));
  return {x * radial + 2.0 * d_.p1 * x * y + d_.p2 * (r2 + 2.0 * x * x),
          y * radial + d_.p1 * (r2 + 2.0 * y * y) + 2.0 * d_.p2 * x * y};
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& xd) const {
  if (d_.is_zero()) return xd;
  Eigen::Vector2d x = xd;
  for (int it = 0; it < 20; ++it) {
    const double u = x.x(), v = x.y();
    const double r2 = u * u + v * v;
    const double radial = 1.0 + r2 * (d_.k1 + r2 * (d_.k2 + r2 * d_.k3));
    const double dradial = d_.k1 + r2 * (2.0 * d_.k2 + 3.0 * r2 * d_.k3);  // d radial / d r2
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * u * u * dradial + 2.0 * d_.p1 * v + 6.0 * d_.p2 * u;
    J(0, 1) = 2.0 * u * v * dradial + 2.0 * d_.p1 * u + 2.0 * d_.p2 * v;
    J(1, 0) = 2.0 * u * v * dradial + 2.0 * d_.p1 * u + 2.0 * d_.p2 * v;
    J(1, 1) = radial + 2.0 * v * v * dradial + 6.0 * d_.p1 * v + 2.0 * d_.p2 * u;
    const Eigen::Vector2d step = J.inverse() * (distort(x) - xd);
    x -= step;
    if (step.squaredNorm() < 1e-24) break;
  }
  return x;
}

Eigen::Vector2d PinholeCamera::project(const Eigen::Vector3d& p_cam) const {
  const Eigen::Vector2d xn(p_cam.x() / p_cam.z(), p_cam.y() / p_cam.z());
  const Eigen::Vector2d xd = d_.is_zero() ? xn : distort(xn);
  return {k_.fx * xd.x() + k_.cx, k_.fy * xd.y() + k_.cy};
}

Eigen::Vector3d PinholeCamera::unproject(const Eigen::Vector2d& uv, double depth_m) const {
  const Eigen::Vector2d xd((uv.x() - k_.cx) / k_.fx, (uv.y() - k_.cy) / k_.fy);
  const Eigen::Vector2d xn = undistort(xd);
  return {xn.x() * depth_m, xn.y() * depth_m, depth_m};
}

Eigen::Vector2d PinholeCamera::undistort_pixel(const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d xd((uv.x() - k_.cx) / k_.fx, (uv.y() - k_.cy) / k_.fy);
  const Eigen::Vector2d xn = undistort(xd);
  return {k_.fx * xn.x() + k_.cx, k_.fy * xn.y() + k_.cy};
}

PinholeCamera PinholeCamera::without_distortion() const { return PinholeCamera(k_); }

PinholeCamera PinholeCamera::scaled(double s) const {
  PinholeIntrinsics k = k_;
  k.fx *= s;
  k.fy *= s;
  k.cx = (k_.cx + 0.5) * s - 0.5;
  k.cy = (k_.cy + 0.5) * s - 0.5;
  k.width = static_cast<int>(std::lround(k_.width * s));
  k.height = static_cast<int>(std::lround(k_.height * s));
  return PinholeCamera(k, d_);
}

std::string PinholeCamera::describe() const {
  std::ostringstream os;
  os << "pinhole " << k_.width << "x" << k_.height << " fx=" << k_.fx << " fy=" << k_.fy
     << " cx=" << k_.cx << " cy=" << k_.cy;
  if (has_distortion()) {
    os << " radtan=[" << d_.k1 << ", " << d_.k2 << ", " << d_.p1 << ", " << d_.p2 << ", " << d_.k3
       << "]";
  }
  return os.str();
}

PinholeCamera RectifiedStereo::left() const {
  return PinholeCamera(PinholeIntrinsics{f, f, cu, cv, width, height});
}

void RectifiedStereo::validate() const {
  if (!(f > 0.0) || !(baseline_m > 0.0) || width <= 0 || height <= 0) {
    throw std::invalid_argument(
        "RectifiedStereo: f, baseline_m, width and height must all be positive");
  }
  if (!std::isfinite(f) || !std::isfinite(baseline_m) || !std::isfinite(cu) || !std::isfinite(cv)) {
    throw std::invalid_argument("RectifiedStereo: f, baseline_m, cu and cv must be finite");
  }
}

}  // namespace kestrel
