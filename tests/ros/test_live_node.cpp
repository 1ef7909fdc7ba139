// The live node end to end on a loopback rosmaster: `kestrel_ros node` runs as a child process,
// this test publishes the shared TUM frames (and EuRoC stereo + IMU) and checks the Odometry,
// TF and fused-state messages; unexpected encodings, missing camera_info and bad parameters are
// logged and handled; SIGINT always stops the node. Every wait has a deadline.
#include <geometry_msgs/Vector3Stamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_msgs/TFMessage.h>

#include <mutex>
#include <opencv2/imgproc.hpp>

#include "conversions.hpp"
#include "kestrel/ros/dataset_bridge.hpp"
#include "library_reference.hpp"
#include "ros_test_support.hpp"
#include "test_data.hpp"

namespace kestrel::test {
namespace {

namespace fs = std::filesystem;
namespace enc = sensor_msgs::image_encodings;
constexpr const char* kEuroc = "euroc/V1_01_easy_part1";

const ::testing::Environment* const kRosTeardown =
    ::testing::AddGlobalTestEnvironment(new RosTestTeardown);

sensor_msgs::ImagePtr image_message(const cv::Mat& m, const std::string& encoding,
                                    std::int64_t t_ns, const std::string& frame_id) {
  auto msg = boost::make_shared<sensor_msgs::Image>();
  msg->header.stamp = ros::to_ros_time(t_ns);
  msg->header.frame_id = frame_id;
  msg->width = static_cast<std::uint32_t>(m.cols);
  msg->height = static_cast<std::uint32_t>(m.rows);
  msg->encoding = encoding;
  msg->step = static_cast<std::uint32_t>(m.cols * m.elemSize());
  msg->data.resize(static_cast<std::size_t>(msg->step) * msg->height);
  cv::Mat view(m.rows, m.cols, m.type(), msg->data.data(), msg->step);
  m.copyTo(view);
  return msg;
}

sensor_msgs::ImagePtr rgb8(const cv::Mat& bgr, std::int64_t t_ns) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return image_message(rgb, enc::RGB8, t_ns, "/openni_rgb_optical_frame");
}

sensor_msgs::ImagePtr depth32(const cv::Mat& depth_m, std::int64_t t_ns) {
  return image_message(depth_m, enc::TYPE_32FC1, t_ns, "/openni_rgb_optical_frame");
}

/// What the node publishes, collected on the test's spinner threads.
class Collector {
 public:
  Collector(::ros::NodeHandle& nh, const std::string& node, const std::string& child_frame)
      : child_frame_(child_frame) {
    odom_ =
        nh.subscribe<nav_msgs::Odometry>(node + "/odometry", 1000,
                                         boost::function<void(const nav_msgs::Odometry::ConstPtr&)>(
                                             [this](const nav_msgs::Odometry::ConstPtr& m) {
                                               std::lock_guard<std::mutex> lock(mutex_);
                                               odometry_.push_back(*m);
                                             }));
    tf_ = nh.subscribe<tf2_msgs::TFMessage>(
        "/tf", 1000,
        boost::function<void(const tf2_msgs::TFMessage::ConstPtr&)>(
            [this](const tf2_msgs::TFMessage::ConstPtr& m) {
              std::lock_guard<std::mutex> lock(mutex_);
              for (const auto& t : m->transforms) {
                if (t.child_frame_id == child_frame_) transforms_.push_back(t);
              }
            }));
    fused_ =
        nh.subscribe<nav_msgs::Odometry>(node + "/fused/odometry", 1000,
                                         boost::function<void(const nav_msgs::Odometry::ConstPtr&)>(
                                             [this](const nav_msgs::Odometry::ConstPtr& m) {
                                               std::lock_guard<std::mutex> lock(mutex_);
                                               fused_states_.push_back(*m);
                                             }));
    gyro_bias_ = nh.subscribe<geometry_msgs::Vector3Stamped>(
        node + "/fused/gyro_bias", 1000,
        boost::function<void(const geometry_msgs::Vector3Stamped::ConstPtr&)>(
            [this](const geometry_msgs::Vector3Stamped::ConstPtr&) {
              std::lock_guard<std::mutex> lock(mutex_);
              ++gyro_biases_;
            }));
  }
  std::size_t odometry_count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return odometry_.size();
  }
  std::vector<nav_msgs::Odometry> odometry() {
    std::lock_guard<std::mutex> lock(mutex_);
    return odometry_;
  }
  std::vector<geometry_msgs::TransformStamped> transforms() {
    std::lock_guard<std::mutex> lock(mutex_);
    return transforms_;
  }
  std::vector<nav_msgs::Odometry> fused() {
    std::lock_guard<std::mutex> lock(mutex_);
    return fused_states_;
  }
  std::size_t gyro_biases() {
    std::lock_guard<std::mutex> lock(mutex_);
    return gyro_biases_;
  }
  /// The fused states and the gyro-bias messages counted so far, at one instant.
  std::pair<std::vector<nav_msgs::Odometry>, std::size_t> fused_and_gyro_biases() {
    std::lock_guard<std::mutex> lock(mutex_);
    return {fused_states_, gyro_biases_};
  }
  [[nodiscard]] bool connected() const { return odom_.getNumPublishers() > 0; }

 private:
  std::string child_frame_;
  std::mutex mutex_;
  std::vector<nav_msgs::Odometry> odometry_, fused_states_;
  std::vector<geometry_msgs::TransformStamped> transforms_;
  std::size_t gyro_biases_ = 0;
  ::ros::Subscriber odom_, tf_, fused_, gyro_bias_;
};

/// A node in its own namespace (so that tests of one process never see each other's topics).
class LiveNode {
 public:
  LiveNode(const std::string& ns, std::vector<std::string> params)
      : ns_("/" + ns), log_(RosTestEnvironment::instance().dir() / (ns + ".log")) {
    std::vector<std::string> argv{KESTREL_ROS_BINARY, "node", "__name:=kestrel", "__ns:=" + ns_};
    argv.insert(argv.end(), params.begin(), params.end());
    process_ =
        std::make_unique<ChildProcess>(argv,
                                       ros_child_env(RosTestEnvironment::instance().master_uri(),
                                                     RosTestEnvironment::instance().dir()),
                                       log_);
  }
  [[nodiscard]] std::string topic(const std::string& relative) const {
    return ns_ + "/" + relative;
  }
  [[nodiscard]] std::string node() const { return ns_ + "/kestrel"; }
  ChildProcess& process() { return *process_; }
  [[nodiscard]] std::string log() const { return process_->log(); }
  /// Waits until the log holds `text`.
  bool wait_for_log(const std::string& text, double timeout_s) {
    return wait_until([&] { return log().find(text) != std::string::npos; }, timeout_s);
  }

 private:
  std::string ns_;
  fs::path log_;
  std::unique_ptr<ChildProcess> process_;
};

bool wait_for_subscribers(const ::ros::Publisher& pub, double timeout_s = 30.0) {
  return wait_until([&] { return pub.getNumSubscribers() > 0; }, timeout_s);
}

void expect_stops_cleanly(LiveNode& node, const std::string& statistics) {
  const int code = node.process().stop(15.0);
  EXPECT_EQ(code, 0) << "the node did not stop cleanly on SIGINT (-1: had to be killed)\n"
                     << node.log();
  EXPECT_NE(node.log().find("kestrel_ros: stopped: " + statistics), std::string::npos)
      << node.log();
}

// (b) The node on the first frames of fr1/rpy: one Odometry and one TF per frame, at the
// library's poses (same frames, same code: equal to rounding), with ROS covariances.
TEST(RosLiveNode, RgbdOdometryAndTfMatchTheLibrary) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  KESTREL_REQUIRE_ROS_MASTER();
  const std::string folder = (shared_data_dir() / kTumRpyPart1).string();
  constexpr std::size_t kFrames = 15;
  const auto reference = library_rgbd_trajectory(folder, "fr1", kFrames);
  ::ros::NodeHandle nh;
  LiveNode node("rgbd", {"_camera:=fr1", "_warn_period:=0.001"});
  Collector collector(nh, node.node(), "openni_rgb_optical_frame");
  auto pub_rgb = nh.advertise<sensor_msgs::Image>(node.topic("camera/rgb/image_color"), 10);
  auto pub_depth = nh.advertise<sensor_msgs::Image>(node.topic("camera/depth/image"), 10);
  ASSERT_TRUE(wait_for_subscribers(pub_rgb) && wait_for_subscribers(pub_depth)) << node.log();
  ASSERT_TRUE(wait_until([&] { return collector.connected(); }, 30.0)) << node.log();

  const ros::TumFolder tum(folder);
  for (std::size_t i = 0; i < kFrames; ++i) {
    const ros::TumFrame f = tum.load(i);
    pub_depth.publish(depth32(f.depth_m, f.depth_t_ns));
    pub_rgb.publish(rgb8(f.bgr, f.t_ns));
    ASSERT_TRUE(wait_until([&] { return collector.odometry_count() == i + 1; }, 30.0))
        << "no odometry for frame " << i << "\n"
        << node.log();
  }
  ASSERT_TRUE(wait_until([&] { return collector.transforms().size() >= kFrames; }, 10.0))
      << node.log();

  const auto odometry = collector.odometry();
  double max_dp = 0.0, max_dq = 0.0;
  for (std::size_t i = 0; i < kFrames; ++i) {
    const nav_msgs::Odometry& m = odometry[i];
    EXPECT_EQ(ros::to_ns(m.header.stamp), reference[i].t_ns);
    EXPECT_EQ(m.header.frame_id, "odom");
    EXPECT_EQ(m.child_frame_id, "openni_rgb_optical_frame");
    const Eigen::Vector3d p(m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z);
    const Eigen::Quaterniond q(m.pose.pose.orientation.w, m.pose.pose.orientation.x,
                               m.pose.pose.orientation.y, m.pose.pose.orientation.z);
    const auto [dp, dq] = pose_difference(p, q, reference[i].p, reference[i].q);
    max_dp = std::max(max_dp, dp);
    max_dq = std::max(max_dq, dq);
    for (int k = 0; k < 6; ++k) {
      const double variance = m.pose.covariance[static_cast<std::size_t>(7 * k)];
      if (i == 0) {
        EXPECT_EQ(variance, 0.0);
      } else {
        EXPECT_GT(variance, 0.0) << "frame " << i;
        EXPECT_LT(variance, 1.0) << "frame " << i;
      }
    }
    if (i > 0) {
      EXPECT_GT(m.twist.covariance[0], 0.0);
    }
  }
  EXPECT_LT(max_dp, 1e-9);
  EXPECT_LT(max_dq, 1e-9);
  std::cout << "live node vs library: " << kFrames << " poses, max |dp| " << max_dp
            << " m, max rotation difference " << max_dq << " rad\n";

  const auto transforms = collector.transforms();
  const geometry_msgs::TransformStamped& last = transforms.back();
  EXPECT_EQ(last.header.frame_id, "odom");
  EXPECT_EQ(ros::to_ns(last.header.stamp), reference.back().t_ns);
  EXPECT_NEAR(last.transform.translation.x, reference.back().p.x(), 1e-9);
  EXPECT_NEAR(last.transform.translation.z, reference.back().p.z(), 1e-9);
  expect_stops_cleanly(node, "published=15 dropped=0");
}

// (c) Frames with unexpected encodings, a truncated image and a wrong size between good
// frames: each is dropped with a warning naming topic and problem; later frames are tracked.
TEST(RosLiveNode, BadFramesAreDroppedWithWarningsAndTheNodeGoesOn) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  KESTREL_REQUIRE_ROS_MASTER();
  const std::string folder = (shared_data_dir() / kTumRpyPart1).string();
  ::ros::NodeHandle nh;
  LiveNode node("bad", {"_camera:=fr1", "_warn_period:=0.001"});
  Collector collector(nh, node.node(), "openni_rgb_optical_frame");
  auto pub_rgb = nh.advertise<sensor_msgs::Image>(node.topic("camera/rgb/image_color"), 10);
  auto pub_depth = nh.advertise<sensor_msgs::Image>(node.topic("camera/depth/image"), 10);
  ASSERT_TRUE(wait_for_subscribers(pub_rgb) && wait_for_subscribers(pub_depth)) << node.log();
  ASSERT_TRUE(wait_until([&] { return collector.connected(); }, 30.0)) << node.log();

  const ros::TumFolder tum(folder);
  const ros::TumFrame f0 = tum.load(0);
  pub_depth.publish(depth32(f0.depth_m, f0.depth_t_ns));
  pub_rgb.publish(rgb8(f0.bgr, f0.t_ns));
  ASSERT_TRUE(wait_until([&] { return collector.odometry_count() == 1; }, 30.0)) << node.log();

  // Bad frames 1 ms apart after frame 0, each pair stamped alike (paired with each other).
  std::int64_t t = f0.t_ns;
  const auto bad_pair = [&](const sensor_msgs::ImagePtr& rgb, const sensor_msgs::ImagePtr& depth) {
    t += 1'000'000;
    rgb->header.stamp = depth->header.stamp = ros::to_ros_time(t);
    pub_depth.publish(depth);
    pub_rgb.publish(rgb);
  };
  cv::Mat grey, grey16, depth8, small_bgr, small_depth;
  cv::cvtColor(f0.bgr, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey16, CV_16UC1, 256.0);
  f0.depth_m.convertTo(depth8, CV_8UC1, 40.0);
  cv::resize(f0.bgr, small_bgr, cv::Size(320, 240));
  cv::resize(f0.depth_m, small_depth, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);

  bad_pair(image_message(grey16, enc::MONO16, 0, "cam"), depth32(f0.depth_m, 0));
  EXPECT_TRUE(
      node.wait_for_log("unexpected encoding 'mono16' 640x480 for an intensity image", 20.0))
      << node.log();
  bad_pair(rgb8(f0.bgr, 0), image_message(depth8, "8UC1", 0, "cam"));
  EXPECT_TRUE(node.wait_for_log("unexpected encoding '8UC1' 640x480 for a depth image", 20.0))
      << node.log();
  auto truncated = rgb8(f0.bgr, 0);
  truncated->data.resize(1000);
  bad_pair(truncated, depth32(f0.depth_m, 0));
  EXPECT_TRUE(node.wait_for_log("1000 bytes of data, 921600 expected", 20.0)) << node.log();
  bad_pair(rgb8(small_bgr, 0), depth32(small_depth, 0));
  EXPECT_TRUE(node.wait_for_log("invalid_input: ", 20.0)) << node.log();
  const std::string log = node.log();
  EXPECT_NE(log.find(node.topic("camera/rgb/image_color") + " at t="), std::string::npos) << log;
  EXPECT_NE(log.find(node.topic("camera/depth/image") + " at t="), std::string::npos) << log;

  for (std::size_t i = 1; i < 5; ++i) {
    const ros::TumFrame f = tum.load(i);
    pub_depth.publish(depth32(f.depth_m, f.depth_t_ns));
    pub_rgb.publish(rgb8(f.bgr, f.t_ns));
    ASSERT_TRUE(wait_until([&] { return collector.odometry_count() == i + 1; }, 30.0))
        << "frame " << i << " after the bad ones was not tracked\n"
        << node.log();
  }
  const auto odometry = collector.odometry();
  EXPECT_EQ(ros::to_ns(odometry.back().header.stamp), tum.load(4).t_ns);
  expect_stops_cleanly(node, "published=5 dropped=4");
}

// Without ~camera the node waits for camera_info (saying so) and starts on the first one.
TEST(RosLiveNode, WaitsForCameraInfoWhenNoCameraIsGiven) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  KESTREL_REQUIRE_ROS_MASTER();
  ::ros::NodeHandle nh;
  LiveNode node("info", {"_warn_period:=0.001", "_odom_frame:=/my_odom", "_camera_frame:=kinect"});
  Collector collector(nh, node.node(), "kinect");
  auto pub_rgb = nh.advertise<sensor_msgs::Image>(node.topic("camera/rgb/image_color"), 10);
  auto pub_depth = nh.advertise<sensor_msgs::Image>(node.topic("camera/depth/image"), 10);
  auto pub_info = nh.advertise<sensor_msgs::CameraInfo>(node.topic("camera/rgb/camera_info"), 10);
  ASSERT_TRUE(wait_for_subscribers(pub_rgb) && wait_for_subscribers(pub_depth) &&
              wait_for_subscribers(pub_info))
      << node.log();
  ASSERT_TRUE(wait_until([&] { return collector.connected(); }, 30.0)) << node.log();
  const ros::TumFolder tum((shared_data_dir() / kTumRpyPart1).string());
  ros::TumFrame f = tum.load(0);
  pub_depth.publish(depth32(f.depth_m, f.depth_t_ns));
  pub_rgb.publish(rgb8(f.bgr, f.t_ns));
  EXPECT_TRUE(node.wait_for_log("no camera model yet: waiting for " +
                                    node.topic("camera/rgb/camera_info") + " (or set ~camera)",
                                20.0))
      << node.log();
  sensor_msgs::CameraInfo info = ros::camera_info_from_model(ros::load_camera_model("fr1"));
  info.header.stamp = ros::to_ros_time(f.t_ns);
  pub_info.publish(info);
  ASSERT_TRUE(node.wait_for_log("camera from " + node.topic("camera/rgb/camera_info"), 20.0))
      << node.log();
  for (std::size_t i = 1; i < 4; ++i) {
    f = tum.load(i);
    pub_depth.publish(depth32(f.depth_m, f.depth_t_ns));
    pub_rgb.publish(rgb8(f.bgr, f.t_ns));
    ASSERT_TRUE(wait_until([&] { return collector.odometry_count() == i; }, 30.0)) << node.log();
  }
  const auto odometry = collector.odometry();
  EXPECT_EQ(odometry.front().header.frame_id, "my_odom") << "leading '/' removed";
  EXPECT_EQ(odometry.front().child_frame_id, "kinect");
  EXPECT_EQ(odometry.front().pose.pose.position.x, 0.0) << "the first tracked frame is the origin";
  expect_stops_cleanly(node, "published=3 dropped=1");
}

// Stereo + IMU on EuRoC: odometry of the left camera and the fused EKF state.
TEST(RosLiveNode, StereoWithImuPublishesFusedStates) {
  KESTREL_REQUIRE_DATA(kEuroc);
  KESTREL_REQUIRE_ROS_MASTER();
  const std::string folder = (shared_data_dir() / kEuroc).string();
  ::ros::NodeHandle nh;
  LiveNode node("stereo", {"_mode:=stereo", "_stereo_calibration:=" + folder, "_use_imu:=true",
                           "_queue_size:=100", "_warn_period:=0.001"});
  Collector collector(nh, node.node(), "cam0");
  auto pub_left = nh.advertise<sensor_msgs::Image>(node.topic("stereo/left/image_raw"), 100);
  auto pub_right = nh.advertise<sensor_msgs::Image>(node.topic("stereo/right/image_raw"), 100);
  auto pub_imu = nh.advertise<sensor_msgs::Imu>(node.topic("imu"), 2000);
  ASSERT_TRUE(wait_for_subscribers(pub_left) && wait_for_subscribers(pub_right) &&
              wait_for_subscribers(pub_imu))
      << node.log();
  ASSERT_TRUE(wait_until([&] { return collector.connected(); }, 30.0)) << node.log();

  const ros::EurocFolder euroc(folder);
  constexpr std::size_t kPairs = 60;  // the EKF initialises after ~44 (docs/pipeline.md)
  ASSERT_GE(euroc.size(), kPairs);
  std::int64_t from = euroc.load(0).t_ns - 1'000'000'000;
  for (std::size_t i = 0; i < kPairs; ++i) {
    const ros::StereoFrame f = euroc.load(i);
    for (const ros::ImuReading& s : euroc.imu(from, f.t_ns + 1)) {
      sensor_msgs::Imu imu;
      imu.header.stamp = ros::to_ros_time(s.t_ns);
      imu.header.frame_id = "imu4";
      imu.angular_velocity.x = s.gyro_rad_s.x();
      imu.angular_velocity.y = s.gyro_rad_s.y();
      imu.angular_velocity.z = s.gyro_rad_s.z();
      imu.linear_acceleration.x = s.accel_m_s2.x();
      imu.linear_acceleration.y = s.accel_m_s2.y();
      imu.linear_acceleration.z = s.accel_m_s2.z();
      pub_imu.publish(imu);
    }
    from = f.t_ns + 1;
    ::ros::WallDuration(0.02).sleep();  // the IMU before the images, as a driver would
    pub_left.publish(image_message(f.left, enc::MONO8, f.t_ns, "cam0"));
    pub_right.publish(image_message(f.right, enc::MONO8, f.t_ns, "cam1"));
    ASSERT_TRUE(wait_until([&] { return collector.odometry_count() == i + 1; }, 60.0))
        << "no odometry for pair " << i << "\n"
        << node.log();
  }
  // Each fused state comes with a gyro-bias message on its own topic: wait for both (under load
  // the last pair of messages can arrive one after the other's check).
  ASSERT_TRUE(wait_until(
      [&] {
        const auto [states, biases] = collector.fused_and_gyro_biases();
        return states.size() >= 5 && biases == states.size();
      },
      10.0))
      << collector.fused().size() << " fused states, " << collector.gyro_biases()
      << " gyro biases\n"
      << node.log();
  const auto [fused, gyro_biases] = collector.fused_and_gyro_biases();
  for (const auto& s : fused) {
    EXPECT_EQ(s.header.frame_id, "world");
    EXPECT_EQ(s.child_frame_id, "imu4");
    EXPECT_LT(std::abs(s.pose.pose.position.x) + std::abs(s.pose.pose.position.y) +
                  std::abs(s.pose.pose.position.z),
              1.0);
    EXPECT_GT(s.pose.covariance[0], 0.0);
  }
  EXPECT_EQ(gyro_biases, fused.size());
  std::cout << "stereo + IMU live: " << collector.odometry_count() << " odometry, " << fused.size()
            << " fused states\n";
  expect_stops_cleanly(node, "published=60 dropped=0");
}

TEST(RosLiveNode, BadParametersStopTheNodeWithTheReason) {
  KESTREL_REQUIRE_ROS_MASTER();
  LiveNode node("param", {"_mode:=lidar"});
  EXPECT_EQ(node.process().wait_exit(30.0), 1) << node.log();
  EXPECT_NE(node.log().find("parameter ~mode: rgbd or stereo, got 'lidar'"), std::string::npos)
      << node.log();
  LiveNode missing("missing", {"_camera:=/nonexistent/camera.yaml"});
  EXPECT_EQ(missing.process().wait_exit(30.0), 1) << missing.log();
  EXPECT_NE(missing.log().find("/nonexistent/camera.yaml"), std::string::npos) << missing.log();
}

// No master: the node waits for one, saying so (roscpp's "Failed to contact master at
// [127.0.0.1:PORT]" while ros::init sets the _params, or Kestrel's "no ROS master at ..."), and
// still stops on SIGINT.
TEST(RosLiveNode, StopsOnSigintWhileWaitingForAMaster) {
  const fs::path dir = fresh_temp_dir("ros_no_master");
  const std::string port = std::to_string(free_loopback_port());
  const std::string uri = "http://127.0.0.1:" + port;
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{KESTREL_ROS_BINARY, "node", "_camera:=fr1"},
        std::vector<std::string>{KESTREL_ROS_BINARY, "node"}}) {
    ChildProcess node(args, ros_child_env(uri, dir), dir / "node.log");
    EXPECT_TRUE(wait_until(
        [&] {
          const std::string log = node.log();
          return log.find("Failed to contact master at [127.0.0.1:" + port + "]") !=
                     std::string::npos ||
                 log.find("no ROS master at " + uri) != std::string::npos;
        },
        20.0))
        << node.log();
    EXPECT_TRUE(node.running());
    const int code = node.stop(15.0);
    EXPECT_NE(code, -1) << "SIGINT did not stop the node waiting for a master\n" << node.log();
  }
}

}  // namespace
}  // namespace kestrel::test
