// Tracks a TUM RGB-D folder with Kestrel's direct tracker and prints the trajectory in TUM
// format (`t tx ty tz qx qy qz qw`), as `kestrel odometry` writes it.
#include <cstdio>
#include <exception>
#include <string>

#include "kestrel/core/time.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s TUM_FOLDER [fr1|fr2|fr3|camera.yaml]\n", argv[0]);
    return 2;
  }
  try {
    const kestrel::io::CameraFile camera =
        kestrel::io::load_camera_description(argc > 2 ? argv[2] : "fr1");
    const kestrel::io::TumRgbdSequence sequence(argv[1]);
    kestrel::odometry::DirectTracker tracker(
        camera.camera, {}, kestrel::odometry::RollingShutter{camera.rolling_shutter_readout_s});
    // The camera's stamp offset: poses carry the exposure time, as in `kestrel odometry`.
    const kestrel::TimeNs offset_ns = kestrel::s_to_ns(camera.time_offset_s);
    int failures = 0;
    for (std::size_t i = 0; i < sequence.size(); ++i) {
      const kestrel::io::RgbdImages images = sequence.load(i);
      const kestrel::odometry::RgbdFrame frame{images.t_ns + offset_ns, images.bgr, images.depth_m};
      const kestrel::odometry::TrackResult r = tracker.track(frame);
      failures += r.ok() ? 0 : 1;
      const Eigen::Vector3d& t = r.T_world_cam.translation();
      const Eigen::Quaterniond& q = r.T_world_cam.unit_quaternion();
      std::printf("%s %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n",
                  kestrel::io::format_seconds(r.t_ns).c_str(), t.x(), t.y(), t.z(), q.x(), q.y(),
                  q.z(), q.w());
    }
    std::fprintf(stderr, "tracked %zu frames, %d failures\n", sequence.size(), failures);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "track_tum: %s\n", e.what());
    return 1;
  }
}
