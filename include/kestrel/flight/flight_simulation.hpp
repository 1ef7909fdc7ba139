// The whole closed loop in simulation, every component the real one: the vehicle (rigid-body
// dynamics under a Naza-like attitude flight controller) is seen by the rig's active-stereo
// cameras (rendered from the true pose), whose disparity and depth feed the direct odometry;
// the odometry's relative motions and the IMU feed the error-state EKF; the EKF's state,
// carried to the present by the IMU, feeds the safety supervisor and the position controller,
// whose commands go through the limits, the command watchdog and the PWM mapper to the flight
// controller. Simulated time, deterministic from the seed.
//
// Timing (defaults): dynamics, flight controller and IMU at 1 kHz; control at 200 Hz; camera
// at 30 Hz with its measurement reaching the filter vision_latency_s after the exposure.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/flight/scenario.hpp"
#include "kestrel/flight/stereo_vision.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/sim/flight_controller_model.hpp"
#include "kestrel/sim/quadrotor.hpp"
#include "kestrel/sim/world.hpp"

namespace kestrel::flight {

struct FlightOptions {
  double physics_rate_hz = 1000.0;  ///< dynamics, flight-controller model and IMU
  double control_rate_hz = 200.0;   ///< estimator output, safety and position control
  double camera_rate_hz = 30.0;
  /// Exposure to measurement in the filter: USB transfer, matching and tracking on board.
  double vision_latency_s = 0.040;
  /// Odometry switched off over [vo_off_at_s, vo_off_at_s + vo_off_for_s) (the outage test of
  /// docs/flight.md); a negative time: never.
  double vo_off_at_s = -1.0;
  double vo_off_for_s = 0.0;
  std::uint64_t seed = 1;  ///< IMU noise and biases, camera noise, pattern, scene textures
  /// The mission's clock runs only while the supervisor flies the mission: a hold (odometry
  /// lost) eases it to a stop (MissionClock) and the hold flies it
  /// (SafetyOptions::hold_flies_mission is set to this), so that the vehicle brakes along the
  /// path and resumes where it stopped instead of being handed a reference that ran on
  /// meanwhile (false: the clock is the flight's, the hold a fixed point).
  bool pause_mission_in_hold = true;
  /// Time constant of the mission clock's easing: at v along the path the hold brakes at
  /// most v / (e T) and stops 2 v T further on (0.5 m/s: 0.74 m/s^2, 25 cm).
  double mission_ease_time_s = 0.25;

  /// Wind, the true vehicle against `vehicle`, the IMU's in-flight noise and drift, the
  /// camera's imperfections (default: ideal, none of them).
  sim::WorldOptions world;
  /// The nominal vehicle: the controller's, the flight controller's and the filter's; the
  /// simulated one is world.vehicle_mismatch.true_vehicle(vehicle).
  sim::QuadrotorParameters vehicle;
  sim::FlightControllerModelOptions flight_controller;
  /// Data-sheet densities (default: sim::default_vehicle_imu_noise()); the simulated IMU and
  /// the filter use them times world.imu's scales.
  io::ImuNoise imu_noise;
  StereoVisionOptions vision;
  /// Noise densities and T_body_cam are taken from imu_noise and vision; the reorder window
  /// is raised to the longest vision latency (with the world's jitter and time offset) + 10 ms
  /// if it is shorter (the filter must wait for the camera's measurements). The odometry
  /// covariance's online scale (adaptive_vo_noise) is on in flight (docs/flight.md, "An adaptive
  /// odometry covariance").
  fusion::FusionOptions fusion;
  control::PositionControllerOptions controller;
  control::PwmMapperOptions pwm;
  control::SafetyOptions safety;
  control::WatchdogOptions watchdog;
  control::CommandLimits limits;

  FlightOptions();
  void validate() const;  ///< throws std::invalid_argument naming the field
};

/// One control step.
struct FlightSample {
  double t_s = 0.0;
  Eigen::Vector3d p_true = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_ref = Eigen::Vector3d::Zero();  ///< the reference flown (the mission's,
                                                    ///< or the supervisor's hold or landing)
  Eigen::Vector3d p_est = Eigen::Vector3d::Zero();
  bool vo_ok = false;  ///< the last camera frame was tracked (odometry on and healthy)
  control::SafetyMode mode = control::SafetyMode::kNominal;
  double position_sigma_m = 0.0;  ///< the filter's largest position standard deviation
  control::AttitudeThrustCommand command;
  bool crashed = false;
  /// The estimator against the truth (estimator.csv): velocities, the attitude error
  /// Log(R_est R_true^T) in the world frame (x, y: tilt; z: yaw), the accelerometer bias the
  /// filter holds and the simulated one (random walk + warm-up drift), and the filter's
  /// standard deviations of [p, theta, v] at its last output.
  Eigen::Vector3d v_true = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_est = Eigen::Vector3d::Zero();
  Eigen::Vector3d attitude_error_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_est = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_true = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 9, 1> sigma_p_theta_v = Eigen::Matrix<double, 9, 1>::Zero();
};

struct FlightCounters {
  std::size_t frames = 0;          ///< camera frames processed
  std::size_t frames_tracked = 0;  ///< ... that the odometry tracked
  std::size_t frames_off = 0;      ///< camera frames while the odometry was switched off
  std::size_t frames_dropped = 0;  ///< camera frames lost on the way (world.camera)
  /// Relocalisations after an odometry gap (StereoVisionOptions::relocalize_after_gap): tried,
  /// and passing their checks (their measurements went to the filter).
  std::size_t relocalizations_tried = 0;
  std::size_t relocalizations_ok = 0;
  double expose_ms = 0.0;  ///< blur and rolling shutter (part of render_ms), total
  double depth_fill_sum = 0.0;
  double render_ms = 0.0, match_ms = 0.0, track_ms = 0.0;  ///< totals
  double wall_s = 0.0;                                     ///< whole run
  fusion::FusionCounters fusion;
  [[nodiscard]] std::string describe() const;
};

/// One relocalisation after an odometry gap, at the camera frame's simulated time.
struct RelocalizationEvent {
  double t_s = 0.0;
  odometry::RelocalizationResult result;
  /// The relocalised pose's error against the true relative pose of the two frames (the
  /// simulation knows it): translation (m) and rotation (deg).
  double translation_error_m = 0.0;
  double rotation_error_deg = 0.0;
  double ms = 0.0;  ///< wall time of the relocalisation
};

/// One odometry measurement against the truth, which the simulation knows for both of its
/// frames: the relative motion from the reference frame, in that camera's axes (x right, y down,
/// z forward), beside the uncertainty sent with it to the filter (the tracker's covariance times
/// `covariance_scale`, before the filter's adaptive scale). Where the estimate drifts, this says
/// whether the odometry lied and in which direction (docs/flight.md, "Outputs").
struct OdometryCheck {
  double t_s = 0.0;                                                ///< the frame's time stamp (s)
  double t_ref_s = 0.0;                                            ///< its reference frame's
  Eigen::Vector3d translation_true = Eigen::Vector3d::Zero();      ///< m
  Eigen::Vector3d translation_measured = Eigen::Vector3d::Zero();  ///< m
  Eigen::Vector3d sigma_translation = Eigen::Vector3d::Zero();     ///< m
  /// Log(R_true^T R_measured): the measured rotation's error about the reference axes (deg).
  Eigen::Vector3d rotation_error_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma_rotation_deg = Eigen::Vector3d::Zero();
  bool geometric_fallback = false;  ///< the tracker's geometric fallback gave it
  bool new_reference = false;       ///< the frame becomes the next reference (keyframe)
  bool relocalised = false;         ///< a relocalisation across a gap gave it

  /// measured - true translation (m, reference camera axes).
  [[nodiscard]] Eigen::Vector3d translation_error() const {
    return translation_measured - translation_true;
  }
};

struct FlightResult {
  std::string scenario;
  std::vector<FlightSample> samples;
  FlightCounters counters;
  std::vector<RelocalizationEvent> relocalizations;
  std::vector<OdometryCheck> odometry_checks;  ///< every measurement the filter was sent
  double settle_s = 0.0;                       ///< errors are scored from here on
  double duration_s = 0.0;
  bool crashed = false;
  bool interrupted = false;  ///< stopped early by the stop flag; duration_s is what was flown
  std::string final_mode;
  /// RMS of |p_true - p_ref| over the samples at t >= settle_s (the tracking figure of
  /// docs/flight.md; while the supervisor holds or lands, its reference counts). Samples after
  /// the motors are off (landed) are not flight and do not count: the estimate of a vehicle
  /// standing on the floor after a touchdown is not used any more.
  [[nodiscard]] double rms_tracking_m() const;
  /// RMS of |p_est - p_true| over the same samples.
  [[nodiscard]] double rms_estimate_m() const;
  /// Largest |p_true - p_ref| over the same samples.
  [[nodiscard]] double max_tracking_m() const;
};

class FlightSimulation {
 public:
  /// Builds the scene and every component. Throws std::invalid_argument for invalid options.
  FlightSimulation(Scenario scenario, FlightOptions options);

  /// Flies for duration_s of simulated time (stops 1 s after a crash). `progress` is called
  /// once per simulated second. `stop` (may be null), when raised, ends the flight after the
  /// current control step (result.interrupted).
  FlightResult run(double duration_s, const std::function<void(const FlightSample&)>& progress = {},
                   const std::atomic<bool>* stop = nullptr);

  [[nodiscard]] const Scenario& scenario() const { return scenario_; }
  [[nodiscard]] const FlightOptions& options() const { return options_; }

 private:
  Scenario scenario_;
  FlightOptions options_;
};

}  // namespace kestrel::flight
