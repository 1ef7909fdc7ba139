// DirectTracker: dense direct RGB-D odometry (thesis 3.5-3.10): inverse-compositional
// Lucas-Kanade over an SE(3) twist with global gain/bias, Tukey weights, coarse to fine,
// aligning each frame to a keyframe (or to the previous frame). Fed by depth (RgbdFrame) or,
// built from a rectified rig, by disparity in disparity space (DisparityFrame, thesis 2.4, 3.10).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/image/pyramid.hpp"
#include "kestrel/image/undistortion.hpp"
#include "kestrel/odometry/direct_tracker_options.hpp"

namespace kestrel::odometry {

/// One RGB-D frame as the camera gives it (distorted if the camera model has distortion).
struct RgbdFrame {
  TimeNs t_ns = 0;
  cv::Mat image;    ///< CV_8UC3 BGR, CV_8UC1 gray, or CV_32FC1 intensity in [0, 1]
  cv::Mat depth_m;  ///< CV_32FC1 metres; 0, NaN, inf or negative = no depth
};

/// One rectified stereo frame in disparity space (thesis 2.4): the LEFT view and its disparity.
struct DisparityFrame {
  TimeNs t_ns = 0;
  cv::Mat image;  ///< rectified left view: CV_8UC3 BGR, CV_8UC1, or CV_32FC1 in [0, 1]
  /// CV_32FC1, d = uL - uR in full-resolution pixels; <= 0, NaN or inf = no disparity
  /// (sensor::kNoDisparity is +inf).
  cv::Mat disparity_px;
};

/// How the colour camera reads out its rows: a fact of the sensor that comes with the camera
/// description (io::CameraFile::rolling_shutter_readout_s), not a tuning option. Rolling-shutter
/// compensation after Ringaby & Forssen (IJCV 2012) and Kerl et al. (ICCV 2015).
struct RollingShutter {
  /// Time from the first row to the last (s); 0 = global shutter. With a readout each frame is
  /// rectified to its middle row's time (image/rolling_shutter.hpp) with the rotation rate of
  /// the constant-velocity prior, depth map alike, resampled with the finest level's kernel.
  double readout_s = 0.0;
};

enum class TrackFailure : std::uint8_t {
  kNone = 0,
  kInvalidInput,       ///< wrong size or type, empty image
  kTooFewPoints,       ///< the reference has too few usable points (no depth, no texture)
  kNoOverlap,          ///< too few reference points project into the current image
  kHighResidual,       ///< robust sigma above max_sigma: the images do not match
  kLowInlierRatio,     ///< too few residuals within the Tukey cut-off
  kImplausibleMotion,  ///< motion to the reference beyond max_translation_m / max_rotation_deg
  kNumerical,          ///< singular normal equations or non-finite values
};
std::string_view to_string(TrackFailure failure);

/// The result of tracking one frame, with its health.
struct TrackResult {
  TimeNs t_ns = 0;
  TrackFailure failure = TrackFailure::kNone;
  [[nodiscard]] bool ok() const { return failure == TrackFailure::kNone; }

  SE3 T_world_cam;      ///< pose of this frame (world = first frame); on failure the prediction
  SE3 T_ref_cur;        ///< this frame relative to the reference (keyframe) it was aligned to
  TimeNs ref_t_ns = 0;  ///< time stamp of that reference frame
  /// Covariance of xi in T_ref_cur = exp(xi) * estimate, xi = [v, w] in the reference frame:
  /// sigma^2 (J^T W J)^-1 of the finest level iterated (pose block, gain/bias marginalised).
  Matrix6d covariance = Matrix6d::Identity();

  bool converged = false;     ///< the finest level stopped by a tolerance, not the cap
  int iterations = 0;         ///< Gauss-Newton iterations over all levels
  double sigma = 0.0;         ///< final robust sigma (intensity units, [0, 1] images) ...
  int photometric_level = 0;  ///< ... on this pyramid level (> finest_level: a blurred frame)
  double depth_sigma = 0.0;   ///< final robust sigma of the geometric residuals (m), 0 if unused
  int depth_points = 0;       ///< reference points with a geometric residual on that level
  double depth_inlier_ratio = 0.0;  ///< geometric residuals within c sigma / points with a normal
  /// Residuals within c sigma / reference points, and reference points that project into the
  /// image / all, as measured by the last alignment (also on a failed one); 1 for a frame that
  /// starts the sequence (its own reference); NaN where nothing was aligned (invalid input, or a
  /// first frame with too few points).
  double inlier_ratio = 0.0;
  double overlap = 0.0;
  int points = 0;     ///< reference points on the finest level iterated
  double gain = 0.0;  ///< g of I_ref = (1 + g) I_cur + b
  double bias = 0.0;
  bool new_keyframe = false;  ///< this frame became the reference for the next ones
  /// The photometric alignment failed (blur) or a finer level jumped away from the coarser
  /// one's estimate, and the geometric fallback was accepted by its own health checks
  /// (TermsOptions::geometric = fallback, FallbackOptions). With geometric = always: the joint
  /// alignment's images agreed only on a coarser level, or a finer level jumped, and the
  /// fallback's policy (FallbackOptions) was applied.
  bool geometric_fallback = false;
  /// The fallback's rotation came from the previous frame
  /// (FallbackOptions::rotation_from_previous_frame).
  bool fallback_rotation_from_previous = false;
  std::string failure_detail;  ///< human-readable, empty when ok
};

/// Per-level reference data: points and their precomputed IC Jacobians (structure of arrays,
/// float, reused across keyframes).
struct ReferenceLevel {
  float fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  int count = 0;
  std::vector<float> x, y, z, intensity;
  std::array<std::vector<float>, 8> jac;  ///< the 8 columns of J (pose, gain, bias)
  /// Geometric residual: unit normal and n.P; has_normal = 0 where the depth around the point
  /// gives no reliable normal (those points are photometric only).
  std::vector<float> nx, ny, nz, n_dot_p;
  std::vector<std::uint8_t> has_normal;
  int normal_count = 0;
  /// Geometric residual: per point, (median_depth / z)^2. Depth noise grows as z^2 (Kinect v1,
  /// Khoshelham & Elberink 2012), so each point-to-plane residual and its Jacobian are multiplied
  /// by it: the term's one robust scale is that of a point at the median depth. Empty (1) with
  /// `terms.depth_noise_per_m` 0.
  std::vector<float> depth_noise_scale;
  double median_depth = 0.0;
};

class DirectTracker {
 public:
  /// `camera` is the model of the input images: with distortion, frames are undistorted
  /// before tracking; `shutter` how its rows are read out. Throws InputError for invalid
  /// options or readout.
  explicit DirectTracker(const PinholeCamera& camera, const DirectTrackerOptions& options = {},
                         const RollingShutter& shutter = {});
  /// Disparity input (thesis 2.4, 3.10): frames are rectified views of `rig` with disparity maps;
  /// the reference points and Jacobians are built in disparity space (disparity_space.hpp) with
  /// the baseline scaled per pyramid level (rectified global-shutter views). Throws InputError
  /// for an invalid rig or options that need depth maps
  /// (terms.geometric: always).
  explicit DirectTracker(const RectifiedStereo& rig, const DirectTrackerOptions& options = {});
  ~DirectTracker();
  DirectTracker(const DirectTracker&) = delete;
  DirectTracker& operator=(const DirectTracker&) = delete;

  /// Tracks the next frame of a sequence. The first frame (or the first after reset())
  /// defines the world frame and is returned at the identity.
  TrackResult track(const RgbdFrame& frame);
  /// The same for a disparity frame (a tracker built from a rig; a depth tracker reports
  /// kInvalidInput for it, and vice versa).
  TrackResult track(const DisparityFrame& frame);
  /// Forgets the keyframe, motion and pose.
  void reset();

  /// Aligns `current` to `reference` alone, from the guess T_ref_cur (no keyframes, no prior):
  /// the two-frame problem, for tests and tools. Leaves the sequence state reset.
  TrackResult align_pair(const RgbdFrame& reference, const RgbdFrame& current,
                         const SE3& T_ref_cur_guess = SE3());
  TrackResult align_pair(const DisparityFrame& reference, const DisparityFrame& current,
                         const SE3& T_ref_cur_guess = SE3());

  [[nodiscard]] const PinholeCamera& camera() const { return camera_; }
  [[nodiscard]] const DirectTrackerOptions& options() const { return options_; }
  /// True for a tracker built from a rectified rig (disparity input).
  [[nodiscard]] bool disparity_input() const { return disparity_input_; }

  struct Impl;  // buffers and state, opaque (direct_tracker.cpp)

 private:
  TrackResult track_prepared(TimeNs t_ns);
  // align_pair for either input kind (defined and instantiated in direct_tracker.cpp).
  template <typename Frame>
  TrackResult align_frames(const Frame& reference, const Frame& current,
                           const SE3& T_ref_cur_guess);
  TrackResult align_prepared_pair(const SE3& T_ref_cur_guess, TimeNs ref_t_ns, TimeNs t_ns);

  PinholeCamera camera_;  // undistorted
  DirectTrackerOptions options_;
  bool disparity_input_ = false;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel::odometry
