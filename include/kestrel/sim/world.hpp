// The world a simulated flight flies in: wind, the true vehicle against the one the controller
// and filter assume, the IMU's in-flight noise and drift, and the camera's imperfections.
// Every default is the ideal world (no wind, the nominal vehicle, data-sheet IMU noise, a
// perfect camera); WorldOptions::realistic() is the preset of docs/flight.md, "World".
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>

#include "kestrel/sim/exposure.hpp"
#include "kestrel/sim/quadrotor.hpp"
#include "kestrel/sim/wind.hpp"

namespace kestrel::sim {

/// The true vehicle against the nominal one (which the controller, the flight controller's
/// mixer and the filter keep).
struct VehicleMismatchOptions {
  double mass_scale = 1.0;                 ///< true mass / nominal
  double thrust_coefficient_scale = 1.0;   ///< true rotor thrust constant / nominal
  double motor_time_constant_scale = 1.0;  ///< true motor lag / nominal
  /// Centre of mass off the rotors' centre, body frame (m): an asymmetric arm or payload.
  Eigen::Vector3d center_of_mass_offset_m = Eigen::Vector3d::Zero();

  template <typename V>
  void visit_fields(V&& v) {
    v("mass_scale", mass_scale);
    v("thrust_coefficient_scale", thrust_coefficient_scale);
    v("motor_time_constant_scale", motor_time_constant_scale);
    v("center_of_mass_offset_m", center_of_mass_offset_m);
  }
  void validate() const;
  /// The true vehicle for a nominal one (inertia scaled with the mass).
  [[nodiscard]] QuadrotorParameters true_vehicle(const QuadrotorParameters& nominal) const;
};

struct ImuWorldOptions {
  /// Factor on the IMU's data-sheet white-noise densities (FlightOptions::imu_noise): 15 is
  /// the in-flight noise measured on EuRoC V1_02 (fusion::kInFlightImuNoiseInflation). The
  /// filter is given the same densities, as a real one reads them from the sensor file times
  /// its in-flight factor.
  double white_noise_scale = 1.0;
  double bias_random_walk_scale = 1.0;  ///< factor on the bias random walks
  /// Warm-up bias drift (VehicleImuSimulator::set_warm_up_drift), not modelled by the filter.
  double warm_up_gyro_drift_rad_s = 0.0;
  double warm_up_accel_drift_m_s2 = 0.0;
  double warm_up_time_constant_s = 120.0;
  /// True camera-IMU time offset t_d (a frame stamped t was exposed at IMU time t + t_d), NOT
  /// given to the filter: it starts from its own prior (FusionOptions::time_offset_s).
  double camera_time_offset_s = 0.0;

  template <typename V>
  void visit_fields(V&& v) {
    v("white_noise_scale", white_noise_scale);
    v("bias_random_walk_scale", bias_random_walk_scale);
    v("warm_up_gyro_drift_rad_s", warm_up_gyro_drift_rad_s);
    v("warm_up_accel_drift_m_s2", warm_up_accel_drift_m_s2);
    v("warm_up_time_constant_s", warm_up_time_constant_s);
    v("camera_time_offset_s", camera_time_offset_s);
  }
  void validate() const;
};

struct CameraWorldOptions {
  double drop_probability = 0.0;  ///< each frame lost independently (never reaches the odometry)
  double exposure_s = 0.0;        ///< motion blur over the exposure; 0: none
  double readout_s = 0.0;         ///< rolling shutter, first to last row; 0: global shutter
  int blur_max_taps = 5;          ///< samples per exposure (sim::ExposureOptions::max_taps)
  /// The camera-to-filter latency varies uniformly by +- this around
  /// FlightOptions::vision_latency_s.
  double latency_jitter_s = 0.0;

  template <typename V>
  void visit_fields(V&& v) {
    v("drop_probability", drop_probability);
    v("exposure_s", exposure_s);
    v("readout_s", readout_s);
    v("blur_max_taps", blur_max_taps);
    v("latency_jitter_s", latency_jitter_s);
  }
  void validate() const;
  [[nodiscard]] ExposureOptions exposure() const {
    return ExposureOptions{exposure_s, readout_s, blur_max_taps};
  }
};

struct WorldOptions {
  std::string name = "ideal";  ///< for the reports
  WindOptions wind;
  VehicleMismatchOptions vehicle_mismatch;
  ImuWorldOptions imu;
  CameraWorldOptions camera;

  template <typename V>
  void visit_fields(V&& v) {
    v("name", name);
    v("wind", wind);
    v("vehicle_mismatch", vehicle_mismatch);
    v("imu", imu);
    v("camera", camera);
  }

  static WorldOptions ideal() { return {}; }
  static WorldOptions realistic();
  /// Throws InputError naming the field ("world option 'imu.white_noise_scale': ...").
  void validate() const;
  /// YAML that load() reads back, every field with its meaning as a comment.
  [[nodiscard]] std::string to_documented_yaml() const;
  /// A YAML file (the fields at the top level or under `world:`); missing fields keep the
  /// ideal values. Errors name the file and field.
  static WorldOptions load(const std::filesystem::path& path);
  static WorldOptions from_yaml(const YAML::Node& node, const std::string& source);
  /// "ideal", "realistic", or a YAML file.
  static WorldOptions from_argument(const std::string& name_or_path);
  /// One line for the run header.
  [[nodiscard]] std::string describe() const;
};

}  // namespace kestrel::sim
