// `kestrel odometry`: direct RGB-D odometry over a TUM RGB-D folder, or with --stereo over an
// EuRoC folder (rectify -> block matching -> disparity-space tracking); TUM trajectory out,
// evaluation when the folder has ground truth, timing summary as the last stderr line.
// A frame that cannot be read is skipped and counted (--strict stops instead); Ctrl-C or
// SIGTERM stops after the current frame and writes what was done (exit status 130 / 143).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/core/time.hpp"
#include "kestrel/eval/csv_writer.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/odometry_frame_log.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "option_checks.hpp"
#include "progress.hpp"

namespace kestrel::cli {
namespace {

constexpr const char* kOdometryCommand = "odometry";

struct OdometryArgs {
  std::filesystem::path dataset;
  std::filesystem::path out;
  std::filesystem::path config;
  std::filesystem::path frames;    // --frames: per-frame health CSV
  std::filesystem::path plot_dir;  // --plot: the evaluation's CSVs and figures (needs ground truth)
  std::string camera;
  std::optional<double> depth_scale;  // --depth-scale: depth PNG units per metre
  bool force = false;
  bool strict = false;  // --strict: an unreadable frame ends the run instead of being skipped
  bool quiet = false;
  // --stereo: an EuRoC folder, block-matched and tracked in disparity space.
  bool stereo = false;
  std::filesystem::path matcher_options;
  std::string matcher;                // --matcher sad|census|sgm; empty: the options' cost
  std::filesystem::path sgm_options;  // --sgm-options (--matcher sgm)
  int block = 0;                      // 0: from the matcher options (default 9)
  int max_disparity = 0;              // 0: ditto (default 64)
  int min_disparity = -1;
};

void print_options(const odometry::DirectTrackerOptions& options, const OdometryArgs& args) {
  std::cerr << "tracker options"
            << (args.config.empty() ? " (defaults)" : " from " + args.config.string()) << ":\n";
  std::istringstream lines(options.to_yaml());
  for (std::string line; std::getline(lines, line);) std::cerr << "  " << line << "\n";
}

// --frames: one row per frame with the tracker's health and the reported covariance, for
// finding the frames a trajectory error comes from (docs/odometry.md, "Per-frame log").
class FrameLog {
 public:
  FrameLog(const std::filesystem::path& path, bool force) {
    if (path.empty()) return;
    // clang-format off
    std::vector<std::string> columns{
        "frame", "t_ns", "ref_t_ns", "ok", "failure", "converged", "iterations", "sigma",
        "photometric_level", "inlier_ratio", "overlap", "points", "gain", "bias", "new_keyframe",
        "geometric_fallback", "fallback_rotation_from_previous", "track_ms",
        "sd_tx_m", "sd_ty_m", "sd_tz_m", "sd_rx_deg", "sd_ry_deg", "sd_rz_deg"};
    // clang-format on
    // The full covariance, for `kestrel fuse --vo-frames` (io/odometry_frame_log.hpp).
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) columns.push_back(io::frame_log_covariance_column(r, c));
    }
    csv_.emplace(path, columns, kOdometryCommand, force);
  }

  void add(std::size_t frame, const odometry::TrackResult& r, double track_ms) {
    if (!csv_) return;
    auto& c = *csv_;
    const auto flag = [](bool b) { return std::int64_t{b ? 1 : 0}; };
    c.add(static_cast<std::int64_t>(frame)).add(std::int64_t{r.t_ns}).add(std::int64_t{r.ref_t_ns});
    c.add(flag(r.ok())).add(r.ok() ? std::string_view("") : odometry::to_string(r.failure));
    c.add(flag(r.converged)).add(std::int64_t{r.iterations}).add(r.sigma);
    c.add(std::int64_t{r.photometric_level}).add(r.inlier_ratio).add(r.overlap);
    c.add(std::int64_t{r.points}).add(r.gain).add(r.bias);
    c.add(flag(r.new_keyframe)).add(flag(r.geometric_fallback));
    c.add(flag(r.fallback_rotation_from_previous)).add(track_ms);
    const Eigen::Matrix<double, 6, 1> sd = r.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    for (int k = 0; k < 3; ++k) c.add(sd(k));
    for (int k = 3; k < 6; ++k) c.add(sd(k) * 180.0 / std::numbers::pi);
    for (int i = 0; i < 6; ++i) {
      for (int j = i; j < 6; ++j) c.add(r.covariance(i, j));
    }
    c.end_row();
    c.flush();  // whole rows on disk as they come: a log read while the run goes on, or after
                // it was killed, ends on a complete row
  }

  void close() {
    if (csv_) csv_->close();
  }

 private:
  std::optional<eval::CsvWriter> csv_;
};

// Mean and median of the per-frame times, as the last stderr line (its format is stable).
void print_summary(const std::vector<double>& ms, std::size_t frames, std::size_t failures) {
  // `frames`: the frames processed (fewer than the sequence's after an interrupt).
  double mean = 0.0, median = 0.0;
  if (!ms.empty()) {
    for (double v : ms) mean += v;
    mean /= static_cast<double>(ms.size());
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    median = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  }
  if (frames == 1) {
    std::cerr << "kestrel odometry: the sequence has one frame: nothing to track\n";
  }
  std::ostringstream summary;
  summary << std::fixed << std::setprecision(3) << "SUMMARY frames=" << frames
          << " failures=" << failures << " mean_ms=" << mean << " median_ms=" << median;
  std::cout.flush();
  std::cerr << summary.str() << std::endl;  // the LAST line on stderr: keep its format stable
}

std::string failure_line(std::size_t i, const odometry::TrackResult& r) {
  return "frame " + std::to_string(i) + " (t=" + io::format_seconds(r.t_ns) +
         "): " + std::string(odometry::to_string(r.failure)) + ": " + r.failure_detail;
}

// What one run did, shared by the RGB-D and the stereo loop.
struct RunTally {
  std::size_t frames = 0;     // frames in the sequence
  std::size_t processed = 0;  // frames handled before the end or an interrupt (read or skipped)
  std::size_t tracked = 0;    // frames tracked (ok), the first one included
  std::size_t failures = 0, keyframes = 0, fallbacks = 0;
  std::vector<std::string> skipped;  // unreadable frames, with the reason
  std::vector<std::string> failure_lines;
  std::vector<double> ms;
  bool interrupted = false;
};

// An unreadable frame: skipped and counted, or with --strict the run's end (after the frames
// done so far are written: the caller catches StrictStop).
struct StrictStop {
  std::string message;
};

void skip_frame(RunTally& tally, const OdometryArgs& args, std::size_t i,
                const std::string& message) {
  const std::string line = "frame " + std::to_string(i) + ": " + message;
  if (args.strict) throw StrictStop{line};
  std::cerr << "kestrel odometry: skipped unreadable " << line << "\n";
  tally.skipped.push_back(line);
}

std::string skipped_note(const RunTally& tally) {
  if (tally.skipped.empty()) return "";
  return ", " + std::to_string(tally.skipped.size()) + " unreadable frame" +
         (tally.skipped.size() == 1 ? "" : "s") + " skipped";
}

// After the loop: the trajectory and frame log of what was done, then the verdict: an interrupt,
// a --strict stop or a run without one tracked frame is an error that says what was written.
void finish_run(const OdometryArgs& args, const Trajectory& trajectory, FrameLog& frame_log,
                const RunTally& tally, const std::optional<StrictStop>& strict_stop,
                const InterruptScope& interrupt) {
  frame_log.close();
  io::write_tum_trajectory(args.out, trajectory, kOdometryCommand, args.force);
  const std::string wrote = "wrote " + args.out.string() + " (" +
                            std::to_string(trajectory.size()) + " poses)" +
                            (args.frames.empty() ? "" : " and " + args.frames.string());
  if (tally.interrupted) {
    print_summary(tally.ms, tally.processed, tally.failures);
    throw_interrupted(interrupt, "after " + std::to_string(tally.processed) + " of " +
                                     std::to_string(tally.frames) + " frames" +
                                     skipped_note(tally) + "; " + wrote);
  }
  if (strict_stop) {
    throw InputError(strict_stop->message + " (--strict: stopped after " +
                     std::to_string(tally.processed) + " frames; " + wrote + ")");
  }
  if (!tally.skipped.empty()) {
    std::cerr << "kestrel odometry: " << tally.skipped.size() << " of " << tally.frames
              << " frames could not be read and were skipped (--strict stops at the first)\n";
  }
  if (tally.tracked == 0) {
    print_summary(tally.ms, tally.processed, tally.failures);
    throw InputError(args.dataset.string() + ": no frame was tracked (" +
                     std::to_string(tally.failures) + " failures" + skipped_note(tally) + "; " +
                     wrote + ")");
  }
}

// One tracked frame: its time, the tracker's result and the tracking time.
struct TrackedFrame {
  TimeNs t_ns = 0;
  odometry::TrackResult result;
  double ms = 0.0;
};

// The frame loop of both modes: Ctrl-C between frames, the tally, the per-frame log, the
// trajectory and the progress bar. `load(i)` reads frame i (an InputError skips it, or ends the
// run with --strict); `track(images, i)` tracks it, or returns nothing for a frame it skipped.
// Returns the --strict stop, if any.
template <class Load, class Track>
std::optional<StrictStop> run_frames(std::size_t count, const char* label, const OdometryArgs& args,
                                     const InterruptScope& interrupt, RunTally& tally,
                                     FrameLog& frame_log, Trajectory& trajectory, Load&& load,
                                     Track&& track) {
  ProgressBar progress(label, count);
  std::optional<StrictStop> strict_stop;
  try {
    for (std::size_t i = 0; i < count; ++i) {
      if (interrupt.requested()) {
        tally.interrupted = true;
        break;
      }
      tally.processed = i + 1;
      decltype(load(i)) images;
      try {
        images = load(i);  // decoding: not timed
      } catch (const InputError& e) {
        skip_frame(tally, args, i, e.what());
        continue;
      }
      const std::optional<TrackedFrame> f = track(images, i);
      if (!f) continue;
      if (!trajectory.empty()) tally.ms.push_back(f->ms);
      frame_log.add(i, f->result, f->ms);
      if (f->result.ok()) {
        ++tally.tracked;
      } else {
        ++tally.failures;
        if (tally.failure_lines.size() < 20)
          tally.failure_lines.push_back(failure_line(i, f->result));
      }
      tally.keyframes += f->result.new_keyframe ? 1 : 0;
      tally.fallbacks += f->result.geometric_fallback ? 1 : 0;
      trajectory.push_back({f->t_ns, f->result.T_world_cam});
      progress.update(i + 1);
    }
  } catch (const StrictStop& stop) {
    strict_stop = stop;
  }
  progress.finish();
  for (const auto& line : tally.failure_lines) std::cerr << "failure: " << line << "\n";
  return strict_stop;
}

void evaluate_and_print(const Trajectory& gt, const Trajectory& trajectory,
                        const OdometryArgs& args) {
  try {
    const eval::Evaluation evaluation = eval::evaluate(gt, trajectory, eval::EvaluationOptions{});
    std::cout << eval::format_report(evaluation);
    // --plot: the same files as `kestrel evaluate --plot` (the folder was claimed before the run).
    if (!args.plot_dir.empty()) {
      for (const auto& path : eval::write_evaluation_files(
               args.plot_dir, gt, trajectory, evaluation, kOdometryCommand, args.force)) {
        std::cout << "wrote " << path.string() << "\n";
      }
    }
    std::cout << eval::format_summary_line(evaluation) << std::endl;
  } catch (const InputError& e) {
    // Asked for (--plot), the evaluation's failure is the run's error; otherwise a note.
    if (!args.plot_dir.empty()) {
      throw InputError("--plot " + args.plot_dir.string() + ": no evaluation (the trajectory " +
                       args.out.string() + " is written): " + e.what());
    }
    std::cerr << "kestrel odometry: evaluation skipped: " << e.what() << "\n";
  }
}

// --plot needs ground truth; the folder is claimed before the run, not after it.
void check_plot_dir(const OdometryArgs& args, bool has_groundtruth, io::OutputGuard& outputs) {
  if (args.plot_dir.empty()) return;
  if (!has_groundtruth) {
    throw InputError("--plot " + args.plot_dir.string() + ": " + args.dataset.string() +
                     " has no ground truth to evaluate against");
  }
  outputs.folder("--plot", args.plot_dir);
}

// The block matcher's options: the YAML file (if any), then the flags given.
sensor::BlockMatcherOptions matcher_options(const OdometryArgs& args) {
  sensor::BlockMatcherOptions o =
      args.matcher_options.empty() ? sensor::BlockMatcherOptions{}
                                   : sensor::BlockMatcherOptions::load_yaml(args.matcher_options);
  if (args.block != 0) o.block_size = args.block;
  if (args.max_disparity != 0) o.max_disparity = args.max_disparity;
  if (args.min_disparity >= 0) o.min_disparity = args.min_disparity;
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("stereo matcher options (--block, --max-disparity, "
                                 "--min-disparity, --matcher-options): ") +
                     e.what());
  }
  return o;
}

// The front end's matcher: --matcher (kind), the block matcher's options (its file, then the
// flags; their range is every matcher's) and --sgm-options.
sensor::StereoFrontEndOptions front_end_options(const OdometryArgs& args) {
  sensor::MatcherSelection selection{std::nullopt, args.matcher_options, args.sgm_options};
  if (!args.matcher.empty()) {
    selection.kind = sensor::StereoMatcherKind{};
    try {
      parse_option(args.matcher, *selection.kind);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--matcher: ") + e.what());
    }
  }
  sensor::StereoFrontEndOptions o;
  sensor::apply_matcher_selection(selection, "odometry", o,
                                  {"--matcher", "--matcher-options", "--sgm-options"});
  o.matcher = matcher_options(args);
  return o;
}

/// EuRoC ground truth as poses of the rectified left camera, T_world_rect = T_world_cam0 *
/// T_cam0_rect with T_cam0_rect = (R_rect_left^T, 0). A body ground truth (state CSVs) gives
/// T_world_cam0 = T_world_body * T_BS (cam0 sensor.yaml). groundtruth_cam0/ (ORB-SLAM3's, V1_01)
/// is cam0 already, but its quaternion is R_cam_world (the evidence: docs/fusion.md, "V1_01
/// ground truth", and lab/fusion_experiments.cpp): it is inverted here.
Trajectory rectified_camera_groundtruth(const io::EurocSequence& sequence,
                                        const Eigen::Matrix3d& R_rect_left) {
  Trajectory gt;
  const auto csv = sequence.groundtruth_csv();
  if (!csv) return gt;
  const bool camera_gt = csv->parent_path().filename() == "groundtruth_cam0";
  const io::CameraFile cam0 = sequence.cam0_calibration();
  if (!camera_gt && !cam0.T_body_sensor) {
    throw InputError(
        sequence.mav0() / "cam0" / "sensor.yaml", "T_BS",
        "missing (needed to compare with the body ground truth " + csv->string() + ")");
  }
  const SE3 T_cam0_rect(SO3::from_matrix(R_rect_left.transpose()), Eigen::Vector3d::Zero());
  for (const StampedPose& p : io::read_euroc_trajectory(*csv)) {
    const SE3 T_world_cam0 = camera_gt
                                 ? SE3(p.T_world_body.so3().inverse(), p.T_world_body.translation())
                                 : p.T_world_body * *cam0.T_body_sensor;
    gt.push_back({p.t_ns, T_world_cam0 * T_cam0_rect});
  }
  return gt;
}

void run_stereo_odometry(const OdometryArgs& args) {
  if (!args.camera.empty()) {
    throw InputError(
        "--camera: not used with --stereo (the rig comes from the EuRoC folder's "
        "cam0/cam1 sensor.yaml)");
  }
  if (args.depth_scale) {
    throw InputError("--depth-scale: not used with --stereo (depth comes from the disparity)");
  }
  // Depth from the pair: the stereo head's defaults, which a --config file overrides.
  const odometry::DirectTrackerOptions options =
      args.config.empty() ? odometry::stereo_head_tracker_options()
                          : odometry::DirectTrackerOptions::load(
                                args.config, odometry::stereo_head_tracker_options());
  const sensor::StereoFrontEndOptions matching = front_end_options(args);
  const io::EurocSequence sequence(args.dataset);
  io::OutputGuard outputs(kOdometryCommand, args.force);
  outputs.input("dataset", args.dataset)
      .input("--config", args.config)
      .input("--matcher-options", args.matcher_options)
      .input("--sgm-options", args.sgm_options);
  for (const char* file :
       {"cam0/data.csv", "cam1/data.csv", "cam0/sensor.yaml", "cam1/sensor.yaml"}) {
    outputs.input("dataset", sequence.mav0() / file);
  }
  if (const auto gt_csv = sequence.groundtruth_csv()) outputs.input("dataset", *gt_csv);
  outputs.text_file("--out", args.out).text_file("--frames", args.frames);
  const sensor::StereoCalibration calibration = sensor::StereoCalibration::from_euroc(sequence);
  odometry::StereoOdometry stereo(calibration, matching, options);
  const RectifiedStereo& rig = stereo.rig();
  std::cerr << "kestrel odometry --stereo: dataset=" << args.dataset.string()
            << " stereo pairs=" << sequence.stereo_size() << "\n"
            << "calibration: " << calibration.describe() << "\n"
            << "rectified: f " << rig.f << " px, c (" << rig.cu << ", " << rig.cv << "), baseline "
            << rig.baseline_m << " m, " << rig.width << "x" << rig.height << "\n"
            << "matcher: " << stereo.front_end().matcher().describe() << "\n";
  print_options(options, args);
  if (sequence.stereo_size() == 0) {
    throw InputError(args.dataset.string() +
                     ": no stereo pairs (cam0 and cam1 frames with equal "
                     "time stamps in mav0/cam0/data.csv, mav0/cam1/data.csv)");
  }

  const Trajectory gt = rectified_camera_groundtruth(sequence, stereo.R_rect_left());
  check_plot_dir(args, !gt.empty(), outputs);

  Trajectory trajectory;
  trajectory.reserve(sequence.stereo_size());
  RunTally tally;
  tally.frames = sequence.stereo_size();
  double fill_sum = 0.0;
  FrameLog frame_log(args.frames, args.force);
  const InterruptScope interrupt;
  const std::optional<StrictStop> strict_stop = run_frames(
      sequence.stereo_size(), "odometry --stereo", args, interrupt, tally, frame_log, trajectory,
      [&](std::size_t i) { return sequence.load_stereo(i); },
      [&](const io::StereoImages& images, std::size_t i) -> std::optional<TrackedFrame> {
        const auto t0 = std::chrono::steady_clock::now();
        const odometry::StereoTrackResult r = stereo.track(images.t_ns, images.left, images.right);
        const double track_ms = ms_since(t0);
        if (r.track.failure == odometry::TrackFailure::kInvalidInput) {
          skip_frame(tally, args, i,
                     "stereo pair t_ns " + std::to_string(images.t_ns) +
                         " (mav0/cam0 and mav0/cam1): " + r.track.failure_detail);
          return std::nullopt;
        }
        fill_sum += r.match.fill_rate();
        return TrackedFrame{images.t_ns, r.track, track_ms};
      });
  finish_run(args, trajectory, frame_log, tally, strict_stop, interrupt);
  std::cout << "wrote " << args.out.string() << " (" << trajectory.size() << " poses of the "
            << "rectified left camera, " << tally.keyframes << " keyframes, " << tally.failures
            << " failures" << skipped_note(tally) << ", mean disparity fill "
            << 100.0 * fill_sum / static_cast<double>(std::max<std::size_t>(trajectory.size(), 1))
            << " %)\n";
  if (!gt.empty()) evaluate_and_print(gt, trajectory, args);
  print_summary(tally.ms, tally.processed, tally.failures);
}

// A camera named on the command line that is not the folder's own camera.yaml: said before the
// run. A rendered folder's file has no lens distortion where the preset of its camera family
// has; tracked with the preset, every image is warped by a distortion it never had.
void warn_if_not_the_folders_camera(const OdometryArgs& args, const PinholeCamera& camera) {
  const std::filesystem::path own = args.dataset / "camera.yaml";
  std::error_code ec;
  if (args.camera.empty() || !std::filesystem::is_regular_file(own, ec) ||
      std::filesystem::equivalent(own, args.camera, ec)) {
    return;
  }
  std::string folder;
  try {
    folder = io::load_camera(own.string()).describe();
  } catch (const std::exception& e) {
    std::cerr << "kestrel odometry: warning: the folder's " << own.string()
              << " could not be read (" << e.what() << "); --camera " << args.camera
              << " is used\n";
    return;
  }
  if (folder == camera.describe()) return;
  std::cerr << "kestrel odometry: warning: --camera " << args.camera << " (" << camera.describe()
            << ") is not the folder's " << own.string() << " (" << folder
            << "), which describes how these images were made; leave out --camera to use it\n";
}

void run_odometry(const OdometryArgs& args) {
  if (args.stereo) {
    run_stereo_odometry(args);
    return;
  }
  if (!args.matcher_options.empty() || args.block != 0 || args.max_disparity != 0 ||
      args.min_disparity >= 0 || !args.matcher.empty() || !args.sgm_options.empty()) {
    throw InputError(
        "--block, --max-disparity, --min-disparity, --matcher-options, --matcher and "
        "--sgm-options need --stereo");
  }
  std::string camera_name = args.camera;
  if (camera_name.empty()) camera_name = io::camera_for_folder(args.dataset);
  if (camera_name.empty()) {
    throw InputError(args.dataset.string() +
                     ": no camera.yaml in the folder and its name does not say which camera "
                     "(freiburg1/2/3): give --camera fr1|fr2|fr3|ros|FILE.yaml");
  }
  // The camera description: the pinhole model, the depth scale and the rolling-shutter readout.
  const io::CameraFile described = io::load_camera_description(camera_name);
  const PinholeCamera& camera = described.camera;
  warn_if_not_the_folders_camera(args, camera);
  const odometry::DirectTrackerOptions options =
      args.config.empty() ? odometry::DirectTrackerOptions{}
                          : odometry::DirectTrackerOptions::load(args.config);
  // Refuse to overwrite someone else's file, or an input, before doing the work.
  io::OutputGuard outputs(kOdometryCommand, args.force);
  outputs.input("dataset", args.dataset).input("--config", args.config);
  for (const char* file : {"rgb.txt", "depth.txt", "groundtruth.txt"}) {
    outputs.input("dataset", args.dataset / file);
  }
  // Every image the lists name is an input too: no output is written over one, --force or not.
  for (const char* list : {"rgb.txt", "depth.txt"}) {
    if (!std::filesystem::exists(args.dataset / list)) continue;
    for (const io::TimedFile& f : io::read_tum_file_list(args.dataset / list)) {
      outputs.input("dataset", f.file);
    }
  }
  if (std::filesystem::exists(camera_name)) outputs.input("--camera", camera_name);
  outputs.text_file("--out", args.out).text_file("--frames", args.frames);
  io::TumRgbdOptions sequence_options;
  sequence_options.depth_scale =
      args.depth_scale.value_or(described.depth_scale.value_or(sequence_options.depth_scale));
  const io::TumRgbdSequence sequence(args.dataset, sequence_options);

  std::cerr << "kestrel odometry: dataset=" << args.dataset.string()
            << " frames=" << sequence.size() << " (unmatched rgb: " << sequence.unmatched_rgb()
            << ")\n"
            << "camera " << camera_name << ": " << camera.describe() << "\n"
            << "depth: " << sequence_options.depth_scale << " PNG units per metre"
            << (args.depth_scale ? " (--depth-scale)" : "") << "\n"
            << "rolling-shutter readout: " << described.rolling_shutter_readout_s
            << " s (0: global shutter)\n"
            << "camera time offset: " << described.time_offset_s
            << " s (a frame stamped t was exposed at t + offset: the poses carry that time)\n";
  print_options(options, args);
  if (sequence.size() == 0)
    throw InputError(args.dataset.string() + ": no associated rgb/depth frames");
  const auto gt = sequence.groundtruth();
  check_plot_dir(args, gt.has_value(), outputs);

  odometry::DirectTracker tracker(camera, options,
                                  odometry::RollingShutter{described.rolling_shutter_readout_s});
  // Every frame moved to its exposure time on the reference clock (the tracker uses only
  // differences of stamps, which a constant offset leaves as they are).
  const TimeNs offset_ns = s_to_ns(described.time_offset_s);
  Trajectory trajectory;
  trajectory.reserve(sequence.size());
  RunTally tally;
  tally.frames = sequence.size();
  tally.ms.reserve(sequence.size());
  FrameLog frame_log(args.frames, args.force);
  const InterruptScope interrupt;
  const std::optional<StrictStop> strict_stop = run_frames(
      sequence.size(), "odometry", args, interrupt, tally, frame_log, trajectory,
      [&](std::size_t i) { return sequence.load(i); },
      [&](const io::RgbdImages& images, std::size_t) -> std::optional<TrackedFrame> {
        const odometry::RgbdFrame frame{images.t_ns + offset_ns, images.bgr, images.depth_m};
        const auto t0 = std::chrono::steady_clock::now();
        odometry::TrackResult r = tracker.track(frame);
        const double track_ms = ms_since(t0);
        return TrackedFrame{frame.t_ns, std::move(r), track_ms};
      });
  finish_run(args, trajectory, frame_log, tally, strict_stop, interrupt);
  std::cout << "wrote " << args.out.string() << " (" << trajectory.size() << " poses, "
            << tally.keyframes << " keyframes, " << tally.failures << " failures, "
            << tally.fallbacks << " by the geometric fallback" << skipped_note(tally) << ")\n";

  if (gt) evaluate_and_print(*gt, trajectory, args);
  print_summary(tally.ms, tally.processed, tally.failures);
}

}  // namespace

void add_odometry_command(CLI::App& app) {
  auto args = std::make_shared<OdometryArgs>();
  CLI::App* cmd = app.add_subcommand(
      "odometry",
      "Direct dense RGB-D odometry over a TUM RGB-D folder (or, with --stereo, stereo odometry in "
      "disparity space over an EuRoC folder); writes camera-to-world poses in TUM format (first "
      "frame at the identity) and evaluates them against the folder's ground truth if present");
  cmd->add_option("dataset", args->dataset,
                  "TUM RGB-D folder (rgb.txt, depth.txt, rgb/, depth/); with --stereo an EuRoC "
                  "folder (mav0/cam0, mav0/cam1 with data.csv and sensor.yaml)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out", args->out, "output trajectory (TUM format)")->required();
  cmd->add_option("--config", args->config, "tracker options YAML (top level or under 'tracker:')")
      ->check(CLI::ExistingFile);
  cmd->add_option("--frames", args->frames,
                  "per-frame log (CSV): health (converged, iterations, sigma, inlier ratio, "
                  "keyframe, fallback, failure), tracking ms and the reported 1-sigma of the "
                  "motion to the reference frame");
  cmd->add_option("--plot", args->plot_dir,
                  "folder for the evaluation's per-axis and RPE CSVs, the aligned estimate and PNG "
                  "figures, as `kestrel evaluate --plot` (needs the folder's ground truth)");
  cmd->add_option("--camera", args->camera,
                  "fr1|fr2|fr3|ros|FILE.yaml (default: the folder's camera.yaml, as `kestrel "
                  "render` writes, else from the folder name, freiburgN); a Kestrel camera file "
                  "may give depth_scale, rolling_shutter_readout_s and time_offset_s");
  cmd->add_option("--depth-scale", args->depth_scale,
                  "depth PNG units per metre, overriding the camera's (TUM RGB-D: 5000; many "
                  "other RGB-D recordings: 1000)")
      ->check(number_in(0.0, 1e6, "depth units per metre in (0, 1000000]", true));
  cmd->add_flag("--stereo", args->stereo,
                "EuRoC stereo input: rectify, block-match, track the left view in disparity space");
  cmd->add_option("--block", args->block, "--stereo: matching window side (odd; default 9)")
      ->check(whole_in(3, 51, "an odd whole number of pixels from 3 to 51", true));
  cmd->add_option("--max-disparity", args->max_disparity,
                  "--stereo: disparities searched: min <= d < max (default 64)")
      ->check(whole_in(1, 1024, "a whole number of pixels from 1 to 1024"));
  cmd->add_option("--min-disparity", args->min_disparity,
                  "--stereo: smallest disparity (default 0)")
      ->check(whole_in(0, 1023, "a whole number of pixels from 0 to 1023"));
  cmd->add_option("--matcher-options", args->matcher_options,
                  "--stereo: block matcher options YAML (the flags above override it)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--matcher", args->matcher,
                  "--stereo: stereo matcher, sad (default), census or sgm (docs/stereo.md)");
  cmd->add_option("--sgm-options", args->sgm_options,
                  "--stereo --matcher sgm: semi-global matcher options YAML")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--force", args->force, "overwrite an output file written by something else");
  cmd->add_flag("--strict", args->strict,
                "stop at the first frame that cannot be read (default: skip it, count it and "
                "report it)");
  cmd->callback([args] { run_odometry(*args); });
}

}  // namespace kestrel::cli
