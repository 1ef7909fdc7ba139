// What the odometry peer runners share: chaining frame-to-frame motions into a trajectory,
// timing, and the "PEER ..." summary line that scripts/bench_odometry.sh reads.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/trajectory.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::peer {

/// A frame-to-frame odometry run: the chained trajectory (first frame at the identity), the
/// time per tracked frame and the frames whose motion the method could not give.
class ChainedRun {
 public:
  /// Adds frame t_ns. `T_cur_prev` maps points of the previous frame into this one; without it
  /// (the first frame, or a failure) the pose stays where it was, as the peers give no
  /// prediction.
  void add(TimeNs t_ns, const Eigen::Matrix4d* T_cur_prev, bool tracked, double ms) {
    if (T_cur_prev != nullptr) T_world_prev_ = T_world_prev_ * T_cur_prev->inverse();
    if (tracked) ms_.push_back(ms);
    // Re-orthonormalise the accumulated rotation before it becomes a quaternion.
    Eigen::Matrix3d R = T_world_prev_.topLeftCorner<3, 3>();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    R = svd.matrixU() * svd.matrixV().transpose();
    trajectory_.push_back(
        {t_ns, SE3(Eigen::Quaterniond(R), T_world_prev_.topRightCorner<3, 1>().eval())});
  }
  void fail() { ++failures_; }

  /// Writes the trajectory (TUM) and prints
  /// "PEER method=<m> frames=<N> failures=<F> mean_ms=<X> median_ms=<Y>".
  void finish(const std::filesystem::path& out, const std::string& writer,
              const std::string& method) const {
    io::write_tum_trajectory(out, trajectory_, writer, true);
    double mean = 0.0;
    for (const double v : ms_) mean += v;
    mean = ms_.empty() ? 0.0 : mean / static_cast<double>(ms_.size());
    std::vector<double> sorted = ms_;
    std::sort(sorted.begin(), sorted.end());
    const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
    std::printf("PEER method=%s frames=%zu failures=%d mean_ms=%.3f median_ms=%.3f\n",
                method.c_str(), trajectory_.size(), failures_, mean, median);
  }

 private:
  Eigen::Matrix4d T_world_prev_ = Eigen::Matrix4d::Identity();
  Trajectory trajectory_;
  std::vector<double> ms_;
  int failures_ = 0;
};

/// The pinhole model a peer runs with: the preset or camera file named on its command line, else
/// the one `kestrel odometry` would take for the folder (its camera.yaml, else freiburgN's
/// preset), so that the peers and Kestrel see the same intrinsics. Throws when neither says.
inline PinholeCamera peer_camera(const std::filesystem::path& dataset, const char* named) {
  std::string name = named != nullptr ? named : io::camera_for_folder(dataset);
  if (name.empty()) {
    throw std::runtime_error(dataset.string() +
                             ": no camera.yaml and no freiburgN in the name: name a camera "
                             "(fr1|fr2|fr3|ros|FILE.yaml)");
  }
  return io::load_camera(name);
}

}  // namespace kestrel::peer
