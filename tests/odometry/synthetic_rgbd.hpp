// A small ray-cast scene of textured rectangles for tracker tests: exact depth and a smooth,
// band-limited texture, rendered for any camera pose (until the sim renderer is used here).
#pragma once

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/odometry/direct_tracker.hpp"

namespace kestrel::test {

/// SE3::exp of the twist [tx, ty, tz, rx, ry, rz], the rotation part given in degrees.
inline SE3 motion(double tx, double ty, double tz, double rx_deg, double ry_deg, double rz_deg) {
  Vector6d xi;
  xi << tx, ty, tz, rx_deg * M_PI / 180.0, ry_deg * M_PI / 180.0, rz_deg * M_PI / 180.0;
  return SE3::exp(xi);
}

struct TexturedRect {
  Eigen::Vector3d origin;             // centre, world frame
  Eigen::Vector3d e1, e2;             // orthonormal in-plane axes
  double half_a = 1e9, half_b = 1e9;  // half extents along e1, e2
  // Texture: sum of sinusoids in the plane's (a, b) coordinates.
  std::vector<Eigen::Vector2d> freq;  // cycles per metre
  std::vector<double> phase, amp;

  [[nodiscard]] double texture(double a, double b) const {
    double s = 0.5;
    for (std::size_t k = 0; k < freq.size(); ++k) {
      s += amp[k] * std::sin(2.0 * M_PI * (freq[k].x() * a + freq[k].y() * b) + phase[k]);
    }
    return s;
  }
};

inline TexturedRect make_rect(const Eigen::Vector3d& origin, const Eigen::Vector3d& e1,
                              const Eigen::Vector3d& e2, double half_a, double half_b,
                              unsigned seed) {
  TexturedRect r{origin, e1.normalized(), e2.normalized(), half_a, half_b, {}, {}, {}};
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * M_PI);
  std::uniform_real_distribution<double> wavelength(0.12, 0.8);
  const int k = 10;
  for (int i = 0; i < k; ++i) {
    const double th = angle(rng);
    const double f = 1.0 / wavelength(rng);
    r.freq.emplace_back(f * std::cos(th), f * std::sin(th));
    r.phase.push_back(angle(rng));
    r.amp.push_back(0.38 / k * 2.0);
  }
  return r;
}

/// A box-shaped room seen from near its middle: back wall, floor, ceiling, side walls.
inline std::vector<TexturedRect> make_room(unsigned seed = 1) {
  using V = Eigen::Vector3d;
  return {make_rect(V(0, 0, 3.0), V::UnitX(), V::UnitY(), 3.0, 2.0, seed),
          make_rect(V(0, 1.2, 1.5), V::UnitX(), V::UnitZ(), 3.0, 2.0, seed + 1),
          make_rect(V(0, -1.2, 1.5), V::UnitX(), V::UnitZ(), 3.0, 2.0, seed + 2),
          make_rect(V(-1.8, 0, 1.5), V::UnitZ(), V::UnitY(), 2.0, 2.0, seed + 3),
          make_rect(V(1.8, 0, 1.5), V::UnitZ(), V::UnitY(), 2.0, 2.0, seed + 4),
          // a box face in front of the back wall: depth discontinuities
          make_rect(V(0.4, 0.2, 2.2), V::UnitX(), V::UnitY(), 0.35, 0.3, seed + 5)};
}

/// Renders intensity (CV_32FC1, [0, 1]) and depth (CV_32FC1, m) with each row v seen from the
/// camera pose T_world_cam_of_row(v) (a rolling shutter; the same pose for all rows: global).
template <typename PoseOfRow>
odometry::RgbdFrame render_rows(const std::vector<TexturedRect>& scene, const PinholeCamera& cam,
                                PoseOfRow&& T_world_cam_of_row, TimeNs t_ns = 0) {
  odometry::RgbdFrame f;
  f.t_ns = t_ns;
  f.image.create(cam.height(), cam.width(), CV_32FC1);
  f.depth_m.create(cam.height(), cam.width(), CV_32FC1);
  for (int v = 0; v < cam.height(); ++v) {
    const SE3 T_world_cam = T_world_cam_of_row(v);
    const Eigen::Matrix3d R = T_world_cam.rotation_matrix();
    const Eigen::Vector3d C = T_world_cam.translation();
    for (int u = 0; u < cam.width(); ++u) {
      const Eigen::Vector3d d_cam((u - cam.cx()) / cam.fx(), (v - cam.cy()) / cam.fy(), 1.0);
      const Eigen::Vector3d d = R * d_cam;
      double best = std::numeric_limits<double>::infinity();
      double value = 0.0;
      for (const auto& rect : scene) {
        const Eigen::Vector3d n = rect.e1.cross(rect.e2);
        const double den = d.dot(n);
        if (std::abs(den) < 1e-12) continue;
        const double t = (rect.origin - C).dot(n) / den;
        if (t <= 0.0 || t >= best) continue;
        const Eigen::Vector3d h = C + t * d - rect.origin;
        const double a = h.dot(rect.e1), b = h.dot(rect.e2);
        if (std::abs(a) > rect.half_a || std::abs(b) > rect.half_b) continue;
        best = t;
        value = rect.texture(a, b);
      }
      const bool hit = std::isfinite(best);
      f.image.at<float>(v, u) = hit ? static_cast<float>(value) : 0.0F;
      f.depth_m.at<float>(v, u) = hit ? static_cast<float>(best) : 0.0F;
    }
  }
  return f;
}

/// Renders intensity (CV_32FC1, [0, 1]) and depth (CV_32FC1, m) for camera pose T_world_cam.
inline odometry::RgbdFrame render(const std::vector<TexturedRect>& scene, const PinholeCamera& cam,
                                  const SE3& T_world_cam, TimeNs t_ns = 0) {
  return render_rows(
      scene, cam, [&T_world_cam](int) { return T_world_cam; }, t_ns);
}

/// A small camera for fast tests (320x240, ROS-like intrinsics scaled).
inline PinholeCamera test_camera() { return PinholeCamera({262.5, 262.5, 159.5, 119.5, 320, 240}); }

inline double translation_error_m(const SE3& a, const SE3& b) {
  return (a.inverse() * b).translation().norm();
}
inline double rotation_error_deg(const SE3& a, const SE3& b) {
  return (a.inverse() * b).so3().log().norm() * 180.0 / M_PI;
}

}  // namespace kestrel::test
