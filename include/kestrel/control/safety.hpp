// Safety layer between the estimator, the position controller and the PWM output:
// - SafetySupervisor: odometry loss -> hold position on the IMU-propagated estimate, then
//   land after a timeout; estimator failure -> level, open-loop descent, motors off;
// - bound_command: every command finite and inside the vehicle's limits;
// - CommandWatchdog: commands stop arriving -> level and descend, then motors off.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "kestrel/control/types.hpp"

namespace kestrel::control {

struct SafetyOptions {
  double vision_timeout_s = 0.3;      ///< no odometry for longer: odometry lost, hold on the IMU
  double imu_hold_timeout_s = 5.0;    ///< odometry lost for longer: land
  double max_position_sigma_m = 1.0;  ///< a larger position uncertainty is an estimator failure
  double landing_speed_m_s = 0.4;     ///< descent speed of the reference while landing
  double ground_z_m = 0.0;            ///< the floor, world z
  double landed_height_m = 0.10;      ///< estimated height under which, ...
  double landed_speed_m_s = 0.15;     ///< ... at a vertical speed below this, ...
  double landed_hold_s = 1.0;         ///< ... for this long, the vehicle has landed: motors off
  /// Open-loop descent: this fraction of the hover thrust, level, until blind_descent_max_s.
  double blind_descent_thrust_fraction = 0.95;
  double blind_descent_max_s = 10.0;
  /// Odometry that returns while landing resumes the mission (false: the landing completes).
  bool resume_when_landing = false;
  /// The IMU hold flies the mission reference it is handed, which the caller brings to rest
  /// (the flight's MissionClock eases its clock to a stop), instead of a fixed point at the
  /// estimate's position with zero velocity, whose velocity step the vehicle overshoots; a
  /// landing then starts below the last of it. False: the fixed point.
  bool hold_flies_mission = false;

  void validate() const;
  [[nodiscard]] std::string to_yaml() const;
  static SafetyOptions from_yaml(const YAML::Node& node, const std::string& source);
  /// The options at the top level or under a `safety:` key.
  static SafetyOptions load(const std::filesystem::path& path);

  template <typename V>
  void visit_fields(V&& v) {
    v("vision_timeout_s", vision_timeout_s);
    v("imu_hold_timeout_s", imu_hold_timeout_s);
    v("max_position_sigma_m", max_position_sigma_m);
    v("landing_speed_m_s", landing_speed_m_s);
    v("ground_z_m", ground_z_m);
    v("landed_height_m", landed_height_m);
    v("landed_speed_m_s", landed_speed_m_s);
    v("landed_hold_s", landed_hold_s);
    v("blind_descent_thrust_fraction", blind_descent_thrust_fraction);
    v("blind_descent_max_s", blind_descent_max_s);
    v("resume_when_landing", resume_when_landing);
    v("hold_flies_mission", hold_flies_mission);
  }
};

enum class SafetyMode {
  kNominal,       ///< flying the mission reference
  kImuHold,       ///< odometry lost: holding the last position on the IMU-propagated estimate
  kLanding,       ///< descending at landing_speed_m_s on the estimate
  kBlindDescent,  ///< the estimate is unusable: level, open-loop descent
  kLanded,        ///< motors off
};
std::string_view to_string(SafetyMode mode);

/// What to fly this step: the controller tracks `reference` unless `override_command` is set
/// (then that goes to the PWM mapper directly); motors_off asks for PwmMapper::motors_off().
struct SafetyDecision {
  SafetyMode mode = SafetyMode::kNominal;
  PositionReference reference;
  std::optional<AttitudeThrustCommand> override_command;
  bool motors_off = false;
  std::string reason;  ///< why the mode is what it is (empty when nominal)
};

/// Besides the failure modes, the supervisor ends a mission that lands: after the vehicle has
/// flown, a mission reference resting on the ground (below landed_height_m, still) with the
/// estimate low and still for landed_hold_s switches the motors off (kLanded).
class SafetySupervisor {
 public:
  explicit SafetySupervisor(SafetyOptions options = {});

  /// One step at t_ns. hover_thrust_N: the thrust that holds the vehicle (e.g. the
  /// controller's learnt PositionController::hover_thrust_estimate_N()).
  SafetyDecision update(TimeNs t_ns, const VehicleStateEstimate& estimate,
                        const EstimatorHealth& health, const PositionReference& mission,
                        double hover_thrust_N);

  [[nodiscard]] SafetyMode mode() const { return mode_; }
  [[nodiscard]] const SafetyOptions& options() const { return options_; }

 private:
  void enter(SafetyMode mode, TimeNs t_ns, std::string reason);
  // update()'s three steps: the mode's transitions, the touchdown at a mission's end, and
  // what the mode flies.
  void transition(TimeNs t_ns, const VehicleStateEstimate& est, const EstimatorHealth& health,
                  double hover_thrust_N);
  void check_touchdown(TimeNs t_ns, const VehicleStateEstimate& est,
                       const PositionReference& mission);
  SafetyDecision decide(TimeNs t_ns, const VehicleStateEstimate& est,
                        const PositionReference& mission);
  SafetyOptions options_;
  SafetyMode mode_ = SafetyMode::kNominal;
  TimeNs mode_since_ns_ = 0;
  std::string reason_;
  PositionReference hold_;
  double landing_start_z_ = 0.0;
  std::optional<TimeNs> low_since_ns_;
  bool airborne_ = false;  // has been above 2 landed_height_m: a touchdown can end the flight
  std::optional<TimeNs> touchdown_since_ns_;
  double blind_thrust_N_ = 0.0;
};

struct CommandLimits {
  double max_tilt_deg = 35.0;
  double max_yaw_rate_deg_s = 120.0;
  double min_thrust_N = 0.0;
  double max_thrust_N = 26.0;
};

struct BoundedCommand {
  AttitudeThrustCommand command;
  bool clipped = false;     ///< some field was outside its limits
  bool non_finite = false;  ///< some field was NaN or infinite (replaced: 0 or fallback thrust)
};
/// Clamps each field; a non-finite angle or rate becomes 0, a non-finite thrust the fallback.
BoundedCommand bound_command(const AttitudeThrustCommand& command, const CommandLimits& limits,
                             double fallback_thrust_N);

struct WatchdogOptions {
  double command_timeout_s = 0.25;         ///< no command for longer: trip
  double descent_thrust_fraction = 0.95;   ///< of the learnt hover thrust, level
  double descent_max_s = 8.0;              ///< then motors off (cut-off)
  double hover_thrust_N = 1.2 * kGravity;  ///< until commands have taught it better
  double hover_learning_time_s = 2.0;      ///< low-pass time constant of the learnt hover thrust
};

enum class WatchdogState { kActive, kTripped, kCutOff };
std::string_view to_string(WatchdogState state);

struct WatchdogOutput {
  WatchdogState state = WatchdogState::kActive;
  AttitudeThrustCommand command;
  bool motors_off = false;
};

/// Sits just before the PWM output (on the vehicle, in the output thread): the controller
/// submits commands, the output loop asks for what to send now. After a cut-off only rearm()
/// lets commands through again.
class CommandWatchdog {
 public:
  explicit CommandWatchdog(WatchdogOptions options = {});
  void submit(TimeNs t_ns, const AttitudeThrustCommand& command);
  [[nodiscard]] WatchdogOutput output(TimeNs t_ns);
  void rearm();
  [[nodiscard]] double hover_thrust_N() const { return hover_thrust_N_; }

 private:
  WatchdogOptions options_;
  std::optional<TimeNs> last_submit_ns_;
  AttitudeThrustCommand last_command_;
  double hover_thrust_N_;
  bool cut_off_ = false;
};

}  // namespace kestrel::control
