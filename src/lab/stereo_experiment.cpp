// The thesis' fig. 2.7 experiment: the wall scene rendered passive and active, matched and
// scored (docs/stereo.md).
#include "kestrel/lab/stereo_experiment.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::lab {

std::string StereoExperimentOptions::describe() const {
  std::ostringstream os;
  os << "cameras " << width << "x" << height << ", f " << f_px << " px, baseline " << baseline_m
     << " m, intensity noise sigma " << intensity_sigma << ", active mode "
     << sim::projector_mode_name(active_mode) << ", seed " << seed << "\n  " << projector.describe()
     << "\n  pattern: " << pattern.describe() << "\n  matcher: " << matcher.describe();
  return os.str();
}

namespace {

StereoExperimentRun match_and_score(std::string name, sim::StereoFrame frame,
                                    sensor::BlockMatcher& matcher, const cv::Mat& covisible,
                                    const cv::Mat& lit, double bad_threshold_px) {
  StereoExperimentRun run;
  run.name = std::move(name);
  run.frame = std::move(frame);
  run.stats = matcher.match(run.frame.left.color_bgr, run.frame.right.color_bgr, run.disparity_px);
  run.score =
      score_disparity(run.disparity_px, run.frame.disparity_px, bad_threshold_px, covisible);
  run.score_lit = score_disparity(run.disparity_px, run.frame.disparity_px, bad_threshold_px, lit);
  return run;
}

// Covisible left pixels the projector lights: a noise-free dark-room render of an all-white
// pattern is non-zero exactly where the light reaches (its image, facing it, no shadow).
cv::Mat projector_lit_mask(const sim::Scene& scene, const RectifiedStereo& rig,
                           const SE3& T_world_left, const sim::ProjectorOptions& projector,
                           const cv::Mat& covisible) {
  const cv::Mat white(projector.height, projector.width, CV_8UC3, cv::Scalar::all(255));
  sim::ProjectorOptions sharp = projector;
  sharp.blur_sigma_px = 0.0;
  sim::RenderOptions clean;
  clean.noise = {};
  clean.noise.intensity_sigma = 0.0;
  const sim::StereoFrame f = sim::render_active_stereo(
      scene, rig, T_world_left, white, sim::ProjectorMode::kDarkRoom, sharp, clean, 1);
  cv::Mat gray;
  cv::cvtColor(f.left.color_bgr, gray, cv::COLOR_BGR2GRAY);
  cv::Mat lit = gray > 0;
  cv::bitwise_and(lit, covisible, lit);
  return lit;
}

}  // namespace

StereoExperimentResult run_stereo_experiment(const StereoExperimentOptions& options) {
  options.projector.validate();
  options.pattern.validate();
  options.matcher.validate();
  if (options.pattern.width != options.projector.width ||
      options.pattern.height != options.projector.height) {
    throw std::invalid_argument("stereo experiment: the pattern size must be the projector's");
  }
  const RectifiedStereo rig =
      RectifiedStereo::centred(options.width, options.height, options.f_px, options.baseline_m);
  rig.validate();

  const sim::Scene scene = sim::make_scene("wall", options.seed);
  const SE3 T_world_left = scene.T_world_start() * sim::forward_camera_mount();
  sim::RenderOptions render;
  render.noise.intensity_sigma = options.intensity_sigma;  // depth stays exact (the truth)

  StereoExperimentResult result;
  result.pattern = sensor::generate_pattern(options.pattern, options.seed);
  // Different noise seeds for the two renderings: independent frames, as in a real capture.
  sim::StereoFrame passive =
      sim::render_active_stereo(scene, rig, T_world_left, result.pattern, sim::ProjectorMode::kOff,
                                options.projector, render, options.seed * 2 + 1);
  sim::StereoFrame active =
      sim::render_active_stereo(scene, rig, T_world_left, result.pattern, options.active_mode,
                                options.projector, render, options.seed * 2 + 2);
  result.covisible = sim::covisible_mask(passive);
  result.lit = projector_lit_mask(scene, rig, T_world_left, options.projector, result.covisible);
  sensor::BlockMatcher matcher(options.matcher, rig);
  result.passive = match_and_score("passive", std::move(passive), matcher, result.covisible,
                                   result.lit, options.bad_threshold_px);
  result.active = match_and_score(
      std::string("active-") + sim::projector_mode_name(options.active_mode), std::move(active),
      matcher, result.covisible, result.lit, options.bad_threshold_px);
  return result;
}

}  // namespace kestrel::lab
