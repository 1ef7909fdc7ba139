// Kestrel's dataset and output helpers (TUM folders, time association, trajectory files, the
// output guard) for the ROS adapter's C++17 code: the same library calls `kestrel odometry`
// makes, so that a bag and the folder it was made from are read alike. Compiles as C++17.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "kestrel/ros/odometry_core.hpp"

namespace kestrel::ros {

/// The benchmark's rgb/depth tolerance (TumRgbdOptions::max_association_diff_s).
constexpr std::int64_t kTumMaxAssociationDiffNs = 20'000'000;

/// Greedy nearest-time association as TUM's associate.py and `kestrel odometry`: pairs with
/// |a - b| < max_diff, closest first, each element used once; (index in a, index in b) sorted
/// by a.
std::vector<std::pair<std::size_t, std::size_t>> associate_stamps(
    const std::vector<std::int64_t>& a, const std::vector<std::int64_t>& b,
    std::int64_t max_diff_ns);

/// "fr1", "fr2", "fr3" when the name holds freiburg1/2/3 (as `kestrel odometry` guesses from
/// the folder), else empty.
std::string camera_preset_for_name(const std::string& path);

/// A TUM folder's camera as `kestrel odometry` picks it (io::camera_for_folder): the folder's
/// camera.yaml, else the preset its name says, else empty.
std::string camera_for_tum_folder(const std::string& folder);

/// The output guard (io/output_guard.hpp): throws unless `path` may be written by `command`.
void check_can_write_output(const std::string& path, const std::string& command, bool force);

struct TrajectoryPose {
  std::int64_t t_ns = 0;
  Eigen::Matrix4d T_world_cam = Eigen::Matrix4d::Identity();
};
/// TUM trajectory with Kestrel's provenance line, as `kestrel odometry` writes it.
void write_tum_trajectory(const std::string& path, const std::vector<TrajectoryPose>& poses,
                          const std::string& command, bool force);
/// Exact decimal seconds of a time stamp ("1305031229.728464").
std::string format_seconds(std::int64_t t_ns);

/// A TUM RGB-D folder read by io::TumRgbdSequence (rgb.txt, depth.txt, association).
struct TumFrame {
  std::int64_t t_ns = 0;        ///< colour image time
  std::int64_t depth_t_ns = 0;  ///< associated depth image time
  cv::Mat bgr;                  ///< CV_8UC3
  cv::Mat depth_m;              ///< CV_32FC1 metres (the 16-bit PNG / 5000)
};
class TumFolder {
 public:
  /// Throws std::exception (InputError) naming the list file and line.
  explicit TumFolder(const std::string& folder);
  ~TumFolder();
  TumFolder(const TumFolder&) = delete;
  TumFolder& operator=(const TumFolder&) = delete;
  [[nodiscard]] std::size_t size() const;
  [[nodiscard]] std::size_t unmatched_rgb() const;
  [[nodiscard]] TumFrame load(std::size_t i) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// An EuRoC folder read by io::EurocSequence: stereo pairs (cam0/cam1 with equal stamps) and
/// the IMU (for tests and tools that replay it to the node).
struct StereoFrame {
  std::int64_t t_ns = 0;
  cv::Mat left, right;  ///< raw CV_8UC1
};
struct ImuReading {
  std::int64_t t_ns = 0;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};
class EurocFolder {
 public:
  /// Throws std::exception (InputError) naming the file and line.
  explicit EurocFolder(const std::string& folder);
  ~EurocFolder();
  EurocFolder(const EurocFolder&) = delete;
  EurocFolder& operator=(const EurocFolder&) = delete;
  [[nodiscard]] std::size_t size() const;
  [[nodiscard]] StereoFrame load(std::size_t i) const;
  /// mav0/imu0/data.csv samples with from_ns <= t < to_ns.
  [[nodiscard]] std::vector<ImuReading> imu(std::int64_t from_ns, std::int64_t to_ns) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kestrel::ros
