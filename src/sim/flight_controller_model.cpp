// The Naza-like flight controller model: RC decoding, attitude P, body-rate PI, X mixer with
// attitude priority over collective thrust.
#include "kestrel/sim/flight_controller_model.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sim {

void FlightControllerModelOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw InputError("flight controller option '" + field + "': " + why);
  };
  auto pos = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0)) fail(name, "must be positive and finite");
  };
  if (!(channel_min_us < channel_centre_us && channel_centre_us < channel_max_us)) {
    fail("channel_centre_us", "must lie strictly between channel_min_us and channel_max_us");
  }
  if (deadband_us < 0 || 2 * deadband_us >= channel_max_us - channel_centre_us) {
    fail("deadband_us", "must be >= 0 and well inside the half range");
  }
  if (throttle_idle_us < channel_min_us || throttle_idle_us >= channel_max_us) {
    fail("throttle_idle_us", "must lie within [channel_min_us, channel_max_us)");
  }
  pos("max_tilt_deg", max_tilt_deg);
  if (max_tilt_deg >= 90.0) fail("max_tilt_deg", "must be below 90");
  pos("max_yaw_rate_deg_s", max_yaw_rate_deg_s);
  pos("max_throttle_thrust_fraction", max_throttle_thrust_fraction);
  if (max_throttle_thrust_fraction > 1.0) fail("max_throttle_thrust_fraction", "must be <= 1");
  pos("attitude_gain_rp", attitude_gain_rp);
  pos("attitude_gain_yaw", attitude_gain_yaw);
  pos("rate_gain_rp", rate_gain_rp);
  pos("rate_gain_yaw", rate_gain_yaw);
  if (!(rate_integral_gain >= 0.0)) fail("rate_integral_gain", "must be >= 0");
  if (!(rate_integral_limit >= 0.0)) fail("rate_integral_limit", "must be >= 0");
  pos("max_body_rate_deg_s", max_body_rate_deg_s);
}

std::string FlightControllerModelOptions::to_yaml() const {
  return io::option_fields::to_yaml(*this);
}

FlightControllerModelOptions FlightControllerModelOptions::from_yaml(const YAML::Node& node,
                                                                     const std::string& source) {
  FlightControllerModelOptions o;
  io::option_fields::read_fields(node, source, "flight controller", o);
  o.validate();
  return o;
}

FlightControllerModelOptions FlightControllerModelOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["flight_controller"]) {
    return from_yaml(root["flight_controller"], path.string());
  }
  return from_yaml(root, path.string());
}

FlightControllerModel::FlightControllerModel(FlightControllerModelOptions options,
                                             QuadrotorParameters vehicle)
    : options_(std::move(options)), vehicle_(std::move(vehicle)) {
  options_.validate();
  vehicle_.validate();
  allocation_inverse_ = Quadrotor(vehicle_).allocation_matrix().inverse();
}

DecodedSticks FlightControllerModel::decode(const control::PwmChannels& pwm) const {
  const auto& o = options_;
  auto stick = [&](int us) {
    const double d = us - o.channel_centre_us;
    const double half =
        d >= 0 ? o.channel_max_us - o.channel_centre_us : o.channel_centre_us - o.channel_min_us;
    if (std::abs(d) <= o.deadband_us) return 0.0;
    const double s = (std::abs(d) - o.deadband_us) / (half - o.deadband_us);
    return std::copysign(std::min(s, 1.0), d);
  };
  DecodedSticks s;
  s.roll = stick(pwm.us[control::PwmChannels::kRoll]);
  s.pitch = stick(pwm.us[control::PwmChannels::kPitch]);
  s.yaw = stick(pwm.us[control::PwmChannels::kYaw]);
  const int t = pwm.us[control::PwmChannels::kThrottle];
  s.throttle = std::clamp(
      static_cast<double>(t - o.channel_min_us) / (o.channel_max_us - o.channel_min_us), 0.0, 1.0);
  s.idle = t <= o.throttle_idle_us;
  return s;
}

Eigen::Vector4d FlightControllerModel::update(double dt_s, const control::PwmChannels& pwm,
                                              const QuadrotorState& state) {
  const auto& o = options_;
  const DecodedSticks sticks = decode(pwm);
  const double yaw_now = control::yaw_of(state.R_world_body);
  const double w_min2 = vehicle_.min_rotor_speed_rad_s * vehicle_.min_rotor_speed_rad_s;
  const double w_max2 = vehicle_.max_rotor_speed_rad_s * vehicle_.max_rotor_speed_rad_s;

  if (sticks.idle) {
    // Motors idle, targets follow the vehicle so that the take-off starts from where it sits.
    yaw_target_rad_ = yaw_now;
    yaw_target_set_ = true;
    rate_integral_.setZero();
    R_world_desired_ = state.R_world_body;
    return Eigen::Vector4d::Constant(vehicle_.min_rotor_speed_rad_s);
  }
  if (!yaw_target_set_) {
    yaw_target_rad_ = yaw_now;
    yaw_target_set_ = true;
  }

  // Stick -> desired attitude R = Rz(yaw_target) Ry(pitch) Rx(roll) and yaw rate.
  const double yaw_rate = -sticks.yaw * o.max_yaw_rate_deg_s * kDegToRad;  // stick right: clockwise
  // Yaw stick deflected: pure rate control (the heading target follows the vehicle); stick
  // centred: heading lock on where the vehicle points when it is released.
  if (sticks.yaw != 0.0) yaw_target_rad_ = yaw_now;
  const double roll = sticks.roll * o.max_tilt_deg * kDegToRad;
  const double pitch = sticks.pitch * o.max_tilt_deg * kDegToRad;
  R_world_desired_ = SO3::exp(Eigen::Vector3d(0, 0, yaw_target_rad_)) *
                     SO3::exp(Eigen::Vector3d(0, pitch, 0)) * SO3::exp(Eigen::Vector3d(roll, 0, 0));

  // Attitude P: body-rate command from the rotation error (body frame) plus the yaw feed-forward.
  const Eigen::Vector3d e_att = (state.R_world_body.inverse() * R_world_desired_).log();
  Eigen::Vector3d rate_cmd(o.attitude_gain_rp * e_att.x(), o.attitude_gain_rp * e_att.y(),
                           o.attitude_gain_yaw * e_att.z());
  rate_cmd += state.R_world_body.inverse() * Eigen::Vector3d(0, 0, yaw_rate);
  const double max_rate = o.max_body_rate_deg_s * kDegToRad;
  for (int i = 0; i < 3; ++i) rate_cmd[i] = std::clamp(rate_cmd[i], -max_rate, max_rate);

  // Body-rate PI -> torque (with the gyroscopic term).
  const Eigen::Vector3d e_rate = rate_cmd - state.omega_body;
  if (dt_s > 0.0) {
    rate_integral_ += o.rate_integral_gain * e_rate * dt_s;
    rate_integral_ =
        rate_integral_.cwiseMax(-o.rate_integral_limit).cwiseMin(o.rate_integral_limit);
  }
  const Eigen::Vector3d gains(o.rate_gain_rp, o.rate_gain_rp, o.rate_gain_yaw);
  const Eigen::Vector3d J = vehicle_.inertia_kg_m2;
  const Eigen::Vector3d angular_accel = gains.cwiseProduct(e_rate) + rate_integral_;
  const Eigen::Vector3d torque =
      J.cwiseProduct(angular_accel) + state.omega_body.cross(J.cwiseProduct(state.omega_body));

  // Mixer: squared rotor speeds from [T, tau]; saturation is resolved by moving the collective
  // first (attitude has priority), then by clipping.
  const double thrust = sticks.throttle * o.max_throttle_thrust_fraction * vehicle_.max_thrust_N();
  Eigen::Vector4d w2 = allocation_inverse_ * Eigen::Vector4d(thrust, torque.x(), torque.y(), 0.0);
  // Yaw has the least authority: it gets what is left within the rotor limits (as flight
  // controllers do; a yaw demand must not change the climb rate).
  const Eigen::Vector4d w2_yaw = allocation_inverse_ * Eigen::Vector4d(0.0, 0.0, 0.0, torque.z());
  double yaw_scale = 1.0;
  for (int i = 0; i < 4; ++i) {
    const double next = w2[i] + w2_yaw[i];
    if (next > w_max2 && w2_yaw[i] > 0.0)
      yaw_scale = std::min(yaw_scale, std::max(0.0, (w_max2 - w2[i]) / w2_yaw[i]));
    if (next < w_min2 && w2_yaw[i] < 0.0)
      yaw_scale = std::min(yaw_scale, std::max(0.0, (w_min2 - w2[i]) / w2_yaw[i]));
  }
  w2 += yaw_scale * w2_yaw;
  const double hi = w2.maxCoeff();
  const double lo = w2.minCoeff();
  if (hi > w_max2 && lo - (hi - w_max2) >= w_min2) {
    w2.array() -= hi - w_max2;
  } else if (lo < w_min2 && hi + (w_min2 - lo) <= w_max2) {
    w2.array() += w_min2 - lo;
  }
  w2 = w2.cwiseMax(w_min2).cwiseMin(w_max2);
  return w2.cwiseSqrt();
}

}  // namespace kestrel::sim
