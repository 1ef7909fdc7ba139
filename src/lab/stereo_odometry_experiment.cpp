// Passive vs active stereo odometry on a rendered corridor: render both lightings along one
// trajectory, match, track in disparity space, score against the rendered truth.
#include "kestrel/lab/stereo_odometry_experiment.hpp"

#include <cmath>
#include <iomanip>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/sequence_writer.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::lab {

void StereoOdometryExperimentOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw std::invalid_argument("stereo odometry experiment: " + field + " " + why);
  };
  if (frames < 2) fail("frames", "must be at least 2");
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) fail("rate_hz", "must be positive");
  if (width < 32 || height < 32) fail("width/height", "must be at least 32");
  if (!(f_px > 0.0) || !std::isfinite(f_px)) fail("f_px", "must be positive");
  if (!(baseline_m > 0.0) || !std::isfinite(baseline_m)) fail("baseline_m", "must be positive");
  if (!(intensity_sigma >= 0.0)) fail("intensity_sigma", "must be >= 0");
  if (active_mode == sim::ProjectorMode::kOff) fail("active_mode", "must light the pattern");
  projector.validate();
  pattern.validate();
  matcher.validate();
  if (pattern.width != projector.width || pattern.height != projector.height) {
    fail("pattern", "size must be the projector's");
  }
  tracker.validate();
}

std::string StereoOdometryExperimentOptions::describe() const {
  std::ostringstream os;
  os << "scene " << scene << ", trajectory " << trajectory << ", " << frames << " frames at "
     << rate_hz << " Hz, cameras " << width << "x" << height << ", f " << f_px << " px, baseline "
     << baseline_m << " m, intensity noise sigma " << intensity_sigma << ", active mode "
     << sim::projector_mode_name(active_mode) << ", seed " << seed << "\n  " << projector.describe()
     << "\n  pattern: " << pattern.describe() << "\n  matcher: " << matcher.describe()
     << "\n  tracker: pyramid.levels " << tracker.pyramid.levels << ", selection.max_points "
     << tracker.selection.max_points << " (other tracker options at their defaults unless set)";
  return os.str();
}

namespace {

double angle_deg(const SE3& T) { return T.so3().log().norm() * 180.0 / std::numbers::pi; }

// One configuration's accumulators.
struct RunState {
  StereoOdometryRun run;
  double fill_sum = 0.0;
  double points_sum = 0.0;
  int tracked = 0;

  void add(std::size_t k, TimeNs t_ns, const odometry::TrackResult& r, double fill) {
    run.estimate.push_back({t_ns, r.T_world_cam});
    ++run.frames;
    fill_sum += fill;
    if (k > 0) {
      points_sum += r.points;
      ++tracked;
    }
    run.keyframes += r.new_keyframe ? 1 : 0;
    if (!r.ok()) {
      ++run.failures;
      if (run.first_failure.empty()) {
        run.first_failure = "frame " + std::to_string(k) + ": " +
                            std::string(to_string(r.failure)) + ": " + r.failure_detail;
      }
    }
  }

  void finish(const Trajectory& gt) {
    run.mean_fill = run.frames > 0 ? fill_sum / run.frames : 0.0;
    run.mean_points = tracked > 0 ? points_sum / tracked : 0.0;
    const SE3 T_err = gt.back().T_world_body.inverse() * run.estimate.back().T_world_body;
    run.final_error_m =
        (gt.back().T_world_body.translation() - run.estimate.back().T_world_body.translation())
            .norm();
    run.final_error_deg = angle_deg(T_err);
    for (std::size_t i = 1; i < gt.size(); ++i) {
      run.path_length_m +=
          (gt[i].T_world_body.translation() - gt[i - 1].T_world_body.translation()).norm();
    }
    try {
      const eval::EvaluationOptions eo;
      run.ate = eval::compute_ate(gt, run.estimate, eo);
      run.rpe = eval::compute_rpe(gt, run.estimate, eo);
      run.evaluated = true;
    } catch (const InputError&) {
      run.evaluated = false;  // too short for a 1 s RPE window: the final error still stands
    }
  }
};

}  // namespace

StereoOdometryExperimentResult run_stereo_odometry_experiment(
    const StereoOdometryExperimentOptions& o) {
  o.validate();
  const RectifiedStereo rig = RectifiedStereo::centred(o.width, o.height, o.f_px, o.baseline_m);
  rig.validate();

  const sim::Scene scene = sim::make_scene(o.scene, o.seed);
  const sim::SmoothTrajectory trajectory =
      sim::make_trajectory(o.trajectory, scene.T_world_start(), o.seed);
  const SE3 T_body_cam = sim::forward_camera_mount();
  const cv::Mat pattern = sensor::generate_pattern(o.pattern, o.seed);
  sim::RenderOptions render;
  render.noise.intensity_sigma = o.intensity_sigma;
  const sim::FrameClock clock = sim::FrameClock::from_rate(o.rate_hz);

  std::unique_ptr<sim::SequenceWriter> passive_writer, active_writer;
  if (!o.write_sequences_to.empty()) {
    sim::SequenceLayout layout;
    layout.camera = rig.left();
    layout.T_body_cam = T_body_cam;
    layout.rate_hz = o.rate_hz;
    layout.stereo = rig;
    passive_writer =
        std::make_unique<sim::SequenceWriter>(o.write_sequences_to / "passive", layout, o.force);
    active_writer =
        std::make_unique<sim::SequenceWriter>(o.write_sequences_to / "active", layout, o.force);
  }

  odometry::StereoOdometry passive(rig, o.matcher, o.tracker);
  odometry::StereoOdometry active(rig, o.matcher, o.tracker);
  odometry::DirectTracker active_depth(rig, o.tracker);  // active disparity, passive intensity

  RunState rp, ra, rd;
  rp.run.name = "passive";
  rp.run.description = "scene lights only; disparity and tracking from the passive pair";
  ra.run.name = std::string("active-") + sim::projector_mode_name(o.active_mode);
  ra.run.description =
      "disparity and tracking from the pattern-lit pair (the pattern moves "
      "with the rig)";
  rd.run.name = "active-depth";
  rd.run.description =
      "disparity from the pattern-lit pair, tracking on the passive left view "
      "(pattern invisible to the intensity camera: infrared or strobed)";

  StereoOdometryExperimentResult result;
  SE3 T_left0_world;
  for (int k = 0; k < o.frames; ++k) {
    if (o.stop != nullptr && o.stop->load()) {
      result.stopped = true;
      break;
    }
    const TimeNs t_ns = clock.time_ns(static_cast<std::size_t>(k));
    const sim::KinematicState state = trajectory.state(clock.trajectory_time_s(t_ns));
    const SE3 T_world_left = state.T_world_body * T_body_cam;
    if (k == 0) T_left0_world = T_world_left.inverse();
    result.groundtruth.push_back({t_ns, T_left0_world * T_world_left});

    const std::uint64_t noise_seed = o.seed * 1'000'003ULL + 2ULL * static_cast<std::uint64_t>(k);
    const sim::StereoFrame p =
        sim::render_active_stereo(scene, rig, T_world_left, pattern, sim::ProjectorMode::kOff,
                                  o.projector, render, noise_seed + 1);
    const sim::StereoFrame a = sim::render_active_stereo(
        scene, rig, T_world_left, pattern, o.active_mode, o.projector, render, noise_seed + 2);

    const odometry::StereoTrackResult r_p =
        passive.track(t_ns, p.left.color_bgr, p.right.color_bgr);
    rp.add(static_cast<std::size_t>(k), t_ns, r_p.track, r_p.match.fill_rate());
    const odometry::StereoTrackResult r_a = active.track(t_ns, a.left.color_bgr, a.right.color_bgr);
    ra.add(static_cast<std::size_t>(k), t_ns, r_a.track, r_a.match.fill_rate());
    const odometry::TrackResult r_d =
        active_depth.track(odometry::DisparityFrame{t_ns, p.left.color_bgr, active.disparity()});
    rd.add(static_cast<std::size_t>(k), t_ns, r_d, r_a.match.fill_rate());

    if (passive_writer) {
      passive_writer->write(t_ns, state, p);
      active_writer->write(t_ns, state, a);
    }
  }
  if (passive_writer) {
    passive_writer->finish();
    active_writer->finish();
  }
  if (result.groundtruth.empty()) return result;  // stopped before the first frame
  for (RunState* s : {&rp, &ra, &rd}) {
    s->finish(result.groundtruth);
    result.runs.push_back(std::move(s->run));
  }
  return result;
}

std::string format_stereo_odometry_result(const StereoOdometryExperimentResult& result) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(4);
  for (const StereoOdometryRun& r : result.runs) {
    os << r.name << ": " << r.failures << " failures of " << r.frames - 1 << " tracked frames, "
       << r.keyframes << " keyframes, fill " << std::setprecision(1) << 100.0 * r.mean_fill
       << " %, points " << std::setprecision(0) << r.mean_points << std::setprecision(4);
    if (r.evaluated) {
      os << ", ATE rmse " << r.ate.stats_m.rmse << " m, RPE " << r.rpe.trans_rmse_m_s() << " m/s "
         << r.rpe.rot_rmse_deg_s() << " deg/s";
    } else {
      os << ", ATE/RPE n/a (too short)";
    }
    os << ", final error " << r.final_error_m << " m " << r.final_error_deg << " deg over "
       << r.path_length_m << " m\n";
    os << "  (" << r.description << ")\n";
    if (!r.first_failure.empty()) os << "  first failure: " << r.first_failure << "\n";
  }
  return os.str();
}

}  // namespace kestrel::lab
