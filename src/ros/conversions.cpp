// ROS message <-> odometry core conversions (C++17; see conversions.hpp).
#include "conversions.hpp"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>

namespace kestrel::ros {
namespace enc = sensor_msgs::image_encodings;

namespace {

bool host_is_big_endian() {
  const std::uint16_t probe = 1;
  return *reinterpret_cast<const std::uint8_t*>(&probe) == 0;
}

std::string describe_image(const sensor_msgs::Image& msg) {
  std::ostringstream os;
  os << "'" << msg.encoding << "' " << msg.width << "x" << msg.height;
  return os.str();
}

void set_covariance(boost::array<double, 36>& out, const Eigen::Matrix<double, 6, 6>& c) {
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) out[static_cast<std::size_t>(6 * r + k)] = c(r, k);
  }
}

}  // namespace

std::string check_image_layout(const sensor_msgs::Image& msg) {
  if (msg.width == 0 || msg.height == 0) return "empty image " + describe_image(msg);
  int channels = 0, bytes = 0;
  try {
    channels = enc::numChannels(msg.encoding);
    bytes = enc::bitDepth(msg.encoding) / 8;
  } catch (const std::exception& e) {
    return "unknown encoding " + describe_image(msg) + ": " + e.what();
  }
  const std::uint64_t row_bytes =
      static_cast<std::uint64_t>(msg.width) * static_cast<std::uint64_t>(channels * bytes);
  if (msg.step < row_bytes) {
    std::ostringstream os;
    os << "image " << describe_image(msg) << ": step " << msg.step << " is less than a row ("
       << row_bytes << " bytes)";
    return os.str();
  }
  const std::uint64_t needed = static_cast<std::uint64_t>(msg.step) * msg.height;
  if (msg.data.size() < needed) {
    std::ostringstream os;
    os << "image " << describe_image(msg) << ": " << msg.data.size() << " bytes of data, " << needed
       << " expected (step " << msg.step << " x height " << msg.height << ")";
    return os.str();
  }
  if (bytes > 1 && static_cast<bool>(msg.is_bigendian) != host_is_big_endian()) {
    return "image " + describe_image(msg) + ": byte order differs from this machine's";
  }
  return {};
}

ImageConversion intensity_image(const sensor_msgs::Image& msg) {
  ImageConversion out;
  const std::string& e = msg.encoding;
  const bool colour = e == enc::BGR8 || e == enc::RGB8 || e == enc::BGRA8 || e == enc::RGBA8;
  if (!colour && e != enc::MONO8) {
    out.error = "unexpected encoding " + describe_image(msg) +
                " for an intensity image (expected bgr8, rgb8, bgra8, rgba8 or mono8)";
    return out;
  }
  out.error = check_image_layout(msg);
  if (!out.ok()) return out;
  try {
    out.image = cv_bridge::toCvCopy(msg, colour ? enc::BGR8 : enc::MONO8)->image;
  } catch (const std::exception& ex) {  // cv_bridge::Exception, cv::Exception
    out.error = "cannot convert " + describe_image(msg) + ": " + ex.what();
  }
  return out;
}

ImageConversion depth_image(const sensor_msgs::Image& msg, double depth_unit_m) {
  ImageConversion out;
  const std::string& e = msg.encoding;
  if (e != enc::TYPE_32FC1 && e != enc::TYPE_16UC1 && e != enc::MONO16) {
    out.error = "unexpected encoding " + describe_image(msg) +
                " for a depth image (expected 32FC1 in metres, or 16UC1 / mono16)";
    return out;
  }
  out.error = check_image_layout(msg);
  if (!out.ok()) return out;
  try {
    const cv::Mat raw = cv_bridge::toCvShare(msg, nullptr)->image;  // aliases msg, copied below
    if (e == enc::TYPE_32FC1) {
      out.image = raw.clone();
    } else {
      raw.convertTo(out.image, CV_32FC1, depth_unit_m);
    }
  } catch (const std::exception& ex) {
    out.error = "cannot convert " + describe_image(msg) + ": " + ex.what();
  }
  return out;
}

std::optional<CameraModel> camera_from_info(const sensor_msgs::CameraInfo& info,
                                            std::string& error) {
  if (info.width == 0 || info.height == 0) {
    error = "camera_info has no image size";
    return std::nullopt;
  }
  if (!(info.K[0] > 0.0) || !(info.K[4] > 0.0)) {
    error = "camera_info has no intrinsics (K is zero)";
    return std::nullopt;
  }
  CameraModel c;
  c.width = static_cast<int>(info.width);
  c.height = static_cast<int>(info.height);
  c.fx = info.K[0];
  c.fy = info.K[4];
  c.cx = info.K[2];
  c.cy = info.K[5];
  const bool plumb_bob =
      info.distortion_model == "plumb_bob" || info.distortion_model == "rational_polynomial";
  if (!info.D.empty() && !plumb_bob) {
    error = "camera_info distortion model '" + info.distortion_model +
            "' is not supported (plumb_bob: k1 k2 p1 p2 k3)";
    return std::nullopt;
  }
  if (info.distortion_model == "rational_polynomial") {
    for (std::size_t i = 5; i < info.D.size(); ++i) {
      if (info.D[i] != 0.0) {
        error = "camera_info rational_polynomial with k4..k6 is not supported";
        return std::nullopt;
      }
    }
  } else if (info.D.size() > 5) {
    error = "camera_info has " + std::to_string(info.D.size()) + " distortion coefficients";
    return std::nullopt;
  }
  for (std::size_t i = 0; i < info.D.size() && i < 5; ++i) c.distortion[i] = info.D[i];
  error = check_camera_model(c);
  if (!error.empty()) return std::nullopt;
  return c;
}

sensor_msgs::CameraInfo camera_info_from_model(const CameraModel& camera) {
  sensor_msgs::CameraInfo info;
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(camera.distortion.begin(), camera.distortion.end());
  info.K = {camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx, 0.0, camera.cx, 0.0, 0.0, camera.fy, camera.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

std::int64_t to_ns(const ::ros::Time& t) {
  return static_cast<std::int64_t>(t.sec) * 1'000'000'000 + static_cast<std::int64_t>(t.nsec);
}

::ros::Time to_ros_time(std::int64_t t_ns) {
  ::ros::Time t;
  t.sec = static_cast<std::uint32_t>(t_ns / 1'000'000'000);
  t.nsec = static_cast<std::uint32_t>(t_ns % 1'000'000'000);
  return t;
}

std::string clean_frame_id(const std::string& frame_id) {
  std::size_t start = 0;
  while (start < frame_id.size() && frame_id[start] == '/') ++start;
  return frame_id.substr(start);
}

nav_msgs::Odometry odometry_message(const OdometryOutput& out,
                                    const Eigen::Isometry3d& T_odom_child,
                                    const std::string& odom_frame, const std::string& child_frame) {
  nav_msgs::Odometry msg;
  msg.header.stamp = to_ros_time(out.t_ns);
  msg.header.frame_id = odom_frame;
  msg.child_frame_id = child_frame;
  const Eigen::Vector3d p = T_odom_child.translation();
  const Eigen::Quaterniond q(T_odom_child.rotation());
  msg.pose.pose.position.x = p.x();
  msg.pose.pose.position.y = p.y();
  msg.pose.pose.position.z = p.z();
  msg.pose.pose.orientation.x = q.x();
  msg.pose.pose.orientation.y = q.y();
  msg.pose.pose.orientation.z = q.z();
  msg.pose.pose.orientation.w = q.w();
  set_covariance(msg.pose.covariance, out.pose_covariance);
  if (out.has_twist) {
    msg.twist.twist.linear.x = out.twist(0);
    msg.twist.twist.linear.y = out.twist(1);
    msg.twist.twist.linear.z = out.twist(2);
    msg.twist.twist.angular.x = out.twist(3);
    msg.twist.twist.angular.y = out.twist(4);
    msg.twist.twist.angular.z = out.twist(5);
    set_covariance(msg.twist.covariance, out.twist_covariance);
  } else {
    // No previous frame: velocity unknown. A variance of -1 marks it, as in sensor_msgs/Imu.
    set_covariance(msg.twist.covariance, -Eigen::Matrix<double, 6, 6>::Identity());
  }
  return msg;
}

geometry_msgs::TransformStamped transform_message(const Eigen::Isometry3d& T_parent_child,
                                                  std::int64_t t_ns, const std::string& parent,
                                                  const std::string& child) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = to_ros_time(t_ns);
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  const Eigen::Vector3d p = T_parent_child.translation();
  const Eigen::Quaterniond q(T_parent_child.rotation());
  msg.transform.translation.x = p.x();
  msg.transform.translation.y = p.y();
  msg.transform.translation.z = p.z();
  msg.transform.rotation.x = q.x();
  msg.transform.rotation.y = q.y();
  msg.transform.rotation.z = q.z();
  msg.transform.rotation.w = q.w();
  return msg;
}

nav_msgs::Odometry fused_message(const FusedOutput& state, const Eigen::Vector3d& last_gyro_rad_s,
                                 const std::string& world_frame, const std::string& body_frame) {
  nav_msgs::Odometry msg;
  msg.header.stamp = to_ros_time(state.t_ns);
  msg.header.frame_id = world_frame;
  msg.child_frame_id = body_frame;
  msg.pose.pose.position.x = state.p_world.x();
  msg.pose.pose.position.y = state.p_world.y();
  msg.pose.pose.position.z = state.p_world.z();
  const Eigen::Quaterniond q = state.q_world_body.normalized();
  msg.pose.pose.orientation.x = q.x();
  msg.pose.pose.orientation.y = q.y();
  msg.pose.pose.orientation.z = q.z();
  msg.pose.pose.orientation.w = q.w();
  // The EKF's attitude error is in the body frame (q <- q exp(dtheta)); ROS wants it about the
  // world axes: R diag(sigma^2) R^T. Only the standard deviations are available (no
  // cross-correlations between position, attitude and velocity).
  const Eigen::Matrix3d R = q.toRotationMatrix();
  Eigen::Matrix<double, 6, 6> pose_cov = Eigen::Matrix<double, 6, 6>::Zero();
  pose_cov.block<3, 3>(0, 0) = state.sigma.head<3>().cwiseAbs2().asDiagonal();
  pose_cov.block<3, 3>(3, 3) =
      R * Eigen::Matrix3d(state.sigma.segment<3>(3).cwiseAbs2().asDiagonal()) * R.transpose();
  set_covariance(msg.pose.covariance, pose_cov);
  const Eigen::Vector3d v_body = R.transpose() * state.v_world;
  const Eigen::Vector3d w_body = last_gyro_rad_s - state.gyro_bias_rad_s;
  msg.twist.twist.linear.x = v_body.x();
  msg.twist.twist.linear.y = v_body.y();
  msg.twist.twist.linear.z = v_body.z();
  msg.twist.twist.angular.x = w_body.x();
  msg.twist.twist.angular.y = w_body.y();
  msg.twist.twist.angular.z = w_body.z();
  Eigen::Matrix<double, 6, 6> twist_cov = Eigen::Matrix<double, 6, 6>::Zero();
  twist_cov.block<3, 3>(0, 0) =
      R.transpose() * Eigen::Matrix3d(state.sigma.tail<3>().cwiseAbs2().asDiagonal()) * R;
  // Angular rate: the gyro's noise is not known here; a variance of -1 marks it unknown.
  twist_cov.block<3, 3>(3, 3) = -Eigen::Matrix3d::Identity();
  set_covariance(msg.twist.covariance, twist_cov);
  return msg;
}

}  // namespace kestrel::ros
