// What the pipeline's controller stage put out, one record per output: the attitude/thrust
// command and the four RC pulses (there is no flight controller attached: they are logged
// only), with what decided them (safety mode, watchdog state, the input it acted on).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/control/safety.hpp"
#include "kestrel/control/types.hpp"
#include "kestrel/core/time.hpp"

namespace kestrel::pipeline {

enum class ControllerInput {
  kState,       ///< a fused state, flown (or refused: disarmed)
  kStaleState,  ///< a fused state older than the watchdog's timeout: not flown
  kNoState,     ///< no state for silence_check_s: the watchdog's output
};
std::string_view to_string(ControllerInput input);

struct ControllerRecord {
  TimeNs now_ns = 0;      ///< when the output was decided (data time, see ControllerStage)
  TimeNs state_t_ns = 0;  ///< the state acted on (kNoState: the last one received)
  ControllerInput input = ControllerInput::kState;
  std::uint32_t fusion_flags = 0;  ///< the state's fusion::FusionFlag bits (kNoState: 0)
  control::SafetyMode mode = control::SafetyMode::kNominal;
  control::WatchdogState watchdog = control::WatchdogState::kActive;
  /// The state was not fused (camera source) and allow_unfused is off: motors off.
  bool disarmed = false;
  bool motors_off = false;                          ///< the PWM is PwmMapper::motors_off()
  Eigen::Vector3d p_ref = Eigen::Vector3d::Zero();  ///< the reference flown (world)
  double yaw_ref_rad = 0.0;
  control::AttitudeThrustCommand command;  ///< what the pulses stand for (zero if motors off)
  control::PwmChannels pwm;
};

/// The CSV's columns, in order (header row).
const std::vector<std::string>& controller_csv_columns();

/// Writes `records` to `path` (provenance line, header row, one row per record; times in ns,
/// angles in rad, thrust in N, pulses in us). The output guard's rules apply
/// (io::check_can_write_file): throws InputError for a foreign file unless `force`.
void write_controller_csv(const std::filesystem::path& path,
                          const std::vector<ControllerRecord>& records, std::string_view command,
                          bool force);

}  // namespace kestrel::pipeline
