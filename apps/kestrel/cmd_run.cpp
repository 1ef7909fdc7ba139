// `kestrel run --config FILE.yaml`: the real-time pipeline (source -> depth -> tracker ->
// fusion -> controller, one thread each) over a recorded EuRoC folder or the live V4L2 stereo
// camera; prints per-stage statistics and the end-to-end latency, writes the fused trajectory
// (TUM; with the camera, which brings no IMU, the odometry's own trajectory) and the
// controller's commands and PWM pulses (CSV; no flight controller is driven).
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/pipeline/pipeline.hpp"

namespace kestrel::cli {
namespace {

namespace fs = std::filesystem;
constexpr const char* kRunCommand = "run";

struct RunArgs {
  fs::path config;
  fs::path out;
  bool force = false;
};

std::string load_average() {
  double l[3] = {0, 0, 0};
  if (getloadavg(l, 3) != 3) return "unknown";
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << l[0] << " " << l[1] << " " << l[2];
  return s.str();
}

// The controller's outputs by what decided them; the pulses were computed, not sent.
void print_controller(const pipeline::PipelineReport& r) {
  std::size_t flown = 0, stale = 0, silent = 0, motors_off = 0, tripped = 0;
  std::map<std::string, std::size_t> modes;
  for (const auto& c : r.controller) {
    if (c.input == pipeline::ControllerInput::kState && !c.disarmed) ++flown;
    if (c.input == pipeline::ControllerInput::kStaleState) ++stale;
    if (c.input == pipeline::ControllerInput::kNoState) ++silent;
    if (c.motors_off) ++motors_off;
    if (c.watchdog != control::WatchdogState::kActive) ++tripped;
    if (c.input == pipeline::ControllerInput::kState && !c.disarmed) {
      ++modes[std::string(control::to_string(c.mode))];
    }
  }
  std::cout << "controller: " << r.controller.size() << " outputs: " << flown << " states flown, "
            << stale << " stale (older than the watchdog timeout, not flown), " << silent
            << " without a state (watchdog); " << tripped << " watchdog failsafe, " << motors_off
            << " motors off; safety modes:";
  for (const auto& [mode, n] : modes) std::cout << " " << mode << " " << n;
  std::cout
      << "\n  PWM NOT SENT: no flight controller is attached; the pulses go to the CSV only\n";
  if (r.controller_disarmed) {
    std::cout << "  DISARMED: the states are not fused (camera source, no IMU), so no flight is "
                 "commanded: every output is the motors-off PWM (controller.allow_unfused: true "
                 "to fly on the odometry)\n";
  }
}

void print_report(const pipeline::PipelineReport& r) {
  std::cout << std::fixed << std::setprecision(2);
  std::cout << "stage        in   out  drop  fail   ms p50   ms p95   ms max   rate Hz"
               "   lat p50   lat p95   lat max\n";
  for (const auto& s : r.stages) {
    const auto p = pipeline::summarize(s.processing_ms);
    const auto l = pipeline::summarize(s.latency_ms);
    // A fusion that only passes the odometry through is marked in its row, not just below.
    const bool marked = r.fusion_pass_through && s.name == "fusion";
    std::cout << std::left << std::setw(10) << (marked ? s.name + "*" : s.name) << std::right
              << std::setw(6) << s.in << std::setw(6) << s.out << std::setw(6) << s.dropped
              << std::setw(6) << s.failed << std::setw(9) << p.p50 << std::setw(9) << p.p95
              << std::setw(9) << p.max << std::setw(10) << s.rate_hz() << std::setw(10) << l.p50
              << std::setw(10) << l.p95 << std::setw(10) << l.max << "\n";
  }
  const auto e = pipeline::summarize(r.end_to_end_ms);
  const double fps = r.wall_s > 0.0 ? static_cast<double>(r.stereo_pairs) / r.wall_s : 0.0;
  std::cout << "(ms per item = work time; latency = ms from the pair's arrival to the stage's "
               "output; rate = items finished per second)\n"
            << "end-to-end latency (image pair in -> fused state out), " << r.end_to_end_ms.size()
            << " states: p50 " << e.p50 << " ms, p95 " << e.p95 << " ms, max " << e.max << " ms\n"
            << "pairs " << r.stereo_pairs << ", IMU samples " << r.imu_samples << ", wall "
            << std::setprecision(3) << r.wall_s << " s (" << std::setprecision(1) << fps
            << " pairs/s overall)" << (r.interrupted ? ", INTERRUPTED" : "") << "\n"
            << "matcher: " << r.matcher << "; mean disparity fill " << std::setprecision(1)
            << 100.0 * r.mean_disparity_fill << " %\n";
  if (r.camera) {
    std::cout << "camera: " << r.camera_info.describe()
              << "\n  format: " << r.camera_format.describe()
              << "\n  capture: " << r.camera->describe()
              << "\n  (source fail = frames dropped as truncated, corrupted or out of order)\n";
  }
  if (r.fusion_pass_through) {
    std::cout << "fusion* PASS-THROUGH: the camera source has no IMU, so no EKF ran; the states "
                 "are the odometry's rectified-left-camera poses (world = that camera at the "
                 "first tracked pair), not fused body poses; fail = pairs without a track\n";
  } else {
    std::cout << "fusion options used: " << r.fusion_options.describe() << "\n"
              << "fusion: " << r.fusion_counters.describe() << "\n";
  }
  print_controller(r);
}

// The camera opened (and closed again) before any output is claimed: a missing, busy or
// foreign device is the driver's own error, naming the config field and the device path.
void check_camera(const fs::path& config, const std::string& device) {
  try {
    const driver::V4l2Camera probe(device);
  } catch (const driver::DeviceError& e) {
    throw InputError(config, "camera.device", e.what());
  }
}

void run_run(const RunArgs& a) {
  pipeline::PipelineOptions options = pipeline::PipelineOptions::load_yaml(a.config);
  const bool camera = options.source == pipeline::Source::kCamera;
  if (camera) {
    check_camera(a.config, options.camera.device);
  } else if (!fs::exists(options.input)) {  // before any output folder is claimed
    throw InputError(a.config.string() + ": input folder " + options.input.string() +
                     " does not exist");
  }
  fs::path out_file = options.output;
  fs::path controller_file = options.controller.output;
  io::OutputGuard outputs(kRunCommand, a.force);
  outputs.input("--config", a.config);
  if (!camera) outputs.input("input", options.input);
  if (!a.out.empty()) {
    outputs.folder("--out", a.out);
    out_file = a.out / options.output;
    controller_file = a.out / options.controller.output;
  }
  // Before the run, not after it.
  outputs.text_file("output", out_file).text_file("controller.output", controller_file);
  std::cerr << "kestrel run: config=" << a.config.string() << "\n  " << options.describe()
            << "\n  matcher: " << options.describe_matcher()
            << "\n  load average: " << load_average()
            << ", hardware threads: " << std::thread::hardware_concurrency() << "\n";

  // Ctrl-C asks the pipeline to stop: the source ends, queues close, the stages drain.
  const InterruptScope interrupt;
  pipeline::PipelineReport report;
  {
    pipeline::PipelineEnvironment environment;
    environment.log = &std::cerr;  // the camera's dropped frames
    report = pipeline::run_pipeline(options, interrupt.flag(), environment);
  }

  Trajectory trajectory;
  trajectory.reserve(report.states.size());
  for (const auto& s : report.states) {
    trajectory.push_back({s.t_ns, SE3(s.state.q_world_body, s.state.p_world)});
  }
  io::write_tum_trajectory(out_file, trajectory, kRunCommand, a.force);
  pipeline::write_controller_csv(controller_file, report.controller, kRunCommand, a.force);
  print_report(report);
  if (report.fusion_pass_through) {
    std::cout << "odometry trajectory (rectified left camera, NOT fused, " << trajectory.size()
              << " poses): " << out_file.string() << "\n";
  } else {
    std::cout << "fused trajectory (body/IMU frame, " << trajectory.size()
              << " poses): " << out_file.string() << "\n";
  }
  std::cout << "controller commands and PWM (" << report.controller.size()
            << " rows, not sent to any flight controller): " << controller_file.string() << "\n";
  std::cout << "load average after the run: " << load_average() << std::endl;
  if (report.interrupted) {
    throw_interrupted(interrupt, "after " + std::to_string(report.stereo_pairs) +
                                     " stereo pairs; wrote " + out_file.string() + " (" +
                                     std::to_string(trajectory.size()) + " poses) and " +
                                     controller_file.string());
  }
  // A camera that went away or stalled ended the run cleanly (trajectory written), but not as
  // asked: the exit status says so, as `kestrel capture` does.
  if (report.camera && !report.camera->ended_as_asked()) {
    throw InputError("run: camera " + options.camera.device + " " +
                     std::string(driver::capture_stop_name(report.camera->stop)) + " after " +
                     std::to_string(report.camera->frames) +
                     " frames: " + report.camera->stop_message + "; the trajectory so far is in " +
                     out_file.string());
  }
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Run the real-time pipeline (source -> depth -> tracker -> fusion -> controller, "
      "one thread each, bounded queues) over a recorded EuRoC folder or the V4L2 stereo "
      "camera (source: camera)");
  cmd->add_option("--config", args->config, "Pipeline config YAML (see docs/pipeline.md)")
      ->required();
  cmd->add_option("--out", args->out,
                  "Output folder for the trajectory and the controller CSV (default: the "
                  "config's output paths as given)");
  cmd->add_flag("--force", args->force, "Overwrite files or folders written by something else");
  cmd->callback([args] { run_run(*args); });
}

}  // namespace kestrel::cli
