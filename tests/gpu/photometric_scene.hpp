// A reference level with its Jacobians and a current image, built like the tracker builds them
// (central gradients, odometry::photometric_jacobian), for the photometric-step tests and bench.
#pragma once

#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <random>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/image/gradient.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"

namespace kestrel::gpu::test {

struct PhotometricScene {
  cv::Mat reference, current;  ///< CV_32FC1 in [0, 1]
  odometry::ReferenceLevel level;
  SE3 T_cur_ref;
};

/// `points` reference points at random pixels and depths in [0.8, 4] m (a few with depths that
/// put them behind or at the camera, a few near the border so that they leave the image);
/// the current image is the reference shifted by (1.3, -0.7) px with noise.
inline PhotometricScene photometric_scene(int width, int height, int points, std::uint64_t seed) {
  PhotometricScene s;
  cv::RNG cvrng(seed);
  cv::Mat noise(height, width, CV_32F);
  cvrng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, s.reference, cv::Size(0, 0), 2.0);
  cv::normalize(s.reference, s.reference, 0.05, 0.95, cv::NORM_MINMAX);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1.3, 0, 1, -0.7);
  cv::warpAffine(s.reference, s.current, shift, s.reference.size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT_101);
  cv::Mat n(height, width, CV_32F);
  cvrng.fill(n, cv::RNG::NORMAL, 0.0, 0.01);
  s.current += n;
  cv::Mat gx, gy;
  image::central_gradients(s.reference, gx, gy);

  odometry::ReferenceLevel& L = s.level;
  L.fx = 0.8F * static_cast<float>(width);
  L.fy = L.fx;
  L.cx = 0.5F * static_cast<float>(width) - 0.5F;
  L.cy = 0.5F * static_cast<float>(height) - 0.5F;
  L.width = width;
  L.height = height;
  L.count = points;
  auto n_pts = static_cast<std::size_t>(points);
  for (auto* v : {&L.x, &L.y, &L.z, &L.intensity}) v->resize(n_pts);
  for (auto& c : L.jac) c.resize(n_pts);
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> ux(1, width - 2), uy(1, height - 2);
  std::uniform_real_distribution<double> uz(0.8, 4.0);
  for (std::size_t i = 0; i < n_pts; ++i) {
    const int u = ux(rng), v = uy(rng);
    double z = uz(rng);
    if (i % 997 == 5) z = 0.0005;  // at the camera: never inside
    const double fx = L.fx, fy = L.fy, cx = L.cx, cy = L.cy;
    const Eigen::Vector3d P((u - cx) / fx * z, (v - cy) / fy * z, z);
    const float i_ref = s.reference.at<float>(v, u);
    const odometry::Vector8d J =
        odometry::photometric_jacobian(P, gx.at<float>(v, u), gy.at<float>(v, u), fx, fy, i_ref);
    L.x[i] = static_cast<float>(P.x());
    L.y[i] = static_cast<float>(P.y());
    L.z[i] = static_cast<float>(P.z());
    L.intensity[i] = i_ref;
    for (std::size_t c = 0; c < 8; ++c) L.jac[c][i] = static_cast<float>(J(static_cast<long>(c)));
  }
  Vector6d xi;
  xi << 0.02, -0.01, 0.03, 0.01, -0.02, 0.005;
  s.T_cur_ref = SE3::exp(xi);
  return s;
}

}  // namespace kestrel::gpu::test
