// Peer runner for the comparison in docs/odometry.md ("Peers"): OpenCV contrib's RgbdOdometry
// (dense photometric) and RgbdICPOdometry (projective point-to-plane ICP) frame to frame on a TUM
// RGB-D folder, single threaded, writing a TUM trajectory (first frame at the identity) and the
// per-frame time.
//
//   peer_opencv_odometry rgbd|icp DATASET_DIR OUT.txt [fr1|fr2|fr3|ros|CAMERA.yaml]
//
// The camera: the one named, else the folder's camera.yaml, else its freiburgN preset.
//
// Frames come from kestrel's own TUM reader (same association as `kestrel odometry`); images are
// not undistorted (OpenCV's odometry assumes a pinhole image, as its users feed it). Prints
// "PEER method=<m> frames=<N> failures=<F> mean_ms=<X> median_ms=<Y>" on stdout, where the time
// is that of odometry.compute() plus the conversion to gray and the frame preparation.
#include <Eigen/Dense>
#include <chrono>
#include <iostream>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/rgbd.hpp>
#include <string>

#include "kestrel/core/stopwatch.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "peer_support.hpp"

int main(int argc, char** argv) {
  using namespace kestrel;
  if (argc < 4) {
    std::cerr << "usage: " << argv[0]
              << " rgbd|icp DATASET_DIR OUT.txt [fr1|fr2|fr3|ros|CAMERA.yaml]\n";
    return 2;
  }
  const std::string method = argv[1];
  if (method != "rgbd" && method != "icp") {
    std::cerr << "method must be rgbd or icp\n";
    return 2;
  }
  try {
    cv::setNumThreads(1);
    const io::TumRgbdSequence seq(argv[2]);
    const PinholeCamera camera = peer::peer_camera(argv[2], argc > 4 ? argv[4] : nullptr);
    cv::Mat K = (cv::Mat_<float>(3, 3) << static_cast<float>(camera.fx()), 0.F,
                 static_cast<float>(camera.cx()), 0.F, static_cast<float>(camera.fy()),
                 static_cast<float>(camera.cy()), 0.F, 0.F, 1.F);
    cv::Ptr<cv::rgbd::Odometry> odometry;
    if (method == "rgbd") {
      odometry = cv::rgbd::RgbdOdometry::create(K);
    } else {
      odometry = cv::rgbd::RgbdICPOdometry::create(K);
    }
    peer::ChainedRun run;
    cv::Ptr<cv::rgbd::OdometryFrame> prev;
    for (std::size_t i = 0; i < seq.size(); ++i) {
      const io::RgbdImages im = seq.load(i);
      const auto t0 = std::chrono::steady_clock::now();
      cv::Mat gray;
      cv::cvtColor(im.bgr, gray, cv::COLOR_BGR2GRAY);
      cv::Mat depth = im.depth_m.clone();
      depth.setTo(std::numeric_limits<float>::quiet_NaN(), depth <= 0.0F);  // OpenCV: NaN = none
      cv::Ptr<cv::rgbd::OdometryFrame> cur = cv::makePtr<cv::rgbd::OdometryFrame>(
          gray, depth, cv::Mat(), cv::Mat(), static_cast<int>(i));
      Eigen::Matrix4d T_cur_prev;
      bool ok = false;
      if (prev) {
        cv::Mat Rt;
        // Rt maps points of the source (previous) frame into the destination (current) one.
        ok = odometry->compute(prev, cur, Rt) && !Rt.empty();
        if (ok) cv::cv2eigen(Rt, T_cur_prev);
        if (!ok) run.fail();
      }
      run.add(im.t_ns, ok ? &T_cur_prev : nullptr, prev != nullptr, ms_since(t0));
      prev = cur;
    }
    run.finish(argv[3], std::string("peer_opencv_odometry ") + method, method);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
