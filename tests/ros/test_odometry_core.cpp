// OdometryCore, the ROS-free side of the node: same poses as the library, covariance and twist
// in ROS's conventions (and consistent under a change of child frame), bad frames dropped
// without harm, stereo + IMU fusion producing states.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/odometry/stereo_odometry.hpp"
#include "kestrel/ros/dataset_bridge.hpp"
#include "kestrel/ros/odometry_core.hpp"
#include "kestrel/sensor/rectification.hpp"
#include "library_reference.hpp"
#include "test_data.hpp"

namespace kestrel::ros {
namespace {

using test::kTumRpyPart1;
constexpr const char* kEuroc = "euroc/V1_01_easy_part1";
using Matrix6 = Eigen::Matrix<double, 6, 6>;

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

void expect_symmetric_psd(const Matrix6& c, const std::string& what) {
  EXPECT_TRUE(c.allFinite()) << what;
  EXPECT_LT((c - c.transpose()).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + c.cwiseAbs().maxCoeff()))
      << what;
  const Eigen::SelfAdjointEigenSolver<Matrix6> eig(0.5 * (c + c.transpose()));
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12 * (1.0 + eig.eigenvalues().maxCoeff())) << what;
}

TEST(OdometryCore, RgbdMatchesTheLibraryWithRosCovariances) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const std::string folder = (test::shared_data_dir() / kTumRpyPart1).string();
  constexpr std::size_t kFrames = 20;
  const auto reference = test::library_rgbd_trajectory(folder, "fr1", kFrames);
  OdometryCore core(OdometryCoreOptions{}, load_camera_model("fr1"));
  const TumFolder tum(folder);
  ASSERT_GE(tum.size(), kFrames);
  std::size_t with_twist = 0;
  for (std::size_t i = 0; i < kFrames; ++i) {
    const TumFrame f = tum.load(i);
    const OdometryOutput out = core.track_rgbd(f.t_ns, f.bgr, f.depth_m);
    ASSERT_FALSE(out.invalid_input) << out.failure;
    EXPECT_EQ(out.t_ns, reference[i].t_ns);
    EXPECT_EQ(out.ok, reference[i].ok) << "frame " << i;
    const Eigen::Vector3d p = out.T_odom_child.block<3, 1>(0, 3);
    const Eigen::Quaterniond q(Eigen::Matrix3d(out.T_odom_child.block<3, 3>(0, 0)));
    const auto [dp, dq] = test::pose_difference(p, q, reference[i].p, reference[i].q);
    EXPECT_LT(dp, 1e-12) << "frame " << i;
    EXPECT_LT(dq, 1e-12) << "frame " << i;
    if (i == 0) {
      EXPECT_EQ(out.pose_covariance, Matrix6::Zero()) << "the first frame defines the odom frame";
      EXPECT_FALSE(out.has_twist);
      continue;
    }
    if (!out.ok) continue;
    expect_symmetric_psd(out.pose_covariance, "pose covariance, frame " + std::to_string(i));
    EXPECT_GT(out.pose_covariance.trace(), 0.0);
    if (i == 1) {
      // Aligned to the first frame (the odometry frame itself): Sigma_ros = J Sigma J^T with
      // the tracker's covariance and J = [[I, -p^], [0, I]] (position error of exp(xi) T).
      Matrix6 J = Matrix6::Identity();
      J.block<3, 3>(0, 3) = -skew(reference[1].p);
      const Matrix6 expected = J * reference[1].covariance * J.transpose();
      EXPECT_LT((out.pose_covariance - expected).cwiseAbs().maxCoeff(),
                1e-9 * expected.cwiseAbs().maxCoeff());
    }
    if (out.has_twist) {
      ++with_twist;
      expect_symmetric_psd(out.twist_covariance, "twist covariance, frame " + std::to_string(i));
      // fr1/rpy is hand-held: well under 2 m/s and 10 rad/s.
      EXPECT_LT(out.twist.head<3>().norm(), 2.0);
      EXPECT_LT(out.twist.tail<3>().norm(), 10.0);
    }
  }
  EXPECT_GE(with_twist, kFrames / 2);
}

// A child frame rotated about the camera centre (a base_link whose axes differ from the
// optical frame): poses are conjugated, covariances and twists rotate with it.
TEST(OdometryCore, ChildFrameRotatesPosesCovariancesAndTwists) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const std::string folder = (test::shared_data_dir() / kTumRpyPart1).string();
  // Optical (x right, y down, z forward) -> body (x forward, y left, z up).
  Eigen::Matrix3d R_base_cam;
  R_base_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Matrix4d T_base_cam = Eigen::Matrix4d::Identity();
  T_base_cam.block<3, 3>(0, 0) = R_base_cam;
  OdometryCore cam(OdometryCoreOptions{}, load_camera_model("fr1"));
  OdometryCore base(OdometryCoreOptions{}, load_camera_model("fr1"));
  base.set_child_from_camera(T_base_cam);
  Matrix6 R6 = Matrix6::Zero();
  R6.block<3, 3>(0, 0) = R_base_cam;
  R6.block<3, 3>(3, 3) = R_base_cam;
  const TumFolder tum(folder);
  for (std::size_t i = 0; i < 8; ++i) {
    const TumFrame f = tum.load(i);
    const OdometryOutput a = cam.track_rgbd(f.t_ns, f.bgr, f.depth_m);
    const OdometryOutput b = base.track_rgbd(f.t_ns, f.bgr, f.depth_m);
    ASSERT_TRUE(a.ok && b.ok) << a.failure << b.failure;
    const Eigen::Matrix4d expected = T_base_cam * a.T_odom_child * T_base_cam.inverse();
    EXPECT_LT((b.T_odom_child - expected).cwiseAbs().maxCoeff(), 1e-12);
    const Matrix6 cov = R6 * a.pose_covariance * R6.transpose();
    EXPECT_LT((b.pose_covariance - cov).cwiseAbs().maxCoeff(),
              1e-9 * (1e-12 + cov.cwiseAbs().maxCoeff()));
    ASSERT_EQ(a.has_twist, b.has_twist);
    if (a.has_twist) {
      EXPECT_LT((b.twist - R6 * a.twist).norm(), 1e-9 * (1.0 + a.twist.norm()));
    }
  }
}

TEST(OdometryCore, BadFramesAreReportedAndTrackingGoesOn) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const std::string folder = (test::shared_data_dir() / kTumRpyPart1).string();
  const auto reference = test::library_rgbd_trajectory(folder, "fr1", 4);
  OdometryCore core(OdometryCoreOptions{}, load_camera_model("fr1"));
  const TumFolder tum(folder);
  TumFrame f0 = tum.load(0);
  EXPECT_TRUE(core.track_rgbd(f0.t_ns, f0.bgr, f0.depth_m).ok);
  // Half-size images: not the camera's size.
  cv::Mat small_bgr, small_depth;
  cv::resize(f0.bgr, small_bgr, cv::Size(320, 240));
  cv::resize(f0.depth_m, small_depth, cv::Size(320, 240));
  const OdometryOutput bad = core.track_rgbd(f0.t_ns + 1'000'000, small_bgr, small_depth);
  EXPECT_TRUE(bad.invalid_input);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.failure.find("320"), std::string::npos) << bad.failure;
  // Depth of the wrong type.
  cv::Mat depth_u16;
  f0.depth_m.convertTo(depth_u16, CV_16UC1, 5000.0);
  EXPECT_TRUE(core.track_rgbd(f0.t_ns + 2'000'000, f0.bgr, depth_u16).invalid_input);
  for (std::size_t i = 1; i < 4; ++i) {
    const TumFrame f = tum.load(i);
    const OdometryOutput out = core.track_rgbd(f.t_ns, f.bgr, f.depth_m);
    ASSERT_TRUE(out.ok) << out.failure;
    const Eigen::Vector3d p = out.T_odom_child.block<3, 1>(0, 3);
    EXPECT_LT((p - reference[i].p).norm(), 1e-12) << "the dropped frames left no trace";
  }
  EXPECT_NE(core.statistics().find("invalid=2"), std::string::npos) << core.statistics();
}

TEST(OdometryCore, RgbdWithoutCameraWaitsForOne) {
  OdometryCore core(OdometryCoreOptions{});
  EXPECT_FALSE(core.has_camera());
  const cv::Mat image(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  const cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(1.0f));
  const OdometryOutput out = core.track_rgbd(1, image, depth);
  EXPECT_TRUE(out.invalid_input);
  EXPECT_NE(out.failure.find("no camera model"), std::string::npos) << out.failure;
  CameraModel broken = load_camera_model("fr1");
  broken.fx = 0.0;
  EXPECT_FALSE(check_camera_model(broken).empty());
  EXPECT_THROW(core.set_camera(broken), std::invalid_argument);
  core.set_camera(load_camera_model("fr1"));
  EXPECT_TRUE(core.has_camera());
}

TEST(OdometryCore, OptionErrorsNameTheProblem) {
  OdometryCoreOptions stereo;
  stereo.mode = OdometryMode::kStereo;
  try {
    OdometryCore core(stereo);
    FAIL() << "stereo without calibration was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("stereo calibration"), std::string::npos) << e.what();
  }
  OdometryCoreOptions imu;
  imu.use_imu = true;
  try {
    OdometryCore core(imu);
    FAIL() << "IMU fusion without a noise model was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("imu_noise"), std::string::npos) << e.what();
  }
  OdometryCoreOptions missing;
  missing.tracker_options_file = "/nonexistent/tracker.yaml";
  try {
    OdometryCore core(missing);
    FAIL() << "a missing options file was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/tracker.yaml"), std::string::npos)
        << e.what();
  }
}

// The matcher parameters: an unknown name, or sgm_options without matcher sgm, is an error
// naming the parameter; matcher "sgm" gives the library's SGM odometry, pose for pose.
TEST(OdometryCore, MatcherParameterSelectsTheSemiGlobalMatcher) {
  KESTREL_REQUIRE_DATA(kEuroc);
  const std::string folder = (test::shared_data_dir() / kEuroc).string();
  OdometryCoreOptions options;
  options.mode = OdometryMode::kStereo;
  options.stereo_calibration = folder;
  options.matcher = "sgbm";
  try {
    OdometryCore core(options);
    FAIL() << "an unknown matcher was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("~matcher"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sad, census or sgm"), std::string::npos) << e.what();
  }
  options.matcher = "";
  options.sgm_options_file = "/nonexistent/sgm.yaml";
  try {
    OdometryCore core(options);
    FAIL() << "sgm_options without matcher sgm was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("~sgm_options"), std::string::npos) << e.what();
  }
  options.sgm_options_file.clear();
  options.matcher = "sgm";
  OdometryCore core(options);
  EXPECT_NE(core.describe().find("matcher: sgm "), std::string::npos) << core.describe();
  const io::EurocSequence sequence(folder);
  sensor::StereoFrontEndOptions front_end;
  front_end.kind = sensor::StereoMatcherKind::kSgm;
  odometry::StereoOdometry library(sensor::StereoCalibration::from_euroc(sequence), front_end,
                                   odometry::stereo_head_tracker_options());
  const SE3 C(SO3::from_matrix(library.R_rect_left().transpose()), Eigen::Vector3d::Zero());
  const EurocFolder euroc(folder);
  for (std::size_t i = 0; i < 4; ++i) {
    const StereoFrame f = euroc.load(i);
    const OdometryOutput out = core.track_stereo(f.t_ns, f.left, f.right);
    const odometry::StereoTrackResult r = library.track(f.t_ns, f.left, f.right);
    ASSERT_TRUE(out.ok && r.track.ok()) << out.failure;
    const Eigen::Matrix4d expected = (C * r.track.T_world_cam * C.inverse()).matrix();
    EXPECT_LT((out.T_odom_child - expected).cwiseAbs().maxCoeff(), 1e-12) << "pair " << i;
  }
}

// Stereo on EuRoC with its IMU: poses are the library's StereoOdometry poses (of the rectified
// left camera) expressed for the raw left camera, and the EKF produces fused states once its
// static initialisation has found a still second of IMU (as `kestrel run` on this folder).
TEST(OdometryCore, StereoWithImuMatchesTheLibraryAndFuses) {
  KESTREL_REQUIRE_DATA(kEuroc);
  const std::string folder = (test::shared_data_dir() / kEuroc).string();
  OdometryCoreOptions options;
  options.mode = OdometryMode::kStereo;
  options.stereo_calibration = folder;
  options.use_imu = true;
  OdometryCore core(options);
  const io::EurocSequence sequence(folder);
  odometry::StereoOdometry library(sensor::StereoCalibration::from_euroc(sequence),
                                   sensor::BlockMatcherOptions{},
                                   odometry::stereo_head_tracker_options());
  const SE3 C(SO3::from_matrix(library.R_rect_left().transpose()), Eigen::Vector3d::Zero());
  const EurocFolder euroc(folder);
  const std::size_t n = euroc.size();
  ASSERT_GE(n, 50u);
  std::size_t fused = 0, ok = 0;
  std::int64_t last_t = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const StereoFrame f = euroc.load(i);
    for (const ImuReading& s : euroc.imu(i == 0 ? f.t_ns - 1'000'000'000 : last_t, f.t_ns + 1)) {
      core.add_imu(s.t_ns, s.gyro_rad_s, s.accel_m_s2);
    }
    last_t = f.t_ns + 1;
    const OdometryOutput out = core.track_stereo(f.t_ns, f.left, f.right);
    const odometry::StereoTrackResult r = library.track(f.t_ns, f.left, f.right);
    ASSERT_FALSE(out.invalid_input) << out.failure;
    EXPECT_EQ(out.ok, r.track.ok());
    const Eigen::Matrix4d expected = (C * r.track.T_world_cam * C.inverse()).matrix();
    EXPECT_LT((out.T_odom_child - expected).cwiseAbs().maxCoeff(), 1e-12) << "pair " << i;
    ok += out.ok ? 1 : 0;
    for (const FusedOutput& s : out.fused) {
      ++fused;
      EXPECT_TRUE(s.p_world.allFinite() && s.v_world.allFinite() && s.sigma.allFinite());
      EXPECT_LT(s.p_world.norm(), 1.0) << "V1_01's first 3 s move the drone by centimetres";
      EXPECT_NEAR(s.q_world_body.norm(), 1.0, 1e-9);
    }
  }
  EXPECT_GE(ok, n - 2);
  EXPECT_GE(fused, 5u) << core.statistics();
  std::cout << "stereo + IMU over " << n << " pairs: " << core.statistics() << "\n";
}

}  // namespace
}  // namespace kestrel::ros
