// Time bookkeeping around the EKF: buffers IMU samples and odometry measurements that arrive
// late or out of order, initialises (static start or given state), gates odometry updates,
// flags odometry dropout and IMU gaps, and emits the fused state at IMU rate.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kestrel/fusion/adaptive_noise.hpp"
#include "kestrel/fusion/stochastic_cloning_ekf.hpp"
#include "kestrel/io/euroc.hpp"

namespace kestrel::fusion {

/// The factor on a real IMU's white-noise densities (its sensor YAML's, measured at rest) for
/// in-flight use, where vibration and unmodelled errors are far above them (Kalibr's and
/// OpenVINS' users inflate them alike). Chosen on EuRoC V1_02 over 20 noise draws and checked
/// on V1_01 (docs/fusion.md, "IMU noise for in-flight use"; config/imu_default.yaml). An IMU
/// sensor YAML's `in_flight_noise_inflation` replaces it.
inline constexpr double kInFlightImuNoiseInflation = 15.0;

/// Every option of the fusion, with its default; YAML keys are the field names.
struct FusionOptions {
  ImuNoiseDensities noise;  ///< from the IMU sensor YAML (EuRoC imu0/sensor.yaml)
  /// The filter uses noise's white-noise densities (gyro, accel) times this factor; the bias
  /// random walks as given. 0 (the default): not set here; set_imu_noise(), reading a real
  /// IMU's sensor YAML, then makes it the YAML's `in_flight_noise_inflation` or
  /// kInFlightImuNoiseInflation, and without a sensor file it is 1 (the densities as they are: a
  /// simulated IMU draws exactly them). A value set here (options YAML) is kept.
  double imu_noise_inflation = 0.0;
  /// Camera-IMU time offset t_d (a frame stamped t was taken at IMU time t + t_d): its start
  /// value, and whether it is estimated online (as OpenVINS and VINS-Fusion do) with the prior
  /// std init_sigma_time_offset_s. 20 ms: a frame period of a 50 Hz camera, more than the few
  /// ms of a hardware-triggered rig and the 5-15 ms of USB cameras with software stamps.
  double time_offset_s = 0.0;
  bool estimate_time_offset = true;
  double init_sigma_time_offset_s = 0.02;
  /// Odometry-IMU rotation (the rotation of T_body_cam, and of any frame the odometry's poses
  /// are referenced to): estimated online as a 3-dof correction q_body_odom with the prior std
  /// init_sigma_extrinsic_rotation_rad per axis (docs/fusion.md, "V1_01's misalignment and the
  /// online odometry-IMU rotation"). Off (the default: not chosen on V1_01's reference, as
  /// that section says): the rotation of T_body_cam is taken as exact. Prior 2 deg: a CAD or
  /// hand-measured mount is good to a degree or two.
  bool estimate_extrinsic_rotation = false;
  double init_sigma_extrinsic_rotation_rad = 0.0349;

  double gravity_m_s2 = 9.81;  ///< world z is up; g = (0, 0, -gravity)
  /// Odometry camera in the body (IMU) frame, EuRoC T_BS of cam0 (identity if the odometry
  /// already reports body poses).
  SE3 T_body_cam;
  /// Chi-square gate probability for the 6-dof relative-pose update; 0 disables the gate.
  double gate_probability = 0.999;
  /// No accepted odometry update for this long -> IMU-only, `vo_dropout` flag set.
  double dropout_timeout_s = 0.25;
  /// Consecutive IMU samples further apart than this set the `imu_gap` flag (the step is
  /// still propagated, in sub-steps of the nominal period, with growing covariance).
  double max_imu_gap_s = 0.05;
  /// IMU full scale per axis: a sample with an axis beyond it (a saturated or corrupt
  /// reading) is rejected, counted. Defaults +-16 g and +-2000 deg/s, the widest full-scale
  /// settings of common MEMS IMUs (ADIS16448 of EuRoC: +-18 g, +-1000 deg/s); an IMU sensor
  /// YAML with `accelerometer_range_m_s2` / `gyroscope_range_rad_s` replaces them.
  double accel_range_m_s2 = 16.0 * 9.80665;
  double gyro_range_rad_s = 2000.0 * 3.14159265358979323846 / 180.0;
  /// The longest the filter is carried on the IMU alone past its last sample: an odometry
  /// measurement later than this after the last IMU sample (past the IMU's end, before its
  /// start, or inside a longer gap) is refused, counted, and gives no output; an IMU gap
  /// longer than this is counted apart (`imu_gaps_beyond_horizon`).
  double imu_horizon_s = 0.5;
  /// Plausibility of an output for a micro aerial vehicle: a speed above max_speed_m_s, or a
  /// step between consecutive outputs longer than max_speed_m_s * dt + max_position_jump_m,
  /// flags it `implausible` (counted; `kestrel fuse` stops with an error).
  double max_speed_m_s = 50.0;
  double max_position_jump_m = 2.0;
  /// Inputs are held this long (in data time, relative to the newest input) so that late or
  /// out-of-order samples are processed in time order. Older arrivals are dropped, counted.
  double reorder_window_s = 0.02;
  /// Static initialisation: this long a still window of IMU samples, gravity from the mean
  /// accelerometer, gyro bias from the mean rate.
  double static_init_s = 1.0;
  double static_max_gyro_std_rad_s = 0.02;
  double static_max_accel_std_m_s2 = 0.3;
  /// Initial standard deviations of the current state (both initialisations).
  double init_sigma_p_m = 1e-3;
  double init_sigma_roll_pitch_rad = 0.02;
  double init_sigma_yaw_rad = 0.02;
  double init_sigma_v_m_s = 0.05;
  double init_sigma_gyro_bias_rad_s = 0.01;
  double init_sigma_accel_bias_m_s2 = 0.1;
  /// First-estimates Jacobians (StochasticCloningEkf::set_first_estimate_jacobians): keeps the
  /// yaw about gravity unobservable to the filter; off only to compare (docs/fusion.md).
  bool first_estimate_jacobians = true;
  /// Two gated measurements in a row from a keyframe that stays the reference re-anchor the
  /// following ones from that keyframe on the second (they then measure the motion since), so
  /// that one odometry jump against a kept keyframe does not get every later measurement from
  /// it gated; a single outlier is only rejected.
  bool reanchor_after_gate = true;
  /// An online scale on the odometry's covariance from the NIS of the recent updates, gated ones
  /// included (fusion/adaptive_noise.hpp; docs/fusion.md, "Adaptive odometry covariance"): the
  /// filter's R follows the scene instead of one fixed covariance_scale for every scene.
  AdaptiveNoiseOptions adaptive_vo_noise;

  /// The YAML fields (io/option_fields.hpp). The noise densities carry the EuRoC sensor.yaml
  /// names; T_body_cam is a calibration, not an option, and is not among them.
  template <typename V>
  void visit_fields(V&& v) {
    v("gyroscope_noise_density", noise.gyro_noise);
    v("gyroscope_random_walk", noise.gyro_walk);
    v("accelerometer_noise_density", noise.accel_noise);
    v("accelerometer_random_walk", noise.accel_walk);
    v("imu_noise_inflation", imu_noise_inflation);
    v("time_offset_s", time_offset_s);
    v("estimate_time_offset", estimate_time_offset);
    v("init_sigma_time_offset_s", init_sigma_time_offset_s);
    v("estimate_extrinsic_rotation", estimate_extrinsic_rotation);
    v("init_sigma_extrinsic_rotation_rad", init_sigma_extrinsic_rotation_rad);
    v("gravity_m_s2", gravity_m_s2);
    v("gate_probability", gate_probability);
    v("dropout_timeout_s", dropout_timeout_s);
    v("max_imu_gap_s", max_imu_gap_s);
    v("accelerometer_range_m_s2", accel_range_m_s2);
    v("gyroscope_range_rad_s", gyro_range_rad_s);
    v("imu_horizon_s", imu_horizon_s);
    v("max_speed_m_s", max_speed_m_s);
    v("max_position_jump_m", max_position_jump_m);
    v("reorder_window_s", reorder_window_s);
    v("static_init_s", static_init_s);
    v("static_max_gyro_std_rad_s", static_max_gyro_std_rad_s);
    v("static_max_accel_std_m_s2", static_max_accel_std_m_s2);
    v("init_sigma_p_m", init_sigma_p_m);
    v("init_sigma_roll_pitch_rad", init_sigma_roll_pitch_rad);
    v("init_sigma_yaw_rad", init_sigma_yaw_rad);
    v("init_sigma_v_m_s", init_sigma_v_m_s);
    v("init_sigma_gyro_bias_rad_s", init_sigma_gyro_bias_rad_s);
    v("init_sigma_accel_bias_m_s2", init_sigma_accel_bias_m_s2);
    v("first_estimate_jacobians", first_estimate_jacobians);
    v("reanchor_after_gate", reanchor_after_gate);
    v("adaptive_vo_noise", adaptive_vo_noise.enabled);
    v("adaptive_vo_noise_window", adaptive_vo_noise.window_updates);
    v("adaptive_vo_noise_min_scale", adaptive_vo_noise.min_scale);
    v("adaptive_vo_noise_max_scale", adaptive_vo_noise.max_scale);
  }

  /// Loads the fields present in a YAML map (unknown keys are errors naming the file).
  static FusionOptions load_yaml(const std::filesystem::path& path);
  /// Takes the noise densities of an EuRoC IMU sensor.yaml, and its ranges where it has them;
  /// the in-flight inflation from its `in_flight_noise_inflation`, else
  /// kInFlightImuNoiseInflation (a sensor file describes a real IMU).
  void set_imu_noise(const io::ImuNoise& imu);
  /// The densities the filter uses: the white noise times imu_noise_inflation (1 if unset).
  [[nodiscard]] ImuNoiseDensities filter_noise() const;
  /// One line for logs.
  [[nodiscard]] std::string describe() const;
  /// The YAML fields, as load_yaml() reads them.
  [[nodiscard]] std::string to_yaml() const;
  /// Throws InputError for non-positive densities and similar impossible values.
  void validate() const;
  [[nodiscard]] Matrix15d initial_covariance() const;
};

/// Health flags of an output, as bits.
enum FusionFlag : std::uint32_t {
  kFlagNone = 0,
  kFlagVoDropout = 1u << 0,    ///< no accepted odometry update within dropout_timeout_s
  kFlagImuGap = 1u << 1,       ///< the last IMU step bridged a gap > max_imu_gap_s
  kFlagRejected = 1u << 2,     ///< the last odometry measurement was rejected
  kFlagUpdated = 1u << 3,      ///< this output follows an accepted update
  kFlagImplausible = 1u << 4,  ///< speed or position step beyond FusionOptions' MAV limits
};
std::string describe_flags(std::uint32_t flags);

/// One fused output (IMU rate, or at the odometry's time stamps).
struct FusedState {
  TimeNs t_ns = 0;
  NominalState state;
  /// std of [p, theta, v]; NaN in a state the filter has not output (unknown, not zero)
  Eigen::Matrix<double, 9, 1> sigma =
      Eigen::Matrix<double, 9, 1>::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d sigma_gyro_bias = Eigen::Vector3d::Zero();  ///< std of b_g
  double sigma_time_offset_s = 0.0;                           ///< std of t_d

  /// std of dphi, the odometry-IMU rotation's error (0 when it is not estimated)
  Eigen::Vector3d sigma_extrinsic_rotation_rad = Eigen::Vector3d::Zero();
  std::uint32_t flags = kFlagNone;
  bool at_odometry = false;  ///< emitted at an odometry time stamp (after its update)
};

/// A relative motion of the odometry camera between two of its frames.
struct RelativePoseMeasurement {
  TimeNs t_ref_ns = 0;
  TimeNs t_ns = 0;
  SE3 T_ref_cur;  ///< camera frame at t_ns in the camera frame at t_ref_ns
  /// Left perturbation [v, w] in the reference frame (TrackResult's). NaN until set: a
  /// measurement whose covariance was never filled in is rejected as invalid (counted in
  /// FusionCounters::updates_invalid) instead of being applied with whatever the memory held.
  Matrix6d covariance = Matrix6d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The frame at t_ns becomes the odometry's reference: later measurements start there, so
  /// the filter re-clones after this update (frame-to-frame odometry: always true). False
  /// for keyframe odometry while the keyframe is kept: the clone of t_ref_ns stays and the
  /// next measurement is again relative to it (the thesis' clone of the keyframe, 4.6).
  bool starts_new_reference = true;
};

struct FusionCounters {
  std::size_t imu_samples = 0;
  std::size_t imu_dropped_late = 0;     ///< arrived older than the processed time
  std::size_t imu_before_start = 0;     ///< at or before a given initial state (not an error)
  std::size_t imu_dropped_invalid = 0;  ///< non-finite values
  std::size_t imu_out_of_range = 0;     ///< an axis beyond accel/gyro_range
  std::size_t imu_duplicate = 0;        ///< same time stamp as the previous sample
  std::size_t imu_gaps = 0;
  std::size_t imu_gaps_beyond_horizon = 0;  ///< gaps longer than imu_horizon_s
  std::size_t updates_accepted = 0;
  std::size_t updates_gated = 0;
  std::size_t updates_invalid = 0;
  std::size_t updates_no_reference = 0;  ///< reference time was not the clone's
  std::size_t measurements_dropped_late = 0;
  std::size_t measurements_before_init = 0;
  std::size_t measurements_outside_imu = 0;  ///< later than imu_horizon_s after the last IMU sample
  std::size_t implausible_outputs = 0;
  /// Sum of r^T S^-1 r over the accepted updates: its mean (mean_nis()) is 6 for a consistent
  /// filter, above it when the filter trusts the IMU or the odometry more than they deserve.
  double nis_sum_accepted = 0.0;
  /// The adaptive odometry covariance scale (FusionOptions::adaptive_vo_noise) over the updates
  /// it was applied to (accepted and gated): its sum and largest value; 0 when it is off.
  double vo_noise_scale_sum = 0.0;
  double vo_noise_scale_max = 0.0;
  [[nodiscard]] double mean_vo_noise_scale() const {
    const std::size_t n = updates_accepted + updates_gated;
    return n > 0 ? vo_noise_scale_sum / static_cast<double>(n) : 0.0;
  }
  [[nodiscard]] double mean_nis() const {
    return updates_accepted > 0 ? nis_sum_accepted / static_cast<double>(updates_accepted) : 0.0;
  }
  [[nodiscard]] std::string describe() const;
  /// What was rejected, per reason, in words ("" if nothing): for a run's summary.
  [[nodiscard]] std::string describe_rejections() const;
};

class FusionEngine {
 public:
  explicit FusionEngine(FusionOptions options);

  /// Starts from a given state instead of the static initialisation (biases included); the
  /// covariance is options().initial_covariance().
  void initialize(const NominalState& state);

  /// Inputs, in any order within reorder_window_s. Non-finite samples, and samples beyond the
  /// IMU's range, are dropped, counted.
  void add_imu(const io::ImuSample& sample);
  void add_relative_pose(const RelativePoseMeasurement& measurement);

  /// Processes everything older than (newest input - reorder_window) and returns the outputs
  /// produced (at every IMU sample if imu_rate, else only at odometry time stamps).
  std::vector<FusedState> poll(bool imu_rate);
  /// Processes all that is buffered.
  std::vector<FusedState> flush(bool imu_rate);

  [[nodiscard]] bool initialized() const { return initialized_; }
  [[nodiscard]] const StochasticCloningEkf& filter() const { return ekf_; }
  [[nodiscard]] const FusionCounters& counters() const { return counters_; }
  [[nodiscard]] const FusionOptions& options() const { return options_; }
  /// The first implausible output (kFlagImplausible), with what was implausible in words.
  [[nodiscard]] const std::optional<std::pair<FusedState, std::string>>& first_implausible() const {
    return first_implausible_;
  }
  /// The UpdateResult of the last odometry measurement processed.
  [[nodiscard]] const std::optional<UpdateResult>& last_update() const { return last_update_; }
  /// The scale the next odometry covariance is multiplied by (1 when adaptive_vo_noise is off).
  [[nodiscard]] double vo_noise_scale() const {
    return vo_noise_scale_ ? vo_noise_scale_->scale() : 1.0;
  }

 private:
  void process_until(TimeNs t_ns, bool imu_rate, std::vector<FusedState>& out);
  void process_imu(const io::ImuSample& s, bool imu_rate, std::vector<FusedState>& out);
  void process_measurement(const RelativePoseMeasurement& m, std::vector<FusedState>& out);
  void propagate_to(TimeNs t_ns);
  bool try_static_init(const io::ImuSample& s);
  FusedState output(bool at_odometry) const;
  void emit(bool at_odometry, std::vector<FusedState>& out);
  [[nodiscard]] std::string implausibility(const FusedState& f) const;

  FusionOptions options_;
  StochasticCloningEkf ekf_;
  double gate_chi2_ = 0.0;
  bool initialized_ = false;
  std::multimap<TimeNs, io::ImuSample> imu_buffer_;
  std::multimap<TimeNs, RelativePoseMeasurement> vo_buffer_;
  TimeNs newest_input_ns_ = std::numeric_limits<TimeNs>::min();
  TimeNs processed_ns_ = std::numeric_limits<TimeNs>::min();
  std::optional<io::ImuSample> last_imu_;
  TimeNs last_imu_t_ns_ = std::numeric_limits<TimeNs>::min();  ///< last sample processed
  std::optional<FusedState> last_output_;
  std::optional<std::pair<FusedState, std::string>> first_implausible_;
  std::deque<io::ImuSample> init_window_;
  TimeNs last_accepted_update_ns_ = 0;
  std::uint32_t sticky_flags_ = kFlagNone;
  std::optional<UpdateResult> last_update_;
  FusionCounters counters_;
  // A keyframe the filter never cloned (it came before the filter started, or before a gap):
  // the first measurement from it was cloned as `clone_t_ns` and its motion from the keyframe
  // kept, so that the next measurements from the same keyframe are re-based on that clone.
  struct KeyframeAnchor {
    TimeNs keyframe_t_ns = 0;
    TimeNs clone_t_ns = 0;
    SE3 T_keyframe_clone;
    Matrix6d covariance = Matrix6d::Zero();
  };
  std::optional<KeyframeAnchor> anchor_;
  std::optional<NisNoiseScale> vo_noise_scale_;  ///< set when adaptive_vo_noise.enabled
  int gated_in_a_row_ = 0;  ///< gated measurements from the kept keyframe since the last accepted
};

/// Whether every axis of a sample is finite and within the options' full scale.
bool imu_sample_in_range(const io::ImuSample& s, const FusionOptions& options);

/// Static initialisation from still IMU samples: roll and pitch from the mean specific force
/// (yaw 0), gyro bias from the mean rate; nullopt if the window is not still enough.
std::optional<NominalState> static_initial_state(const std::vector<io::ImuSample>& samples,
                                                 const FusionOptions& options);

}  // namespace kestrel::fusion
