// Rigid alignment of two point sets (Horn 1987 / Umeyama 1991 without scale), as in the TUM
// benchmark's evaluate_ate.py.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "kestrel/geometry/se3.hpp"

namespace kestrel::eval {

/// The rigid motion T that minimises sum_i |T p_source[i] - p_target[i]|^2 (rotation and
/// translation, no scale). With the point sets of an estimate and its ground truth,
/// T = T_gtworld_estworld. Needs at least 3 pairs of equal-size sets (throws
/// std::invalid_argument otherwise); for degenerate (collinear) sets the rotation about the
/// line is arbitrary but the alignment error is still minimal.
SE3 align_rigid(const std::vector<Eigen::Vector3d>& p_source,
                const std::vector<Eigen::Vector3d>& p_target);

}  // namespace kestrel::eval
