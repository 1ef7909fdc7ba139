// Rigid alignment: recovers known motions exactly, is a proper rotation, and is optimal.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "kestrel/eval/alignment.hpp"

namespace kestrel::eval {
namespace {

double sum_squared_error(const SE3& T, const std::vector<Eigen::Vector3d>& source,
                         const std::vector<Eigen::Vector3d>& target) {
  double sum = 0.0;
  for (std::size_t i = 0; i < source.size(); ++i) sum += (T * source[i] - target[i]).squaredNorm();
  return sum;
}

SE3 random_motion(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector6d xi;
  for (int k = 0; k < 6; ++k) xi[k] = 3.0 * u(rng);
  return SE3::exp(xi);
}

std::vector<Eigen::Vector3d> random_points(std::mt19937& rng, std::size_t n) {
  std::normal_distribution<double> g(0.0, 2.0);
  std::vector<Eigen::Vector3d> points;
  for (std::size_t i = 0; i < n; ++i) points.emplace_back(g(rng), g(rng), g(rng));
  return points;
}

TEST(Alignment, RecoversRandomRigidMotionsExactly) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 100; ++trial) {
    const SE3 T_target_source = random_motion(rng);
    const auto source = random_points(rng, 3 + static_cast<std::size_t>(trial));
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : source) target.push_back(T_target_source * p);
    const SE3 T = align_rigid(source, target);
    EXPECT_LT((T.matrix() - T_target_source.matrix()).norm(), 1e-9) << trial;
    EXPECT_LT(sum_squared_error(T, source, target), 1e-18) << trial;
  }
}

TEST(Alignment, NeverReturnsAReflection) {
  // A mirrored copy is best fitted by a reflection; the fix must give a rotation instead.
  std::mt19937 rng(2);
  for (int trial = 0; trial < 50; ++trial) {
    const auto source = random_points(rng, 10);
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : source) target.emplace_back(-p.x(), p.y(), p.z());
    const SE3 T = align_rigid(source, target);
    EXPECT_NEAR(T.rotation_matrix().determinant(), 1.0, 1e-12);
    EXPECT_LT((T.rotation_matrix() * T.rotation_matrix().transpose() - Eigen::Matrix3d::Identity())
                  .norm(),
              1e-12);
  }
}

TEST(Alignment, IsALeastSquaresMinimum) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T_true = random_motion(rng);
    const auto source = random_points(rng, 30);
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : source) {
      target.push_back(T_true * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
    const SE3 T = align_rigid(source, target);
    const double best = sum_squared_error(T, source, target);
    for (int k = 0; k < 12; ++k) {
      Vector6d delta = Vector6d::Zero();
      delta[k % 6] = (k < 6 ? 1e-4 : -1e-4);
      EXPECT_GT(sum_squared_error(SE3::exp(delta) * T, source, target), best) << trial;
    }
  }
}

TEST(Alignment, RefusesTooFewOrUnequalPoints) {
  const std::vector<Eigen::Vector3d> two(2, Eigen::Vector3d::Zero());
  const std::vector<Eigen::Vector3d> three(3, Eigen::Vector3d::Zero());
  EXPECT_THROW(align_rigid(two, two), std::invalid_argument);
  EXPECT_THROW(align_rigid(three, two), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::eval
