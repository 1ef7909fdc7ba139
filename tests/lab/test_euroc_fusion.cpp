// The fusion on the real EuRoC V1_02 IMU with relative poses from the ground truth (the
// targets and figures are in docs/fusion.md). Skips where the shared data is absent.
#include <gtest/gtest.h>

#include <cstdint>
#include <utility>
#include <vector>

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/lab/fusion_experiments.hpp"
#include "test_data.hpp"

namespace kestrel::lab {
namespace {

// The real IMU starts with a large gyro bias and the filter at zero bias (fuse-eval's prior).
fusion::FusionOptions wide_bias_prior() {
  fusion::FusionOptions o;
  o.init_sigma_gyro_bias_rad_s = 0.1;
  o.init_sigma_accel_bias_m_s2 = 0.2;
  return o;
}

/// Summaries of V1_02 and V1_01 over the noise draws (seeds) 1..n, with options `o`, `eo`.
std::pair<EurocSeedSummary, EurocSeedSummary> over_draws(const fusion::FusionOptions& o,
                                                         EurocExperimentOptions eo,
                                                         std::uint64_t n) {
  std::vector<EurocExperimentResult> v1_02, v1_01;
  for (std::uint64_t seed = 1; seed <= n; ++seed) {
    eo.seed = seed;
    v1_02.push_back(
        run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo));
    v1_01.push_back(run_v1_01(test::shared_data_dir() / "euroc/V1_01_easy_part1", o, eo));
  }
  return {summarise_draws(v1_02), summarise_draws(v1_01)};
}

TEST(FusionExperiments, SummaryOfDrawsCountsTheDrawsMeetingEachTarget) {
  std::vector<EurocExperimentResult> draws(3);
  const double fused[] = {0.1, 0.3, 0.6}, gap[] = {0.2, 0.3, 0.5}, bias[] = {0.001, 0.003, 0.004};
  for (std::size_t i = 0; i < 3; ++i) {
    draws[i].fused_rmse_m = fused[i];
    draws[i].chained_rmse_m = 1.0;
    draws[i].gap_max_error_m = gap[i];
    draws[i].gyro_bias_checked = i != 2;  // the last draw has no bias reference
    draws[i].gyro_bias_error_at_check = bias[i];
    draws[i].gyro_bias_error_max_after = bias[i];
  }
  const EurocSeedSummary s = summarise_draws(draws);
  EXPECT_EQ(s.draws, 3);
  EXPECT_DOUBLE_EQ(s.ratio.median, 0.3);
  EXPECT_DOUBLE_EQ(s.ratio.min, 0.1);
  EXPECT_DOUBLE_EQ(s.ratio.max, 0.6);
  EXPECT_EQ(s.ratio.meeting, 3);  // <= 0.7 (the worst draw)
  EXPECT_EQ(s.ratio_above_one, 0);
  EXPECT_EQ(s.gap_max_error.meeting, 2);                   // <= 0.45 (the 90th percentile)
  EXPECT_DOUBLE_EQ(s.gap_max_error.p90, 0.3 + 0.8 * 0.2);  // between the 2nd and 3rd of 3
  EXPECT_EQ(s.bias_draws, 2);
  EXPECT_EQ(s.bias_at_check.meeting, 2);  // <= 0.005
  EXPECT_DOUBLE_EQ(s.bias_at_check.median, 0.002);
  EXPECT_NEAR(s.mean_fused_m, 1.0 / 3.0, 1e-12);
  EXPECT_THROW(summarise_draws({}), std::invalid_argument);
}

TEST(FusionEuroc, V1_02FusedBeatsChainingAndTracksTheGyroBias) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;  // the configuration before the defaults changed
  eo.vo_keyframes = false;
  eo.imu_noise_scale = 1.0;
  const auto r = run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo);
  std::cout << format_result(r);
  // REGRESSION GUARDS at seed 1, a favourable noise draw: ratio 0.34 (0.268 vs 0.779 m), gyro
  // bias 0.0026 rad/s at 20 s but 0.0045 later, gap 1.07 m. Over 20 draws frame to frame with
  // the YAML noise meets the ratio in 4, the bias at 20 s in 3, on every later sample in none
  // (docs/fusion.md, FusionEuroc.KeyframeOdometryOverNoiseDraws): the targets are
  // NOT met by this configuration.
  EXPECT_LE(r.gyro_bias_error_at_check, 0.003);
  EXPECT_LT(r.gyro_bias_error_max_after, 0.006);
  EXPECT_LT(r.gap_max_error_m, 1.3);
  EXPECT_LT(r.fused_rot_rmse_deg, 5.0);
  EXPECT_TRUE(r.gap_flag_raised);
  EXPECT_EQ(r.counters.updates_invalid, 0u);
  EXPECT_LE(r.counters.updates_gated, 3u);
}

TEST(FusionEuroc, V1_02StaticStartBias) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;
  eo.vo_keyframes = false;
  eo.imu_noise_scale = 1.0;
  eo.static_gyro_bias_init = true;  // gyro bias from the still IMU before the first pose
  const auto r = run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo);
  std::cout << format_result(r);
  EXPECT_LE(r.fused_rmse_m, 0.5 * r.chained_rmse_m);
  // REGRESSION GUARDS (measured max 0.0040 rad/s after 20 s, 0.98 m in the gap; targets 0.003
  // and 0.3 m missed).
  EXPECT_LT(r.gyro_bias_error_max_after, 0.005);
  EXPECT_LT(r.gap_max_error_m, 1.2);
}

// Keyframe odometry (each pose relative to a keyframe kept for up to 5 deg, 0.15 m or 20
// frames, the same noise per measurement): the clone is kept across updates, and the yaw-axis
// gyro bias becomes observable to the 0.003 rad/s (measured 0.0010 at 20 s, max
// 0.0010 after). The chained baseline improves as much, so fused/chained is 0.79 here with
// the YAML's IMU noise (docs/fusion.md has the table).
TEST(FusionEuroc, V1_02KeyframeOdometryTracksTheGyroBias) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;
  eo.vo_keyframes = true;
  eo.imu_noise_scale = 1.0;
  const auto r = run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo);
  std::cout << format_result(r);
  EXPECT_EQ(r.counters.updates_no_reference, 0u);
  EXPECT_LE(r.gyro_bias_error_at_check, 0.003);  // issue target
  EXPECT_LE(r.gyro_bias_error_max_after, 0.003);
  EXPECT_LT(r.fused_rmse_m, r.chained_rmse_m);
  EXPECT_LT(r.fused_rot_rmse_deg, 3.0);
  EXPECT_TRUE(r.gap_flag_raised);
  // The gap's decomposition is faithful: dead reckoning from the filter's own state one IMU step
  // into the gap reproduces the filter's error in the gap (0.7211 m both), and from the
  // ground-truth state the real IMU alone drifts by 0.088 m.
  const auto& d = r.gap_decomposition;
  ASSERT_TRUE(d.measured);
  EXPECT_NEAR(d.filter, r.gap_max_error_m, 0.01);
  EXPECT_LT(d.truth, 0.15);
  EXPECT_GT(d.with_velocity, d.truth);
  EXPECT_GT(d.with_attitude, d.truth);
}

// Over noise draws (each seed one draw of the 1 cm / 0.5 deg measurement noise), keyframe
// odometry with the IMU noise at 10x the YAML's: the ratio of the mean RMSEs meets the issue's
// 0.5 on both sequences (measured over seeds 1-8: V1_02 0.364, V1_01 0.477) and the bias target
// holds in every draw; the V1_02 gap does not (3 of these 8; docs/fusion.md: 11 of 20).
TEST(FusionEuroc, KeyframeOdometryOverNoiseDraws) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/imu0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;
  eo.vo_keyframes = true;
  eo.imu_noise_scale = 10.0;
  const auto [a, b] = over_draws(o, eo, 8);
  std::cout << format_summary(a) << format_summary(b);
  EXPECT_LE(a.mean_fused_m, 0.5 * a.mean_chained_m);  // issue target, on the mean
  EXPECT_LE(b.mean_fused_m, 0.5 * b.mean_chained_m);  // issue target, on the mean
  EXPECT_GE(a.bias_max_after.meeting, 7);             // of 8 (measured 8)
  EXPECT_GE(b.gap_max_error.meeting, 8);              // of 8 (measured 8)
  // REGRESSION GUARD, NOT the target: the V1_02 gap holds in 3 of these 8 draws.
  EXPECT_GE(a.gap_max_error.meeting, 2);
}

// The control experiment (--synthetic-imu): the same trajectories, measurements and noise
// draws, the real IMU replaced by one synthesised from the ground truth exactly as
// imu0/sensor.yaml models it, the filter with the YAML's noise (1x). With the IMU it models the
// filter is consistent (NIS ~6) and the V1_02 gap is met in most draws (measured 7 of 8,
// median 0.19 m) where the real IMU at the same settings meets it in none (median 0.66 m): the
// real IMU's unmodelled in-flight errors, not the filter, cost the gap (docs/fusion.md). It
// also shows the targets are not met in EVERY draw even then (1 of 8 gaps above 0.3 m).
TEST(FusionEuroc, SyntheticImuControlExperiment) {
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;
  eo.vo_keyframes = true;
  eo.imu_noise_scale = 1.0;
  std::vector<EurocExperimentResult> synthetic, real;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    eo.seed = seed;
    eo.synthetic_imu = true;
    synthetic.push_back(
        run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo));
    eo.synthetic_imu = false;
    real.push_back(
        run_v1_02(test::shared_data_dir() / "euroc/V1_02_medium_imu_groundtruth", o, eo));
  }
  const EurocSeedSummary s = summarise_draws(synthetic), r = summarise_draws(real);
  std::cout << "synthetic IMU: " << format_summary(s) << "real IMU: " << format_summary(r);
  const auto& d = synthetic.front().gap_decomposition;
  ASSERT_TRUE(d.measured);
  EXPECT_LT(d.truth, 0.03);  // dead reckoning from the truth (measured 0.006; the real IMU 0.085 m)
  // The 1 s window check: the synthetic IMU agrees with the ground truth as the YAML's white
  // noise says (measured accel 0.0046 vs 0.0035 m/s^2, gyro 0.0003 vs 0.0003 rad/s); the real
  // accelerometer does not (0.055 m/s^2: 15x).
  const auto& cs = synthetic.front().imu_consistency;
  const auto& cr = real.front().imu_consistency;
  ASSERT_GT(cs.windows, 30);
  EXPECT_LT(cs.accel_rms_m_s2, 2.0 * cs.accel_yaml_m_s2);
  EXPECT_LT(cs.gyro_rms_rad_s, 2.0 * cs.gyro_yaml_rad_s);
  EXPECT_GT(cr.accel_rms_m_s2, 5.0 * cr.accel_yaml_m_s2);
  EXPECT_NEAR(d.filter, synthetic.front().gap_max_error_m, 0.01);
  for (const auto& x : synthetic) {
    EXPECT_GT(x.counters.mean_nis(), 5.5);  // 6 for a consistent filter (measured 6.2)
    EXPECT_LT(x.counters.mean_nis(), 7.0);
  }
  EXPECT_EQ(s.bias_max_after.meeting, 8);
  EXPECT_LT(s.gap_max_error.median, 0.5 * r.gap_max_error.median);
  EXPECT_GE(s.gap_max_error.meeting, 6);    // regression guard (measured 7 of 8)
  EXPECT_GT(r.gap_max_error.median, 0.45);  // the real IMU at 1x (median 0.61 m over 20)
}

// The evidence for reading groundtruth_cam0's quaternion as R_cam_world: the relative
// rotations, moved to the body with T_BS, agree with the integrated gyro only when inverted.
TEST(FusionEuroc, V1_01Cam0QuaternionIsTheInverseOrientation) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/groundtruth_cam0/data.csv");
  const auto mav0 = test::shared_data_dir() / "euroc/V1_01_easy_part1/mav0";
  const Trajectory gt = io::read_euroc_trajectory(mav0 / "groundtruth_cam0/data.csv");
  const SE3 T_bc = *io::load_camera_file(mav0 / "cam0/sensor.yaml").T_body_sensor;
  std::vector<io::ImuSample> imu;
  io::ImuCsvReader reader(mav0 / "imu0/data.csv");
  for (io::ImuSample s; reader.next(s);) imu.push_back(s);
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  int n_still = 0;
  for (const auto& s : imu) {
    if (s.t_ns >= gt[0].t_ns) break;
    bias += s.gyro_rad_s;
    ++n_still;
  }
  ASSERT_GT(n_still, 50);
  bias /= n_still;
  double cos_as_is = 0.0, cos_inverted = 0.0;
  int n = 0;
  std::size_t k = 0;
  for (std::size_t i = 0; i + 1 < gt.size() && i < 300; ++i) {
    SO3 gyro;
    while (k + 1 < imu.size() && imu[k + 1].t_ns <= gt[i].t_ns) ++k;
    for (std::size_t j = k; j + 1 < imu.size() && imu[j].t_ns < gt[i + 1].t_ns; ++j) {
      const TimeNs a = std::max(imu[j].t_ns, gt[i].t_ns),
                   b = std::min(imu[j + 1].t_ns, gt[i + 1].t_ns);
      if (b <= a) continue;
      gyro = gyro *
             SO3::exp((0.5 * (imu[j].gyro_rad_s + imu[j + 1].gyro_rad_s) - bias) * ns_to_s(b - a));
    }
    const Eigen::Vector3d w = gyro.log();
    if (w.norm() < 0.01) continue;
    const SO3 R0 = gt[i].T_world_body.so3(), R1 = gt[i + 1].T_world_body.so3();
    const SO3 Rbc = T_bc.so3();
    const Eigen::Vector3d as_is = (Rbc * (R0.inverse() * R1) * Rbc.inverse()).log();
    const Eigen::Vector3d inverted = (Rbc * (R0 * R1.inverse()) * Rbc.inverse()).log();
    cos_as_is += as_is.normalized().dot(w.normalized());
    cos_inverted += inverted.normalized().dot(w.normalized());
    ++n;
  }
  ASSERT_GT(n, 50);
  EXPECT_LT(cos_as_is / n, 0.6);
  EXPECT_GT(cos_inverted / n, 0.99);
}

TEST(FusionEuroc, V1_01Cam0GroundTruthIsAcceptedAfterTheQuaternionFix) {
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/groundtruth_cam0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;  // the configuration before the defaults changed
  eo.vo_keyframes = false;
  eo.imu_noise_scale = 1.0;
  const auto r = run_v1_01(test::shared_data_dir() / "euroc/V1_01_easy_part1", o, eo);
  std::cout << format_result(r);
  // Before the fix (q read as R_world_cam) 2867 of 2870 updates were gated and the filter
  // diverged; now at most a handful are.
  EXPECT_GE(r.counters.updates_accepted, r.measurements - 20);
  EXPECT_LT(r.fused_rmse_m, r.chained_rmse_m);
  // REGRESSION GUARDS, NOT the targets: ratio 0.69 (target 0.5, missed); gap growth 0.19 m
  // (max absolute error in the gap 0.45 m, target 0.3 m).
  EXPECT_LT(r.fused_rmse_m, 0.8 * r.chained_rmse_m);
  EXPECT_LT(r.gap_error_growth_m, 0.3);
}

// The targets with the DEFAULTS (keyframe-referenced odometry, the in-flight IMU noise,
// the online time offset) over 20 noise draws, as `kestrel lab fuse-eval --skip-sim --seeds 20`
// prints them: the bounds are the figures, except V1_01's median ratio, whose 0.4 is
// missed (docs/fusion.md) and guarded at its measured level. ~15 s: not under the sanitizers.
TEST(FusionEuroc, DefaultsMeetTheTargetsOverTwentyDraws) {
#if !defined(NDEBUG) || defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "20 noise draws of two EuRoC runs: release builds without sanitizers only";
#endif
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/imu0/data.csv");
  const fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions eo;  // the defaults
  const auto [a, b] = over_draws(o, eo, 20);
  std::cout << format_summary(a) << format_summary(b);
  EXPECT_LE(a.ratio.median, 0.4);
  EXPECT_LE(a.ratio.max, 0.7);
  EXPECT_EQ(a.ratio_above_one, 0);
  ASSERT_EQ(a.bias_draws, 20);
  EXPECT_LE(a.bias_at_check.median, 0.003);
  EXPECT_LE(a.bias_at_check.p90, 0.005);
  EXPECT_LE(a.gap_max_error.median, 0.3);
  EXPECT_LE(a.gap_max_error.p90, 0.45);
  EXPECT_GE(a.gap_samples_inside_3sigma, 0.95 * a.gap_samples);
  // V1_01: REGRESSION GUARD on the median ratio (target 0.4 missed, docs/fusion.md).
  EXPECT_LE(b.ratio.median, 0.45);
  EXPECT_LE(b.ratio.max, 0.7);
  EXPECT_EQ(b.ratio_above_one, 0);
  EXPECT_LE(b.gap_max_error.median, 0.3);
  EXPECT_LE(b.gap_max_error.p90, 0.45);
  EXPECT_GE(b.gap_samples_inside_3sigma, 0.95 * b.gap_samples);
}

// What V1_01's median misses 0.4 by (docs/fusion.md, "V1_01's misalignment and the online
// odometry-IMU rotation"): its odometry frame is turned against the IMU. The IMU's readings
// rotated by (-1.5, 0.5, -1.25) deg bring V1_01's median ratio to 0.353 over 20 draws (0.428
// without) and make V1_02's worse (0.424), and the online rotation state finds the tilt part of
// that rotation on V1_01 (seed 1: R_D z 1.33 +- 0.21 deg; the IMU rotated by delta moves R_D by
// +delta). Measured figures; bounds with a margin.
TEST(FusionEuroc, V1_01OdometryFrameIsTurnedAgainstTheImu) {
#if !defined(NDEBUG) || defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "20 noise draws of two EuRoC runs: release builds without sanitizers only";
#endif
  KESTREL_REQUIRE_DATA("euroc/V1_02_medium_imu_groundtruth/mav0/gt0/data.csv");
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1/mav0/imu0/data.csv");
  fusion::FusionOptions o = wide_bias_prior();
  EurocExperimentOptions turned;
  turned.imu_rotation_deg = Eigen::Vector3d(-1.5, 0.5, -1.25);
  const auto [a, b] = over_draws(o, turned, 20);
  std::cout << format_summary(a) << format_summary(b);
  EXPECT_LE(b.ratio.median, 0.37);  // V1_01: 0.353
  EXPECT_GE(a.ratio.median, 0.38);  // V1_02: 0.424
  o.estimate_extrinsic_rotation = true;
  const auto r = run_v1_01(test::shared_data_dir() / "euroc/V1_01_easy_part1", o, {});
  std::cout << format_result(r);
  EXPECT_GT(r.extrinsic_rotation_final_deg.z(), 0.9);
  EXPECT_LT(r.extrinsic_rotation_final_deg.z(), 1.9);
  EXPECT_GT(r.extrinsic_rotation_final_deg.z(), 3.0 * r.extrinsic_rotation_sigma_final_deg.z());
}

}  // namespace
}  // namespace kestrel::lab
