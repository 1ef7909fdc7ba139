// The closed loop's vision: render the active-stereo pair, match, depth, track.
#include "kestrel/flight/stereo_vision.hpp"

#include <algorithm>
#include <chrono>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <string>

#include "kestrel/core/stopwatch.hpp"

namespace kestrel::flight {
namespace {

sim::RenderOptions render_options(const StereoVisionOptions& o) {
  sim::RenderOptions r;
  r.noise.intensity_sigma = o.intensity_sigma;
  return r;
}

// Rendered pairs are rectified already; the RGB-D tracker needs metric depth.
sensor::StereoFrontEndOptions front_end_options(const StereoVisionOptions& o) {
  sensor::StereoFrontEndOptions f;
  f.matcher = o.matcher;
  f.kind = o.matcher_kind;
  f.sgm = o.sgm;
  f.compute_depth = true;
  return f;
}

}  // namespace

sim::ProjectorOptions rig_projector_options() {
  sim::ProjectorOptions p;
  // Shadow rays cost more than they add: each tests every face of the scene, and from 8 cm
  // beside the camera the projector's shadows are thin slivers, so the depth fill is the same
  // without them (docs/flight.md, "The sensor head", has the timings).
  p.shadows = false;
  return p;
}

RectifiedStereo StereoVisionOptions::rig() const {
  return RectifiedStereo::centred(width, height, f_px, baseline_m);
}

void StereoVisionOptions::validate() const {
  if (width < 32 || height < 32)
    throw std::invalid_argument("vision: width and height must be >= 32");
  if (!(f_px > 0.0)) throw std::invalid_argument("vision: f_px must be positive");
  if (!(baseline_m > 0.0)) throw std::invalid_argument("vision: baseline_m must be positive");
  if (!(intensity_sigma >= 0.0))
    throw std::invalid_argument("vision: intensity_sigma must be >= 0");
  if (!(covariance_scale > 0.0))
    throw std::invalid_argument("vision: covariance_scale must be positive");
  if (!(max_frame_gap_s > 0.0))
    throw std::invalid_argument("vision: max_frame_gap_s must be positive");
  if (!(relocalization_prior_sigmas > 0.0) || !(relocalization_prior_min_translation_m >= 0.0) ||
      !(relocalization_prior_rotation_deg > 0.0)) {
    throw std::invalid_argument(
        "vision: relocalization_prior_sigmas and _rotation_deg must be positive, "
        "_min_translation_m >= 0");
  }
  try {
    relocalizer.validate();
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("vision: ") + e.what());
  }
  rig().validate();
  matcher.validate();
  if (matcher_kind == sensor::StereoMatcherKind::kSgm) {
    sensor::SgmOptions s = sgm;  // the range the front end gives it
    s.min_disparity = matcher.min_disparity;
    s.max_disparity = matcher.max_disparity;
    s.validate();
  }
  projector.validate();
}

std::string StereoVisionOptions::describe() const {
  std::ostringstream os;
  os << width << "x" << height << " f=" << f_px << " px, baseline " << baseline_m
     << " m, projector " << sim::projector_mode_name(projector_mode) << ", noise "
     << intensity_sigma << " grey levels, "
     << (matcher_kind == sensor::StereoMatcherKind::kSgm
             ? "sgm (paths " + std::to_string(sgm.paths) + ")"
             : std::string(matcher_kind ? to_string(*matcher_kind) : to_string(matcher.cost)) +
                   " block " + std::to_string(matcher.block_size))
     << ", disparities " << matcher.min_disparity << ".." << matcher.max_disparity
     << ", odometry depth " << tracker.selection.min_depth_m << "-" << tracker.selection.max_depth_m
     << " m, covariance x" << covariance_scale << ", measurements from the "
     << fusion::odometry_reference_name(measurement_reference)
     << (relocalize_after_gap ? ", relocalised after a gap" : ", restarted after a gap");
  return os.str();
}

StereoVision::StereoVision(const sim::Scene& scene, const StereoVisionOptions& options,
                           std::uint64_t seed)
    : options_((options.validate(), options)),
      rig_(options.rig()),
      projector_(std::make_shared<sim::ProjectorLight>(
          SE3(), sensor::generate_pattern(options.pattern, seed), options.projector)),
      tracking_view_(options_.track_without_pattern &&
                     options_.projector_mode == sim::ProjectorMode::kAmbientAndPattern),
      // With a tracking view the projector is a rig light (the same light, evaluated after
      // the scene's, as the scene's last light would be): the left renderer then gives the
      // view without it in the same pass.
      lit_scene_(tracking_view_
                     ? scene
                     : sim::scene_with_projector(scene, projector_, options.projector_mode)),
      renderer_(rig_, render_options(options), seed),
      front_end_(rig_, front_end_options(options)),
      tracker_(rig_.left(), options.tracker),
      measurements_(options.measurement_reference, options.covariance_scale) {
  if (options_.relocalize_after_gap) {
    relocalizer_ = std::make_unique<odometry::Relocalizer>(rig_.left(), options_.relocalizer,
                                                           options_.tracker);
  }
  if (tracking_view_) {
    renderer_.add_rig_light(projector_);
    // The seed of the separate tracking renderer this replaces: the same noise, frame by frame.
    renderer_.reseed_left_without_rig_lights(seed + 7919);
  }
}

StereoVision::~StereoVision() = default;

namespace {

// The camera's twist in its own frame from the body's (world velocity, body rate), the camera
// at T_body_cam.
std::pair<Eigen::Vector3d, Eigen::Vector3d> camera_twist(const BodyTwist& b,
                                                         const SE3& T_world_body,
                                                         const SE3& T_body_cam) {
  const Eigen::Matrix3d R_cam_body = T_body_cam.so3().matrix().transpose();
  const Eigen::Vector3d v_body =
      T_world_body.so3().inverse() * b.v_world + b.omega_body.cross(T_body_cam.translation());
  return {R_cam_body * v_body, R_cam_body * b.omega_body};
}

}  // namespace

VisionFrame StereoVision::process(TimeNs t_ns, const SE3& T_world_body, const BodyTwist* twist,
                                  const PoseEstimate* estimate) {
  VisionFrame out;
  out.t_ns = t_ns;
  const SE3 T_world_left = T_world_body * options_.T_body_cam;
  // The projector is on the rig: it moves with the cameras (both views see the same pattern).
  projector_->set_pose(T_world_left * options_.projector.T_left_projector);

  auto start = std::chrono::steady_clock::now();
  // The tracking view is the left view without the projector: the left renderer shades it in
  // the same pass (one rasterisation, one texture lookup per pixel for both).
  renderer_.render(lit_scene_, T_world_left, frame_, tracking_view_ ? &tracking_frame_ : nullptr);
  cv::cvtColor(frame_.left.color_bgr, left_gray_, cv::COLOR_BGR2GRAY);
  cv::cvtColor(frame_.right.color_bgr, right_gray_, cv::COLOR_BGR2GRAY);
  if (tracking_view_) {
    cv::cvtColor(tracking_frame_.color_bgr, tracking_gray_, cv::COLOR_BGR2GRAY);
  } else {
    tracking_gray_ = left_gray_;
  }
  if (twist != nullptr && exposure_.active()) {
    const auto expose_start = std::chrono::steady_clock::now();
    const bool shared = tracking_gray_.data == left_gray_.data;
    const SE3 T_body_right = options_.T_body_cam * renderer_.T_left_right();
    const auto [v_left, w_left] = camera_twist(*twist, T_world_body, options_.T_body_cam);
    const auto [v_right, w_right] = camera_twist(*twist, T_world_body, T_body_right);
    const PinholeCamera left = rig_.left();
    sim::image_flow(left, frame_.left.depth_m, v_left, w_left, flow_);
    sim::expose(left_gray_, flow_, exposure_, exposed_, expose_workspace_);
    exposed_.copyTo(left_gray_);
    if (shared) {
      tracking_gray_ = left_gray_;
    } else {
      // The tracking view is the left camera: same flow (its depth is the same surface).
      sim::expose(tracking_gray_, flow_, exposure_, exposed_, expose_workspace_);
      exposed_.copyTo(tracking_gray_);
    }
    sim::image_flow(left, frame_.right.depth_m, v_right, w_right, flow_);
    sim::expose(right_gray_, flow_, exposure_, exposed_, expose_workspace_);
    exposed_.copyTo(right_gray_);
    out.expose_ms = ms_since(expose_start);
  }
  out.render_ms = ms_since(start);

  front_end_.process(t_ns, left_gray_, right_gray_, depth_);
  out.depth_fill = depth_.match.fill_rate();
  out.match_ms = depth_.rectify_ms + depth_.match_ms;

  // A long gap (odometry switched off, a stalled pipeline): the keyframe is stale and the
  // constant-velocity guess meaningless, so the tracker restarts from this frame.
  const bool gap = last_frame_ns_ && ns_to_s(t_ns - *last_frame_ns_) > options_.max_frame_gap_s;
  if (gap) {
    tracker_.reset();
    measurements_.reset();
  }
  last_frame_ns_ = t_ns;

  start = std::chrono::steady_clock::now();
  odometry::RgbdFrame frame;
  frame.t_ns = t_ns;
  frame.image = tracking_gray_;
  frame.depth_m = depth_.depth_m;
  out.track = tracker_.track(frame);
  out.measurement = measurements_.next(out.track);
  if (gap && relocalizer_ && reference_) {
    const auto relocalize_start = std::chrono::steady_clock::now();
    relocalize(frame, estimate, out);
    out.relocalization_ms = ms_since(relocalize_start);
  }
  out.track_ms = ms_since(start);
  // The filter clones this frame (or anchors the tracker's keyframe on it): the reference a
  // relocalisation after a gap would be measured against.
  if (relocalizer_ && out.measurement && out.measurement->starts_new_reference) {
    // Copied into the kept buffers: a new reference comes with every keyframe, and after the
    // first the copies allocate nothing.
    if (!reference_) reference_.emplace();
    reference_->t_ns = t_ns;
    tracking_gray_.copyTo(reference_->image);
    depth_.depth_m.copyTo(reference_->depth_m);
    reference_estimate_.reset();
    if (estimate != nullptr) reference_estimate_ = *estimate;
  }
  return out;
}

// The tracker restarted on `frame` (its measurement only clones it). A relocalisation against
// the kept reference replaces that by the motion across the gap, which the filter applies
// against its clone of the reference and then clones this frame, where the restarted tracker's
// next measurements start.
void StereoVision::relocalize(const odometry::RgbdFrame& frame, const PoseEstimate* estimate,
                              VisionFrame& out) {
  // The prior: the estimate's camera motion since the reference, within a few of its sigma.
  std::optional<odometry::RelocalizationPrior> prior;
  if (estimate != nullptr && reference_estimate_) {
    const SE3& T_bc = options_.T_body_cam;
    prior = odometry::RelocalizationPrior{
        (reference_estimate_->T_world_body * T_bc).inverse() * (estimate->T_world_body * T_bc),
        std::max(options_.relocalization_prior_min_translation_m,
                 options_.relocalization_prior_sigmas * estimate->position_sigma_m),
        options_.relocalization_prior_rotation_deg};
  }
  out.relocalization = relocalizer_->relocalize(*reference_, frame, prior ? &*prior : nullptr);
  out.relocalization_reference_ns = reference_->t_ns;
  if (!out.relocalization->ok() || !out.track.ok()) return;
  fusion::RelativePoseMeasurement m;
  m.t_ref_ns = reference_->t_ns;
  m.t_ns = frame.t_ns;
  m.T_ref_cur = out.relocalization->T_ref_cur;
  m.covariance = options_.covariance_scale * out.relocalization->covariance;
  m.starts_new_reference = true;
  out.measurement = m;
}

}  // namespace kestrel::flight
