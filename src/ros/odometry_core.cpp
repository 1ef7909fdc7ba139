// OdometryCore: the ROS-free side of the ROS adapter (C++20). Runs the DirectTracker (RGB-D)
// or StereoOdometry, turns each result into the ROS conventions (pose covariance about the
// odometry frame's axes, body twist) and feeds the FusionEngine as `kestrel run` does.
#include "kestrel/ros/odometry_core.hpp"

#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/core/stopwatch.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "kestrel/sensor/stereo_front_end.hpp"
#include "kestrel/sensor/stereo_matcher.hpp"

namespace kestrel::ros {
namespace fs = std::filesystem;

namespace {

PinholeCamera to_pinhole(const CameraModel& c) {
  PinholeIntrinsics k;
  k.fx = c.fx;
  k.fy = c.fy;
  k.cx = c.cx;
  k.cy = c.cy;
  k.width = c.width;
  k.height = c.height;
  RadTanDistortion d;
  d.k1 = c.distortion[0];
  d.k2 = c.distortion[1];
  d.p1 = c.distortion[2];
  d.p2 = c.distortion[3];
  d.k3 = c.distortion[4];
  return PinholeCamera(k, d);  // throws std::invalid_argument
}

CameraModel from_pinhole(const PinholeCamera& p) {
  CameraModel c;
  c.width = p.width();
  c.height = p.height();
  c.fx = p.fx();
  c.fy = p.fy();
  c.cx = p.cx();
  c.cy = p.cy();
  const RadTanDistortion& d = p.distortion();
  c.distortion = {d.k1, d.k2, d.p1, d.p2, d.k3};
  return c;
}

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

/// An EuRoC folder given as the stereo calibration: the folder holding mav0/, or mav0 itself.
std::optional<fs::path> euroc_mav0(const std::string& calibration) {
  const fs::path p(calibration);
  if (!fs::is_directory(p)) return std::nullopt;
  if (fs::exists(p / "mav0" / "cam0" / "sensor.yaml")) return p / "mav0";
  if (fs::exists(p / "cam0" / "sensor.yaml")) return p;
  throw InputError(calibration +
                   ": a folder given as stereo calibration must be an EuRoC folder "
                   "(mav0/cam0/sensor.yaml and mav0/cam1/sensor.yaml)");
}

}  // namespace

CameraModel load_camera_model(const std::string& preset_or_path) {
  return from_pinhole(io::load_camera(preset_or_path));
}

std::string check_camera_model(const CameraModel& camera) {
  try {
    (void)to_pinhole(camera);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return {};
}

std::string describe(const CameraModel& camera) {
  try {
    return to_pinhole(camera).describe();
  } catch (const std::invalid_argument& e) {
    return std::string("invalid camera: ") + e.what();
  }
}

struct OdometryCore::Impl {
  /// What the covariance bookkeeping keeps of a tracked frame.
  struct FrameRecord {
    TimeNs t_ns = 0;
    SE3 T_world_cam;
    Matrix6d cov_world = Matrix6d::Zero();  ///< left perturbation [v, w] in the tracker's world
    Matrix6d cov_ref = Matrix6d::Zero();    ///< TrackResult::covariance (relative to its reference)
    TimeNs ref_t_ns = 0;
  };

  OdometryCoreOptions options;
  odometry::DirectTrackerOptions tracker_options;
  sensor::StereoFrontEndOptions front_end_options;  // stereo: the matcher's choice and options
  std::optional<CameraModel> camera;
  std::unique_ptr<odometry::DirectTracker> tracker;  // RGB-D
  std::unique_ptr<odometry::StereoOdometry> stereo;  // stereo
  std::optional<sensor::StereoCalibration> calibration;
  std::string calibration_text;
  /// Raw (left) camera <- the camera the tracker estimates (the rectified left view for
  /// stereo, the identity for RGB-D).
  SE3 T_raw_track;
  /// Output (child) frame <- raw camera (set_child_from_camera).
  SE3 T_child_raw;
  /// Outputs are the tracker's poses conjugated by T_child_track = T_child_raw * T_raw_track.
  [[nodiscard]] SE3 T_child_track() const { return T_child_raw * T_raw_track; }

  // Covariance bookkeeping.
  std::optional<FrameRecord> keyframe, previous;

  // Fusion.
  std::optional<fusion::FusionOptions> fusion_options;
  std::unique_ptr<fusion::FusionEngine> engine;
  /// The odometry's measurements for the fusion; the constructor sets its reference and scale.
  fusion::OdometryMeasurements measurements{fusion::OdometryReference::kKeyframe, 1.0};
  std::deque<io::ImuSample> held_imu;
  std::size_t imu_rejected = 0, fused_states = 0;

  std::size_t frames = 0, failures = 0, invalid = 0, keyframes = 0;

  void build_stereo();
  void build_fusion(const std::optional<fs::path>& mav0);
  OdometryOutput finish(const odometry::TrackResult& r, double ms);
  void release_imu_until(TimeNs t_ns);
  std::vector<FusedOutput> fuse(const odometry::TrackResult& r);
};

void OdometryCore::Impl::build_stereo() {
  if (options.stereo_calibration.empty()) {
    throw InputError(
        "stereo mode needs a stereo calibration (a Kestrel stereo_pair YAML or an "
        "EuRoC folder)");
  }
  const auto mav0 = euroc_mav0(options.stereo_calibration);
  if (mav0) {
    calibration = sensor::StereoCalibration::from_euroc_files(*mav0 / "cam0" / "sensor.yaml",
                                                              *mav0 / "cam1" / "sensor.yaml");
  } else {
    calibration = sensor::load_stereo_calibration(options.stereo_calibration);
  }
  stereo =
      std::make_unique<odometry::StereoOdometry>(*calibration, front_end_options, tracker_options);
  T_raw_track = SE3(SO3::from_matrix(stereo->R_rect_left().transpose()), Eigen::Vector3d::Zero());
  camera = from_pinhole(calibration->left);
  calibration_text = calibration->describe();
  build_fusion(mav0);
}

void OdometryCore::Impl::build_fusion(const std::optional<fs::path>& mav0) {
  if (!options.use_imu) return;
  fusion::FusionOptions f = options.fusion_options_file.empty()
                                ? fusion::FusionOptions{}
                                : fusion::FusionOptions::load_yaml(options.fusion_options_file);
  if (!options.imu_noise_file.empty()) {
    f.set_imu_noise(io::load_imu_noise(options.imu_noise_file));
  } else if (mav0 && fs::exists(*mav0 / "imu0" / "sensor.yaml")) {
    f.set_imu_noise(io::load_imu_noise(*mav0 / "imu0" / "sensor.yaml"));
  } else if (options.fusion_options_file.empty()) {
    throw InputError(
        "IMU fusion needs the IMU's noise model: an imu_noise file (EuRoC "
        "imu0/sensor.yaml layout) or a fusion_options file with its densities");
  }
  SE3 T_body_raw;
  if (options.T_body_cam) {
    T_body_raw = SE3::from_matrix(*options.T_body_cam);
  } else if (mav0) {
    const io::CameraFile cam0 = io::load_camera_file(*mav0 / "cam0" / "sensor.yaml");
    if (!cam0.T_body_sensor) {
      throw InputError(*mav0 / "cam0" / "sensor.yaml", "T_BS",
                       "missing (camera-to-body extrinsics, needed by the fusion)");
    }
    T_body_raw = *cam0.T_body_sensor;
  }
  // The tracker's poses are of T_raw_track's camera: T_body_cam = T_body_raw * T_raw_track.
  f.T_body_cam = T_body_raw * T_raw_track;
  f.reorder_window_s = 0.0;  // inputs are put in time order here (held IMU samples)
  f.validate();
  fusion_options = f;
  engine = std::make_unique<fusion::FusionEngine>(f);
}

OdometryCore::OdometryCore(const OdometryCoreOptions& options,
                           const std::optional<CameraModel>& camera)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.options = options;
  if (!(options.vo_covariance_scale > 0.0)) {
    throw InputError("vo_covariance_scale must be positive");
  }
  if (!(options.max_imu_hold_s > 0.0)) throw InputError("max_imu_hold_s must be positive");
  m.measurements = fusion::OdometryMeasurements(options.vo_from_keyframe
                                                    ? fusion::OdometryReference::kKeyframe
                                                    : fusion::OdometryReference::kPreviousFrame,
                                                options.vo_covariance_scale);
  // Depth from a stereo pair: the stereo head's defaults (no far depth limit); RGB-D: the
  // library's. A tracker_options file overrides either.
  const odometry::DirectTrackerOptions tracker_base = options.mode == OdometryMode::kStereo
                                                          ? odometry::stereo_head_tracker_options()
                                                          : odometry::DirectTrackerOptions{};
  m.tracker_options =
      options.tracker_options_file.empty()
          ? tracker_base
          : odometry::DirectTrackerOptions::load(options.tracker_options_file, tracker_base);
  m.tracker_options.validate();
  if (options.mode == OdometryMode::kStereo) {
    sensor::MatcherSelection selection{std::nullopt, options.matcher_options_file,
                                       options.sgm_options_file};
    if (!options.matcher.empty()) {
      selection.kind = sensor::StereoMatcherKind{};
      try {
        sensor::parse_option(options.matcher, *selection.kind);
      } catch (const std::invalid_argument& e) {
        throw InputError(std::string("parameter ~matcher: ") + e.what());
      }
    }
    sensor::apply_matcher_selection(selection, "parameters", m.front_end_options,
                                    {"~matcher", "~matcher_options", "~sgm_options"});
    m.build_stereo();
  } else {
    if (camera) set_camera(*camera);
    m.build_fusion(std::nullopt);
  }
}

OdometryCore::~OdometryCore() = default;

const OdometryCoreOptions& OdometryCore::options() const { return impl_->options; }

bool OdometryCore::has_camera() const {
  return impl_->tracker != nullptr || impl_->stereo != nullptr;
}

std::optional<CameraModel> OdometryCore::camera() const { return impl_->camera; }

void OdometryCore::set_camera(const CameraModel& camera) {
  if (impl_->options.mode == OdometryMode::kStereo) {
    throw std::invalid_argument("set_camera: stereo mode takes its cameras from the calibration");
  }
  const PinholeCamera pinhole = to_pinhole(camera);
  impl_->tracker = std::make_unique<odometry::DirectTracker>(pinhole, impl_->tracker_options);
  impl_->camera = camera;
  reset();
}

void OdometryCore::set_child_from_camera(const Eigen::Matrix4d& T_child_cam) {
  impl_->T_child_raw = SE3::from_matrix(T_child_cam);
}

void OdometryCore::reset() {
  Impl& m = *impl_;
  if (m.tracker) m.tracker->reset();
  if (m.stereo && m.calibration) {
    m.stereo = std::make_unique<odometry::StereoOdometry>(*m.calibration, m.front_end_options,
                                                          m.tracker_options);
  }
  m.keyframe.reset();
  m.previous.reset();
  m.held_imu.clear();
  m.measurements.reset();
  if (m.fusion_options) m.engine = std::make_unique<fusion::FusionEngine>(*m.fusion_options);
}

OdometryOutput OdometryCore::track_rgbd(std::int64_t t_ns, const cv::Mat& image,
                                        const cv::Mat& depth_m) {
  Impl& m = *impl_;
  if (!m.tracker) {
    OdometryOutput out;
    out.t_ns = t_ns;
    out.invalid_input = true;
    out.failure = m.options.mode == OdometryMode::kStereo
                      ? "invalid input: an RGB-D frame given to the stereo odometry"
                      : "invalid input: no camera model yet (camera_info or camera parameter)";
    ++m.invalid;
    return out;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const odometry::TrackResult r = m.tracker->track(odometry::RgbdFrame{t_ns, image, depth_m});
  return m.finish(r, ms_since(t0));
}

OdometryOutput OdometryCore::track_stereo(std::int64_t t_ns, const cv::Mat& left,
                                          const cv::Mat& right) {
  Impl& m = *impl_;
  if (!m.stereo) {
    OdometryOutput out;
    out.t_ns = t_ns;
    out.invalid_input = true;
    out.failure = "invalid input: a stereo pair given to the RGB-D odometry";
    ++m.invalid;
    return out;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const odometry::StereoTrackResult r = m.stereo->track(t_ns, left, right);
  OdometryOutput out = m.finish(r.track, ms_since(t0));
  out.disparity_fill = r.match.fill_rate();
  return out;
}

OdometryOutput OdometryCore::Impl::finish(const odometry::TrackResult& r, double ms) {
  OdometryOutput out;
  out.t_ns = r.t_ns;
  out.processing_ms = ms;
  out.iterations = r.iterations;
  out.sigma = r.sigma;
  out.inlier_ratio = r.inlier_ratio;
  if (r.failure == odometry::TrackFailure::kInvalidInput) {
    // Nothing was tracked (wrong size or type): the frame is dropped, the state untouched.
    out.invalid_input = true;
    out.failure = std::string(odometry::to_string(r.failure)) + ": " + r.failure_detail;
    ++invalid;
    return out;
  }
  ++frames;
  const SE3 C = T_child_track();
  const SE3 T_odom_child = C * r.T_world_cam * C.inverse();
  out.T_odom_child = T_odom_child.matrix();
  out.ok = r.ok();
  if (!r.ok()) {
    ++failures;
    out.failure = std::string(odometry::to_string(r.failure)) + ": " + r.failure_detail;
    out.fused = fuse(r);
    return out;
  }
  out.new_keyframe = r.new_keyframe;
  keyframes += r.new_keyframe ? 1 : 0;

  // Pose covariance. T_world_cur = T_world_ref exp(xi) T_ref_cur = exp(Ad(T_world_ref) xi) ...,
  // so the world-frame left perturbation adds Ad Sigma Ad^T to the reference's own.
  FrameRecord cur;
  cur.t_ns = r.t_ns;
  cur.T_world_cam = r.T_world_cam;
  cur.cov_ref = r.covariance;
  cur.ref_t_ns = r.ref_t_ns;
  if (keyframe || previous) {
    const SE3 T_world_ref = r.T_world_cam * r.T_ref_cur.inverse();
    Matrix6d cov_ref_world = Matrix6d::Zero();
    if (keyframe && keyframe->t_ns == r.ref_t_ns) {
      cov_ref_world = keyframe->cov_world;
    } else if (previous) {
      cov_ref_world = previous->cov_world;  // retried on the previous frame (or unknown ref)
    }
    const Matrix6d Ad = T_world_ref.adjoint();
    cur.cov_world = cov_ref_world + Ad * r.covariance * Ad.transpose();
  }  // else: the first frame defines the world: zero covariance.

  // Into the child's odometry frame (exp(d) T -> C exp(d) T C^-1 = exp(Ad_C d) C T C^-1), then
  // ROS's [dp, dtheta] about the odometry axes: p = exp(d) p_hat = p_hat + v + w x p_hat.
  const Matrix6d Ad_C = C.adjoint();
  Matrix6d J = Matrix6d::Identity();
  J.block<3, 3>(0, 3) = -skew(T_odom_child.translation());
  out.pose_covariance = J * Ad_C * cur.cov_world * Ad_C.transpose() * J.transpose();

  // Twist of the camera in its own frame from the previous tracked frame (constant body
  // velocity over the interval); its covariance approximates the relative motion's from the
  // two frames' covariances to their reference, as a right perturbation of the current frame.
  if (previous && r.t_ns > previous->t_ns) {
    const double dt = static_cast<double>(r.t_ns - previous->t_ns) * 1e-9;
    const SE3 T_prev_cur = previous->T_world_cam.inverse() * r.T_world_cam;
    const Vector6d xi_track = T_prev_cur.log() / dt;
    Matrix6d cov_rel = r.covariance;
    if (previous->ref_t_ns == r.ref_t_ns && previous->t_ns != r.ref_t_ns) {
      cov_rel += previous->cov_ref;
    }
    const Matrix6d Ad_cur_ref = r.T_ref_cur.inverse().adjoint();
    const Matrix6d cov_twist_track = Ad_cur_ref * cov_rel * Ad_cur_ref.transpose() / (dt * dt);
    // A body twist of the child frame: (C T C^-1)^-1 d/dt (C T C^-1) = C xi^ C^-1 -> Ad_C xi.
    out.has_twist = true;
    out.twist = Ad_C * xi_track;
    out.twist_covariance = Ad_C * cov_twist_track * Ad_C.transpose();
  }
  if (r.new_keyframe) keyframe = cur;
  previous = cur;
  out.fused = fuse(r);
  return out;
}

void OdometryCore::Impl::release_imu_until(TimeNs t_ns) {
  while (!held_imu.empty() && held_imu.front().t_ns <= t_ns) {
    engine->add_imu(held_imu.front());
    held_imu.pop_front();
  }
}

std::vector<FusedOutput> OdometryCore::Impl::fuse(const odometry::TrackResult& r) {
  std::vector<FusedOutput> out;
  if (!engine) return out;
  release_imu_until(r.t_ns);
  // As `kestrel run`'s tracker stage.
  if (const auto m = measurements.next(r)) engine->add_relative_pose(*m);
  for (const fusion::FusedState& s : engine->poll(/*imu_rate=*/false)) {
    FusedOutput f;
    f.t_ns = s.t_ns;
    f.p_world = s.state.p_world;
    f.q_world_body = s.state.q_world_body;
    f.v_world = s.state.v_world;
    f.gyro_bias_rad_s = s.state.gyro_bias_rad_s;
    f.accel_bias_m_s2 = s.state.accel_bias_m_s2;
    f.sigma = s.sigma;
    f.flags = s.flags;
    f.flags_text = fusion::describe_flags(s.flags);
    out.push_back(std::move(f));
  }
  fused_states += out.size();
  return out;
}

bool OdometryCore::add_imu(std::int64_t t_ns, const Eigen::Vector3d& gyro_rad_s,
                           const Eigen::Vector3d& accel_m_s2) {
  Impl& m = *impl_;
  if (!m.engine) return false;
  if (!gyro_rad_s.allFinite() || !accel_m_s2.allFinite() ||
      (!m.held_imu.empty() && t_ns <= m.held_imu.back().t_ns)) {
    ++m.imu_rejected;
    return false;
  }
  m.held_imu.push_back(io::ImuSample{t_ns, gyro_rad_s, accel_m_s2});
  const auto hold_ns = static_cast<TimeNs>(m.options.max_imu_hold_s * 1e9);
  if (t_ns - m.held_imu.front().t_ns > hold_ns) {
    m.release_imu_until(t_ns - hold_ns);
    (void)m.engine->poll(/*imu_rate=*/false);  // no frame: states only at odometry times
  }
  return true;
}

std::string OdometryCore::describe() const {
  const Impl& m = *impl_;
  std::ostringstream os;
  os << "mode: " << (m.options.mode == OdometryMode::kStereo ? "stereo" : "rgbd") << "\n";
  if (m.camera) os << "camera: " << ros::describe(*m.camera) << "\n";
  if (!m.calibration_text.empty()) os << "stereo calibration: " << m.calibration_text << "\n";
  if (m.stereo) os << "matcher: " << m.stereo->front_end().matcher().describe() << "\n";
  os << "tracker options"
     << (m.options.tracker_options_file.empty() ? " (defaults)"
                                                : " from " + m.options.tracker_options_file)
     << ":\n";
  std::istringstream lines(m.tracker_options.to_yaml());
  for (std::string line; std::getline(lines, line);) os << "  " << line << "\n";
  if (m.fusion_options) {
    os << "fusion: " << m.fusion_options->describe()
       << " vo_covariance_scale=" << m.options.vo_covariance_scale
       << " vo_from_keyframe=" << (m.options.vo_from_keyframe ? "true" : "false") << "\n";
  } else {
    os << "fusion: off\n";
  }
  return os.str();
}

std::string OdometryCore::statistics() const {
  const Impl& m = *impl_;
  std::ostringstream os;
  os << "frames=" << m.frames << " failures=" << m.failures << " invalid=" << m.invalid
     << " keyframes=" << m.keyframes;
  if (m.engine) {
    os << " fused_states=" << m.fused_states << " imu_rejected=" << m.imu_rejected
       << " fusion: " << m.engine->counters().describe();
  }
  return os.str();
}

}  // namespace kestrel::ros
