// SimulatedVehicle: flight-controller cycles interleaved with the dynamics.
#include "kestrel/sim/simulated_vehicle.hpp"

#include <algorithm>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

SimulatedVehicle::SimulatedVehicle(QuadrotorParameters parameters,
                                   FlightControllerModelOptions fc_options, QuadrotorState initial,
                                   double fc_rate_hz,
                                   const std::optional<QuadrotorParameters>& fc_vehicle)
    : quadrotor_(parameters, std::move(initial)),
      fc_(std::move(fc_options), fc_vehicle.value_or(parameters)),
      fc_period_s_(fc_rate_hz > 0.0 ? 1.0 / fc_rate_hz : 0.0) {
  if (!(fc_rate_hz > 0.0)) throw InputError("simulated vehicle: fc_rate_hz must be positive");
}

void SimulatedVehicle::step(double dt_s, const control::PwmChannels& pwm) {
  double left = dt_s;
  while (left > 1e-12) {
    const double h = std::min(fc_period_s_, left);
    const Eigen::Vector4d rotors = fc_.update(h, pwm, quadrotor_.state());
    quadrotor_.step(h, rotors);
    left -= h;
  }
}

}  // namespace kestrel::sim
