// The ROS-free heart of the ROS adapter: Kestrel's odometry (RGB-D or stereo) and IMU fusion
// behind an interface of plain Eigen / OpenCV / std types. This header must compile as C++17:
// Debian's ROS 1 message headers use std::allocator<void>::rebind, which C++20 removed, so the
// ROS side of the adapter is built as C++17 and reaches Kestrel (C++20) only through here.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace kestrel::ros {

/// A pinhole camera with radial-tangential distortion (k1, k2, p1, p2, k3), as in a ROS
/// CameraInfo with the plumb_bob model.
struct CameraModel {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::array<double, 5> distortion{};  ///< k1, k2, p1, p2, k3
};

/// A preset name (fr1, fr2, fr3, ros) or a camera file (Kestrel YAML, EuRoC sensor.yaml).
/// Throws std::exception (Kestrel's InputError) naming the file and field.
CameraModel load_camera_model(const std::string& preset_or_path);
/// Checks the model as the tracker will (positive size and focal lengths, finite values);
/// returns an empty string when valid, else what is wrong.
std::string check_camera_model(const CameraModel& camera);
/// One line for logs.
std::string describe(const CameraModel& camera);

enum class OdometryMode { kRgbd, kStereo };

/// Everything the core needs besides the images. Paths may be empty (defaults).
struct OdometryCoreOptions {
  OdometryMode mode = OdometryMode::kRgbd;
  std::string tracker_options_file;  ///< DirectTrackerOptions YAML; empty: the defaults
  /// Stereo: a Kestrel `stereo_pair` YAML or an EuRoC folder (its mav0/cam0, cam1 sensor.yaml).
  std::string stereo_calibration;
  std::string matcher_options_file;  ///< stereo: BlockMatcherOptions YAML; empty: defaults
  /// Stereo: the matcher, "sad", "census" or "sgm"; empty: the block matcher with the cost of
  /// matcher_options (sad by default). The range is matcher_options' for every matcher.
  std::string matcher;
  std::string sgm_options_file;  ///< stereo, matcher "sgm": SgmOptions YAML; empty: defaults

  // --- IMU fusion (error-state EKF with stochastic cloning, docs/fusion.md) ---
  bool use_imu = false;
  /// EuRoC-style IMU sensor.yaml (noise densities, random walks). Empty with an EuRoC folder
  /// as stereo_calibration: its mav0/imu0/sensor.yaml. Required otherwise when use_imu.
  std::string imu_noise_file;
  std::string fusion_options_file;  ///< FusionOptions YAML; empty: the defaults
  /// The (raw) camera in the body (IMU) frame. Unset: the EuRoC folder's cam0 T_BS when the
  /// calibration is one, else the identity.
  std::optional<Eigen::Matrix4d> T_body_cam;
  /// Factor on the tracker's covariance before it is given to the EKF (as `kestrel run`).
  double vo_covariance_scale = 25.0;
  /// Each odometry measurement relative to the keyframe (true) or to the previous tracked
  /// frame (false), as `kestrel run`'s `vo_reference` (docs/flight.md compares them).
  bool vo_from_keyframe = true;
  /// IMU samples are held until a frame at least as late has been tracked (so the EKF sees
  /// time order); samples older than the newest one minus this are released without a frame.
  double max_imu_hold_s = 0.5;
};

/// One fused EKF state, in the gravity-aligned world of the static initialisation.
struct FusedOutput {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_world_body = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 9, 1> sigma = Eigen::Matrix<double, 9, 1>::Zero();  ///< p, theta, v
  std::uint32_t flags = 0;
  std::string flags_text;
};

/// The result of one frame. Poses are of the child frame (the raw, left camera, or the frame
/// set by set_child_from_camera) in the odometry frame: the child frame at the first frame
/// tracked.
struct OdometryOutput {
  std::int64_t t_ns = 0;
  bool ok = false;
  bool invalid_input = false;  ///< the images did not fit the camera (size, type): dropped
  std::string failure;         ///< "reason: detail" when not ok
  Eigen::Matrix4d T_odom_child = Eigen::Matrix4d::Identity();  ///< the prediction on failure
  /// ROS convention (nav_msgs/Odometry): [x, y, z, rot x, rot y, rot z], position and
  /// rotation errors about the odometry frame's fixed axes.
  Eigen::Matrix<double, 6, 6> pose_covariance = Eigen::Matrix<double, 6, 6>::Zero();
  /// Velocity of the child frame in itself, [v; w], from this and the previous tracked frame.
  bool has_twist = false;
  Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> twist_covariance = Eigen::Matrix<double, 6, 6>::Zero();
  bool new_keyframe = false;
  int iterations = 0;
  double sigma = 0.0;  ///< final robust sigma of the photometric residuals
  double inlier_ratio = 0.0;
  double processing_ms = 0.0;
  double disparity_fill = 0.0;     ///< stereo: share of pixels with a disparity
  std::vector<FusedOutput> fused;  ///< EKF states produced by this frame (use_imu)
};

class OdometryCore {
 public:
  /// RGB-D: `camera` may be unset (set_camera() later, e.g. from a CameraInfo). Stereo: the
  /// calibration comes from options.stereo_calibration. Throws std::exception (InputError)
  /// naming the file or field that is wrong.
  explicit OdometryCore(const OdometryCoreOptions& options,
                        const std::optional<CameraModel>& camera = std::nullopt);
  ~OdometryCore();
  OdometryCore(const OdometryCore&) = delete;
  OdometryCore& operator=(const OdometryCore&) = delete;

  [[nodiscard]] bool has_camera() const;
  /// RGB-D: (re)builds the tracker for this camera; the trajectory restarts. Throws
  /// std::invalid_argument for an invalid model.
  void set_camera(const CameraModel& camera);
  [[nodiscard]] std::optional<CameraModel> camera() const;
  /// Outputs describe a frame rigidly attached to the camera (a robot's base_link):
  /// T_child_cam maps camera points into it. Identity by default. Set it before the first
  /// frame: the odometry frame is the child frame at the first frame tracked.
  void set_child_from_camera(const Eigen::Matrix4d& T_child_cam);

  /// image: CV_8UC3 BGR or CV_8UC1; depth_m: CV_32FC1 metres (0, NaN = none).
  OdometryOutput track_rgbd(std::int64_t t_ns, const cv::Mat& image, const cv::Mat& depth_m);
  /// Raw (distorted, unrectified) left and right views, CV_8UC1 or CV_8UC3.
  OdometryOutput track_stereo(std::int64_t t_ns, const cv::Mat& left, const cv::Mat& right);
  /// One IMU sample (body frame). Held until a later frame is tracked (see max_imu_hold_s).
  /// Returns false (and ignores it) when use_imu is off or a value is not finite.
  bool add_imu(std::int64_t t_ns, const Eigen::Vector3d& gyro_rad_s,
               const Eigen::Vector3d& accel_m_s2);
  /// Forgets the trajectory (and the EKF): the next frame defines a new odometry frame.
  void reset();

  [[nodiscard]] const OdometryCoreOptions& options() const;
  /// The options in use (tracker, matcher, fusion), one per line, for the start-up log.
  [[nodiscard]] std::string describe() const;
  /// Counters for the shutdown log.
  [[nodiscard]] std::string statistics() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel::ros
