// The controller stage's per-state logic, without threads (the stage thread in pipeline.cpp
// feeds it): the chain of `kestrel fly` (src/flight/flight_simulation.cpp) on the pipeline's
// fused states: safety supervisor -> position controller -> bound_command -> command watchdog
// -> PWM mapper. The pulses are recorded, not sent (no flight controller is attached).
//
// Time: every call gives `now_ns`, the data-time clock of the decision (the state's capture
// time plus its age in the pipeline). A state older than the watchdog's timeout is not flown
// (stale); a state stream that stops leaves the watchdog without commands, so on_silence()
// returns its failsafe (level, reduced thrust; motors off after its cut-off time). States that
// keep coming without accepted odometry (vo_dropout flag, no `updated`) or with an unusable
// estimate are the supervisor's cases: hold, land, blind descent (control/safety.hpp).
#pragma once

#include <optional>

#include "kestrel/control/position_controller.hpp"
#include "kestrel/control/pwm_mapper.hpp"
#include "kestrel/control/safety.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/pipeline/controller_log.hpp"
#include "kestrel/pipeline/controller_options.hpp"

namespace kestrel::pipeline {

class ControllerStage {
 public:
  /// fused: the states come from the EKF; false: the odometry passed through (camera source),
  /// flown only with options.allow_unfused, otherwise every output is the disarmed PWM.
  ControllerStage(ControllerStageOptions options, bool fused);

  /// One fused state, decided at now_ns (>= the state's time).
  ControllerRecord on_state(const fusion::FusedState& state, TimeNs now_ns);
  /// No state has come since the last call: the watchdog's output at now_ns. Nothing before
  /// the first state (there is no time yet, and the PWM is the disarmed one).
  std::optional<ControllerRecord> on_silence(TimeNs now_ns);

  /// The state stream is not flown at all (unfused, not allowed).
  [[nodiscard]] bool disarmed() const { return disarmed_; }
  /// The mission reference (set point, or the first usable state's pose), once known.
  [[nodiscard]] const std::optional<control::PositionReference>& mission() const {
    return mission_;
  }
  [[nodiscard]] const control::PwmMapper& mapper() const { return mapper_; }

 private:
  control::VehicleStateEstimate estimate_of(const fusion::FusedState& state) const;
  // The watchdog's output at now_ns into the record's command and pulses.
  void output(TimeNs now_ns, bool motors_off_asked, ControllerRecord& r);

  ControllerStageOptions options_;
  bool fused_;
  bool disarmed_;
  control::PositionController controller_;
  control::PwmMapper mapper_;
  control::SafetySupervisor supervisor_;
  control::CommandWatchdog watchdog_;
  std::optional<control::PositionReference> mission_;
  control::PositionReference last_reference_;
  TimeNs last_vision_update_ns_ = 0;
  std::optional<TimeNs> last_now_ns_;
  TimeNs last_state_t_ns_ = 0;
};

}  // namespace kestrel::pipeline
