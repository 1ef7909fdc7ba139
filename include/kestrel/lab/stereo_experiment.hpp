// The thesis' fig. 2.7 experiment: passive vs active stereo on a low-texture wall, rendered,
// block-matched and scored against the rendered truth.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "kestrel/lab/stereo_evaluation.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/pattern.hpp"
#include "kestrel/sim/projector_light.hpp"

namespace kestrel::lab {

/// The thesis' fig. 2.7 experiment: the "wall" scene (a plain low-texture wall with a box
/// before it) seen from its start pose by a rectified pair, rendered passive (the scene's
/// ambient + ceiling light) and active (the pattern), both matched by the sensor::BlockMatcher and
/// scored against the rendered truth over the pixels both cameras see.
struct StereoExperimentOptions {
  int width = 640;  ///< camera image size
  int height = 480;
  double f_px = 420.0;  ///< rectified focal length (71 x 59 deg field of view at 640x480)
  double baseline_m = 0.12;
  /// Gaussian intensity noise of both cameras, grey levels (sim SensorNoiseOptions).
  double intensity_sigma = 2.0;
  sim::ProjectorMode active_mode = sim::ProjectorMode::kDarkRoom;
  sim::ProjectorOptions projector;
  sensor::PatternOptions pattern;  ///< thesis 2.3: 200 lines at 1280x720
  sensor::BlockMatcherOptions matcher;
  std::uint64_t seed = 1;  ///< pattern, scene textures and noise
  double bad_threshold_px = 1.0;

  [[nodiscard]] std::string describe() const;
};

struct StereoExperimentRun {
  std::string name;        ///< "passive" or the projector mode
  sim::StereoFrame frame;  ///< rendered views and the true left disparity
  cv::Mat disparity_px;    ///< the matcher's left disparity (sensor::kNoDisparity where none)
  sensor::MatchStats stats;
  DisparityScore score;  ///< over the covisible pixels
  /// Over the covisible pixels the projector lights (inside its image, facing it, not in its
  /// shadow): where an active sensor can give depth at all (thesis 5: the projector's lens
  /// limits the sensor's field of view).
  DisparityScore score_lit;
  /// Share of the filled covisible pixels off by more than the threshold.
  [[nodiscard]] double bad_rate() const { return score.bad_rate_of_filled(); }
};

struct StereoExperimentResult {
  StereoExperimentRun passive;
  StereoExperimentRun active;
  cv::Mat pattern;    ///< the projected image (CV_8UC3)
  cv::Mat covisible;  ///< CV_8U mask of the scored pixels
  cv::Mat lit;        ///< CV_8U mask of the covisible pixels the projector lights
};

/// Runs the experiment. Throws std::invalid_argument for invalid options.
StereoExperimentResult run_stereo_experiment(const StereoExperimentOptions& options);

}  // namespace kestrel::lab
