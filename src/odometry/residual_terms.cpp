// The residual terms of the direct alignment (residual_terms.hpp).
#include "kestrel/odometry/residual_terms.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "kestrel/odometry/robust_weights.hpp"

namespace kestrel::odometry {

void TermBuffers::reserve(std::size_t n) {
  if (residual.size() < n) {
    residual.resize(n);
    weight.resize(n);
    valid.resize(n);
  }
}

void TermBuffers::reserve_jacobian(std::size_t n) {
  if (jac[0].size() < n) {
    for (auto& col : jac) col.assign(n, 0.0F);
  }
}

void TermBuffers::pad(int count) {
  for (int i = count; i < kernels::pad_to_lanes(count); ++i) {
    const auto k = static_cast<std::size_t>(i);
    weight[k] = 0.0F;
    residual[k] = 0.0F;
  }
}

void ResidualTerm::update_scale(int iteration, float* scratch) {
  if (frozen_) return;
  const kernels::AbsMedian med =
      kernels::abs_median(b_.residual.data(), b_.valid.data(), count_, median_hint_, scratch);
  median_hint_ = med.median;
  const double s =
      std::max(robust_sigma_from_median(med.median, med.valid, rule_.params), rule_.floor);
  if (iteration > 0 && std::fabs(s - sigma_) < rule_.freeze_abs + rule_.freeze_rel * s)
    frozen_ = true;
  sigma_ = s;
}

// ---------------------------------------------------------------------------------------
// Photometric

PhotometricTerm::PhotometricTerm(const ReferenceLevel& L, const cv::Mat& current,
                                 kernels::Sampling sampling, TermBuffers& buffers, float tukey_c,
                                 const ScaleRule& rule)
    : ResidualTerm(buffers, L.count, tukey_c, rule), L_(L), cur_(current), sampling_(sampling) {}

int PhotometricTerm::evaluate(const Estimate& e) {
  const kernels::PointsView points{L_.x.data(), L_.y.data(), L_.z.data(), L_.intensity.data(),
                                   L_.count};
  const kernels::LevelImage image{cur_.ptr<float>(),
                                  static_cast<int>(cur_.step1()),
                                  cur_.cols,
                                  cur_.rows,
                                  L_.fx,
                                  L_.fy,
                                  L_.cx,
                                  L_.cy};
  valid_ = kernels::warp_residuals(points, image, kernels::FloatPose::from(e.T_cur_ref),
                                   static_cast<float>(e.alpha), static_cast<float>(e.beta),
                                   b_.residual.data(), b_.valid.data(), sampling_);
  return valid_;
}

double PhotometricTerm::cost() const {
  return kernels::tukey_cost_sum(b_.residual.data(), b_.valid.data(), count_,
                                 static_cast<float>(1.0 / sigma_), c_);
}

double PhotometricTerm::weigh() {
  const kernels::WeightSums sums =
      kernels::tukey_weights(b_.residual.data(), b_.valid.data(), count_,
                             static_cast<float>(1.0 / sigma_), c_, b_.weight.data());
  inliers_ = sums.inliers;
  return sums.cost;
}

void PhotometricTerm::accumulate(Matrix8d& H, Vector8d& g) const {
  const float* J[8];
  for (std::size_t c = 0; c < 8; ++c) J[c] = L_.jac[c].data();
  kernels::accumulate_normal_equations<8>(J, L_.count, b_.weight.data(), b_.residual.data(), H, g);
}

// ---------------------------------------------------------------------------------------
// Point-to-plane

PointToPlaneTerm::PointToPlaneTerm(const ReferenceLevel& L, const cv::Mat& depth,
                                   float max_relative_spread, const SE3* T_rgb_depth,
                                   TermBuffers& buffers, float tukey_c, const ScaleRule& rule)
    : ResidualTerm(buffers, L.count, tukey_c, rule),
      L_(L),
      depth_(depth),
      max_spread_(max_relative_spread),
      T_rgb_depth_(T_rgb_depth) {}

int PointToPlaneTerm::evaluate(const Estimate& e) {
  if (T_rgb_depth_ != nullptr) {
    valid_ = evaluate_shifted(e.T_cur_ref);
    return valid_;
  }
  const kernels::PlanePointsView points{L_.x.data(),       L_.y.data(),          L_.z.data(),
                                        L_.nx.data(),      L_.ny.data(),         L_.nz.data(),
                                        L_.n_dot_p.data(), L_.has_normal.data(), L_.count};
  const kernels::LevelImage depth{depth_.ptr<float>(),
                                  static_cast<int>(depth_.step1()),
                                  depth_.cols,
                                  depth_.rows,
                                  L_.fx,
                                  L_.fy,
                                  L_.cx,
                                  L_.cy};
  float* const jac[6] = {b_.jac[0].data(), b_.jac[1].data(), b_.jac[2].data(),
                         b_.jac[3].data(), b_.jac[4].data(), b_.jac[5].data()};
  valid_ = kernels::warp_point_to_plane(points, depth, kernels::FloatPose::from(e.T_cur_ref),
                                        max_spread_, b_.residual.data(), b_.valid.data(), jac);
  return valid_;
}

// The same with the depth map taken at another time than the image
// (compensate_depth_time_offset): each sample is read where the ray was then.
int PointToPlaneTerm::evaluate_shifted(const SE3& T_cur_ref) {
  const ReferenceLevel& L = L_;
  const Eigen::Matrix3f R = T_cur_ref.rotation_matrix().cast<float>();
  const Eigen::Vector3f t = T_cur_ref.translation().cast<float>();
  const float fx = L.fx, fy = L.fy, cx = L.cx, cy = L.cy;
  const auto umax = static_cast<float>(depth_.cols - 1);
  const auto vmax = static_cast<float>(depth_.rows - 1);
  const float* data = depth_.ptr<float>();
  const auto stride = static_cast<std::ptrdiff_t>(depth_.step1());
  const float spread = 1.0F + max_spread_;
  const Eigen::Matrix3f Rs = T_rgb_depth_->rotation_matrix().cast<float>();
  const Eigen::Vector3f ts = T_rgb_depth_->translation().cast<float>();
  float* res = b_.residual.data();
  std::uint8_t* val = b_.valid.data();
  int count = 0;
  for (int i = 0; i < L.count; ++i) {
    val[i] = 0;
    res[i] = 0.0F;
    if (!L.has_normal[static_cast<std::size_t>(i)]) continue;
    const Eigen::Vector3f P(L.x[static_cast<std::size_t>(i)], L.y[static_cast<std::size_t>(i)],
                            L.z[static_cast<std::size_t>(i)]);
    const Eigen::Vector3f X = R * P + t;
    if (!(X.z() > 1e-3F)) continue;
    float u = fx * X.x() / X.z() + cx;
    float v = fy * X.y() / X.z() + cy;
    // Where the ray was when the depth map was taken.
    const Eigen::Vector3f ray =
        Rs.transpose() * Eigen::Vector3f((u - cx) / fx, (v - cy) / fy, 1.0F);
    if (!(ray.z() > 1e-6F)) continue;
    u = fx * ray.x() / ray.z() + cx;
    v = fy * ray.y() / ray.z() + cy;
    if (!(u >= 0.0F && u < umax && v >= 0.0F && v < vmax)) continue;
    const int u0 = static_cast<int>(u);
    const int v0 = static_cast<int>(v);
    const float* p = data + v0 * stride + u0;
    const float z00 = p[0], z01 = p[1], z10 = p[stride], z11 = p[stride + 1];
    if (!(z00 > 0.0F && z01 > 0.0F && z10 > 0.0F && z11 > 0.0F && z00 < 1e3F && z01 < 1e3F &&
          z10 < 1e3F && z11 < 1e3F)) {
      continue;
    }
    const float zmin = std::min(std::min(z00, z01), std::min(z10, z11));
    const float zmax = std::max(std::max(z00, z01), std::max(z10, z11));
    if (zmax > spread * zmin) continue;
    const float a = u - static_cast<float>(u0);
    const float b = v - static_cast<float>(v0);
    const float z = (1.0F - b) * ((1.0F - a) * z00 + a * z01) + b * ((1.0F - a) * z10 + a * z11);
    // Q_cur back-projected at (u, v), moved to the image's time, into the reference frame.
    const Eigen::Vector3f Q = Rs * Eigen::Vector3f((u - cx) / fx * z, (v - cy) / fy * z, z) + ts;
    const Eigen::Vector3f Q_ref = R.transpose() * (Q - t);
    const auto k = static_cast<std::size_t>(i);
    const float nx = L.nx[k], ny = L.ny[k], nz = L.nz[k];
    res[i] = nx * Q_ref.x() + ny * Q_ref.y() + nz * Q_ref.z() - L.n_dot_p[k];
    // J_g = -[n, Q_ref x n] (point_to_plane_pose_jacobian).
    b_.jac[0][k] = -nx;
    b_.jac[1][k] = -ny;
    b_.jac[2][k] = -nz;
    b_.jac[3][k] = -(Q_ref.y() * nz - Q_ref.z() * ny);
    b_.jac[4][k] = -(Q_ref.z() * nx - Q_ref.x() * nz);
    b_.jac[5][k] = -(Q_ref.x() * ny - Q_ref.y() * nx);
    val[i] = 1;
    ++count;
  }
  return count;
}

// Points with a normal whose sample is missing cost the maximum, like photometric points
// outside the image; points without a normal take no part (they are invalid, so the kernel
// counts each at the maximum: taken off again).
double PointToPlaneTerm::cost_without_normals() const {
  return static_cast<double>(c_ * c_ / 6.0F) * (L_.count - L_.normal_count);
}

double PointToPlaneTerm::cost() const {
  return kernels::tukey_cost_sum(b_.residual.data(), b_.valid.data(), count_,
                                 static_cast<float>(1.0 / sigma_), c_) -
         cost_without_normals();
}

double PointToPlaneTerm::weigh() {
  const kernels::WeightSums sums =
      kernels::tukey_weights(b_.residual.data(), b_.valid.data(), count_,
                             static_cast<float>(1.0 / sigma_), c_, b_.weight.data());
  inliers_ = sums.inliers;
  return sums.cost - cost_without_normals();
}

void PointToPlaneTerm::accumulate(Matrix8d& H, Vector8d& g) const {
  const float* J[6];
  for (std::size_t c = 0; c < 6; ++c) J[c] = b_.jac[c].data();
  kernels::accumulate_normal_equations<6>(J, L_.count, b_.weight.data(), b_.residual.data(), H, g);
}

}  // namespace kestrel::odometry
