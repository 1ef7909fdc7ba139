// `kestrel lab fuse-eval`: the fusion's target experiments (real EuRoC IMU with noisy relative
// poses from the ground truth, Monte-Carlo NEES in simulation; docs/fusion.md).
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/eval/plot.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/lab/fusion_experiments.hpp"
#include "kestrel/lab/fusion_simulation.hpp"
#include "option_checks.hpp"
#include "progress.hpp"

namespace kestrel::cli {
namespace {

namespace fs = std::filesystem;

struct FuseEvalArgs {
  fs::path data_dir;
  int runs = 50;
  double duration_s = 30.0;
  std::uint64_t seed = 1;
  int seeds = 1;
  bool skip_real = false;
  double init_sigma_gyro_bias = 0.1;
  double init_sigma_accel_bias = 0.2;
  bool skip_sim = false;
  bool static_bias_init = false;
  bool vo_keyframes = false;  // the default now; kept so that older command lines still run
  bool frame_to_frame = false;
  double imu_noise_scale = 0.0;  // 0: the in-flight default
  bool no_time_offset_state = false;
  bool extrinsic_rotation_state = false;
  double extrinsic_sigma_deg = 0.0;  // 0: the FusionOptions default
  std::vector<double> time_offsets_ms{-20.0, 0.0, 15.0};
  int offset_flights = 5;
  double sim_vo_sigma_m = 0.01;  // the simulated odometry's noise per relative pose and axis
  double sim_vo_sigma_deg = 0.5;
  fs::path plot_dir;  // time_offset.png and time_offset.csv of the time-offset runs
  bool force = false;
  double imu_walk_scale = 1.0;
  double gap_start_s = 15.0;
  bool no_first_estimates = false;
  bool synthetic_imu = false;
  std::vector<double> imu_rotation_deg{0.0, 0.0, 0.0};
  std::vector<double> gyro_scale{1.0, 1.0, 1.0};
  std::vector<double> world_rotation_deg{0.0, 0.0, 0.0};
  std::string only;  // "v1_02", "v1_01" or empty: both
};

// P(|e| < 1 ms) for a zero-mean Gaussian error of the given 1-sigma.
double within_1ms(double sigma_s) { return std::erf(1e-3 / (std::sqrt(2.0) * sigma_s)); }

// The t_d runs: time_offset.csv (every run, every stamp) and time_offset.png, one panel per
// offset for the first flight, the estimate's error with the filter's +-1 sigma, the
// oracle bound's +-1 sigma and the +-1 ms target, so that a reader sees convergence against
// information.
void write_time_offset_plots(const fs::path& dir, const std::vector<lab::TimeOffsetRun>& runs,
                             const std::vector<int>& flights, const std::string& setting) {
  const fs::path csv_path = dir / "time_offset.csv";
  std::ofstream csv(csv_path);
  csv << io::provenance_line("lab fuse-eval") << "\n"
      << "offset_ms,flight,t_s,estimate_ms,sigma_ms,oracle_sigma_ms\n";
  csv.precision(9);
  std::vector<eval::Plot> panels;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const lab::TimeOffsetRun& r = runs[k];
    const double offset_ms = 1e3 * r.true_offset_s;
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      csv << offset_ms << ',' << flights[k] << ',' << r.t_s[i] << ',' << 1e3 * r.estimate_s[i]
          << ',' << 1e3 * r.sigma_s[i] << ',' << 1e3 * r.oracle_sigma_s[i] << '\n';
    }
    if (flights[k] != flights.front()) continue;  // one flight per panel: the first
    std::vector<double> err, up, down, o_up, o_down;
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      err.push_back(1e3 * (r.estimate_s[i] - r.true_offset_s));
      up.push_back(1e3 * r.sigma_s[i]);
      down.push_back(-1e3 * r.sigma_s[i]);
      o_up.push_back(1e3 * r.oracle_sigma_s[i]);
      o_down.push_back(-1e3 * r.oracle_sigma_s[i]);
    }
    std::ostringstream title;
    title << "t_d " << offset_ms << " ms, flight " << flights[k] << " (" << setting << ")";
    eval::Plot p;
    p.title = title.str();
    p.x_label = "time [s]";
    p.y_label = "t_d error [ms]";
    p.height_px = 300;
    p.y_range = eval::AxisRange{-6.0, 6.0};
    const std::vector<double> ends{r.t_s.empty() ? 0.0 : r.t_s.front(),
                                   r.t_s.empty() ? 1.0 : r.t_s.back()};
    p.add("estimate - truth", r.t_s, err).thickness_px = 2;
    p.add("filter +-1 sigma", r.t_s, up).colour = eval::palette_colour(1);
    p.add("", r.t_s, down).colour = eval::palette_colour(1);
    p.add("oracle bound +-1 sigma", r.t_s, o_up).colour = eval::palette_colour(2);
    p.add("", r.t_s, o_down).colour = eval::palette_colour(2);
    p.add("+-1 ms target", ends, {1.0, 1.0}).colour = eval::Rgb{0, 0, 0};
    p.add("", ends, {-1.0, -1.0}).colour = eval::Rgb{0, 0, 0};
    panels.push_back(std::move(p));
  }
  if (!csv) throw InputError(csv_path.string() + ": could not be written");
  if (!panels.empty()) eval::write_png(dir / "time_offset.png", eval::render_stacked(panels));
  std::cout << "  wrote " << (dir / "time_offset.png").string() << " and " << csv_path.string()
            << "\n";
}

// The online time offset in simulation: each offset on the same flights and noise as the
// zero-offset run, how soon t_d is within 1 ms for good, and the fused error against that run.
void print_time_offset_runs(const FuseEvalArgs& a, bool estimate, const InterruptScope& interrupt) {
  lab::SimulationOptions sim;
  sim.duration_s = a.duration_s;
  sim.vo_sigma_p_m = a.sim_vo_sigma_m;
  sim.vo_sigma_rot_deg = a.sim_vo_sigma_deg;
  sim.vo_keyframes = !a.frame_to_frame;  // the odometry as the EuRoC runs above make it
  fusion::FusionOptions o;               // the simulated IMU is as modelled: no inflation
  o.estimate_time_offset = estimate;
  std::cout.setf(std::ios::fixed);
  std::cout.precision(3);
  std::cout << "Time offset t_d in simulation (" << a.offset_flights << " flights x "
            << sim.duration_s << " s, prior 0 +- " << 1e3 * o.init_sigma_time_offset_s << " ms"
            << (estimate ? "" : ", NOT estimated (--no-time-offset-state)")
            << (sim.vo_keyframes ? ", keyframe odometry " : ", frame-to-frame odometry ")
            << 100.0 * sim.vo_sigma_p_m << " cm / " << sim.vo_sigma_rot_deg << " deg"
            << "; targets: within 1 ms in 10 s, fused error within 10 % of the zero-offset run)\n";
  std::vector<lab::TimeOffsetRun> plotted;
  std::vector<int> plotted_flights;
  for (const double ms : a.time_offsets_ms) {
    int converged = 0, within10 = 0, within10_after = 0;
    double worst_conv = 0.0;
    double worst_oracle10 = 0.0, best_oracle10 = 1e9;
    std::cout << "  offset " << ms << " ms:";
    for (int f = 0; f < a.offset_flights && !interrupt.requested(); ++f) {
      const auto seed = a.seed + static_cast<std::uint64_t>(f);
      const auto r = lab::time_offset_run(sim, o, 1e-3 * ms, seed);
      const auto r0 = lab::time_offset_run(sim, o, 0.0, seed);
      if (!a.plot_dir.empty()) {
        plotted.push_back(r);
        plotted_flights.push_back(static_cast<int>(seed));
      }
      const double ratio = r.fused_rmse_m / r0.fused_rmse_m;
      const double ratio_after = r.fused_rmse_after_m / r0.fused_rmse_after_m;
      const bool conv = r.converged_after_s >= 0.0 && r.converged_after_s <= 10.0;
      converged += conv ? 1 : 0;
      within10 += ratio <= 1.1 ? 1 : 0;
      within10_after += ratio_after <= 1.1 ? 1 : 0;
      worst_conv = std::max(worst_conv, r.converged_after_s < 0.0 ? 1e9 : r.converged_after_s);
      const double sigma10 = lab::value_at(r.t_s, r.sigma_s, 10.0);
      const double oracle10 = lab::value_at(r.t_s, r.oracle_sigma_s, 10.0);
      worst_oracle10 = std::max(worst_oracle10, oracle10);
      best_oracle10 = std::min(best_oracle10, oracle10);
      std::cout << " [t_d " << 1e3 * r.final_estimate_s << " +- " << 1e3 * r.final_sigma_s
                << " ms; 1-sigma at 10 s " << 1e3 * sigma10 << " ms, oracle bound "
                << 1e3 * oracle10 << " ms (at the end "
                << 1e3 * lab::value_at(r.t_s, r.oracle_sigma_s, 1e9) << "); within 1 ms from "
                << r.converged_after_s << " s on (first at " << r.first_within_s << " s), error x"
                << ratio << ", after 10 s x" << ratio_after << "]";
    }
    std::cout << "\n    within 1 ms by 10 s and from then on: " << converged << " of "
              << a.offset_flights << " (latest: ";
    if (worst_conv > 1e8) {
      std::cout << "not within 1 ms at the end on some flight";
    } else {
      std::cout << worst_conv << " s";
    }
    std::cout << "); fused error within 10 %: " << within10 << " of " << a.offset_flights
              << " (after 10 s: " << within10_after << ")\n"
              << "    oracle bound on t_d's 1-sigma at 10 s (every other quantity known): "
              << 1e3 * best_oracle10 << " to " << 1e3 * worst_oracle10
              << " ms: even that oracle is within 1 ms at 10 s with probability "
              << within_1ms(worst_oracle10) << " to " << within_1ms(best_oracle10) << "\n";
  }
  if (!a.plot_dir.empty() && !interrupt.requested()) {
    std::ostringstream setting;
    setting << (sim.vo_keyframes ? "keyframe" : "frame-to-frame") << " odometry "
            << 100.0 * sim.vo_sigma_p_m << " cm / " << sim.vo_sigma_rot_deg << " deg";
    write_time_offset_plots(a.plot_dir, plotted, plotted_flights, setting.str());
  }
}

void run_fuse_eval(const FuseEvalArgs& a) {
  if (!a.plot_dir.empty()) {
    if (a.skip_sim)
      throw InputError("--plot-dir: the plots are of the simulated runs; drop --skip-sim");
    io::claim_output_dir(a.plot_dir, "lab fuse-eval", a.force);  // before the work, not after
  }
  fs::path data = a.data_dir;
  if (data.empty()) {
    const char* env = std::getenv("KESTREL_DATA_DIR");
    if (env == nullptr || *env == '\0')
      throw InputError("--data or KESTREL_DATA_DIR: where shared/data is");
    data = env;
  }
  fusion::FusionOptions options;
  // The real IMU starts with a large gyro bias (V1_02 ground truth: 0.076 rad/s about z) and
  // the filter starts at zero bias: a wide prior lets it converge.
  options.init_sigma_gyro_bias_rad_s = a.init_sigma_gyro_bias;
  options.init_sigma_accel_bias_m_s2 = a.init_sigma_accel_bias;
  options.first_estimate_jacobians = !a.no_first_estimates;
  options.estimate_time_offset = !a.no_time_offset_state;
  if (a.extrinsic_rotation_state) options.estimate_extrinsic_rotation = true;
  if (a.extrinsic_sigma_deg > 0.0)
    options.init_sigma_extrinsic_rotation_rad = a.extrinsic_sigma_deg / kRadToDeg;
  lab::EurocExperimentOptions eo;
  eo.seed = a.seed;
  eo.static_gyro_bias_init = a.static_bias_init;
  eo.vo_keyframes = !a.frame_to_frame;
  eo.imu_noise_scale = a.imu_noise_scale;
  eo.imu_walk_scale = a.imu_walk_scale;
  eo.synthetic_imu = a.synthetic_imu;
  eo.imu_rotation_deg = Eigen::Vector3d(a.imu_rotation_deg.data());
  eo.gyro_scale = Eigen::Vector3d(a.gyro_scale.data());
  eo.world_rotation_deg = Eigen::Vector3d(a.world_rotation_deg.data());
  const bool do_v1_02 = a.only.empty() || a.only == "v1_02";
  const bool do_v1_01 = a.only.empty() || a.only == "v1_01";
  if (!(std::isfinite(a.gap_start_s) && a.gap_start_s >= 0.0)) {
    throw InputError("--gap-start: must be >= 0 seconds, got " + std::to_string(a.gap_start_s));
  }
  eo.gap_start_s = a.gap_start_s;
  if (a.seeds < 1) throw InputError("--seeds: must be >= 1, got " + std::to_string(a.seeds));
  std::cout << "# kestrel lab fuse-eval (seed " << a.seed;
  if (a.seeds > 1)
    std::cout << "; " << a.seeds << " noise draws, seeds " << a.seed << "-" << a.seed + a.seeds - 1;
  std::cout << ")\n";
  if (a.synthetic_imu && !a.skip_real) {
    std::cout << "# CONTROL EXPERIMENT: the real IMU replaced by one synthesised from the ground "
                 "truth with imu0/sensor.yaml's noise (--synthetic-imu); not the issue's targets\n";
  }
  // Ctrl-C stops between the experiments (each noise draw, each Monte-Carlo run): what was
  // printed stands, and the exit status says the run is incomplete.
  const InterruptScope interrupt;
  if (!a.skip_real) {
    // The first seed's runs in full; with --seeds N the spread of the targets' figures over
    // the N draws (each run is one draw of the measurement noise).
    std::vector<lab::EurocExperimentResult> v1_02, v1_01;
    // Progress over the draws on a terminal (silent in logs); the first draw's full report
    // goes to stdout before the bar starts.
    ProgressBar progress("noise draws", static_cast<std::size_t>(a.seeds));
    for (int k = 0; k < a.seeds; ++k) {
      if (interrupt.requested()) {
        std::cout << std::flush;
        throw_interrupted(interrupt, "after " + std::to_string(k) + " of " +
                                         std::to_string(a.seeds) +
                                         " noise draws of the EuRoC runs (printed above)");
      }
      eo.seed = a.seed + static_cast<std::uint64_t>(k);
      if (do_v1_02) {
        v1_02.push_back(
            lab::run_v1_02(data / "euroc" / "V1_02_medium_imu_groundtruth", options, eo));
        if (k == 0) std::cout << lab::format_result(v1_02.front());
      }
      if (do_v1_01) {
        v1_01.push_back(lab::run_v1_01(data / "euroc" / "V1_01_easy_part1", options, eo));
        if (k == 0) std::cout << lab::format_result(v1_01.front());
      }
      if (a.seeds > 1) progress.update(static_cast<std::size_t>(k) + 1);
    }
    progress.finish();
    if (a.seeds > 1) {
      if (do_v1_02) std::cout << lab::format_summary(lab::summarise_draws(v1_02));
      if (do_v1_01) std::cout << lab::format_summary(lab::summarise_draws(v1_01));
    }
  }
  if (!a.skip_sim) {
    lab::SimulationOptions sim;
    sim.duration_s = a.duration_s;
    sim.vo_sigma_p_m = a.sim_vo_sigma_m;
    sim.vo_sigma_rot_deg = a.sim_vo_sigma_deg;
    // The simulated biases are drawn from the filter's prior: first the FusionOptions
    // defaults (0.01 rad/s, 0.1 m/s^2), then the wide prior of the real-data runs, where the
    // EKF's linearisation with biases up to ~0.3 rad/s shows in the per-step attitude NEES.
    fusion::FusionOptions sim_default;
    sim_default.first_estimate_jacobians = options.first_estimate_jacobians;
    sim_default.estimate_extrinsic_rotation = options.estimate_extrinsic_rotation;
    sim_default.init_sigma_extrinsic_rotation_rad = options.init_sigma_extrinsic_rotation_rad;
    for (const fusion::FusionOptions& o : {sim_default, options}) {
      if (interrupt.requested()) break;
      const auto r = lab::monte_carlo_nees(a.runs, sim, o, a.seed, interrupt.flag());
      if (interrupt.requested()) break;  // an incomplete batch is not printed
      std::cout.setf(std::ios::fixed);
      std::cout.precision(3);
      std::cout << "Monte-Carlo NEES (bias prior " << o.init_sigma_gyro_bias_rad_s << " rad/s, "
                << o.init_sigma_accel_bias_m_s2 << " m/s^2): " << r.runs << " runs x "
                << sim.duration_s << " s, " << r.t_s.size()
                << " updates each; 95% bounds of the average [" << r.lower_bound << ", "
                << r.upper_bound << "] (3 dof)\n"
                << "  position: mean " << r.mean_p << ", inside " << 100.0 * r.inside_p
                << "% of steps\n"
                << "  attitude: mean " << r.mean_theta << ", inside " << 100.0 * r.inside_theta
                << "% of steps\n"
                << "  velocity: mean " << r.mean_v << ", inside " << 100.0 * r.inside_v
                << "% of steps\n"
                << "  position RMSE " << r.rmse_p_m << " m\n";
    }
    if (!interrupt.requested()) print_time_offset_runs(a, options.estimate_time_offset, interrupt);
  }
  if (interrupt.requested()) {
    std::cout << std::flush;
    throw_interrupted(interrupt, "before all experiments ran (those done are printed above)");
  }
}

}  // namespace

void add_fuse_eval_command(CLI::App& lab) {
  auto a = std::make_shared<FuseEvalArgs>();
  CLI::App* cmd = lab.add_subcommand(
      "fuse-eval",
      "The fusion's target experiments: real EuRoC IMU (V1_02, V1_01) with noisy relative "
      "poses from the ground truth, and Monte-Carlo NEES in simulation (docs/fusion.md).");
  cmd->add_option("--data", a->data_dir, "the shared data folder (default $KESTREL_DATA_DIR)");
  cmd->add_option("--runs", a->runs, "Monte-Carlo runs")
      ->capture_default_str()
      ->check(whole_in(1, 10000, "a whole number of runs from 1 to 10000"));
  cmd->add_option("--duration", a->duration_s, "seconds per simulated run")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a duration in (0, 3600] s", true));
  cmd->add_option("--seed", a->seed, "random seed")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  cmd->add_option("--seeds", a->seeds,
                  "real-data runs over this many noise draws (seeds seed, seed+1, ...): prints "
                  "the spread of every target's figure and how many draws meet it")
      ->capture_default_str()
      ->check(whole_in(1, 10000, "a whole number of draws from 1 to 10000"));
  cmd->add_option("--init-sigma-gyro-bias", a->init_sigma_gyro_bias, "prior sigma [rad/s]")
      ->capture_default_str()
      ->check(number_in(0.0, 10.0, "a standard deviation in (0, 10] rad/s", true));
  cmd->add_option("--init-sigma-accel-bias", a->init_sigma_accel_bias, "prior sigma [m/s^2]")
      ->capture_default_str()
      ->check(number_in(0.0, 100.0, "a standard deviation in (0, 100] m/s^2", true));
  cmd->add_flag("--skip-real", a->skip_real, "no EuRoC experiments");
  cmd->add_flag("--skip-sim", a->skip_sim, "no Monte-Carlo NEES");
  cmd->add_flag("--static-bias-init", a->static_bias_init,
                "start the real-data runs with the gyro bias from the still IMU samples before "
                "the first pose (prior sigma 0.01 rad/s) instead of zero");
  cmd->add_flag("--vo-keyframes", a->vo_keyframes,
                "relative poses against a keyframe (the default now; kept for older command "
                "lines)");
  cmd->add_flag("--frame-to-frame", a->frame_to_frame,
                "relative poses between consecutive frames instead of against a keyframe "
                "(switched after 5 deg, 0.15 m or 20 frames, as keyframe odometry reports them)");
  cmd->add_option("--imu-noise-scale", a->imu_noise_scale,
                  "factor on the IMU white-noise densities of imu0/sensor.yaml, in place of the "
                  "in-flight default (15; 0: the default)")
      ->capture_default_str()
      ->check(number_in(0.0, 1000.0, "a factor in [0, 1000]"));
  cmd->add_flag("--no-time-offset-state", a->no_time_offset_state,
                "keep the camera-IMU time offset at 0 instead of estimating it online");
  cmd->add_flag("--extrinsic-rotation-state", a->extrinsic_rotation_state,
                "estimate the odometry-IMU rotation online (3 states)");
  cmd->add_option("--extrinsic-sigma-deg", a->extrinsic_sigma_deg,
                  "prior std of the online odometry-IMU rotation per axis [deg] (0: the default)")
      ->check(number_in(0.0, 30.0, "a standard deviation in [0, 30] deg"));
  cmd->add_option("--time-offset-ms", a->time_offsets_ms,
                  "camera-IMU time offsets injected into the simulated flights of the time-offset "
                  "experiment (default -20 0 15)")
      ->check(number_in(-200.0, 200.0, "an offset in [-200, 200] ms"));
  cmd->add_option("--offset-flights", a->offset_flights, "flights per time offset")
      ->capture_default_str()
      ->check(whole_in(1, 1000, "a whole number of flights from 1 to 1000"));
  cmd->add_option("--sim-vo-sigma-m", a->sim_vo_sigma_m,
                  "simulated odometry: noise per relative pose and axis, translation [m]")
      ->capture_default_str()
      ->check(number_in(1e-5, 1.0, "a standard deviation in [1e-5, 1] m"));
  cmd->add_option("--sim-vo-sigma-deg", a->sim_vo_sigma_deg,
                  "simulated odometry: noise per relative pose and axis, rotation [deg]")
      ->capture_default_str()
      ->check(number_in(1e-4, 30.0, "a standard deviation in [1e-4, 30] deg"));
  cmd->add_option("--plot-dir", a->plot_dir,
                  "write time_offset.png (t_d error against the filter's and the oracle's 1-sigma, "
                  "first flight per offset) and time_offset.csv (every run) into this folder");
  cmd->add_flag("--force", a->force, "write into a --plot-dir that holds other files");
  cmd->add_option("--imu-walk-scale", a->imu_walk_scale,
                  "multiply the IMU bias random walks of imu0/sensor.yaml")
      ->capture_default_str()
      ->check(number_in(0.0, 1000.0, "a factor in [0, 1000]"));
  cmd->add_flag("--no-first-estimates", a->no_first_estimates,
                "Jacobians at the latest estimates instead of the first ones (for comparison: "
                "the filter then gains yaw information no sensor gives)");
  cmd->add_option("--gap-start", a->gap_start_s,
                  "start of the 2 s measurement gap, seconds after the first pose")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a time in [0, 3600] s"));
  cmd->add_flag("--synthetic-imu", a->synthetic_imu,
                "control experiment: the real IMU replaced by one synthesised from the ground "
                "truth (spline through it) with exactly imu0/sensor.yaml's noise and bias walks, "
                "at the real samples' stamps; separates the filter's error from the real IMU's");
  cmd->add_option("--imu-rotation-deg", a->imu_rotation_deg,
                  "diagnostic: rotate the IMU's readings (gyro and accelerometer) by this "
                  "rotation vector [deg] before fusing")
      ->expected(3)
      ->check(number_in(-30.0, 30.0, "an angle in [-30, 30] deg per component"));
  cmd->add_option("--gyro-scale", a->gyro_scale,
                  "diagnostic: scale the gyro's x y z readings by these factors")
      ->expected(3)
      ->check(number_in(0.5, 2.0, "a factor in [0.5, 2]"));
  cmd->add_option("--world-rotation-deg", a->world_rotation_deg,
                  "diagnostic: turn the ground truth's world frame by this rotation vector [deg]")
      ->expected(3)
      ->check(number_in(-30.0, 30.0, "an angle in [-30, 30] deg per component"));
  cmd->add_option("--only", a->only, "run only this sequence (v1_02 or v1_01)")
      ->check(CLI::IsMember({"v1_02", "v1_01"}));
  cmd->callback([a] { run_fuse_eval(*a); });
}

}  // namespace kestrel::cli
