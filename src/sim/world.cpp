// World options: validation, the realistic preset, documented YAML.
#include "kestrel/sim/world.hpp"

#include <cmath>
#include <map>
#include <sstream>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sim {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw InputError("world option '" + field + "': " + why);
}

void check_range(const std::string& field, double v, double lo, double hi) {
  if (!(std::isfinite(v) && v >= lo && v <= hi)) {
    std::ostringstream os;
    os << "must be in [" << lo << ", " << hi << "], got " << v;
    fail(field, os.str());
  }
}

// The comment of each field in to_documented_yaml(), by its dotted name.
const std::map<std::string, std::string>& field_docs() {
  static const std::map<std::string, std::string> docs{
      {"name", "a label for the reports"},
      {"wind", "mean wind + Dryden turbulence (MIL-F-8785C low altitude); drag acts on v - wind"},
      {"wind.mean_world_m_s",
       "mean wind, world frame [m/s]; its horizontal direction is the gusts' u axis"},
      {"wind.turbulence_w20_m_s", "wind speed at 20 ft W20 [m/s]: sigma_w = 0.1 W20; 0 = no gusts"},
      {"wind.min_altitude_m", "Dryden scales below this height are taken at it (10 ft) [m]"},
      {"wind.min_airspeed_m_s", "floor of the airspeed V in the correlation times L/V [m/s]"},
      {"vehicle_mismatch", "the true vehicle vs the nominal one the controller and filter keep"},
      {"vehicle_mismatch.mass_scale", "true mass / nominal (inertia scales with it)"},
      {"vehicle_mismatch.thrust_coefficient_scale", "true rotor thrust constant / nominal"},
      {"vehicle_mismatch.motor_time_constant_scale", "true motor time constant / nominal"},
      {"vehicle_mismatch.center_of_mass_offset_m",
       "centre of mass off the rotors' centre, body frame [m]"},
      {"imu", "the simulated IMU (the filter gets the same white-noise densities)"},
      {"imu.white_noise_scale",
       "x the data-sheet white-noise densities; 15 = EuRoC V1_02 in flight"},
      {"imu.bias_random_walk_scale", "x the data-sheet bias random walks"},
      {"imu.warm_up_gyro_drift_rad_s", "gyro bias warm-up drift amplitude [rad/s], unmodelled"},
      {"imu.warm_up_accel_drift_m_s2", "accel bias warm-up drift amplitude [m/s^2], unmodelled"},
      {"imu.warm_up_time_constant_s", "time constant of the warm-up drift [s]"},
      {"imu.camera_time_offset_s", "true camera-IMU offset t_d [s], not given to the filter"},
      {"camera", "the camera's imperfections"},
      {"camera.drop_probability", "share of frames lost (Bernoulli, seeded)"},
      {"camera.exposure_s", "exposure time: motion blur [s]; 0 = none"},
      {"camera.readout_s", "rolling-shutter readout, first to last row [s]; 0 = global shutter"},
      {"camera.blur_max_taps", "most samples per exposure for the blur (cost)"},
      {"camera.latency_jitter_s", "latency varies uniformly by +- this around the nominal [s]"},
  };
  return docs;
}

}  // namespace

void VehicleMismatchOptions::validate() const {
  check_range("vehicle_mismatch.mass_scale", mass_scale, 0.5, 2.0);
  check_range("vehicle_mismatch.thrust_coefficient_scale", thrust_coefficient_scale, 0.5, 2.0);
  check_range("vehicle_mismatch.motor_time_constant_scale", motor_time_constant_scale, 0.2, 5.0);
  for (int i = 0; i < 3; ++i) {
    check_range("vehicle_mismatch.center_of_mass_offset_m", center_of_mass_offset_m[i], -0.05,
                0.05);
  }
}

QuadrotorParameters VehicleMismatchOptions::true_vehicle(const QuadrotorParameters& nominal) const {
  QuadrotorParameters p = nominal;
  p.mass_kg *= mass_scale;
  p.inertia_kg_m2 *= mass_scale;
  p.thrust_coefficient *= thrust_coefficient_scale;
  // The rotor drag torque scales with the thrust (same propeller, k_m / k_f fixed).
  p.drag_torque_coefficient *= thrust_coefficient_scale;
  p.motor_time_constant_s *= motor_time_constant_scale;
  p.center_of_mass_offset_m += center_of_mass_offset_m;
  return p;
}

void ImuWorldOptions::validate() const {
  check_range("imu.white_noise_scale", white_noise_scale, 0.0, 100.0);
  check_range("imu.bias_random_walk_scale", bias_random_walk_scale, 0.0, 100.0);
  check_range("imu.warm_up_gyro_drift_rad_s", warm_up_gyro_drift_rad_s, 0.0, 0.1);
  check_range("imu.warm_up_accel_drift_m_s2", warm_up_accel_drift_m_s2, 0.0, 1.0);
  check_range("imu.warm_up_time_constant_s", warm_up_time_constant_s, 1e-3, 1e5);
  check_range("imu.camera_time_offset_s", camera_time_offset_s, -0.1, 0.1);
}

void CameraWorldOptions::validate() const {
  if (!(drop_probability >= 0.0 && drop_probability < 1.0)) {
    fail("camera.drop_probability", "must be in [0, 1)");
  }
  check_range("camera.exposure_s", exposure_s, 0.0, 0.1);
  check_range("camera.readout_s", readout_s, 0.0, 0.1);
  if (blur_max_taps < 1 || blur_max_taps > 64) fail("camera.blur_max_taps", "must be in [1, 64]");
  check_range("camera.latency_jitter_s", latency_jitter_s, 0.0, 0.5);
}

void WorldOptions::validate() const {
  wind.validate();
  vehicle_mismatch.validate();
  imu.validate();
  camera.validate();
}

WorldOptions WorldOptions::realistic() {
  WorldOptions w;
  w.name = "realistic";
  // A light breeze (an open door, a courtyard): 1.5 m/s mean, light turbulence W20 = 3 m/s
  // (sigma_w 0.3 m/s, sigma_u = sigma_v 0.59 m/s at <= 10 ft).
  w.wind.mean_world_m_s = Eigen::Vector3d(1.2, 0.9, 0.0);
  w.wind.turbulence_w20_m_s = 3.0;
  // Issue 29: mass +15 %, thrust constant -10 %, a slower motor, an asymmetric arm.
  w.vehicle_mismatch.mass_scale = 1.15;
  w.vehicle_mismatch.thrust_coefficient_scale = 0.90;
  w.vehicle_mismatch.motor_time_constant_scale = 1.5;
  w.vehicle_mismatch.center_of_mass_offset_m = Eigen::Vector3d(0.010, -0.005, 0.0);
  // EuRoC V1_02's in-flight white noise: 15 x the data sheet (docs/fusion.md).
  w.imu.white_noise_scale = 15.0;
  w.imu.bias_random_walk_scale = 1.0;
  w.imu.warm_up_gyro_drift_rad_s = 2e-3;
  w.imu.warm_up_accel_drift_m_s2 = 0.05;
  w.imu.warm_up_time_constant_s = 120.0;
  w.imu.camera_time_offset_s = 0.010;
  w.camera.drop_probability = 0.05;
  w.camera.exposure_s = 0.008;
  w.camera.readout_s = 0.010;
  w.camera.blur_max_taps = 5;
  w.camera.latency_jitter_s = 0.010;
  return w;
}

std::string WorldOptions::to_documented_yaml() const {
  const std::string plain = io::option_fields::to_yaml(*this);
  std::istringstream in(plain);
  std::ostringstream out;
  out << "# kestrel fly --world FILE: the simulated world (docs/flight.md, \"World\").\n"
         "# Missing fields keep the ideal values; unknown fields are errors.\n";
  std::vector<std::string> path;  // dotted name by indentation (two spaces a level)
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t indent = line.find_first_not_of(' ');
    const std::size_t colon = line.find(':');
    if (indent == std::string::npos || colon == std::string::npos) {
      out << line << "\n";
      continue;
    }
    path.resize(indent / 2);
    path.push_back(line.substr(indent, colon - indent));
    std::string dotted;
    for (const auto& p : path) dotted += (dotted.empty() ? "" : ".") + p;
    const auto it = field_docs().find(dotted);
    out << line;
    if (it != field_docs().end()) out << "  # " << it->second;
    out << "\n";
  }
  return out.str();
}

WorldOptions WorldOptions::from_yaml(const YAML::Node& node, const std::string& source) {
  WorldOptions w;
  io::option_fields::read_fields(node, source, "world", w);
  try {
    w.validate();
  } catch (const InputError& e) {
    throw InputError(source + ": " + e.what());
  }
  return w;
}

WorldOptions WorldOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["world"]) return from_yaml(root["world"], path.string());
  return from_yaml(root, path.string());
}

WorldOptions WorldOptions::from_argument(const std::string& name_or_path) {
  if (name_or_path == "ideal") return ideal();
  if (name_or_path == "realistic") return realistic();
  if (!std::filesystem::exists(name_or_path)) {
    throw InputError("--world: '" + name_or_path +
                     "' is neither ideal, realistic nor an existing YAML file");
  }
  return load(name_or_path);
}

std::string WorldOptions::describe() const {
  std::ostringstream os;
  os << name << ": wind " << wind.mean_world_m_s.transpose() << " m/s, W20 "
     << wind.turbulence_w20_m_s << " m/s; vehicle mass x" << vehicle_mismatch.mass_scale
     << ", thrust x" << vehicle_mismatch.thrust_coefficient_scale << ", motor lag x"
     << vehicle_mismatch.motor_time_constant_scale << ", CoM offset "
     << vehicle_mismatch.center_of_mass_offset_m.transpose() << " m; IMU noise x"
     << imu.white_noise_scale << ", drift " << imu.warm_up_gyro_drift_rad_s << " rad/s / "
     << imu.warm_up_accel_drift_m_s2 << " m/s^2, t_d " << 1e3 * imu.camera_time_offset_s
     << " ms; camera drops " << 100.0 * camera.drop_probability << " %, exposure "
     << 1e3 * camera.exposure_s << " ms, readout " << 1e3 * camera.readout_s << " ms, jitter +-"
     << 1e3 * camera.latency_jitter_s << " ms";
  return os.str();
}

}  // namespace kestrel::sim
