// Streams rendered frames to disk as a TUM RGB-D sequence (rgb/, depth/, rgb.txt, depth.txt,
// groundtruth.txt, camera.yaml) and optionally an EuRoC stereo sequence (mav0/cam0, mav0/cam1,
// ground truth, stereo.yaml). One frame at a time: a sequence is never held in memory.
#pragma once

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <optional>
#include <string_view>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/io/trajectory.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {

/// Frame times of a rendered sequence: t_k = epoch_ns + k * period_ns.
struct FrameClock {
  /// 1 s: a fixed epoch, so that the same command writes the same time stamps.
  static constexpr TimeNs kDefaultEpochNs = 1'000'000'000;

  TimeNs epoch_ns = kDefaultEpochNs;
  TimeNs period_ns = 33'333'333;

  /// period = round(1e9 / rate_hz); throws std::invalid_argument unless 0 < rate <= 1e6.
  static FrameClock from_rate(double rate_hz, TimeNs epoch_ns = kDefaultEpochNs);
  [[nodiscard]] TimeNs time_ns(std::size_t k) const {
    return epoch_ns + static_cast<TimeNs>(k) * period_ns;
  }
  /// Seconds since the epoch: the time of a SmoothTrajectory started at the epoch.
  [[nodiscard]] double trajectory_time_s(TimeNs t_ns) const { return ns_to_s(t_ns - epoch_ns); }
};

struct SequenceLayout {
  /// The RGB-D camera (the left camera of a stereo rig), distortion-free.
  PinholeCamera camera;
  /// Where that camera sits on the body (EuRoC sensor.yaml T_BS).
  SE3 T_body_cam = forward_camera_mount();
  double rate_hz = 30.0;
  /// When set, also writes the EuRoC stereo folder mav0/ and stereo.yaml.
  std::optional<RectifiedStereo> stereo;
};

/// 16-bit TUM depth (CV_16U): round(Z * scale), 0 where there is no depth or Z * scale does
/// not fit in 16 bits (beyond 13.1 m at 5000 units per metre).
cv::Mat depth_to_png16(const cv::Mat& depth_m, double units_per_m = 5000.0);
/// 16-bit KITTI-style disparity (CV_16U): round(d * 256), 0 where none.
cv::Mat disparity_to_png16(const cv::Mat& disparity_px);

/// Writes folder `dir`:
///   camera.yaml, rgb.txt, depth.txt, rgb/<t>.png (8-bit BGR), depth/<t>.png (16-bit,
///   5000 per metre, 0 = no depth), groundtruth.txt (T_world_cam of the RGB-D camera, TUM);
/// with a stereo layout also
///   stereo.yaml, mav0/cam{0,1}/data/<t_ns>.png (8-bit grey), mav0/cam{0,1}/data.csv,
///   mav0/cam{0,1}/sensor.yaml, mav0/cam0/disparity/<t_ns>.png (true disparity, 16-bit,
///   1/256 px), mav0/state_groundtruth_estimate0/data.csv (EuRoC's 17-column state of the
///   body: time, position, quaternion wxyz, velocity, zero gyro and accelerometer biases).
/// The folder is claimed with io::claim_output_dir(dir, "render", force); if it already held
/// a render, its image folders are emptied first, so no stale frames remain.
class SequenceWriter {
 public:
  static constexpr std::string_view kCommand = "render";
  static constexpr double kDepthUnitsPerMetre = 5000.0;

  SequenceWriter(std::filesystem::path dir, SequenceLayout layout, bool force = false);
  /// Finishes if finish() was not called (errors are then swallowed: call finish()).
  ~SequenceWriter();
  SequenceWriter(const SequenceWriter&) = delete;
  SequenceWriter& operator=(const SequenceWriter&) = delete;

  /// An RGB-D frame at t_ns; the body's state gives the ground truths.
  void write(TimeNs t_ns, const KinematicState& body, const RenderedFrame& frame);
  /// A stereo frame: its left view is the RGB-D frame. Needs a stereo layout.
  void write(TimeNs t_ns, const KinematicState& body, const StereoFrame& frame);
  /// Writes the ground-truth files and closes the lists; later writes throw.
  void finish();

  [[nodiscard]] std::size_t frames_written() const { return frames_; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }

 private:
  void write_rgbd(TimeNs t_ns, const KinematicState& body, const RenderedFrame& frame);
  void check_open() const;

  std::filesystem::path dir_;
  SequenceLayout layout_;
  bool force_;
  bool finished_ = false;
  std::size_t frames_ = 0;
  std::ofstream rgb_list_;
  std::ofstream depth_list_;
  std::ofstream cam0_csv_;
  std::ofstream cam1_csv_;
  std::ofstream state_csv_;
  Trajectory groundtruth_cam_;
  cv::Mat depth16_;
  cv::Mat gray8_;
};

}  // namespace kestrel::sim
