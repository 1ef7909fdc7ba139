// The fusion's target experiments on real EuRoC data: propagate on the real IMU, feed 20 Hz
// relative poses made from the ground truth with known noise, compare with the ground truth
// and with chaining the same noisy relative poses. `kestrel lab fuse-eval` runs them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "kestrel/fusion/fusion_engine.hpp"

namespace kestrel::lab {

struct EurocExperimentOptions {
  double vo_rate_hz = 20.0;
  double vo_sigma_p_m = 0.01;
  double vo_sigma_rot_deg = 0.5;
  double bias_check_after_s = 20.0;  ///< gyro-bias error is checked from here on
  double gap_start_s = 15.0;         ///< start of the measurement gap, after the first pose
  double gap_s = 2.0;
  std::uint64_t seed = 1;
  /// Reference of the relative poses. On (the default, as Kestrel's odometry reports them):
  /// keyframe odometry as odometry::DirectTracker reports it, each pose relative to the current
  /// keyframe, which is switched (the frame becomes the keyframe) when the true motion from it
  /// exceeds the rotation or translation below, or after vo_keyframe_max_frames frames. Off
  /// (`--frame-to-frame`): each measurement from the previous frame. The same noise per
  /// measurement either way.
  bool vo_keyframes = true;
  double vo_keyframe_max_rot_deg = 5.0;   ///< odometry::DirectTracker's default keyframe rotation
  double vo_keyframe_max_trans_m = 0.15;  ///< 0.05 x a ~3 m median depth (the tracker's rule)
  int vo_keyframe_max_frames = 20;
  /// > 0: the factor on the white-noise densities of imu0/sensor.yaml (gyro and accelerometer)
  /// in place of the in-flight default (fusion::kInFlightImuNoiseInflation; 1 with
  /// synthetic_imu, whose IMU draws exactly the YAML's densities).
  double imu_noise_scale = 0.0;
  double imu_walk_scale = 1.0;
  /// Gyro bias from the still IMU samples before the first pose (static start) when they
  /// pass the still test, with this prior sigma; otherwise zero bias, prior from
  /// fusion::FusionOptions.
  bool static_gyro_bias_init = false;
  double static_gyro_bias_sigma_rad_s = 0.01;
  /// Control experiment: replace the real IMU by one synthesised from the ground truth at the
  /// real samples' time stamps, exactly as imu0/sensor.yaml models it (its densities, before the
  /// scales above; biases starting at the ground truth's, zero where it has none, and walking)
  /// (ground_truth_imu.hpp). The odometry noise is drawn as with the real IMU (the frames start
  /// one ground-truth sample later: the synthetic IMU begins at the first one).
  bool synthetic_imu = false;
  /// Diagnostics (docs/fusion.md, "V1_01's misalignment and the online odometry-IMU rotation"): the
  /// IMU's readings (gyro and accelerometer) rotated by exp(imu_rotation_deg) before fusing, each
  /// gyro axis scaled by gyro_scale, and the ground truth's world frame turned by
  /// exp(world_rotation_deg) (T_w_b -> R T_w_b; the relative poses are unchanged, the start and the
  /// score are not).
  Eigen::Vector3d imu_rotation_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_scale = Eigen::Vector3d::Ones();
  Eigen::Vector3d world_rotation_deg = Eigen::Vector3d::Zero();
};

/// Ground truth pose (body) with optional velocity and gyro bias at one time.
struct GroundTruthSample {
  TimeNs t_ns = 0;
  SE3 T_world_body;
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  bool has_bias = false;
};

struct EurocExperimentResult {
  std::string name;
  double duration_s = 0.0;
  std::size_t measurements = 0;
  double fused_rmse_m = 0.0;
  double chained_rmse_m = 0.0;
  double fused_rot_rmse_deg = 0.0;
  double chained_rot_rmse_deg = 0.0;
  /// |b_g - reference| at bias_check_after_s, and its maximum from then to the end.
  double gyro_bias_error_at_check = 0.0;
  double gyro_bias_error_max_after = 0.0;
  /// The filter's own 1-sigma of the gyro bias (norm over the axes) at bias_check_after_s.
  double gyro_bias_sigma_at_check = 0.0;
  bool gyro_bias_checked = false;  ///< false where there is no bias reference (V1_01)
  std::string bias_reference;      ///< where the reference bias came from
  Eigen::Vector3d gyro_bias_final = Eigen::Vector3d::Zero();
  /// The camera-IMU time offset the filter ends with, and its 1-sigma [s].
  double time_offset_final_s = 0.0, time_offset_sigma_final_s = 0.0;
  /// The odometry-IMU rotation q_body_odom the filter ends with (rotation vector) and its
  /// 1-sigma per axis [deg] (zero when it is not estimated).
  Eigen::Vector3d extrinsic_rotation_final_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d extrinsic_rotation_sigma_final_deg = Eigen::Vector3d::Zero();
  /// Gap run: largest position error inside the gap, its growth over the gap, and the
  /// largest error over the whole run with the gap.
  double gap_max_error_m = 0.0;
  double gap_error_growth_m = 0.0;
  double gap_run_max_error_m = 0.0;
  bool gap_flag_raised = false;    ///< vo_dropout was flagged inside the gap
  double gap_max_sigma_p_m = 0.0;  ///< largest 1-sigma position (norm) inside the gap
  /// Gap samples (IMU rate, where a ground-truth sample is) and how many of them have every
  /// axis' position error inside the filter's 3-sigma bound of that axis.
  int gap_samples = 0;
  int gap_samples_inside_3sigma = 0;
  /// Where the gap's error comes from (sequences whose ground truth has biases: V1_02): the
  /// filter's state at the gap's start against the ground truth, and the largest position
  /// error of IMU-only dead reckoning over the gap started from the ground-truth state with one
  /// part of the filter's state swapped in.
  struct GapDecomposition {
    bool measured = false;
    Eigen::Vector3d dp = Eigen::Vector3d::Zero();          ///< filter - truth, world [m]
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();          ///< world [m/s]
    Eigen::Vector3d dtheta_deg = Eigen::Vector3d::Zero();  ///< body-frame attitude error
    Eigen::Vector3d d_accel_bias = Eigen::Vector3d::Zero();
    Eigen::Vector3d sigma_v = Eigen::Vector3d::Zero();          ///< the filter's own 1-sigma
    Eigen::Vector3d sigma_theta_deg = Eigen::Vector3d::Zero();  ///< the filter's own 1-sigma
    double truth = 0.0, with_position = 0.0, with_velocity = 0.0, with_attitude = 0.0,
           with_biases = 0.0, filter = 0.0;  ///< max position error in the gap [m]
  } gap_decomposition;
  /// Does the IMU agree with the ground truth as its YAML says? Over consecutive 1 s windows,
  /// the IMU integrated along the ground truth's orientation (minus its biases where it has
  /// them) against the ground truth's change of velocity and of orientation (GroundTruthSpline):
  /// the rms of the mean specific-force and rate errors, and what the YAML's white noise alone
  /// predicts for them (density / sqrt(1 s), per axis, as a 3-axis norm).
  struct ImuConsistency {
    int windows = 0;
    double accel_rms_m_s2 = 0.0, gyro_rms_rad_s = 0.0;
    double accel_yaml_m_s2 = 0.0, gyro_yaml_rad_s = 0.0;
  } imu_consistency;
  fusion::FusionCounters counters;
};

/// Runs both experiments (no gap; a gap) on one sequence. `gt` is body ground truth on a
/// regular grid whose rate is a multiple of vo_rate_hz; the filter starts from the first
/// ground-truth pose and velocity with zero biases.
EurocExperimentResult run_euroc_experiment(const std::string& name,
                                           const std::vector<io::ImuSample>& imu,
                                           const std::vector<GroundTruthSample>& gt,
                                           fusion::FusionOptions fusion,
                                           const EurocExperimentOptions& options);

/// V1_02 folder (mav0/imu0 + mav0/gt0): ground-truth state with biases.
EurocExperimentResult run_v1_02(const std::filesystem::path& sequence,
                                const fusion::FusionOptions& fusion,
                                const EurocExperimentOptions& options);
/// V1_01 part folder (mav0/imu0 + mav0/groundtruth_cam0 + cam0/sensor.yaml T_BS): camera
/// ground truth (its quaternion is R_cam_world, inverted on reading; docs/fusion.md) moved to
/// the body; bias reference from the static start of the IMU.
EurocExperimentResult run_v1_01(const std::filesystem::path& sequence,
                                const fusion::FusionOptions& fusion,
                                const EurocExperimentOptions& options);

std::string format_result(const EurocExperimentResult& r);

/// One sequence's experiment over several noise draws (seeds): every figure of a single run is
/// one draw of the measurement noise, and the targets' figures vary with it (docs/fusion.md).
struct EurocSeedSummary {
  struct Spread {
    double median = 0.0, min = 0.0, max = 0.0;
    double p90 = 0.0;  ///< 90th percentile (linear interpolation between order statistics)
    int meeting = 0;   ///< draws meeting the issue's target
  };
  std::string name;
  int draws = 0;
  Spread ratio;             ///< fused / chained position RMSE, target: median <= 0.4, worst <= 0.7
  Spread bias_at_check;     ///< target <= 0.003 rad/s (draws without a bias reference: none)
  Spread bias_max_after;    ///< target <= 0.003 rad/s
  Spread gap_max_error;     ///< target < 0.3 m
  int bias_draws = 0;       ///< draws with a bias reference
  int ratio_above_one = 0;  ///< draws where fusing is worse than chaining
  /// Gap samples inside the filter's 3-sigma bound, over all draws (target >= 95 %).
  int gap_samples = 0, gap_samples_inside_3sigma = 0;
  double mean_fused_m = 0.0, mean_chained_m = 0.0;  ///< means over the draws
};

/// Summarises results of one sequence (non-empty; the same experiment, different seeds).
EurocSeedSummary summarise_draws(const std::vector<EurocExperimentResult>& results);
std::string format_summary(const EurocSeedSummary& s);

}  // namespace kestrel::lab
