// The controller stage's CSV: one row per output, provenance line first (io/output_guard.hpp).
#include "kestrel/pipeline/controller_log.hpp"

#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::pipeline {

std::string_view to_string(ControllerInput input) {
  switch (input) {
    case ControllerInput::kState:
      return "state";
    case ControllerInput::kStaleState:
      return "stale";
    case ControllerInput::kNoState:
      return "none";
  }
  return "?";
}

const std::vector<std::string>& controller_csv_columns() {
  static const std::vector<std::string> columns{
      "now_ns",      "state_t_ns",   "input",           "fusion_flags",   "safety_mode",
      "watchdog",    "disarmed",     "x_ref_m",         "y_ref_m",        "z_ref_m",
      "yaw_ref_rad", "roll_rad",     "pitch_rad",       "yaw_rate_rad_s", "thrust_N",
      "pwm_roll_us", "pwm_pitch_us", "pwm_throttle_us", "pwm_yaw_us"};
  return columns;
}

void write_controller_csv(const std::filesystem::path& path,
                          const std::vector<ControllerRecord>& records, std::string_view command,
                          bool force) {
  io::check_can_write_file(path, command, force);
  std::ofstream out(path);
  if (!out) throw InputError(path.string() + ": cannot open file for writing");
  out << io::provenance_line(command) << "\n";
  const auto& columns = controller_csv_columns();
  for (std::size_t i = 0; i < columns.size(); ++i) out << (i > 0 ? "," : "") << columns[i];
  out << "\n";
  auto num = [](double v) { return io::format_double(v); };
  for (const ControllerRecord& r : records) {
    out << r.now_ns << ',' << r.state_t_ns << ',' << to_string(r.input) << ','
        << fusion::describe_flags(r.fusion_flags) << ',' << control::to_string(r.mode) << ','
        << control::to_string(r.watchdog) << ',' << (r.disarmed ? 1 : 0);
    for (int k = 0; k < 3; ++k) out << ',' << num(r.p_ref[k]);
    out << ',' << num(r.yaw_ref_rad) << ',' << num(r.command.roll_rad) << ','
        << num(r.command.pitch_rad) << ',' << num(r.command.yaw_rate_rad_s) << ','
        << num(r.command.thrust_N);
    for (int us : r.pwm.us) out << ',' << us;
    out << '\n';
  }
  out.flush();
  if (!out) throw InputError(path.string() + ": write failed (disk full?)");
}

}  // namespace kestrel::pipeline
