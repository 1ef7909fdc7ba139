// The simulated vehicle as the companion computer sees it: RC pulses in, motion out. Couples
// the flight-controller model (run at its own loop rate) to the quadrotor dynamics.
#pragma once

#include <optional>

#include "kestrel/sim/flight_controller_model.hpp"
#include "kestrel/sim/quadrotor.hpp"

namespace kestrel::sim {

class SimulatedVehicle {
 public:
  /// `fc_vehicle`: the vehicle the flight controller is set up for (its mixer and throttle
  /// scale), when it is not the true one (a model mismatch); default: `parameters`.
  SimulatedVehicle(QuadrotorParameters parameters, FlightControllerModelOptions fc_options,
                   QuadrotorState initial, double fc_rate_hz = 1000.0,
                   const std::optional<QuadrotorParameters>& fc_vehicle = std::nullopt);

  /// Advances by dt_s with the flight controller reading `pwm` (held over the step), in
  /// flight-controller cycles of 1 / fc_rate_hz (a shorter last one if dt_s is not a multiple).
  void step(double dt_s, const control::PwmChannels& pwm);

  [[nodiscard]] const QuadrotorState& state() const { return quadrotor_.state(); }
  [[nodiscard]] Quadrotor& quadrotor() { return quadrotor_; }
  [[nodiscard]] const FlightControllerModel& flight_controller() const { return fc_; }

 private:
  Quadrotor quadrotor_;
  FlightControllerModel fc_;
  double fc_period_s_;
};

}  // namespace kestrel::sim
