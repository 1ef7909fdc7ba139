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
                                   float max_relative_spread, TermBuffers& buffers, float tukey_c,
                                   const ScaleRule& rule)
    : ResidualTerm(buffers, L.count, tukey_c, rule),
      L_(L),
      depth_(depth),
      max_spread_(max_relative_spread) {}

namespace {

// v[i] *= s[i] over one array at a time: the arrays do not alias, so the loop vectorises (one
// loop over all seven arrays per point did not).
void scale_rows(const float* __restrict s, int n, float* __restrict v) {
  for (int i = 0; i < n; ++i) v[i] *= s[i];
}

}  // namespace

int PointToPlaneTerm::evaluate(const Estimate& e) {
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
  // Each residual in units of a point at the median depth (ReferenceLevel::depth_noise_scale).
  if (!L_.depth_noise_scale.empty()) {
    scale_rows(L_.depth_noise_scale.data(), L_.count, b_.residual.data());
    for (float* col : jac) scale_rows(L_.depth_noise_scale.data(), L_.count, col);
  }
  return valid_;
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
