// Peer runner: Open3D's RGB-D odometry (ComputeRGBDOdometry, the hybrid photometric + geometric
// Jacobian of Park et al. 2017, Open3D's default) frame to frame on a TUM RGB-D folder, single
// threaded, writing a TUM trajectory (first frame at the identity) and the per-frame time.
//
//   peer_open3d_odometry DATASET_DIR OUT.txt [fr1|fr2|fr3|ros|CAMERA.yaml]
//
// The camera: the one named, else the folder's camera.yaml, else its freiburgN preset.
//
// Frames come from kestrel's own TUM reader (the association of `kestrel odometry`); images are
// not undistorted, and Open3D's defaults are kept (depth up to 4 m, as its TUM loader, and
// its OdometryOption), as its users run it. Prints the "PEER ..." line of peer_support.hpp; the
// time covers the image conversion and ComputeRGBDOdometry.
#include <Eigen/Core>
#include <chrono>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "kestrel/core/stopwatch.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "open3d_adapter.hpp"
#include "peer_support.hpp"

int main(int argc, char** argv) {
  using namespace kestrel;
  if (argc < 3) {
    std::cerr << "usage: " << argv[0] << " DATASET_DIR OUT.txt [fr1|fr2|fr3|ros|CAMERA.yaml]\n";
    return 2;
  }
  try {
    const io::TumRgbdSequence seq(argv[1]);
    const PinholeCamera camera = peer::peer_camera(argv[1], argc > 3 ? argv[3] : nullptr);
    peer::Open3dOdometry odometry(
        {camera.width(), camera.height(), camera.fx(), camera.fy(), camera.cx(), camera.cy()});
    peer::ChainedRun run;
    cv::Mat rgb, depth;
    for (std::size_t i = 0; i < seq.size(); ++i) {
      const io::RgbdImages im = seq.load(i);
      const auto t0 = std::chrono::steady_clock::now();
      cv::cvtColor(im.bgr, rgb, cv::COLOR_BGR2RGB);
      depth = im.depth_m.isContinuous() ? im.depth_m : im.depth_m.clone();
      double T[16];
      const bool ok = odometry.add_frame(rgb.ptr<std::uint8_t>(), depth.ptr<float>(), T);
      const bool tracked = i > 0;
      if (tracked && !ok) run.fail();
      const Eigen::Matrix4d T_cur_prev =
          Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(T);
      run.add(im.t_ns, ok ? &T_cur_prev : nullptr, tracked, ms_since(t0));
    }
    run.finish(argv[2], "peer_open3d_odometry", "open3d");
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
