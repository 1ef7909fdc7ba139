// The live ROS 1 node of `kestrel_ros node`: subscribes to RGB-D (colour + depth, paired by
// nearest time stamp) or stereo (left + right) images and optionally an IMU; publishes the
// camera's nav_msgs/Odometry, the odom -> camera (or base) TF and the fused EKF state.
// Parameters and topics: docs/ros.md. C++17 (ROS headers).
#pragma once

#include <geometry_msgs/Vector3Stamped.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "kestrel/ros/frame_pairing.hpp"
#include "kestrel/ros/odometry_core.hpp"

namespace kestrel::ros {

/// Every parameter of the node with its default (private namespace, ~name).
struct NodeParameters {
  std::string mode = "rgbd";  ///< rgbd or stereo
  std::string camera;         ///< rgbd: preset or file; empty: from the camera_info topic
  std::string tracker_options;
  std::string stereo_calibration;  ///< stereo: stereo_pair YAML or EuRoC folder
  std::string matcher_options;
  std::string matcher;      // stereo: sad, census or sgm; empty: matcher_options' cost
  std::string sgm_options;  // stereo, matcher sgm: SgmOptions YAML
  bool use_imu = false;
  std::string imu_noise;
  std::string fusion_options;
  std::vector<double> T_body_cam;  ///< 16 numbers, row-major; empty: see OdometryCoreOptions
  double vo_covariance_scale = 25.0;
  bool vo_from_keyframe = true;
  double max_imu_hold = 0.5;     ///< s
  double sync_tolerance = 0.02;  ///< s, pairing of the two image streams
  double depth_unit = 0.001;     ///< m per unit of 16UC1 / mono16 depth
  int queue_size = 5;
  std::string odom_frame = "odom";
  std::string camera_frame;  ///< empty: the images' frame_id ("camera" if that is empty too)
  std::string base_frame;    ///< empty: odometry and TF of the camera frame itself
  bool publish_tf = true;
  std::string world_frame = "world";  ///< frame of the fused state
  std::string body_frame;             ///< child frame of the fused state; empty: the IMU's frame_id
  double warn_period = 5.0;           ///< s between repeated warnings of one kind

  /// Reads ~params, keeping the defaults for those not set. Throws std::runtime_error for a
  /// value of the wrong type or out of range, naming the parameter.
  static NodeParameters load(const ::ros::NodeHandle& private_nh);
  /// One "name: value" line per parameter.
  [[nodiscard]] std::string describe() const;
};

class OdometryNode {
 public:
  /// Subscribes and advertises. Throws std::exception (bad parameter, unreadable file).
  OdometryNode(::ros::NodeHandle nh, ::ros::NodeHandle private_nh);
  /// Counters for the shutdown log.
  [[nodiscard]] std::string statistics() const;

 private:
  using ImagePtr = sensor_msgs::ImageConstPtr;

  void on_colour(const ImagePtr& msg);
  void on_depth(const ImagePtr& msg);
  void on_left(const ImagePtr& msg);
  void on_right(const ImagePtr& msg);
  void on_camera_info(const sensor_msgs::CameraInfoConstPtr& msg);
  void on_imu(const sensor_msgs::ImuConstPtr& msg);

  void process_rgbd(const ImagePtr& colour, const ImagePtr& depth);
  void process_stereo(const ImagePtr& left, const ImagePtr& right);
  /// Checks time order and the base frame; false: drop the frame.
  bool prepare_frame(std::int64_t t_ns, const std::string& image_frame_id);
  void publish(const OdometryOutput& out);
  /// Counts a dropped frame and warns (throttled per `kind`).
  void drop(const std::string& kind, const std::string& why);
  /// A warning at most once per warn_period for each `kind`; the repeats in between are
  /// counted and reported with the next one, so distinct problems never hide each other.
  void warn_throttled(const std::string& kind, const std::string& message);

  ::ros::NodeHandle nh_, pnh_;
  NodeParameters params_;
  std::unique_ptr<OdometryCore> core_;
  image_transport::ImageTransport it_;
  image_transport::Subscriber sub_a_, sub_b_;
  ::ros::Subscriber sub_info_, sub_imu_;
  ::ros::Publisher pub_odom_, pub_fused_, pub_gyro_bias_, pub_accel_bias_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;

  NearestTimePairing<ImagePtr, ImagePtr> pairing_;
  std::string child_frame_;  ///< resolved at the first frame
  bool child_resolved_ = false;
  std::optional<std::int64_t> last_frame_ns_;
  Eigen::Vector3d last_gyro_ = Eigen::Vector3d::Zero();
  std::string imu_frame_;
  struct Throttle {
    std::chrono::steady_clock::time_point last;
    std::size_t suppressed = 0;
  };
  std::map<std::string, Throttle> throttles_;
  std::size_t published_ = 0, dropped_ = 0, failures_ = 0, resets_ = 0, imu_rejected_ = 0;
};

/// `kestrel_ros node [ROS remappings and _param:=value]`: ros::init, the node, spin, and a
/// clean stop on SIGINT or shutdown. Returns the exit code.
int run_odometry_node(int argc, char** argv);

}  // namespace kestrel::ros
