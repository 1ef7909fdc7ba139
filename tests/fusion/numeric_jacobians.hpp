// Finite-difference Jacobians of the fusion's models, to check the analytic ones against
// (test_ekf_jacobians.cpp, test_time_offset.cpp).
#pragma once

#include "kestrel/fusion/stochastic_cloning_ekf.hpp"

namespace kestrel::fusion::numeric {

/// The relative-pose measurement Jacobian by central differences of step `h` over every
/// error-state entry: the residual r(z, h(x + dx)) ~ -H dx for a fixed measurement z = h(x).
inline Matrix6xs measurement_jacobian(const NominalState& x, double h = 1e-6) {
  using Ekf = StochasticCloningEkf;
  const SE3 z = Ekf::predict_relative_pose(x);
  Matrix6xs H;
  for (int j = 0; j < idx::kDim; ++j) {
    VectorXs d = VectorXs::Zero();
    d(j) = h;
    const Vector6d rp = Ekf::residual(z, Ekf::predict_relative_pose(x.boxplus(d)));
    const Vector6d rm = Ekf::residual(z, Ekf::predict_relative_pose(x.boxplus(-d)));
    H.col(j) = -(rp - rm) / (2 * h);
  }
  return H;
}

}  // namespace kestrel::fusion::numeric
