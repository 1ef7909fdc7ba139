// library_rgbd_trajectory: `kestrel odometry`'s loop (apps/kestrel/cmd_odometry.cpp) over the
// first frames of a TUM folder.
#include "library_reference.hpp"

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"

namespace kestrel::test {

std::vector<ReferencePose> library_rgbd_trajectory(const std::string& folder,
                                                   const std::string& camera,
                                                   std::size_t max_frames) {
  const io::TumRgbdSequence sequence(folder);
  odometry::DirectTracker tracker(io::load_camera(camera), odometry::DirectTrackerOptions{});
  const std::size_t n = max_frames == 0 ? sequence.size() : std::min(max_frames, sequence.size());
  std::vector<ReferencePose> poses;
  for (std::size_t i = 0; i < n; ++i) {
    const io::RgbdImages images = sequence.load(i);
    const odometry::TrackResult r =
        tracker.track(odometry::RgbdFrame{images.t_ns, images.bgr, images.depth_m});
    poses.push_back({images.t_ns, r.T_world_cam.translation(), r.T_world_cam.unit_quaternion(),
                     r.ok(), r.covariance});
  }
  return poses;
}

}  // namespace kestrel::test
