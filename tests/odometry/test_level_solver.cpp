// The level solver on known motions with each residual term alone and with both joined: a
// textured room corner (three planes) rendered analytically at the reference pose and at a known
// motion, reference points on a pixel grid with their exact normals. Each run must recover the
// motion from a start at the identity.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/core.hpp>
#include <vector>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/odometry/level_solver.hpp"
#include "kestrel/odometry/residual_terms.hpp"
#include "kestrel/odometry/warp_jacobian.hpp"

namespace kestrel::odometry {
namespace {

constexpr int kW = 160, kH = 120;
constexpr double kF = 150.0, kCx = 79.5, kCy = 59.5;

// Planes n . X = d in the reference frame: the back wall, a side wall and the floor of a room
// corner seen from inside (the first plane a ray meets is the one it sees).
struct Plane {
  Eigen::Vector3d n;
  double d;
};
const std::array<Plane, 3> kCorner = {Plane{Eigen::Vector3d(0, 0, 1), 1.6},
                                      Plane{Eigen::Vector3d(1, 0, 0), 0.35},
                                      Plane{Eigen::Vector3d(0, 1, 0), 0.3}};

// Grey texture painted on the surfaces (a function of the 3D point: consistent in every view).
double texture(const Eigen::Vector3d& X) {
  return 0.5 + 0.2 * std::sin(14.0 * X.x() + 5.0 * X.y()) +
         0.15 * std::cos(11.0 * X.y() - 9.0 * X.z()) + 0.1 * std::sin(13.0 * X.z() + 6.0 * X.x());
}

// The surface point (reference frame) seen at pixel (u, v) of a camera at T_cam_ref, and the
// normal of its plane; false if the ray meets none.
bool cast(const SE3& T_cam_ref, double u, double v, Eigen::Vector3d& X_ref, Eigen::Vector3d& n) {
  const SE3 T_ref_cam = T_cam_ref.inverse();
  const Eigen::Vector3d o = T_ref_cam.translation();
  const Eigen::Vector3d ray =
      T_ref_cam.rotation_matrix() * Eigen::Vector3d((u - kCx) / kF, (v - kCy) / kF, 1.0);
  double best = std::numeric_limits<double>::infinity();
  for (const Plane& p : kCorner) {
    const double s = (p.d - p.n.dot(o)) / p.n.dot(ray);
    if (s > 1e-6 && s < best) {
      best = s;
      n = p.n;
    }
  }
  if (!std::isfinite(best)) return false;
  X_ref = o + best * ray;
  return true;
}

struct Views {
  cv::Mat intensity, depth;  // CV_32F; depth in metres along the optical axis
};

Views render(const SE3& T_cam_ref) {
  Views v{cv::Mat(kH, kW, CV_32F), cv::Mat(kH, kW, CV_32F)};
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      Eigen::Vector3d X, n;
      const bool hit = cast(T_cam_ref, x, y, X, n);
      v.intensity.at<float>(y, x) = hit ? static_cast<float>(texture(X)) : 0.0F;
      v.depth.at<float>(y, x) = hit ? static_cast<float>((T_cam_ref * X).z()) : 0.0F;
    }
  }
  return v;
}

// Reference points on a grid away from the border and the corner's edges, with the
// inverse-compositional Jacobian from the image's central differences and the exact normals.
ReferenceLevel reference_level(const Views& ref) {
  ReferenceLevel L;
  L.fx = L.fy = static_cast<float>(kF);
  L.cx = static_cast<float>(kCx);
  L.cy = static_cast<float>(kCy);
  L.width = kW;
  L.height = kH;
  std::vector<Eigen::Vector3d> P, N;
  std::vector<Vector8d> J;
  std::vector<double> I;
  for (int y = 6; y < kH - 6; y += 2) {
    for (int x = 6; x < kW - 6; x += 2) {
      Eigen::Vector3d X, n;
      if (!cast(SE3(), x, y, X, n)) continue;
      const float* row = ref.intensity.ptr<float>(y);
      const double gx = 0.5 * static_cast<double>(row[x + 1] - row[x - 1]);
      const double gy = 0.5 * static_cast<double>(ref.intensity.at<float>(y + 1, x) -
                                                  ref.intensity.at<float>(y - 1, x));
      if (gx * gx + gy * gy < 1e-6) continue;
      P.push_back(X);
      N.push_back(n.dot(X) > 0.0 ? Eigen::Vector3d(-n) : n);  // facing the camera
      I.push_back(row[x]);
      J.push_back(photometric_jacobian(X, gx, gy, kF, kF, row[x]));
    }
  }
  const auto count = static_cast<int>(P.size());
  const auto padded = static_cast<std::size_t>(kernels::pad_to_lanes(count));
  for (auto* v : {&L.x, &L.y, &L.z, &L.intensity, &L.nx, &L.ny, &L.nz, &L.n_dot_p}) {
    v->assign(padded, 0.0F);
  }
  for (auto& col : L.jac) col.assign(padded, 0.0F);
  L.has_normal.assign(padded, 0);
  for (std::size_t i = 0; i < P.size(); ++i) {
    L.x[i] = static_cast<float>(P[i].x());
    L.y[i] = static_cast<float>(P[i].y());
    L.z[i] = static_cast<float>(P[i].z());
    L.intensity[i] = static_cast<float>(I[i]);
    for (std::size_t c = 0; c < 8; ++c)
      L.jac[c][i] = static_cast<float>(J[i](static_cast<long>(c)));
    L.nx[i] = static_cast<float>(N[i].x());
    L.ny[i] = static_cast<float>(N[i].y());
    L.nz[i] = static_cast<float>(N[i].z());
    L.n_dot_p[i] = static_cast<float>(N[i].dot(P[i]));
    L.has_normal[i] = 1;
  }
  L.count = count;
  L.normal_count = count;
  L.median_depth = 1.6;
  return L;
}

enum class Terms { kPhotometric, kPointToPlane, kBoth };

struct Solved {
  SE3 T_cur_ref;
  LevelEnd end = LevelEnd::kFailed;
  TrackResult result;
};

Solved solve(Terms which, const ReferenceLevel& L, const Views& cur) {
  TermBuffers photometric_buffers, geometric_buffers;
  const auto n = L.x.size();
  photometric_buffers.reserve(n);
  geometric_buffers.reserve(n);
  geometric_buffers.reserve_jacobian(n);
  photometric_buffers.pad(L.count);
  geometric_buffers.pad(L.count);
  std::vector<float> scratch(n);
  constexpr float kC = 4.6851F;
  PhotometricTerm photometric(L, cur.intensity, kernels::Sampling::kBicubic, photometric_buffers,
                              kC, {8, 0.5 / 255.0, 1e-6, 0.0});
  PointToPlaneTerm geometric(L, cur.depth, 0.05F, geometric_buffers, kC, {6, 1e-5, 0.0, 5e-5});
  std::vector<ResidualTerm*> terms;
  if (which != Terms::kPointToPlane) terms.push_back(&photometric);
  if (which != Terms::kPhotometric) terms.push_back(&geometric);
  SolverRules rules;
  rules.max_iterations = 100;
  rules.estimate_gain_bias = which != Terms::kPointToPlane;  // no gain/bias without intensities
  Solved out;
  Estimate estimate;  // from the identity
  LevelSolver solver(terms, rules, 0, L.count, scratch.data(), estimate, out.result);
  out.end = solver.run();
  out.T_cur_ref = estimate.T_cur_ref;
  return out;
}

class LevelSolverKnownMotion : public ::testing::TestWithParam<Terms> {};

TEST_P(LevelSolverKnownMotion, RecoversTheMotionOfARenderedCorner) {
  const Views ref = render(SE3());
  const ReferenceLevel L = reference_level(ref);
  ASSERT_GT(L.count, 1000);
  // 1.2 cm and 0.8 deg: a few pixels, within one level's reach.
  const SE3 truth = SE3::exp((Vector6d() << 0.008, -0.005, 0.007, 0.006, -0.011, 0.004).finished());
  const Views cur = render(truth);
  const Solved s = solve(GetParam(), L, cur);
  ASSERT_NE(s.end, LevelEnd::kFailed) << s.result.failure_detail;
  const SE3 error = truth.inverse() * s.T_cur_ref;
  EXPECT_LT(error.translation().norm(), 1e-3) << "m";
  EXPECT_LT(error.so3().log().norm() * 180.0 / std::numbers::pi, 0.02) << "deg";
  // The start was far from it: the solver moved.
  EXPECT_GT(truth.translation().norm(), 10.0 * error.translation().norm());
}

INSTANTIATE_TEST_SUITE_P(EachTermAloneAndJoined, LevelSolverKnownMotion,
                         ::testing::Values(Terms::kPhotometric, Terms::kPointToPlane, Terms::kBoth),
                         [](const ::testing::TestParamInfo<Terms>& p) {
                           switch (p.param) {
                             case Terms::kPhotometric:
                               return "Photometric";
                             case Terms::kPointToPlane:
                               return "PointToPlane";
                             default:
                               return "Both";
                           }
                         });

// No overlap: the primary term's points all leave the image, and the solver says so.
TEST(LevelSolver, ReportsNoOverlapWhenThePointsLeaveTheImage) {
  const Views ref = render(SE3());
  const ReferenceLevel L = reference_level(ref);
  TermBuffers buffers;
  buffers.reserve(L.x.size());
  buffers.pad(L.count);
  std::vector<float> scratch(L.x.size());
  PhotometricTerm photometric(L, ref.intensity, kernels::Sampling::kBilinear, buffers, 4.6851F,
                              {8, 0.5 / 255.0, 1e-6, 0.0});
  ResidualTerm* terms[] = {&photometric};
  Estimate estimate{SE3::exp((Vector6d() << 0, 0, 0, 0, 1.2, 0).finished())};  // 69 deg pan
  TrackResult result;
  LevelSolver solver(terms, SolverRules{}, 0, L.count, scratch.data(), estimate, result);
  EXPECT_EQ(solver.run(), LevelEnd::kFailed);
  EXPECT_EQ(result.failure, TrackFailure::kNoOverlap);
  EXPECT_LT(result.overlap, 0.05);
}

}  // namespace
}  // namespace kestrel::odometry
