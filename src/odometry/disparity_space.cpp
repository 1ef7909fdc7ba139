// Disparity space (thesis 2.4, 3.6-3.7, 3.10): level cameras with the scaled baseline, the warp,
// its Jacobian, and the per-level disparity read from the full-resolution map.
#include "kestrel/odometry/disparity_space.hpp"

#include <algorithm>
#include <stdexcept>

namespace kestrel::odometry {

DisparitySpaceCamera DisparitySpaceCamera::at_level(const RectifiedStereo& rig, int level) {
  if (level < 0 || level > 30) throw std::invalid_argument("DisparitySpaceCamera: bad level");
  const double scale = 1.0 / static_cast<double>(1 << level);
  DisparitySpaceCamera c;
  c.f = rig.f * scale;
  c.cu = (rig.cu + 0.5) * scale - 0.5;  // pixel centres of the 2x2 box pyramid
  c.cv = (rig.cv + 0.5) * scale - 0.5;
  c.baseline_m = rig.baseline_m / scale;  // thesis 3.10: B_l = 2^l B, d in level-0 pixels
  return c;
}

Eigen::Matrix4d DisparitySpaceCamera::gamma() const {
  Eigen::Matrix4d G = Eigen::Matrix4d::Zero();
  G(0, 0) = 1.0;  // x = f X / Z  ->  (Z / f) x = X
  G(1, 1) = 1.0;
  G(2, 3) = baseline_m;  // (Z / f) d = B
  G(3, 2) = 1.0 / f;     // (Z / f) 1 = Z / f
  return G;
}

Eigen::Vector3d disparity_warp(const DisparitySpaceCamera& camera, const Eigen::Vector3d& uvd,
                               const SE3& T_cur_ref) {
  // Eq. 3.34 with the third row: p' ~ Gamma T Gamma^-1 p on p = (x, y, d, 1).
  const Eigen::Matrix4d G = camera.gamma();
  const Eigen::Matrix4d H = G * T_cur_ref.matrix() * G.inverse();
  const Eigen::Vector4d p(uvd.x() - camera.cu, uvd.y() - camera.cv, uvd.z(), 1.0);
  const Eigen::Vector4d q = H * p;
  return {q.x() / q.w() + camera.cu, q.y() / q.w() + camera.cv, q.z() / q.w()};
}

Eigen::Matrix<double, 3, 6> disparity_warp_jacobian(const DisparitySpaceCamera& camera, double u,
                                                    double v, double d) {
  const double x = u - camera.cu;
  const double y = v - camera.cv;
  const double f = camera.f;
  const double beta = d / camera.baseline_m;  // 1 / Z = beta / f
  Eigen::Matrix<double, 3, 6> J;
  J << beta, 0.0, -beta * x / f, -x * y / f, f + x * x / f, -y,  //
      0.0, beta, -beta * y / f, -f - y * y / f, x * y / f, x,    //
      0.0, 0.0, -beta * d / f, -y * d / f, x * d / f, 0.0;
  return J;
}

void disparity_at_level(const cv::Mat& disparity_px, int level, float max_relative_spread,
                        cv::Mat& out) {
  if (disparity_px.type() != CV_32FC1 || level < 0 || level > 15) {
    throw std::invalid_argument("disparity_at_level: expected CV_32FC1 and a level in [0, 15]");
  }
  const int w = disparity_px.cols >> level;
  const int h = disparity_px.rows >> level;
  out.create(std::max(h, 0), std::max(w, 0), CV_32FC1);
  // A finite positive disparity; everything else (<= 0, NaN, inf) is none.
  auto valid = [](float d) { return d > 0.0F && d < 1e30F; };
  if (level == 0) {
    for (int y = 0; y < h; ++y) {
      const float* in = disparity_px.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < w; ++x) o[x] = valid(in[x]) ? in[x] : 0.0F;
    }
    return;
  }
  // The 2x2 full-resolution samples nearest the centre (u + 0.5) 2^l - 0.5 of level pixel u.
  const int step = 1 << level;
  const int offset = (step >> 1) - 1;
  for (int y = 0; y < h; ++y) {
    const float* r0 = disparity_px.ptr<float>(y * step + offset);
    const float* r1 = disparity_px.ptr<float>(y * step + offset + 1);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const int c = x * step + offset;
      const float a = r0[c], b = r0[c + 1], e = r1[c], g = r1[c + 1];
      const float lo = std::min(std::min(a, b), std::min(e, g));
      const float hi = std::max(std::max(a, b), std::max(e, g));
      const bool ok =
          valid(a) && valid(b) && valid(e) && valid(g) && hi - lo <= max_relative_spread * hi;
      o[x] = ok ? 0.25F * ((a + b) + (e + g)) : 0.0F;
    }
  }
}

}  // namespace kestrel::odometry
