// `kestrel fly`: the closed-loop flight of the whole pipeline in simulation.
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/flight/flight_report.hpp"
#include "kestrel/flight/flight_simulation.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/yaml_file.hpp"
#include "kestrel/sim/scenes.hpp"
#include "option_checks.hpp"
#include "progress.hpp"

namespace kestrel::cli {
namespace {

// FlightSimulation sets SafetyOptions::hold_flies_mission from its mission clock (a clock that
// eases to a stop in a hold needs a hold that flies it). A safety file that asks for the other
// value is told so, rather than silently overridden.
void warn_if_hold_is_overridden(const std::string& safety_yaml, bool pause_mission_in_hold) {
  const YAML::Node root = io::load_yaml_file(safety_yaml);
  const YAML::Node safety = root.IsMap() && root["safety"] ? root["safety"] : root;
  if (!safety.IsMap() || !safety["hold_flies_mission"]) return;
  if (safety["hold_flies_mission"].as<bool>() == pause_mission_in_hold) return;
  std::cerr << "kestrel fly: warning: " << safety_yaml << ": hold_flies_mission is "
            << (pause_mission_in_hold ? "true" : "false") << " in this flight, not the file's "
            << (pause_mission_in_hold ? "false" : "true")
            << ": kestrel fly sets it with its mission clock (--mission-runs-in-hold: false)\n";
}

struct FlyArgs {
  std::string scenario = "hover";
  double duration_s = 0.0;  // 0: the scenario's default
  std::uint64_t seed = 1;
  std::string out;
  bool force = false;
  bool list = false;
  std::string world = "ideal";
  bool print_world = false;
  bool mission_runs_in_hold = false;
  double vo_off_at_s = -1.0;
  double vo_off_for_s = 2.0;
  double latency_s = -1.0;
  std::string projector;
  std::string vo_reference;
  std::string vehicle_yaml, controller_yaml, imu_yaml, safety_yaml, tracker_yaml, matcher_yaml;
  std::string stereo_matcher, sgm_yaml;       // --stereo-matcher sad|census|sgm, --sgm-options FILE
  std::string adaptive_vo_noise;              // on|off; empty: the fusion's default
  double adaptive_vo_noise_max_scale = -1.0;  // < 0: the fusion's default
  std::string relocalize;                     // on|off; empty: the vision's default (on)
};

void run_fly(const FlyArgs& a) {
  if (a.list) {
    std::cout << "scenarios (--scenario):\n";
    for (const auto& e : flight::scenario_catalogue()) {
      std::cout << "  " << std::left << std::setw(10) << e.name << e.description << " ("
                << flight::make_scenario(e.name, SE3()).default_duration_s << " s)\n";
    }
    return;
  }
  const sim::WorldOptions world = sim::WorldOptions::from_argument(a.world);
  if (a.print_world) {
    std::cout << world.to_documented_yaml();
    return;
  }
  if (a.out.empty()) throw InputError("fly: --out DIR is required");
  flight::FlightOptions options;
  options.seed = a.seed;
  options.world = world;
  options.pause_mission_in_hold = !a.mission_runs_in_hold;
  if (!a.vehicle_yaml.empty()) options.vehicle = sim::QuadrotorParameters::load(a.vehicle_yaml);
  if (!a.controller_yaml.empty()) {
    options.controller = control::PositionControllerOptions::load(a.controller_yaml);
  }
  if (!a.imu_yaml.empty()) options.imu_noise = io::load_imu_noise(a.imu_yaml);
  if (!a.safety_yaml.empty()) {
    options.safety = control::SafetyOptions::load(a.safety_yaml);
    warn_if_hold_is_overridden(a.safety_yaml, options.pause_mission_in_hold);
  }
  if (!a.tracker_yaml.empty()) {
    // Fields the file leaves out keep the stereo head's (odometry::stereo_head_tracker_options()).
    options.vision.tracker =
        odometry::DirectTrackerOptions::load(a.tracker_yaml, options.vision.tracker);
  }
  {
    sensor::MatcherSelection selection{std::nullopt, a.matcher_yaml, a.sgm_yaml};
    if (!a.stereo_matcher.empty()) {
      try {
        selection.kind = sensor::StereoMatcherKind{};
        parse_option(a.stereo_matcher, *selection.kind);
      } catch (const std::invalid_argument& e) {
        throw InputError(std::string("fly: --stereo-matcher: ") + e.what());
      }
    }
    sensor::StereoFrontEndOptions matching;
    sensor::apply_matcher_selection(selection, "fly", matching,
                                    {"--stereo-matcher", "--matcher", "--sgm-options"});
    options.vision.matcher = matching.matcher;
    options.vision.matcher_kind = matching.kind;
    options.vision.sgm = matching.sgm;
  }
  if (!a.projector.empty()) options.vision.projector_mode = sim::parse_projector_mode(a.projector);
  if (!a.vo_reference.empty()) {
    try {
      options.vision.measurement_reference = fusion::parse_odometry_reference(a.vo_reference);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("fly: --vo-reference: ") + e.what());
    }
  }
  if (!a.adaptive_vo_noise.empty()) {
    options.fusion.adaptive_vo_noise.enabled = a.adaptive_vo_noise == "on";
  }
  if (a.adaptive_vo_noise_max_scale >= 0.0) {
    options.fusion.adaptive_vo_noise.max_scale = a.adaptive_vo_noise_max_scale;
  }
  if (!a.relocalize.empty()) options.vision.relocalize_after_gap = a.relocalize == "on";
  if (a.latency_s >= 0.0) options.vision_latency_s = a.latency_s;
  if (a.vo_off_at_s >= 0.0) {
    if (!(a.vo_off_for_s > 0.0)) throw InputError("fly: --vo-off-for must be positive");
    options.vo_off_at_s = a.vo_off_at_s;
    options.vo_off_for_s = a.vo_off_for_s;
  }

  const sim::Scene probe =
      sim::make_scene(flight::make_scenario(a.scenario, SE3()).scene);  // validates the name early
  flight::Scenario scenario = flight::make_scenario(a.scenario, probe.T_world_start());
  const double duration = a.duration_s > 0.0 ? a.duration_s : scenario.default_duration_s;
  if (a.duration_s < 0.0) throw InputError("fly: --duration must be positive");
  if (options.vo_off_at_s >= duration) {
    throw InputError("fly: --vo-off-at is after the end of the flight");
  }
  io::OutputGuard("fly", a.force)
      .input("--vehicle", a.vehicle_yaml)
      .input("--controller", a.controller_yaml)
      .input("--imu", a.imu_yaml)
      .input("--safety", a.safety_yaml)
      .input("--tracker", a.tracker_yaml)
      .input("--matcher", a.matcher_yaml)
      .input("--sgm-options", a.sgm_yaml)
      .input("--world", a.world == "ideal" || a.world == "realistic" ? std::string() : a.world)
      .folder("--out", a.out);

  flight::FlightSimulation simulation(std::move(scenario), options);
  std::cerr << "kestrel fly: scenario " << a.scenario << " in scene '" << probe.name() << "', "
            << duration << " s, seed " << a.seed << "\n  world: " << options.world.describe()
            << "\n  vision: " << options.vision.describe() << "\n";
  const InterruptScope interrupt;  // Ctrl-C: the logs of the flight so far are written
  ProgressBar bar("flying (simulated s)", static_cast<std::size_t>(duration));
  const flight::FlightResult result = simulation.run(
      duration, [&](const flight::FlightSample& s) { bar.update(static_cast<std::size_t>(s.t_s)); },
      interrupt.flag());
  bar.finish();

  auto logs = flight::write_flight_logs(a.out, result);
  {
    // The world flown, as a file `--world` reads back.
    const std::filesystem::path world_path = std::filesystem::path(a.out) / "world.yaml";
    std::ofstream f(world_path);
    f << options.world.to_documented_yaml();
    if (!f) throw InputError(world_path.string() + ": cannot write");
    logs.push_back(world_path);
  }
  const auto plots = flight::write_flight_plots(a.out, result);
  const double realtime =
      result.counters.wall_s > 0.0 ? result.duration_s / result.counters.wall_s : 0.0;
  std::cout << std::fixed << std::setprecision(3) << "scenario " << result.scenario << ": "
            << result.duration_s << " s simulated in " << result.counters.wall_s << " s ("
            << std::setprecision(2) << realtime << "x real time), final mode " << result.final_mode
            << "\n"
            << "  tracking RMS " << std::setprecision(4) << result.rms_tracking_m() << " m (max "
            << result.max_tracking_m() << " m), estimate RMS " << result.rms_estimate_m()
            << " m, scored from t = " << result.settle_s << " s\n"
            << "  " << result.counters.describe() << "\n"
            << "  " << flight::odometry_check_summary(result) << "\n";
  for (const flight::RelocalizationEvent& e : result.relocalizations) {
    const odometry::RelocalizationResult& r = e.result;
    std::cout << "  relocalisation at " << std::setprecision(3) << e.t_s
              << " s: " << (r.ok() ? "ok" : "refused (" + r.detail + ")") << ", " << r.inliers
              << " of " << r.matches << " matches inliers, reprojection " << r.reprojection_rms_px
              << " px, refined sigma " << 255.0 * r.refinement.sigma
              << " grey levels; error against the truth " << 100.0 * e.translation_error_m
              << " cm, " << e.rotation_error_deg << " deg; " << e.ms << " ms\n";
  }
  for (const auto& p : logs) std::cout << "  log:  " << p.string() << "\n";
  for (const auto& p : plots) std::cout << "  plot: " << p.string() << "\n";
  std::cout << flight::flight_summary_line(result) << std::endl;
  if (result.interrupted) {
    std::ostringstream what;
    what << "after " << std::setprecision(3) << result.duration_s << " of " << duration
         << " simulated s; wrote " << logs.size() + plots.size() << " files to " << a.out;
    throw_interrupted(interrupt, what.str());
  }
}

}  // namespace

void add_fly_command(CLI::App& app) {
  auto args = std::make_shared<FlyArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fly",
      "Fly a closed loop in simulation: render -> active stereo -> odometry -> EKF -> "
      "controller -> PWM -> flight controller -> dynamics");
  cmd->add_option("--scenario", args->scenario,
                  sim::catalogue_names(flight::scenario_catalogue()) + " (see --list)")
      ->capture_default_str();
  cmd->add_option("--duration", args->duration_s,
                  "Simulated seconds (default: the scenario's own, see --list)")
      ->check(number_in(0.0, 3600.0, "a duration in (0, 3600] s", true));
  cmd->add_option("--seed", args->seed, "Seed of every random part (IMU, noise, pattern)")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  cmd->add_option("--out", args->out,
                  "Output folder: log.csv, details.csv, estimator.csv, odometry.csv, top_view.png, "
                  "errors.png");
  cmd->add_flag("--force", args->force, "Write into a folder that holds other files");
  cmd->add_flag("--list", args->list, "List the scenarios, then exit");
  cmd->add_option("--world", args->world,
                  "The simulated world: ideal (default), realistic, or a YAML file "
                  "(docs/flight.md, \"World\"; --print-world writes one)")
      ->capture_default_str();
  cmd->add_flag("--mission-runs-in-hold", args->mission_runs_in_hold,
                "Keep the mission's clock running while the supervisor holds, the hold a fixed "
                "point (default: the clock eases to a stop, the hold flies that braking "
                "mission, and the mission resumes where it stopped)");
  cmd->add_flag("--print-world", args->print_world,
                "Print the --world as documented YAML (a file to start from), then exit");
  cmd->add_option("--vo-off-at", args->vo_off_at_s,
                  "Switch the odometry off at this time (s) to test the IMU hold")
      ->check(number_in(0.0, 3600.0, "a time in [0, 3600] s"));
  cmd->add_option("--vo-off-for", args->vo_off_for_s, "... for this long (s)")
      ->capture_default_str()
      ->check(number_in(0.0, 3600.0, "a duration in (0, 3600] s", true));
  cmd->add_option("--latency", args->latency_s,
                  "Camera-to-filter latency in seconds (default 0.040)")
      ->check(number_in(0.0, 1.0, "a latency in [0, 1] s"));
  cmd->add_option("--adaptive-vo-noise", args->adaptive_vo_noise,
                  "Scale the odometry covariance online from the updates' NIS: on|off, on "
                  "by default (docs/fusion.md, \"Adaptive odometry covariance\")")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--adaptive-vo-noise-max-scale", args->adaptive_vo_noise_max_scale,
                  "Upper bound of that scale (0: the gate over the degrees of freedom, 3.74)")
      ->check(number_in(0.0, 1.0e6, "0 or a scale in [1, 1e6]"));
  cmd->add_option("--relocalize", args->relocalize,
                  "After an odometry gap, relocalise the first frame against the last one "
                  "before it (SIFT + PnP, refined by the direct alignment): on|off, on by default "
                  "(docs/flight.md, \"Re-localising after an odometry outage\")")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--vo-reference", args->vo_reference,
                  "What each odometry measurement to the EKF is relative to: keyframe (default) "
                  "or previous_frame (docs/flight.md compares them)");
  cmd->add_option("--projector", args->projector,
                  "Projector mode: ambient (default: room light + pattern), dark, off (passive)");
  cmd->add_option("--vehicle", args->vehicle_yaml,
                  "Vehicle parameters YAML (config/vehicle_default.yaml)");
  cmd->add_option("--controller", args->controller_yaml,
                  "Position-controller gains YAML (config/controller_default.yaml)");
  cmd->add_option("--imu", args->imu_yaml,
                  "IMU noise, EuRoC sensor.yaml format (config/imu_default.yaml)");
  cmd->add_option("--safety", args->safety_yaml, "Safety options YAML");
  cmd->add_option("--tracker", args->tracker_yaml,
                  "Direct-odometry options YAML (fields it leaves out keep the stereo head's: "
                  "the defaults without their 6 m depth limit, docs/flight.md)");
  cmd->add_option("--matcher", args->matcher_yaml, "Block-matcher options YAML");
  cmd->add_option("--stereo-matcher", args->stereo_matcher,
                  "Stereo matcher: sad (default), census or sgm (range: --matcher's)");
  cmd->add_option("--sgm-options", args->sgm_yaml, "Semi-global matcher options YAML (sgm)");
  cmd->callback([args] { run_fly(*args); });
}

}  // namespace kestrel::cli
