// The fusion's behaviour: static start, long-run covariance health (Joseph form), gating,
// dropout, buffering of out-of-order input, and bad input -> error or flag, never NaN.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/lab/fusion_simulation.hpp"
#include "test_data.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;

constexpr TimeNs kPeriod = 5'000'000;  // 200 Hz

io::ImuSample still_sample(TimeNs t, const Eigen::Quaterniond& q, const Vector3d& bg) {
  io::ImuSample s;
  s.t_ns = t;
  s.gyro_rad_s = bg;
  s.accel_m_s2 = q.conjugate() * Vector3d(0, 0, 9.81);
  return s;
}

TEST(FusionBehaviour, StaticImuGivesStaticEstimate) {
  const Eigen::Quaterniond q = SO3::exp(Vector3d(0.1, -0.05, 0.7)).unit_quaternion();
  const Vector3d bg(0.002, -0.01, 0.02);
  FusionEngine engine{FusionOptions{}};
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0.0, 1.0);
  const ImuNoiseDensities nd;
  // 60 s of a still, slightly noisy IMU with odometry saying "no motion" at 20 Hz.
  std::vector<FusedState> out;
  for (int k = 0; k <= 60 * 200; ++k) {
    io::ImuSample s = still_sample(k * kPeriod, q, bg);
    s.gyro_rad_s += Vector3d(n(rng), n(rng), n(rng)) * nd.gyro_noise * std::sqrt(200.0);
    s.accel_m_s2 += Vector3d(n(rng), n(rng), n(rng)) * nd.accel_noise * std::sqrt(200.0);
    engine.add_imu(s);
    if (k > 0 && k % 10 == 0) {
      RelativePoseMeasurement m;
      m.t_ref_ns = (k - 10) * kPeriod;
      m.t_ns = k * kPeriod;
      m.covariance = Vector6d::Constant(1e-6).asDiagonal();
      engine.add_relative_pose(m);
    }
    for (const auto& f : engine.poll(false)) out.push_back(f);
  }
  for (const auto& f : engine.flush(false)) out.push_back(f);
  ASSERT_TRUE(engine.initialized());
  ASSERT_GT(out.size(), 1000u);
  const NominalState& x = engine.filter().state();
  EXPECT_LT(x.p_world.norm(), 0.01);
  EXPECT_LT(x.v_world.norm(), 0.005);
  EXPECT_LT((x.gyro_bias_rad_s - bg).norm(), 5e-4);
  // Roll and pitch from gravity: the body's up axis agrees with the truth's.
  const Vector3d up_est = x.q_world_body.conjugate() * Vector3d::UnitZ();
  const Vector3d up_true = q.conjugate() * Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, up_est.dot(up_true))), 1e-3);
  EXPECT_EQ(engine.counters().updates_gated, 0u);
}

TEST(FusionBehaviour, JosephUpdateKeepsCovarianceSymmetricPositiveDefiniteForAnHour) {
  // One hour of simulated flight at a coarse rate (50 Hz IMU, 5 Hz odometry): cheap, but
  // 180 000 propagations and 18 000 updates with re-cloning.
  FusionOptions fusion;
  lab::SimulationOptions sim;
  sim.duration_s = 3600.0;
  sim.imu_rate_hz = 50.0;
  sim.vo_rate_hz = 5.0;
  fusion.T_body_cam = sim.T_body_cam;
  fusion.reorder_window_s = 0.0;
  fusion.max_imu_gap_s = 0.05;
  std::mt19937_64 rng(3);
  const lab::SimulatedFlight flight(5);
  const lab::SimulatedRun run = lab::simulate_run(flight, sim, fusion, rng);
  FusionEngine engine(fusion);
  engine.initialize(lab::true_state(flight, run, 0, sim.imu_rate_hz));
  std::size_t i = 0, checks = 0;
  double worst_asym = 0.0, min_eig = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < run.odometry.size(); ++k) {
    while (i < run.imu.size() && run.imu[i].t_ns <= run.odometry[k].t_ns)
      engine.add_imu(run.imu[i++]);
    engine.add_relative_pose(run.odometry[k]);
    (void)engine.flush(false);
    if (k % 500 == 0 || k + 1 == run.odometry.size()) {
      const MatrixXs& P = engine.filter().covariance();
      ASSERT_TRUE(P.allFinite());
      worst_asym = std::max(worst_asym, (P - P.transpose()).cwiseAbs().maxCoeff());
      // The clone equals the current pose right after re-cloning, so P is singular along
      // (dp - dp_d, dtheta - dtheta_d); check the 15x15 current block and the full P after
      // one more propagation.
      const Eigen::SelfAdjointEigenSolver<Matrix15d> es(P.topLeftCorner<15, 15>());
      min_eig = std::min(min_eig, es.eigenvalues().minCoeff());
      ++checks;
    }
  }
  EXPECT_GT(checks, 30u);
  EXPECT_EQ(worst_asym, 0.0);
  EXPECT_GT(min_eig, 0.0);
  EXPECT_EQ(engine.counters().updates_accepted + engine.counters().updates_gated,
            run.odometry.size());
  EXPECT_LT(engine.counters().updates_gated, run.odometry.size() / 100);
  // The simulator's noise is the filter's: the normalised innovations average their 6 dof (the
  // gate trims the top ~1 %; the standard error of the mean is sqrt(12 / N) ~ 0.02 here).
  EXPECT_GT(engine.counters().mean_nis(), 5.5);
  EXPECT_LT(engine.counters().mean_nis(), 6.5);
  std::cout << "hour of flight: mean NIS " << engine.counters().mean_nis() << " over "
            << engine.counters().updates_accepted << " updates\n";
  // The covariance of every estimated state (all but the odometry-IMU rotation, not estimated
  // by default: its block is zero) after a propagation step is positive-definite too.
  StochasticCloningEkf ekf = engine.filter();
  ekf.propagate({Vector3d::Zero(), Vector3d(0, 0, 9.81)}, 0.02);
  EXPECT_EQ(ekf.covariance().middleRows<3>(idx::kExt).norm(), 0.0);
  using MatrixEstimated = Eigen::Matrix<double, idx::kExt, idx::kExt>;
  const Eigen::SelfAdjointEigenSolver<MatrixEstimated> es(
      ekf.covariance().topLeftCorner<idx::kExt, idx::kExt>());
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
}

// A short scenario: 10 s at rest, odometry at 20 Hz. Returns the engine after flushing.
struct Scenario {
  std::vector<io::ImuSample> imu;
  std::vector<RelativePoseMeasurement> vo;
};
Scenario still_scenario(double seconds) {
  Scenario s;
  const auto n = static_cast<int>(seconds * 200);
  for (int k = 0; k <= n; ++k)
    s.imu.push_back(still_sample(k * kPeriod, Eigen::Quaterniond::Identity(), Vector3d::Zero()));
  for (int k = 10; k <= n; k += 10) {
    RelativePoseMeasurement m;
    m.t_ref_ns = (k - 10) * kPeriod;
    m.t_ns = k * kPeriod;
    m.covariance = Vector6d::Constant(1e-4).asDiagonal();
    s.vo.push_back(m);
  }
  return s;
}

TEST(FusionBehaviour, OutOfOrderInputWithinTheWindowGivesTheSameResult) {
  const Scenario sc = still_scenario(5.0);
  FusionOptions o;
  o.reorder_window_s = 0.05;
  FusionEngine in_order(o), shuffled(o);
  for (const auto& s : sc.imu) in_order.add_imu(s);
  for (const auto& m : sc.vo) in_order.add_relative_pose(m);
  const auto a = in_order.flush(false);
  // Swap neighbours and deliver odometry 30 ms late.
  std::vector<io::ImuSample> imu = sc.imu;
  for (std::size_t k = 1; k + 1 < imu.size(); k += 2) std::swap(imu[k], imu[k + 1]);
  std::size_t vi = 0;
  std::vector<FusedState> b;
  for (const auto& s : imu) {
    while (vi < sc.vo.size() && sc.vo[vi].t_ns + 30'000'000 <= s.t_ns)
      shuffled.add_relative_pose(sc.vo[vi++]);
    shuffled.add_imu(s);
    for (const auto& f : shuffled.poll(false)) b.push_back(f);
  }
  while (vi < sc.vo.size()) shuffled.add_relative_pose(sc.vo[vi++]);
  for (const auto& f : shuffled.flush(false)) b.push_back(f);
  EXPECT_EQ(shuffled.counters().imu_dropped_late, 0u);
  EXPECT_EQ(shuffled.counters().measurements_dropped_late, 0u);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].t_ns, b[k].t_ns);
    EXPECT_LT((a[k].state.p_world - b[k].state.p_world).norm(), 1e-12);
  }
}

TEST(FusionBehaviour, NanSamplesAreDroppedAndCountedNeverPropagated) {
  Scenario sc = still_scenario(3.0);
  sc.imu[300].gyro_rad_s.x() = std::numeric_limits<double>::quiet_NaN();
  sc.imu[400].accel_m_s2.z() = std::numeric_limits<double>::infinity();
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  for (const auto& m : sc.vo) e.add_relative_pose(m);
  for (const auto& f : e.flush(true)) ASSERT_TRUE(f.state.all_finite());
  EXPECT_EQ(e.counters().imu_dropped_invalid, 2u);
  // A NaN measurement is rejected, not applied.
  RelativePoseMeasurement bad = sc.vo.back();
  bad.t_ref_ns = e.filter().state().clone_t_ns;
  bad.t_ns = bad.t_ref_ns + 50'000'000;
  bad.covariance(0, 0) = std::numeric_limits<double>::quiet_NaN();
  e.add_relative_pose(bad);
  (void)e.flush(false);
  EXPECT_EQ(e.counters().updates_invalid, 1u);
  EXPECT_TRUE(e.filter().state().all_finite());
  // So is one whose covariance was never set (the default is NaN, not uninitialised memory).
  RelativePoseMeasurement unset;
  unset.t_ref_ns = e.filter().state().clone_t_ns;
  unset.t_ns = unset.t_ref_ns + 50'000'000;
  unset.T_ref_cur = bad.T_ref_cur;
  e.add_relative_pose(unset);
  (void)e.flush(false);
  EXPECT_EQ(e.counters().updates_invalid, 2u);
  EXPECT_TRUE(e.filter().state().all_finite());
  // The filter itself refuses NaN readings and non-positive steps with an exception.
  StochasticCloningEkf ekf = e.filter();
  EXPECT_THROW(ekf.propagate({Vector3d::Constant(std::nan("")), Vector3d::Zero()}, 0.005),
               std::invalid_argument);
  EXPECT_THROW(ekf.propagate({Vector3d::Zero(), Vector3d::Zero()}, -0.005), std::invalid_argument);
}

TEST(FusionBehaviour, TimeGoingBackwardsIsDroppedAndCounted) {
  const Scenario sc = still_scenario(3.0);
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  (void)e.flush(false);
  e.add_imu(sc.imu[100]);  // 2.5 s in the past
  EXPECT_EQ(e.counters().imu_dropped_late, 1u);
  RelativePoseMeasurement old = sc.vo.front();
  e.add_relative_pose(old);
  EXPECT_EQ(e.counters().measurements_dropped_late, 1u);
}

TEST(FusionBehaviour, ImuGapOfSecondsIsFlaggedAndCovarianceGrows) {
  Scenario sc = still_scenario(6.0);
  // Remove 3 s of IMU samples.
  sc.imu.erase(sc.imu.begin() + 400, sc.imu.begin() + 1000);
  sc.vo.clear();
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  const auto out = e.flush(true);
  EXPECT_EQ(e.counters().imu_gaps, 1u);
  bool flagged = false;
  double sigma_before = 0.0, sigma_after = 0.0;
  for (const auto& f : out) {
    ASSERT_TRUE(f.state.all_finite());
    if (f.flags & kFlagImuGap) {
      flagged = true;
      sigma_after = f.sigma.head<3>().norm();
    } else if (!flagged) {
      sigma_before = f.sigma.head<3>().norm();
    }
    if (f.t_ns > 2'000'000'000) {
      EXPECT_TRUE(f.flags & kFlagVoDropout);
    }
  }
  EXPECT_TRUE(flagged);
  EXPECT_GT(sigma_after, sigma_before);
}

TEST(FusionBehaviour, OdometryDropoutFlagsAndGrowsCovarianceThenRecovers) {
  Scenario sc = still_scenario(10.0);
  // No odometry between 4 s and 6 s; the first one after starts from an unseen frame.
  std::erase_if(sc.vo, [](const RelativePoseMeasurement& m) {
    return m.t_ns > 4'000'000'000 && m.t_ns <= 6'000'000'000;
  });
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  for (const auto& m : sc.vo) e.add_relative_pose(m);
  const auto out = e.flush(true);
  double s_at_4 = 0, s_at_6 = 0;
  bool dropout_in_gap = false, dropout_at_end = false;
  for (const auto& f : out) {
    if (f.t_ns == 4'000'000'000) s_at_4 = f.sigma.head<3>().norm();
    if (f.t_ns == 5'995'000'000) s_at_6 = f.sigma.head<3>().norm();
    if (f.t_ns > 4'500'000'000 && f.t_ns < 6'000'000'000 && (f.flags & kFlagVoDropout))
      dropout_in_gap = true;
    if (f.t_ns == out.back().t_ns) dropout_at_end = f.flags & kFlagVoDropout;
  }
  EXPECT_TRUE(dropout_in_gap);
  EXPECT_FALSE(dropout_at_end);
  EXPECT_GT(s_at_6, s_at_4);
  // Two measurements start from a frame that is not the clone: the first after the static
  // initialisation (cloned at the init time) and the first after the gap.
  EXPECT_EQ(e.counters().updates_no_reference, 2u);
}

// Keyframe odometry: measurements relative to a kept keyframe update against the same clone;
// the filter re-clones only when a frame becomes the new reference.
TEST(FusionBehaviour, KeyframeMeasurementsKeepTheCloneUntilTheReferenceChanges) {
  Scenario sc = still_scenario(6.0);
  constexpr std::size_t kPerKeyframe = 5;
  TimeNs keyframe_t = 0;
  TimeNs last_keyframe_t = 0;
  for (std::size_t i = 0; i < sc.vo.size(); ++i) {
    sc.vo[i].t_ref_ns = keyframe_t;
    sc.vo[i].starts_new_reference = (i + 1) % kPerKeyframe == 0;
    if (sc.vo[i].starts_new_reference) {
      keyframe_t = sc.vo[i].t_ns;
      last_keyframe_t = keyframe_t;
    }
  }
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  for (const auto& m : sc.vo) e.add_relative_pose(m);
  (void)e.flush(false);
  const FusionCounters& c = e.counters();
  // Before the static initialisation (1 s) measurements are dropped; the keyframe of the first
  // one after it was never cloned: that one is cloned and anchors the next ones from the same
  // keyframe (re-based on it), so only it goes without an update.
  EXPECT_EQ(c.updates_no_reference, 1u);
  EXPECT_EQ(c.updates_accepted, sc.vo.size() - c.measurements_before_init - 1);
  EXPECT_EQ(c.updates_gated, 0u);
  EXPECT_EQ(e.filter().state().clone_t_ns, last_keyframe_t);
  EXPECT_LT(e.filter().state().p_world.norm(), 0.01);
}

// A body yawed by 30 deg gliding at 0.5 m/s along x (constant velocity: the IMU reads gravity
// only); the filter starts on its true state at 1 s, with IMU samples to 3 s.
struct YawedGlide {
  static constexpr TimeNs kStart = 1'000'000'000, kEnd = 3'000'000'000;
  Eigen::Quaterniond q{Eigen::AngleAxisd(M_PI / 6, Vector3d::UnitZ())};
  Vector3d v_world{0.5, 0.0, 0.0};

  [[nodiscard]] SE3 T_world_body(TimeNs t) const { return SE3(SO3(q), v_world * ns_to_s(t)); }
  void start(FusionEngine& e) const {
    NominalState x0;
    x0.t_ns = kStart;
    x0.p_world = T_world_body(kStart).translation();
    x0.q_world_body = q;
    x0.v_world = v_world;
    e.initialize(x0);
    for (TimeNs t = kStart; t <= kEnd; t += kPeriod)
      e.add_imu(still_sample(t, q, Vector3d::Zero()));
  }
  /// The true motion from a kept keyframe (sigma 1 mm, 1 mrad), `error` applied on the left.
  [[nodiscard]] RelativePoseMeasurement from_keyframe(TimeNs keyframe_t, TimeNs t,
                                                      const SE3& error = SE3()) const {
    RelativePoseMeasurement m;
    m.t_ref_ns = keyframe_t;
    m.t_ns = t;
    m.T_ref_cur = error * T_world_body(keyframe_t).inverse() * T_world_body(t);
    m.covariance = Vector6d::Constant(1e-6).asDiagonal();
    m.starts_new_reference = false;
    return m;
  }
};

// A keyframe taken before the filter started (a tracker that ran before the IMU was ready):
// the first measurement from it is only cloned, and the next ones from the same keyframe are
// re-based on that clone, T_clone_cur = T_kf_clone^-1 T_kf_cur. The body moves at 0.5 m/s
// along x and is yawed by 30 deg, so a measurement taken as clone-relative without the
// re-basing would be 0.5 m off and gated.
TEST(FusionBehaviour, MeasurementsFromAnUnclonedKeyframeAreRebasedOnTheFirstOne) {
  const YawedGlide glide;
  FusionEngine e{FusionOptions{}};
  glide.start(e);
  const TimeNs keyframe_t = 0;  // before the filter's start: never cloned
  std::size_t sent = 0;
  for (TimeNs t = 1'050'000'000; t <= YawedGlide::kEnd; t += 50'000'000) {
    e.add_relative_pose(glide.from_keyframe(keyframe_t, t));
    ++sent;
  }
  const auto out = e.flush(false);
  const FusionCounters& c = e.counters();
  EXPECT_EQ(c.updates_no_reference, 1u);
  EXPECT_EQ(c.updates_accepted, sent - 1);
  EXPECT_EQ(c.updates_gated, 0u);
  EXPECT_EQ(e.filter().state().clone_t_ns, 1'050'000'000);
  ASSERT_FALSE(out.empty());
  const SE3 truth = glide.T_world_body(out.back().t_ns);
  EXPECT_LT((out.back().state.p_world - truth.translation()).norm(), 1e-3);
  EXPECT_LT((out.back().state.v_world - glide.v_world).norm(), 1e-3);
}

// Keyframe odometry that jumps once against its kept keyframe: from one frame on, every
// measurement from that keyframe is 5 cm off (sigma 1 mm). The jump is gated twice; the filter
// then anchors the next ones on the second, so they give the motion since and are accepted, and
// the estimate is not moved by the jump. Without the re-anchoring every later one is gated. A
// single outlier (one measurement 5 cm off) is only rejected, and moves nothing either.
TEST(FusionBehaviour, AGatedKeyframeMeasurementReanchorsTheNextOnes) {
  const YawedGlide glide;
  for (const bool reanchor : {true, false}) {
    FusionOptions o;
    o.reanchor_after_gate = reanchor;
    FusionEngine e{o};
    glide.start(e);
    const TimeNs keyframe_t = YawedGlide::kStart;  // the filter's first clone
    std::size_t sent = 0;
    for (TimeNs t = 1'050'000'000; t <= YawedGlide::kEnd; t += 50'000'000) {
      const bool off = t >= 2'000'000'000 || t == 1'500'000'000;  // a lone outlier, then a jump
      e.add_relative_pose(
          glide.from_keyframe(keyframe_t, t, SE3(SO3(), Vector3d(0.0, off ? 0.05 : 0.0, 0.0))));
      ++sent;
    }
    const auto out = e.flush(false);
    const FusionCounters& c = e.counters();
    ASSERT_FALSE(out.empty());
    const double error =
        (out.back().state.p_world - glide.T_world_body(out.back().t_ns).translation()).norm();
    if (reanchor) {
      EXPECT_EQ(c.updates_gated, 3u);  // the outlier, and the jump twice
      EXPECT_EQ(c.updates_accepted, sent - 3);
      EXPECT_LT(error, 2e-3);
    } else {
      EXPECT_EQ(c.updates_gated, 22u);  // the outlier, and every measurement from 2 s to 3 s
    }
  }
}

TEST(FusionBehaviour, ChiSquareGateRejectsAnOutlier) {
  Scenario sc = still_scenario(4.0);
  sc.vo[50].T_ref_cur = SE3(SO3(), Vector3d(0.5, 0, 0));  // a 0.5 m jump, sigma 1 cm
  FusionEngine e{FusionOptions{}};
  for (const auto& s : sc.imu) e.add_imu(s);
  for (const auto& m : sc.vo) e.add_relative_pose(m);
  const auto out = e.flush(false);
  EXPECT_EQ(e.counters().updates_gated, 1u);
  EXPECT_LT(e.filter().state().p_world.norm(), 0.01);
}

TEST(FusionBehaviour, MissingCalibrationFieldIsAnErrorNamingIt) {
  const auto dir = test::fresh_temp_dir("fusion");
  std::ofstream(dir / "imu.yaml")
      << "%YAML:1.0\nrate_hz: 200\ngyroscope_noise_density: 1.6e-4\n"
         "gyroscope_random_walk: 1.9e-5\naccelerometer_noise_density: 2e-3\n";
  try {
    (void)io::load_imu_noise(dir / "imu.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("accelerometer_random_walk"), std::string::npos)
        << e.what();
  }
  std::ofstream(dir / "options.yaml") << "gate_probabilty: 0.99\n";
  try {
    (void)FusionOptions::load_yaml(dir / "options.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gate_probabilty"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "bad.yaml") << "gyroscope_noise_density: -1\n";
  EXPECT_THROW((void)FusionOptions::load_yaml(dir / "bad.yaml"), InputError);
  std::ofstream(dir / "fej.yaml") << "first_estimate_jacobians: false\n";
  EXPECT_FALSE(FusionOptions::load_yaml(dir / "fej.yaml").first_estimate_jacobians);
  EXPECT_TRUE(FusionOptions{}.first_estimate_jacobians);
  std::ofstream(dir / "fej_bad.yaml") << "first_estimate_jacobians: sometimes\n";
  try {
    (void)FusionOptions::load_yaml(dir / "fej_bad.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("first_estimate_jacobians"), std::string::npos)
        << e.what();
  }
}

TEST(FusionBehaviour, StaticInitialisationWaitsForStillness) {
  FusionEngine e{FusionOptions{}};
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  // 2 s of shaking, then still.
  for (int k = 0; k < 1200; ++k) {
    io::ImuSample s = still_sample(k * kPeriod, Eigen::Quaterniond::Identity(), Vector3d::Zero());
    if (k < 400) s.accel_m_s2 += Vector3d(n(rng), n(rng), n(rng)) * 2.0;
    e.add_imu(s);
  }
  (void)e.flush(false);
  ASSERT_TRUE(e.initialized());
  EXPECT_GE(e.filter().state().t_ns, 3 * 1'000'000'000LL - 10 * kPeriod);
}

}  // namespace
}  // namespace kestrel::fusion
