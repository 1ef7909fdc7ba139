// Options of the direct RGB-D tracker (thesis 3.5-3.10 and its future work), in groups, with
// the defaults; loadable from YAML (one map per group, under `tracker:`) and printable, so that
// every run logs what it used. config/tracker_default.yaml lists them all; docs/odometry.md
// ("Options") has the measurements behind the defaults.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "kestrel/image/pyramid.hpp"

namespace kestrel::odometry {

/// When the point-to-plane residual (Kerl et al., "Dense visual SLAM for RGB-D cameras", IROS
/// 2013) joins the photometric one.
enum class GeometricTerm : std::uint8_t {
  kOff,       ///< never: photometric alignment alone
  kFallback,  ///< only for the pairs the photometric alignment cannot settle (FallbackOptions)
  /// on every pair, jointly with the photometric residual, judged by the fallback's health
  /// checks; frames the photometric data alone would have sent to the fallback take its policy
  kAlways,
};
std::string_view to_string(GeometricTerm term);
/// "off", "fallback" or "always"; throws std::invalid_argument otherwise (options-table hook,
/// io/option_fields.hpp).
void parse_option(std::string_view name, GeometricTerm& term);

/// Image and depth pyramids (thesis 3.10).
struct PyramidOptions {
  int levels = 5;        ///< levels incl. full resolution; each half the previous
  int finest_level = 0;  ///< the last level iterated on (0 = full resolution)
  /// Smoothing before each halving: a 2x2 box, or a 5x5 Gaussian first.
  image::PyramidFilter filter = image::PyramidFilter::kBox;
  /// Depth pyramid: depths of a 2x2 block farther than this fraction behind the block's
  /// nearest depth belong to another surface and are not averaged in.
  double depth_max_relative_spread = 0.03;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("levels", levels);
    v("finest_level", finest_level);
    v("filter", filter);
    v("depth_max_relative_spread", depth_max_relative_spread);
  }
};

/// Which reference pixels become points (depth range: thesis 5.2 future work).
struct SelectionOptions {
  double min_depth_m = 0.2;  ///< reference points nearer than this are dropped
  /// ... and farther than this (Kinect depth noise grows as Z^2; .inf: no far limit, as depth
  /// from a stereo head is used, stereo_head_tracker_options()).
  double max_depth_m = 6.0;
  /// Reference pixels need at least this gradient magnitude (intensity in [0, 1] per pixel).
  double min_gradient = 0.004;
  /// At most this many points per level, the ones of largest gradient (0 = no limit).
  int max_points = 6000;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("min_depth_m", min_depth_m);
    v("max_depth_m", max_depth_m);
    v("min_gradient", min_gradient);
    v("max_points", max_points);
  }
};

/// Robust weights: Tukey bi-weight on residuals scaled by their MAD sigma (thesis 3.8, 3.10).
struct RobustOptions {
  double tukey_c = 4.6851;            ///< cut-off in units of sigma (95 % efficiency)
  double sigma_freeze_change = 1e-6;  ///< sigma is frozen once it changes by less than this
  /// Floor of the photometric sigma (intensity units): below half an 8-bit grey level the MAD
  /// estimates quantisation, not noise.
  double min_sigma = 0.5 / 255.0;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("tukey_c", tukey_c);
    v("sigma_freeze_change", sigma_freeze_change);
    v("min_sigma", min_sigma);
  }
};

/// The model's parameters and residuals beyond the photometric one.
struct TermsOptions {
  /// Global gain and bias of the current image (thesis 3.9): 8 parameters instead of 6.
  bool gain_bias = true;
  /// The point-to-plane residual: the distance of each reference point to the current frame's
  /// depth surface at its warped pixel. Depth input only (a tracker fed by disparity has no
  /// depth maps; `always` is an error there, `fallback` never fires).
  GeometricTerm geometric = GeometricTerm::kFallback;
  /// Floor of the geometric robust sigma (m): below ~the TUM PNG's quantisation it is noise of
  /// the estimate, not of the sensor.
  double min_depth_sigma_m = 5e-4;
  /// ... nor below the sensor's depth noise sigma_z = depth_noise_per_m * z^2 at the level's
  /// median depth z: Kinect v1's 1.425e-3 /m (Khoshelham & Elberink, "Accuracy and resolution
  /// of Kinect depth data", Sensors 2012). As the noise grows as z^2, each point-to-plane
  /// residual is also scaled by (median z / z)^2 (ReferenceLevel::depth_noise_scale). 0 = no
  /// such floor and no such scale.
  double depth_noise_per_m = 1.425e-3;
  /// A depth sample of the current frame is used only if its 2x2 neighbourhood spreads less
  /// than this fraction of its depth (no interpolation across occlusion boundaries); also the
  /// normals' neighbourhood.
  double depth_max_relative_spread = 0.05;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("gain_bias", gain_bias);
    v("geometric", geometric);
    v("min_depth_sigma_m", min_depth_sigma_m);
    v("depth_noise_per_m", depth_noise_per_m);
    v("depth_max_relative_spread", depth_max_relative_spread);
  }
};

/// Gauss-Newton per level, coarse to fine (thesis 3.10).
struct SolverOptions {
  /// A level ends when a step moves the points by less than this, in pixels of that level
  /// (rotation f |dw| plus translation f |dv| / median depth): a hundredth of a pixel is far
  /// below what the images resolve, and the same on every level, unlike a bound on the twist.
  double step_tolerance_px = 0.01;
  /// ... or when the step's size changes by less than this from one iteration to the next (it
  /// oscillates at the noise floor), in the same pixels.
  double step_change_tolerance_px = 1e-4;
  int max_iterations_finest = 300;  ///< on level 0
  int max_iterations_coarse = 50;   ///< on every other level
  /// A step that raises the robust cost (at the sigma it was computed with) is undone and ends
  /// the level: Gauss-Newton has reached the noise floor.
  bool stop_on_cost_increase = true;
  /// Sample the current image bicubically (Catmull-Rom) on the finest level; the coarser levels
  /// are sampled bilinearly. Bilinear sampling's derivative jumps at integer pixel positions,
  /// where a still or hovering camera's points land, and the level there ends at the kink short
  /// of the noise floor; the C1 bicubic cost has none. The rolling-shutter rectifier resamples
  /// with the matching kernel (image::Interpolation).
  bool bicubic_finest_level = true;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("step_tolerance_px", step_tolerance_px);
    v("step_change_tolerance_px", step_change_tolerance_px);
    v("max_iterations_finest", max_iterations_finest);
    v("max_iterations_coarse", max_iterations_coarse);
    v("stop_on_cost_increase", stop_on_cost_increase);
    v("bicubic_finest_level", bicubic_finest_level);
  }
};

/// Motion prior and keyframes (thesis 5.2 future work).
struct KeyframeOptions {
  bool constant_velocity_prior = true;  ///< initial guess: the last motion, scaled by dt
  /// Align to a keyframe (true) or always to the previous frame (false).
  bool enabled = true;
  /// A new keyframe is taken after a frame whose overlap (fraction of the keyframe's points
  /// that land inside it) falls below this, ...
  double min_overlap = 0.8;
  double max_rotation_deg = 5.0;      ///< ... or that is rotated by more, ...
  double max_translation_rel = 0.05;  ///< ... or moved by more x median depth.

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("constant_velocity_prior", constant_velocity_prior);
    v("enabled", enabled);
    v("min_overlap", min_overlap);
    v("max_rotation_deg", max_rotation_deg);
    v("max_translation_rel", max_translation_rel);
  }
};

/// The geometric fallback (TermsOptions::geometric = fallback) for motion blur: depth blurs far
/// less than the colour image. When the photometric alignment fails with a high residual, or a
/// finer pyramid level moves the estimate farther than max_level_jump_px from the coarser
/// level's, the pair is aligned again with the point-to-plane residual joining the photometric
/// one. That result is accepted only by its own health checks: overlap, motion, the geometric
/// inlier ratio and point count, and the photometric sigma on the finest level where it passes
/// max_sigma (a blurred image agrees with the keyframe at the scales the blur left); a pair
/// without overlap, or whose images do not match on any level, still fails. A frame that
/// matches only on a coarser level (blurred) becomes the keyframe: the next frames, blurred
/// alike, align better to it. TrackResult::geometric_fallback marks it.
struct FallbackOptions {
  /// The fallback's rotation from the previous frame: for a frame the fallback tracked (to its
  /// keyframe), the previous frame, blurred alike in a fast motion, is aligned to this frame as
  /// the reference (its own gradients, points and normals, as OpenCV's RgbdICPOdometry takes the
  /// current frame's) with the same joint residual and checks. That rotation replaces the
  /// keyframe alignment's; the translation, which drifts less against the keyframe, is kept, and
  /// so is the keyframe. Costs some time per fallback frame.
  bool rotation_from_previous_frame = true;
  /// ... iterated from this pyramid level down to the finest level (it starts from the keyframe
  /// fallback's estimate, a fraction of a pixel off there, so the coarsest levels add time, not
  /// accuracy).
  int rotation_coarsest_level = 2;
  /// A level's estimate farther than this from the coarser level's (in pixels of the coarser
  /// level: rotation f*|w| plus translation f*|t|/median depth) triggers the fallback.
  double max_level_jump_px = 2.0;

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("rotation_from_previous_frame", rotation_from_previous_frame);
    v("rotation_coarsest_level", rotation_coarsest_level);
    v("max_level_jump_px", max_level_jump_px);
  }
};

/// Failure detection: a frame failing these is reported as a failure, never as a pose.
struct HealthOptions {
  double min_overlap = 0.3;        ///< fewer of the points inside the image: failure
  double min_inlier_ratio = 0.3;   ///< fewer points with |r| < c sigma: failure
  double max_sigma = 0.1;          ///< larger final robust sigma (intensity units): failure
  int min_points = 100;            ///< fewer usable points on a level: failure
  double max_translation_m = 0.5;  ///< larger motion to the reference: failure
  double max_rotation_deg = 45.0;  ///< ditto

  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("min_overlap", min_overlap);
    v("min_inlier_ratio", min_inlier_ratio);
    v("max_sigma", max_sigma);
    v("min_points", min_points);
    v("max_translation_m", max_translation_m);
    v("max_rotation_deg", max_rotation_deg);
  }
};

struct DirectTrackerOptions {
  PyramidOptions pyramid;
  SelectionOptions selection;
  RobustOptions robust;
  TermsOptions terms;
  SolverOptions solver;
  KeyframeOptions keyframes;
  FallbackOptions fallback;
  HealthOptions health;

  /// Throws InputError naming the first invalid field ("group.field").
  void validate() const;
  /// Every field, one YAML map per group (valid YAML, loadable by from_yaml()).
  [[nodiscard]] std::string to_yaml() const;
  /// Fields present in `node` override `base` (the defaults unless given); unknown keys are
  /// errors (typos, and the flat keys of earlier versions). `source` names the file in messages.
  static DirectTrackerOptions from_yaml(const YAML::Node& node, const std::string& source,
                                        const DirectTrackerOptions& base = {});
  /// Loads a file: the options may be at the top level or under a `tracker:` key.
  static DirectTrackerOptions load(const std::filesystem::path& path,
                                   const DirectTrackerOptions& base = {});
  /// The field table (name, member) that print and load derive from (io/option_fields.hpp).
  template <typename Visitor>
  void visit_fields(Visitor&& v) {
    v("pyramid", pyramid);
    v("selection", selection);
    v("robust", robust);
    v("terms", terms);
    v("solver", solver);
    v("keyframes", keyframes);
    v("fallback", fallback);
    v("health", health);
  }
};

/// The tracker on depth from a stereo pair (`kestrel fly`, `kestrel run`, `kestrel odometry
/// --stereo`, the ROS node in stereo mode): DirectTrackerOptions' defaults, which were chosen on
/// Kinect-like RGB-D and cut its depth at 6 m where that sensor's noise has grown with Z^2,
/// without the far limit: every depth the stereo matcher gives is used, its own checks having
/// refused what it cannot match. Far points hold the rotation, and down a corridor the
/// structure along its axis (docs/flight.md, "The corridor's far half").
[[nodiscard]] DirectTrackerOptions stereo_head_tracker_options();

}  // namespace kestrel::odometry
