// The dataset and output helpers of the ROS adapter: thin wrappers over io/ (C++20) so that
// the C++17 ROS code reads TUM folders, associates time stamps and writes trajectories with
// exactly the calls `kestrel odometry` makes.
#include "kestrel/ros/dataset_bridge.hpp"

#include <filesystem>

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"

namespace kestrel::ros {

std::vector<std::pair<std::size_t, std::size_t>> associate_stamps(
    const std::vector<std::int64_t>& a, const std::vector<std::int64_t>& b,
    std::int64_t max_diff_ns) {
  return io::associate_by_time(a, b, max_diff_ns);
}

std::string camera_preset_for_name(const std::string& path) {
  return io::camera_preset_in_path(path);
}

std::string camera_for_tum_folder(const std::string& folder) {
  return io::camera_for_folder(folder);
}

void check_can_write_output(const std::string& path, const std::string& command, bool force) {
  io::check_can_write_file(path, command, force);
}

void write_tum_trajectory(const std::string& path, const std::vector<TrajectoryPose>& poses,
                          const std::string& command, bool force) {
  Trajectory trajectory;
  trajectory.reserve(poses.size());
  for (const TrajectoryPose& p : poses) {
    trajectory.push_back({p.t_ns, SE3::from_matrix(p.T_world_cam)});
  }
  io::write_tum_trajectory(path, trajectory, command, force);
}

std::string format_seconds(std::int64_t t_ns) { return io::format_seconds(t_ns); }

struct TumFolder::Impl {
  explicit Impl(const std::string& folder) : sequence(folder) {}
  io::TumRgbdSequence sequence;
};

TumFolder::TumFolder(const std::string& folder) : impl_(std::make_unique<Impl>(folder)) {}
TumFolder::~TumFolder() = default;
std::size_t TumFolder::size() const { return impl_->sequence.size(); }
std::size_t TumFolder::unmatched_rgb() const { return impl_->sequence.unmatched_rgb(); }

TumFrame TumFolder::load(std::size_t i) const {
  io::RgbdImages images = impl_->sequence.load(i);
  return TumFrame{images.t_ns, images.depth_t_ns, std::move(images.bgr), std::move(images.depth_m)};
}

struct EurocFolder::Impl {
  explicit Impl(const std::string& folder) : sequence(folder) {}
  io::EurocSequence sequence;
};

EurocFolder::EurocFolder(const std::string& folder) : impl_(std::make_unique<Impl>(folder)) {}
EurocFolder::~EurocFolder() = default;
std::size_t EurocFolder::size() const { return impl_->sequence.stereo_size(); }

StereoFrame EurocFolder::load(std::size_t i) const {
  io::StereoImages images = impl_->sequence.load_stereo(i);
  return StereoFrame{images.t_ns, std::move(images.left), std::move(images.right)};
}

std::vector<ImuReading> EurocFolder::imu(std::int64_t from_ns, std::int64_t to_ns) const {
  std::vector<ImuReading> out;
  io::ImuCsvReader reader(impl_->sequence.imu_csv());
  for (io::ImuSample s; reader.next(s) && s.t_ns < to_ns;) {
    if (s.t_ns >= from_ns) out.push_back({s.t_ns, s.gyro_rad_s, s.accel_m_s2});
  }
  return out;
}

}  // namespace kestrel::ros
