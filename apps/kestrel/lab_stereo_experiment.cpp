// `kestrel lab stereo-experiment` (thesis fig. 2.7): the "wall" scene rendered passive (ambient
// light, low texture) and active (the projector's pattern), matched by the block matcher and
// scored against the rendered truth; writes the views, both disparity maps (PNG + PFM).
// With --odometry: the corridor sequence rendered passive and active, tracked in disparity
// space and scored against the rendered trajectory (lab/stereo_odometry_experiment.hpp).
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/pfm.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/lab/stereo_experiment.hpp"
#include "kestrel/lab/stereo_odometry_experiment.hpp"
#include "option_checks.hpp"

namespace kestrel::cli {
namespace {
namespace fs = std::filesystem;

constexpr const char* kStereoExperimentCommand = "lab stereo-experiment";

struct ExperimentArgs {
  fs::path out;
  lab::StereoExperimentOptions options;
  std::string mode = "dark";
  bool force = false;
  // --odometry: the passive-vs-active stereo odometry experiment.
  bool odometry = false;
  lab::StereoOdometryExperimentOptions odo;
  std::string odo_mode = "ambient";
  bool write_sequences = false;
};

void run_odometry_experiment(ExperimentArgs& args, const CLI::App& cmd) {
  auto& o = args.odo;
  // The flags shared with the single-frame experiment.
  if (cmd.count("--seed") > 0) o.seed = args.options.seed;
  if (cmd.count("--block") > 0) o.matcher.block_size = args.options.matcher.block_size;
  if (cmd.count("--max-disparity") > 0)
    o.matcher.max_disparity = args.options.matcher.max_disparity;
  if (cmd.count("--lines") > 0) o.pattern.lines = args.options.pattern.lines;
  if (cmd.count("--segments") > 0) o.pattern.full_lines = false;
  if (cmd.count("--min-length") > 0) o.pattern.min_length_px = args.options.pattern.min_length_px;
  if (cmd.count("--max-length") > 0) o.pattern.max_length_px = args.options.pattern.max_length_px;
  if (cmd.count("--noise") > 0) o.intensity_sigma = args.options.intensity_sigma;
  if (cmd.count("--mode") > 0) args.odo_mode = args.mode;
  o.active_mode = sim::parse_projector_mode(args.odo_mode);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  io::OutputGuard(kStereoExperimentCommand, args.force).folder("--out", args.out);
  if (args.write_sequences) {
    o.write_sequences_to = args.out;
    o.force = true;  // inside the folder this command has just claimed
  }
  std::cerr << "kestrel lab stereo-experiment --odometry: " << o.describe() << "\n";
  // Ctrl-C ends the run after the current frame; the trajectories of the frames done are
  // written, then the command says so.
  const InterruptScope interrupt;
  o.stop = interrupt.flag();
  const lab::StereoOdometryExperimentResult r = lab::run_stereo_odometry_experiment(o);
  io::write_tum_trajectory(args.out / "groundtruth.txt", r.groundtruth, kStereoExperimentCommand,
                           true);
  for (const auto& run : r.runs) {
    io::write_tum_trajectory(args.out / (run.name + ".txt"), run.estimate, kStereoExperimentCommand,
                             true);
  }
  std::cout << "wrote " << args.out.string() << "/{groundtruth";
  for (const auto& run : r.runs) std::cout << "," << run.name;
  std::cout << "}.txt" << (args.write_sequences ? " and the sequences passive/, active/" : "")
            << "\n"
            << lab::format_stereo_odometry_result(r);
  for (const auto& run : r.runs) {
    std::cout << run.name << "_failures=" << run.failures << " " << run.name
              << "_final_error_m=" << run.final_error_m << " " << run.name
              << "_ate_m=" << (run.evaluated ? run.ate.stats_m.rmse : -1.0) << " ";
  }
  std::cout << "\n";
  if (r.stopped) {
    throw_interrupted(interrupt, "after " + std::to_string(r.groundtruth.size()) + " of " +
                                     std::to_string(o.frames) + " frames; wrote " +
                                     args.out.string() + " (the frames done)");
  }
}

void write_image(const fs::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) throw InputError(path.string() + ": cannot write");
}

void save_run(const fs::path& dir, const lab::StereoExperimentRun& run, double max_disparity) {
  write_image(dir / (run.name + "_left.png"), run.frame.left.color_bgr);
  write_image(dir / (run.name + "_right.png"), run.frame.right.color_bgr);
  write_image(dir / (run.name + "_disparity.png"),
              lab::colorize_disparity(run.disparity_px, max_disparity));
  io::write_pfm(dir / (run.name + "_disparity.pfm"), run.disparity_px, true);
}

void print_run(const lab::StereoExperimentRun& run) {
  const auto& s = run.score;
  std::cout << run.name << ": fill " << 100.0 * s.fill_rate() << " % of " << s.scored
            << " covisible pixels, RMS error " << s.rms_error_px << " px, bad (> "
            << s.bad_threshold_px << " px) " << 100.0 * run.bad_rate() << " % of filled ("
            << 100.0 * s.bad_rate()
            << " % counting missing as bad); matcher: " << run.stats.describe() << "\n";
  const auto& l = run.score_lit;
  std::cout << "  over the " << l.scored << " covisible pixels the projector lights: fill "
            << 100.0 * l.fill_rate() << " %, RMS error " << l.rms_error_px << " px, bad "
            << 100.0 * l.bad_rate_of_filled() << " % of filled\n";
}

void run_experiment(ExperimentArgs& args, const CLI::App& cmd) {
  if (args.odometry) {
    run_odometry_experiment(args, cmd);
    return;
  }
  args.options.active_mode = sim::parse_projector_mode(args.mode);
  if (args.options.active_mode == sim::ProjectorMode::kOff) {
    throw InputError("--mode: the active run needs the projector: dark or ambient");
  }
  try {
    args.options.matcher.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  io::OutputGuard(kStereoExperimentCommand, args.force).folder("--out", args.out);
  std::cerr << "kestrel lab stereo-experiment: " << args.options.describe() << "\n";
  const lab::StereoExperimentResult r = lab::run_stereo_experiment(args.options);

  const double max_d = args.options.matcher.max_disparity;
  write_image(args.out / "pattern.png", r.pattern);
  write_image(args.out / "covisible.png", r.covisible);
  write_image(args.out / "projector_lit.png", r.lit);
  io::write_pfm(args.out / "truth_disparity.pfm", r.passive.frame.disparity_px, true);
  write_image(args.out / "truth_disparity.png",
              lab::colorize_disparity(r.passive.frame.disparity_px, max_d));
  save_run(args.out, r.passive, max_d);
  save_run(args.out, r.active, max_d);
  std::cout << "wrote " << args.out.string() << "/{pattern,covisible,projector_lit,truth_disparity,"
            << r.passive.name << "_*," << r.active.name << "_*}\n";
  print_run(r.passive);
  print_run(r.active);
  std::cout << "passive_fill=" << r.passive.score.fill_rate()
            << " passive_bad=" << r.passive.bad_rate()
            << " active_fill=" << r.active.score.fill_rate()
            << " active_bad=" << r.active.bad_rate()
            << " active_lit_fill=" << r.active.score_lit.fill_rate()
            << " active_lit_bad=" << r.active.score_lit.bad_rate_of_filled() << "\n";
}

}  // namespace

void add_stereo_experiment_command(CLI::App& lab) {
  auto args = std::make_shared<ExperimentArgs>();
  CLI::App* cmd = lab.add_subcommand(
      "stereo-experiment",
      "Thesis fig. 2.7: a plain wall with a box before it, rendered passive and with the "
      "projector's pattern; fill rate and error of the block matcher against the truth.");
  auto& o = args->options;
  cmd->add_option("--out", args->out, "output folder")->required();
  cmd->add_option("--seed", o.seed, "seed of the pattern, textures and noise")
      ->capture_default_str()
      ->check(whole_in(0, 4294967295, "a seed, a whole number from 0 to 4294967295"));
  cmd->add_option("--block", o.matcher.block_size, "matching window side (odd)")
      ->capture_default_str()
      ->check(whole_in(3, 51, "an odd whole number of pixels from 3 to 51", true));
  cmd->add_option("--max-disparity", o.matcher.max_disparity, "disparities searched: 0 <= d < N")
      ->capture_default_str()
      ->check(whole_in(1, 1024, "a whole number of pixels from 1 to 1024"));
  cmd->add_option("--mode", args->mode,
                  "active lighting: dark (pattern only) or ambient (+ pattern)")
      ->capture_default_str();
  cmd->add_option("--lines", o.pattern.lines, "pattern line count")
      ->capture_default_str()
      ->check(whole_in(1, 100000, "a whole number of lines, 1 to 100000"));
  cmd->add_flag("--segments{false}", o.pattern.full_lines,
                "pattern of segments (--min-length..--max-length) instead of lines across it");
  cmd->add_option("--min-length", o.pattern.min_length_px,
                  "pattern: shortest segment [projector px] (--segments)")
      ->capture_default_str()
      ->check(number_in(1.0, 100000.0, "a length in [1, 100000] px"));
  cmd->add_option("--max-length", o.pattern.max_length_px,
                  "pattern: longest segment [projector px] (--segments)")
      ->capture_default_str()
      ->check(number_in(1.0, 100000.0, "a length in [1, 100000] px"));
  cmd->add_option("--projector-fov", o.projector.horizontal_fov_deg,
                  "projector horizontal field of view [deg]")
      ->capture_default_str()
      ->check(number_in(0.0, 170.0, "an angle in (0, 170] deg", true));
  cmd->add_option("--noise", o.intensity_sigma, "camera intensity noise sigma [grey levels]")
      ->capture_default_str()
      ->check(number_in(0.0, 255.0, "a standard deviation in [0, 255] grey levels"));
  cmd->add_flag("--force", args->force, "write into a folder not claimed by this command");
  // The stereo odometry experiment: defaults in stereo_odometry_experiment.hpp.
  auto& q = args->odo;
  cmd->add_flag("--odometry", args->odometry,
                "stereo odometry instead: the corridor sequence rendered passive and active, "
                "tracked in disparity space (default mode: ambient)");
  cmd->add_option("--scene", q.scene,
                  "--odometry: scene (corridor, bare_corridor, ...: kestrel render --list)")
      ->capture_default_str();
  cmd->add_option("--trajectory", q.trajectory, "--odometry: trajectory")->capture_default_str();
  cmd->add_option("--frames", q.frames, "--odometry: frames")
      ->capture_default_str()
      ->check(whole_in(2, 100000, "a whole number of frames, 2 to 100000"));
  cmd->add_option("--rate", q.rate_hz, "--odometry: frame rate [Hz]")
      ->capture_default_str()
      ->check(number_in(0.0, 1000.0, "a rate in (0, 1000] Hz", true));
  cmd->add_option("--width", q.width, "--odometry: image width")
      ->capture_default_str()
      ->check(whole_in(16, 4096, "a whole number of pixels from 16 to 4096"));
  cmd->add_option("--height", q.height, "--odometry: image height")
      ->capture_default_str()
      ->check(whole_in(16, 4096, "a whole number of pixels from 16 to 4096"));
  cmd->add_option("--focal", q.f_px, "--odometry: focal length [px]")
      ->capture_default_str()
      ->check(number_in(1.0, 100000.0, "a focal length in [1, 100000] px"));
  cmd->add_option("--pyramid-levels", q.tracker.pyramid.levels,
                  "--odometry: tracker pyramid levels")
      ->capture_default_str()
      ->check(whole_in(1, 8, "a whole number of levels from 1 to 8"));
  cmd->add_flag("--write-sequences", args->write_sequences,
                "--odometry: also write the passive/ and active/ EuRoC folders "
                "(for `kestrel odometry --stereo`)");
  cmd->callback([args, cmd] { run_experiment(*args, *cmd); });
}

}  // namespace kestrel::cli
