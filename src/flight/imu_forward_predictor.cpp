// IMU output predictor: the fused state carried from the filter's time to the present.
#include "kestrel/flight/imu_forward_predictor.hpp"

namespace kestrel::flight {

ImuForwardPredictor::ImuForwardPredictor(double gravity_m_s2)
    : gravity_world_(0.0, 0.0, -gravity_m_s2) {}

void ImuForwardPredictor::add_imu(const io::ImuSample& sample) {
  if (!samples_.empty() && sample.t_ns <= samples_.back().t_ns) return;  // out of order: skip
  samples_.push_back(sample);
}

void ImuForwardPredictor::set_fused(const fusion::FusedState& fused) {
  fused_ = fused;
  // Keep the last sample at or before the fused time: the first step averages it with the next.
  while (samples_.size() >= 2 && samples_[1].t_ns <= fused.t_ns) samples_.pop_front();
}

std::optional<control::VehicleStateEstimate> ImuForwardPredictor::predict() const {
  if (!fused_) return std::nullopt;
  // The filter's own nominal step (mean of consecutive samples over each interval), so that
  // the prediction is what the filter would propagate without the measurements.
  fusion::NominalState x = fused_->state;
  const io::ImuSample* previous = nullptr;
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  for (const io::ImuSample& s : samples_) {
    if (s.t_ns <= x.t_ns) {
      previous = &s;
      continue;
    }
    fusion::ImuReading reading{s.gyro_rad_s, s.accel_m_s2};
    if (previous != nullptr) {
      reading.gyro_rad_s = 0.5 * (previous->gyro_rad_s + s.gyro_rad_s);
      reading.accel_m_s2 = 0.5 * (previous->accel_m_s2 + s.accel_m_s2);
    }
    x = fusion::StochasticCloningEkf::propagate_nominal(x, reading, ns_to_s(s.t_ns - x.t_ns),
                                                        gravity_world_);
    x.t_ns = s.t_ns;
    omega = s.gyro_rad_s - x.gyro_bias_rad_s;
    previous = &s;
  }
  control::VehicleStateEstimate e;
  e.t_ns = x.t_ns;
  e.p_world = x.p_world;
  e.v_world = x.v_world;
  e.R_world_body = SO3(x.q_world_body);
  e.omega_body = omega;
  // The specific force for the controller's disturbance observer: the mean of the
  // bias-corrected readings over the last kSpecificForceWindowNs (the control period), so that
  // the 1 kHz samples between two control steps are averaged rather than one of them aliased.
  if (!samples_.empty()) {
    const TimeNs newest = samples_.back().t_ns;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    for (auto it = samples_.rbegin(); it != samples_.rend(); ++it) {
      if (n > 0 && it->t_ns <= newest - kSpecificForceWindowNs) break;
      sum += it->accel_m_s2;
      ++n;
    }
    e.specific_force_body = sum / n - x.accel_bias_m_s2;
  }
  return e;
}

double ImuForwardPredictor::lag_s() const {
  if (!fused_ || samples_.empty()) return 0.0;
  return ns_to_s(samples_.back().t_ns - fused_->t_ns);
}

}  // namespace kestrel::flight
