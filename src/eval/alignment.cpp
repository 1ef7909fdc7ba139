// Closed-form rigid alignment by SVD (Horn; Umeyama 1991 eqs. 38-40 with scale fixed to 1),
// written as evaluate_ate.py's align() so that results match it.
#include "kestrel/eval/alignment.hpp"

#include <Eigen/SVD>
#include <stdexcept>

namespace kestrel::eval {

SE3 align_rigid(const std::vector<Eigen::Vector3d>& p_source,
                const std::vector<Eigen::Vector3d>& p_target) {
  if (p_source.size() != p_target.size()) {
    throw std::invalid_argument("align_rigid: point sets differ in size");
  }
  if (p_source.size() < 3) {
    throw std::invalid_argument("align_rigid: needs at least 3 point pairs");
  }
  const double n = static_cast<double>(p_source.size());
  Eigen::Vector3d mean_source = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_target = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p_source.size(); ++i) {
    mean_source += p_source[i];
    mean_target += p_target[i];
  }
  mean_source /= n;
  mean_target /= n;
  // Cross-covariance H = sum target_c source_c^T; R = U S V^T with H = U D V^T maximises
  // trace(R^T H), i.e. minimises the squared alignment error.
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p_source.size(); ++i) {
    H += (p_target[i] - mean_target) * (p_source[i] - mean_source).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Reflection fix: if U V^T would be a reflection, flip the axis of least singular value.
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * S * svd.matrixV().transpose();
  const SO3 rotation = SO3::from_matrix(R);
  return {rotation, mean_target - rotation * mean_source};
}

}  // namespace kestrel::eval
