// Euler angles (ZYX), angle wrapping, and the per-axis error series and CSV.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <string>

#include "kestrel/core/units.hpp"
#include "kestrel/eval/axis_errors.hpp"
#include "synthetic_trajectory.hpp"
#include "test_data.hpp"

namespace kestrel::eval {
namespace {

TEST(EulerZyx, SingleAxisRotations) {
  const auto rpy = [](const Eigen::Vector3d& axis, double angle) {
    return roll_pitch_yaw_zyx(Eigen::AngleAxisd(angle, axis).toRotationMatrix());
  };
  EXPECT_LT((rpy(Eigen::Vector3d::UnitX(), 30 * kDegToRad) - Eigen::Vector3d(30 * kDegToRad, 0, 0))
                .norm(),
            1e-12);
  EXPECT_LT(
      (rpy(Eigen::Vector3d::UnitY(), -40 * kDegToRad) - Eigen::Vector3d(0, -40 * kDegToRad, 0))
          .norm(),
      1e-12);
  EXPECT_LT(
      (rpy(Eigen::Vector3d::UnitZ(), 170 * kDegToRad) - Eigen::Vector3d(0, 0, 170 * kDegToRad))
          .norm(),
      1e-12);
}

TEST(EulerZyx, RoundTripsOverRandomAngles) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-kPi + 1e-9, kPi);
  std::uniform_real_distribution<double> pitch(-kPi / 2 + 1e-3, kPi / 2 - 1e-3);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d rpy(angle(rng), pitch(rng), angle(rng));
    const Eigen::Matrix3d R = rotation_from_roll_pitch_yaw_zyx(rpy);
    EXPECT_LT((roll_pitch_yaw_zyx(R) - rpy).norm(), 1e-9) << rpy.transpose();
  }
}

TEST(EulerZyx, GimbalLockStillReproducesTheRotation) {
  for (const double p : {kPi / 2, -kPi / 2}) {
    const Eigen::Matrix3d R = rotation_from_roll_pitch_yaw_zyx({0.3, p, -0.2});
    const Eigen::Vector3d rpy = roll_pitch_yaw_zyx(R);
    EXPECT_EQ(rpy.x(), 0.0);
    EXPECT_LT((rotation_from_roll_pitch_yaw_zyx(rpy) - R).norm(), 1e-9);
  }
}

TEST(WrapAngle, MapsIntoHalfOpenInterval) {
  EXPECT_DOUBLE_EQ(wrap_angle(0.5), 0.5);
  EXPECT_DOUBLE_EQ(wrap_angle(kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(3 * kPi / 2), -kPi / 2, 1e-15);
  EXPECT_NEAR(wrap_angle(-7 * kPi / 2), kPi / 2, 1e-14);
  AxisErrorSample s;
  s.rpy_gt_rad = {0, 0, 179 * kDegToRad};
  s.rpy_est_rad = {0, 0, -179 * kDegToRad};
  EXPECT_NEAR(s.rpy_error_rad().z(), 2 * kDegToRad, 1e-12);
}

TEST(AxisErrors, AlignedCopyHasZeroErrorOnEveryAxis) {
  const Trajectory gt = test::sample_trajectory(300, 1'000'000'000, 10'000'000);
  const SE3 T_est_gt = SE3::exp((Vector6d() << 1, -2, 0.5, 0.3, -1.0, 2.0).finished());
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_world_body = T_est_gt * pose.T_world_body;
  const AteResult ate = compute_ate(gt, est, {});
  const auto samples = compute_axis_errors(gt, est, ate);
  ASSERT_EQ(samples.size(), gt.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    EXPECT_EQ(samples[k].t_ns, gt[k].t_ns);
    EXPECT_LT((samples[k].p_gt_m - gt[k].T_world_body.translation()).norm(), 1e-15);
    EXPECT_LT(samples[k].p_error_m().norm(), 1e-9);
    EXPECT_LT(samples[k].rpy_error_rad().norm(), 1e-9);
  }
}

TEST(AxisErrors, CsvHasProvenanceHeaderAndOneRowPerSample) {
  const auto dir = test::fresh_temp_dir("axis_errors");
  AxisErrorSample s;
  s.t_ns = 2'500'000'000;
  s.p_gt_m = {1, 2, 3};
  s.p_est_m = {1.5, 2, 3};
  s.rpy_gt_rad = {0, 0, 90 * kDegToRad};
  s.rpy_est_rad = {0, 0, 80 * kDegToRad};
  write_axis_errors_csv(dir / "a.csv", {s, s}, 2'000'000'000, "evaluate");
  std::ifstream in(dir / "a.csv");
  std::string provenance, header, row;
  std::getline(in, provenance);
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(provenance, "# written by kestrel evaluate");
  EXPECT_EQ(header,
            "t_ns,t_s,x_gt_m,x_est_m,x_err_m,y_gt_m,y_est_m,y_err_m,z_gt_m,z_est_m,z_err_m,"
            "roll_gt_deg,roll_est_deg,roll_err_deg,pitch_gt_deg,pitch_est_deg,pitch_err_deg,"
            "yaw_gt_deg,yaw_est_deg,yaw_err_deg");
  EXPECT_EQ(row.substr(0, 30), "2500000000,0.5,1,1.5,0.5,2,2,0");
  EXPECT_NE(row.find(",90,80,-10"), std::string::npos) << row;
  std::getline(in, row);
  EXPECT_FALSE(row.empty());
  EXPECT_FALSE(std::getline(in, row));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::eval
