// Conversions between ROS 1 messages and the odometry core's plain types (C++17: includes ROS
// message headers). Every image conversion validates the message before touching its data and
// reports what is wrong instead of throwing, so that a node can log it and drop the frame.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "kestrel/ros/odometry_core.hpp"

namespace kestrel::ros {

/// A converted image, or why it could not be converted (empty error = success).
struct ImageConversion {
  cv::Mat image;  ///< owns its data (never aliases the message)
  std::string error;
  [[nodiscard]] bool ok() const { return error.empty(); }
};

/// Image encodings accepted for intensity images: bgr8, rgb8, bgra8, rgba8 -> CV_8UC3 BGR;
/// mono8 -> CV_8UC1. Anything else (mono16, 16UC1, bayer, ...) is an error naming it.
ImageConversion intensity_image(const sensor_msgs::Image& msg);
/// Depth images: 32FC1 in metres, or 16UC1 / mono16 in units of `depth_unit_m` (OpenNI:
/// millimetres, 0.001) -> CV_32FC1 metres, 0 = no depth. Anything else is an error.
ImageConversion depth_image(const sensor_msgs::Image& msg, double depth_unit_m);
/// The checks shared by both: non-empty, step and data size consistent with the encoding.
std::string check_image_layout(const sensor_msgs::Image& msg);

/// A CameraInfo's K and plumb_bob D (5 coefficients, or none) as a camera model; nullopt with
/// `error` set for another distortion model, a zero K, or a missing size.
std::optional<CameraModel> camera_from_info(const sensor_msgs::CameraInfo& info,
                                            std::string& error);
/// A CameraInfo as TUM's bags and camera drivers publish it (plumb_bob, R = I, P = [K | 0]).
sensor_msgs::CameraInfo camera_info_from_model(const CameraModel& camera);

std::int64_t to_ns(const ::ros::Time& t);
::ros::Time to_ros_time(std::int64_t t_ns);
/// A frame id without a leading '/' (tf2 refuses those; TUM's bags use them).
std::string clean_frame_id(const std::string& frame_id);

/// nav_msgs/Odometry of the camera (pose, 6x6 covariance, body twist) in `odom_frame`.
nav_msgs::Odometry odometry_message(const OdometryOutput& out,
                                    const Eigen::Isometry3d& T_odom_child,
                                    const std::string& odom_frame, const std::string& child_frame);
geometry_msgs::TransformStamped transform_message(const Eigen::Isometry3d& T_parent_child,
                                                  std::int64_t t_ns, const std::string& parent,
                                                  const std::string& child);
/// nav_msgs/Odometry of a fused EKF state: pose and velocity (in the body frame) with
/// covariances from the filter's standard deviations; angular rate = gyro - bias.
nav_msgs::Odometry fused_message(const FusedOutput& state, const Eigen::Vector3d& last_gyro_rad_s,
                                 const std::string& world_frame, const std::string& body_frame);

}  // namespace kestrel::ros
