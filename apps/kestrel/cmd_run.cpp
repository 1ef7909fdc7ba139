// `kestrel run --config FILE.yaml`: the real-time pipeline (source -> depth -> tracker ->
// fusion -> controller, one thread each) over a recorded EuRoC folder; prints per-stage
// statistics and the end-to-end latency, writes the fused trajectory (TUM).
#include <atomic>
#include <csignal>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "commands.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/pipeline/pipeline.hpp"

namespace kestrel::cli {
namespace {

namespace fs = std::filesystem;
constexpr const char* kCommand = "run";

struct RunArgs {
  fs::path config;
  fs::path out;
  bool force = false;
};

// Ctrl-C asks the pipeline to stop: the source ends, queues close, the stages drain.
// A lock-free atomic is what a signal handler may touch.
std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free);
extern "C" void on_sigint(int) { g_stop.store(true); }

std::string load_average() {
  double l[3] = {0, 0, 0};
  if (getloadavg(l, 3) != 3) return "unknown";
  std::ostringstream s;
  s << std::fixed << std::setprecision(2) << l[0] << " " << l[1] << " " << l[2];
  return s.str();
}

void print_report(const pipeline::PipelineReport& r) {
  std::cout << std::fixed << std::setprecision(2);
  std::cout << "stage        in   out  drop  fail   ms p50   ms p95   ms max   rate Hz"
               "   lat p50   lat p95   lat max\n";
  for (const auto& s : r.stages) {
    const auto p = pipeline::summarize(s.processing_ms);
    const auto l = pipeline::summarize(s.latency_ms);
    std::cout << std::left << std::setw(10) << s.name << std::right << std::setw(6) << s.in
              << std::setw(6) << s.out << std::setw(6) << s.dropped << std::setw(6) << s.failed
              << std::setw(9) << p.p50 << std::setw(9) << p.p95 << std::setw(9) << p.max
              << std::setw(10) << s.rate_hz() << std::setw(10) << l.p50 << std::setw(10) << l.p95
              << std::setw(10) << l.max << "\n";
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
            << "fusion options used: " << r.fusion_options.describe() << "\n"
            << "fusion: " << r.fusion_counters.describe() << "\n";
}

void run_run(const RunArgs& a) {
  pipeline::PipelineOptions options = pipeline::PipelineOptions::load_yaml(a.config);
  if (!fs::exists(options.input)) {  // before any output folder is claimed
    throw InputError(a.config.string() + ": input folder " + options.input.string() +
                     " does not exist");
  }
  fs::path out_file = options.output;
  if (!a.out.empty()) {
    io::claim_output_dir(a.out, kCommand, a.force);
    out_file = a.out / options.output;
  }
  io::check_can_write_file(out_file, kCommand, a.force);  // before the run, not after it
  std::cerr << "kestrel run: config=" << a.config.string() << "\n  " << options.describe()
            << "\n  matcher: " << options.matcher.describe()
            << "\n  load average: " << load_average()
            << ", hardware threads: " << std::thread::hardware_concurrency() << "\n";

  g_stop = false;
  const auto previous = std::signal(SIGINT, on_sigint);
  pipeline::PipelineReport report;
  try {
    report = pipeline::run_pipeline(options, &g_stop);
  } catch (...) {
    std::signal(SIGINT, previous);
    throw;
  }
  std::signal(SIGINT, previous);

  Trajectory trajectory;
  trajectory.reserve(report.states.size());
  for (const auto& s : report.states) {
    trajectory.push_back({s.t_ns, SE3(s.state.q_world_body, s.state.p_world)});
  }
  io::write_tum_trajectory(out_file, trajectory, kCommand, a.force);
  print_report(report);
  std::cout << "fused trajectory (body/IMU frame, " << trajectory.size()
            << " poses): " << out_file.string() << "\n"
            << "load average after the run: " << load_average() << std::endl;
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Run the real-time pipeline (source -> depth -> tracker -> fusion -> controller, "
      "one thread each, bounded queues) over a recorded EuRoC folder");
  cmd->add_option("--config", args->config, "Pipeline config YAML (see docs/pipeline.md)")
      ->required();
  cmd->add_option("--out", args->out,
                  "Output folder for the trajectory (default: the config's "
                  "output path as given)");
  cmd->add_flag("--force", args->force, "Overwrite files or folders written by something else");
  cmd->callback([args] { run_run(*args); });
}

}  // namespace kestrel::cli
