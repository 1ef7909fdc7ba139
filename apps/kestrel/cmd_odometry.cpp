// `kestrel odometry`: direct RGB-D odometry over a TUM RGB-D folder, TUM trajectory out,
// evaluation when the folder has ground truth, timing summary as the last stderr line.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "progress.hpp"

namespace kestrel::cli {
namespace {

constexpr const char* kCommand = "odometry";

struct OdometryArgs {
  std::filesystem::path dataset;
  std::filesystem::path out;
  std::filesystem::path config;
  std::string camera;
  bool force = false;
  bool quiet = false;
};

std::string default_camera_for(const std::filesystem::path& folder) {
  const std::string name = std::filesystem::absolute(folder).lexically_normal().string();
  if (name.find("freiburg1") != std::string::npos) return "fr1";
  if (name.find("freiburg2") != std::string::npos) return "fr2";
  if (name.find("freiburg3") != std::string::npos) return "fr3";
  return {};
}

void run_odometry(const OdometryArgs& args) {
  std::string camera_name = args.camera;
  if (camera_name.empty()) camera_name = default_camera_for(args.dataset);
  if (camera_name.empty()) {
    throw InputError(args.dataset.string() +
                     ": the folder name does not say which camera (freiburg1/2/3): give "
                     "--camera fr1|fr2|fr3|ros|FILE.yaml");
  }
  const PinholeCamera camera = io::load_camera(camera_name);
  const odometry::DirectTrackerOptions options =
      args.config.empty() ? odometry::DirectTrackerOptions{}
                          : odometry::DirectTrackerOptions::load(args.config);
  // Refuse to overwrite someone else's file before doing the work.
  io::check_can_write_file(args.out, kCommand, args.force);
  const io::TumRgbdSequence sequence(args.dataset);

  std::cerr << "kestrel odometry: dataset=" << args.dataset.string() << " frames=" << sequence.size()
            << " (unmatched rgb: " << sequence.unmatched_rgb() << ")\n"
            << "camera " << camera_name << ": " << camera.describe() << "\n"
            << "tracker options" << (args.config.empty() ? " (defaults)" : " from " + args.config.string())
            << ":\n";
  {
    std::istringstream lines(options.to_yaml());
    for (std::string line; std::getline(lines, line);) std::cerr << "  " << line << "\n";
  }
  if (sequence.size() == 0) throw InputError(args.dataset.string() + ": no associated rgb/depth frames");

  odometry::DirectTracker tracker(camera, options);
  Trajectory trajectory;
  trajectory.reserve(sequence.size());
  std::vector<double> ms;
  ms.reserve(sequence.size());
  std::size_t failures = 0, keyframes = 0;
  std::vector<std::string> failure_lines;
  ProgressBar progress("odometry", sequence.size());
  for (std::size_t i = 0; i < sequence.size(); ++i) {
    const io::RgbdImages images = sequence.load(i);  // decoding: not timed
    odometry::RgbdFrame frame{images.t_ns, images.bgr, images.depth_m, images.depth_t_ns};
    const auto t0 = std::chrono::steady_clock::now();
    const odometry::TrackResult r = tracker.track(frame);
    const auto t1 = std::chrono::steady_clock::now();
    if (i > 0) ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    if (!r.ok()) {
      ++failures;
      if (failure_lines.size() < 20) {
        failure_lines.push_back("frame " + std::to_string(i) + " (t=" + io::format_seconds(r.t_ns) +
                                "): " + std::string(odometry::to_string(r.failure)) + ": " +
                                r.failure_detail);
      }
    }
    keyframes += r.new_keyframe ? 1 : 0;
    trajectory.push_back({images.t_ns, r.T_world_cam});
    progress.update(i + 1);
  }
  progress.finish();
  io::write_tum_trajectory(args.out, trajectory, kCommand, args.force);
  std::cout << "wrote " << args.out.string() << " (" << trajectory.size() << " poses, "
            << keyframes << " keyframes, " << failures << " failures)\n";
  for (const auto& line : failure_lines) std::cerr << "failure: " << line << "\n";

  if (const auto gt = sequence.groundtruth()) {
    try {
      const eval::Evaluation evaluation = eval::evaluate(*gt, trajectory, eval::EvaluationOptions{});
      std::cout << eval::format_report(evaluation);
      std::cout << eval::format_summary_line(evaluation) << std::endl;
    } catch (const InputError& e) {
      std::cerr << "kestrel odometry: evaluation skipped: " << e.what() << "\n";
    }
  }

  double mean = 0.0, median = 0.0;
  if (!ms.empty()) {
    for (double v : ms) mean += v;
    mean /= static_cast<double>(ms.size());
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    median = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  }
  if (sequence.size() == 1) {
    std::cerr << "kestrel odometry: the sequence has one frame: nothing to track\n";
  }
  std::ostringstream summary;
  summary << std::fixed << std::setprecision(3) << "SUMMARY frames=" << sequence.size()
          << " failures=" << failures << " mean_ms=" << mean << " median_ms=" << median;
  std::cout.flush();
  std::cerr << summary.str() << std::endl;  // the LAST line on stderr: keep its format stable
}

}  // namespace

void add_odometry_command(CLI::App& app) {
  auto args = std::make_shared<OdometryArgs>();
  CLI::App* cmd = app.add_subcommand(
      "odometry",
      "Direct dense RGB-D odometry over a TUM RGB-D folder; writes camera-to-world poses in TUM "
      "format (first frame at the identity) and evaluates them against groundtruth.txt if present");
  cmd->add_option("dataset", args->dataset, "TUM RGB-D folder (rgb.txt, depth.txt, rgb/, depth/)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out", args->out, "output trajectory (TUM format)")->required();
  cmd->add_option("--config", args->config, "tracker options YAML (top level or under 'tracker:')")
      ->check(CLI::ExistingFile);
  cmd->add_option("--camera", args->camera,
                  "fr1|fr2|fr3|ros|FILE.yaml (default: from the folder name, freiburgN)");
  cmd->add_flag("--force", args->force, "overwrite an output file written by something else");
  cmd->callback([args] { run_odometry(*args); });
}

}  // namespace kestrel::cli
