// Smooth trajectories: analytic derivatives against central finite differences, start poses,
// determinism of the random ones, and an IMU built from them that integrates back to the
// trajectory.
#include <gtest/gtest.h>

#include "kestrel/core/error.hpp"
#include "kestrel/sim/imu.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {
namespace {

SE3 some_start() { return SE3(SO3::exp({0.0, 0.0, 0.7}), {1.0, -2.0, 1.3}); }

TEST(SmoothTrajectory, DerivativesMatchFiniteDifferences) {
  constexpr double h = 1e-5;
  for (const auto& entry : trajectory_catalogue()) {
    const SmoothTrajectory traj = make_trajectory(entry.name, some_start(), 5);
    for (const double t : {0.0, 0.37, 1.9, 4.2, 11.5}) {
      const KinematicState s = traj.state(t);
      const KinematicState sm = traj.state(t - h);
      const KinematicState sp = traj.state(t + h);
      const Eigen::Vector3d v_fd =
          (sp.T_world_body.translation() - sm.T_world_body.translation()) / (2 * h);
      const Eigen::Vector3d a_fd = (sp.v_world - sm.v_world) / (2 * h);
      // R(t+h) = R(t-h) exp(2h omega_body(t)) + O(h^3).
      const Eigen::Vector3d w_fd =
          (sm.T_world_body.so3().inverse() * sp.T_world_body.so3()).log() / (2 * h);
      const Eigen::Vector3d alpha_fd = (sp.omega_body - sm.omega_body) / (2 * h);
      const double scale = 1.0 + s.a_world.norm() + s.alpha_body.norm();
      EXPECT_LT((s.v_world - v_fd).norm(), 1e-6 * scale) << entry.name << " t=" << t;
      EXPECT_LT((s.a_world - a_fd).norm(), 1e-6 * scale) << entry.name << " t=" << t;
      EXPECT_LT((s.omega_body - w_fd).norm(), 1e-6 * scale) << entry.name << " t=" << t;
      EXPECT_LT((s.alpha_body - alpha_fd).norm(), 1e-6 * scale) << entry.name << " t=" << t;
    }
  }
}

TEST(SmoothTrajectory, EveryTrajectoryStartsAtTheStartPoseAndStaysNearIt) {
  const SE3 start = some_start();
  for (const auto& entry : trajectory_catalogue()) {
    const SmoothTrajectory traj = make_trajectory(entry.name, start, 9);
    EXPECT_EQ(traj.name(), entry.name);
    const SE3 T0 = traj.T_world_body(0.0);
    EXPECT_LT((T0.translation() - start.translation()).norm(), 1e-12) << entry.name;
    EXPECT_LT((T0.so3().inverse() * start.so3()).log().norm(), 1e-12) << entry.name;
    for (double t = 0.0; t < 60.0; t += 0.25) {
      const SE3 T = traj.T_world_body(t);
      EXPECT_LT((T.translation() - start.translation()).norm(), 2.1) << entry.name << " " << t;
      EXPECT_LT((start.so3().inverse() * T.so3()).angle(), 1.0) << entry.name << " " << t;
    }
  }
}

TEST(SmoothTrajectory, StillIsStillAndForwardGoesForward) {
  const SE3 start = some_start();
  const KinematicState still = make_trajectory("still", start).state(3.0);
  EXPECT_LT(still.v_world.norm() + still.a_world.norm() + still.omega_body.norm(), 1e-15);
  // "forward" moves along the body's x axis: after 3 s it is 1 m ahead (1 - cos(pi/2)).
  const SE3 T = make_trajectory("forward", start).T_world_body(3.0);
  const Eigen::Vector3d moved = start.so3().inverse() * (T.translation() - start.translation());
  EXPECT_NEAR(moved.x(), 1.0, 1e-9);
  EXPECT_NEAR(moved.y(), 0.0, 1e-9);
}

TEST(SmoothTrajectory, OrbitKeepsItsCentreOnTheOpticalAxis) {
  const SmoothTrajectory orbit = make_trajectory("orbit", SE3());
  const Eigen::Vector3d centre(2.0, 0.0, 0.0);
  for (const double t : {0.5, 1.7, 3.3, 6.1}) {
    const SE3 T = orbit.T_world_body(t) * forward_camera_mount();
    Eigen::Vector3d p_cam = T.inverse() * (centre + Eigen::Vector3d(0, 0, T.translation().z()));
    EXPECT_NEAR(p_cam.x() / p_cam.z(), 0.0, 1e-12) << t;
    EXPECT_NEAR(p_cam.norm(), 2.0, 1e-12) << t;
  }
}

TEST(SmoothTrajectory, HandheldIsDeterministicFromTheSeed) {
  const SmoothTrajectory a = make_trajectory("handheld", SE3(), 4);
  const SmoothTrajectory b = make_trajectory("handheld", SE3(), 4);
  const SmoothTrajectory c = make_trajectory("handheld", SE3(), 5);
  const SE3 Ta = a.T_world_body(2.5), Tb = b.T_world_body(2.5), Tc = c.T_world_body(2.5);
  EXPECT_EQ((Ta.translation() - Tb.translation()).norm(), 0.0);
  EXPECT_GT((Ta.translation() - Tc.translation()).norm(), 1e-3);
  // Band-limited: accelerations stay those of a hand (under 1 g, under 20 rad/s^2).
  for (double t = 0.0; t < 30.0; t += 0.05) {
    const KinematicState s = a.state(t);
    EXPECT_LT(s.a_world.norm(), 9.81);
    EXPECT_LT(s.alpha_body.norm(), 20.0);
  }
}

TEST(SmoothTrajectory, CameraMountLooksAlongBodyXWithYDown) {
  const SE3 mount = forward_camera_mount();
  const Eigen::Matrix3d R = mount.rotation_matrix();
  EXPECT_LT((R.col(2) - Eigen::Vector3d::UnitX()).norm(), 1e-15);  // optical axis forward
  EXPECT_LT((R.col(1) + Eigen::Vector3d::UnitZ()).norm(), 1e-15);  // image y down
  EXPECT_LT((R.col(0) + Eigen::Vector3d::UnitY()).norm(), 1e-15);  // image x right
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
}

TEST(SmoothTrajectory, SampleGivesSensorPosesAtTheRequestedTimes) {
  const SmoothTrajectory traj = make_trajectory("sway", some_start());
  const TimeNs start = 1'000'000'000;
  const std::vector<TimeNs> times{start, start + 500'000'000, start + 1'250'000'000};
  const Trajectory poses = traj.sample(times, start, forward_camera_mount());
  ASSERT_EQ(poses.size(), 3U);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(poses[i].t_ns, times[i]);
    const SE3 expected = traj.T_world_body(ns_to_s(times[i] - start)) * forward_camera_mount();
    EXPECT_LT((poses[i].T_world_body.translation() - expected.translation()).norm(), 1e-15);
  }
}

TEST(SmoothTrajectory, UnknownNameListsTheValidOnes) {
  try {
    (void)make_trajectory("hand-held", SE3());
    FAIL() << "no exception";
  } catch (const InputError& e) {
    const std::string what = e.what();
    for (const auto& entry : trajectory_catalogue()) {
      EXPECT_NE(what.find(std::string(entry.name)), std::string::npos) << what;
    }
  }
}

TEST(IdealImu, ReadsGravityAtRest) {
  const SE3 tilted(SO3::exp({0.3, -0.2, 1.0}), {0, 0, 1});
  const SmoothTrajectory still = make_trajectory("still", tilted);
  const io::ImuSample s = ideal_imu_sample(still.state(1.0), 5);
  EXPECT_EQ(s.t_ns, 5);
  EXPECT_LT(s.gyro_rad_s.norm(), 1e-15);
  const Eigen::Vector3d up_in_body = tilted.so3().inverse() * Eigen::Vector3d(0, 0, 9.81);
  EXPECT_LT((s.accel_m_s2 - up_in_body).norm(), 1e-12);
}

TEST(IdealImu, IntegratesBackToTheTrajectory) {
  // Strapdown integration of the ideal samples (1 kHz, midpoint rule on SO(3), trapezoid on
  // velocity and position) from the true initial state recovers the trajectory.
  for (const char* name : {"handheld", "orbit", "rpy"}) {
    const SmoothTrajectory traj = make_trajectory(name, some_start(), 2);
    const TimeNs start = 0;
    const TimeNs end = 2'000'000'000;
    const auto imu = ideal_imu_samples(traj, start, end, 1000.0);
    ASSERT_EQ(imu.size(), 2001U);
    KinematicState s0 = traj.state(0.0);
    SO3 R = s0.T_world_body.so3();
    Eigen::Vector3d p = s0.T_world_body.translation();
    Eigen::Vector3d v = s0.v_world;
    const Eigen::Vector3d g = gravity_world();
    for (std::size_t k = 0; k + 1 < imu.size(); ++k) {
      const double dt = ns_to_s(imu[k + 1].t_ns - imu[k].t_ns);
      const Eigen::Vector3d a0 = R * imu[k].accel_m_s2 + g;
      const SO3 R1 = R * SO3::exp(0.5 * (imu[k].gyro_rad_s + imu[k + 1].gyro_rad_s) * dt);
      const Eigen::Vector3d a1 = R1 * imu[k + 1].accel_m_s2 + g;
      p += v * dt + (2.0 * a0 + a1) / 6.0 * dt * dt;
      v += 0.5 * (a0 + a1) * dt;
      R = R1;
    }
    const KinematicState s1 = traj.state(2.0);
    EXPECT_LT((p - s1.T_world_body.translation()).norm(), 1e-4) << name;
    EXPECT_LT((v - s1.v_world).norm(), 1e-4) << name;
    EXPECT_LT((R.inverse() * s1.T_world_body.so3()).log().norm(), 1e-5) << name;
  }
  EXPECT_THROW((void)ideal_imu_samples(make_trajectory("still", SE3()), 0, 10, 0.0),
               std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::sim
