// ROS message conversions: accepted encodings, every rejection reported with what was wrong
// (never an out-of-bounds read of a short message), camera_info, Odometry/TF messages.
#include <gtest/gtest.h>
#include <sensor_msgs/image_encodings.h>

#include "conversions.hpp"

namespace kestrel::ros {
namespace {

namespace enc = sensor_msgs::image_encodings;

sensor_msgs::Image make_image(const std::string& encoding, int width, int height,
                              int bytes_per_px) {
  sensor_msgs::Image m;
  m.encoding = encoding;
  m.width = static_cast<std::uint32_t>(width);
  m.height = static_cast<std::uint32_t>(height);
  m.step = static_cast<std::uint32_t>(width * bytes_per_px);
  m.data.assign(static_cast<std::size_t>(m.step) * m.height, 0);
  return m;
}

TEST(RosConversions, ColourEncodingsBecomeBgrOrGrey) {
  sensor_msgs::Image rgb = make_image(enc::RGB8, 4, 2, 3);
  rgb.data[0] = 10;  // R of pixel (0, 0)
  rgb.data[1] = 20;
  rgb.data[2] = 30;
  ImageConversion c = intensity_image(rgb);
  ASSERT_TRUE(c.ok()) << c.error;
  EXPECT_EQ(c.image.type(), CV_8UC3);
  EXPECT_EQ(c.image.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
  for (const auto& [encoding, bytes] :
       std::vector<std::pair<std::string, int>>{{enc::BGR8, 3}, {enc::BGRA8, 4}, {enc::RGBA8, 4}}) {
    c = intensity_image(make_image(encoding, 4, 2, bytes));
    EXPECT_TRUE(c.ok()) << encoding << ": " << c.error;
    EXPECT_EQ(c.image.type(), CV_8UC3) << encoding;
  }
  c = intensity_image(make_image(enc::MONO8, 4, 2, 1));
  ASSERT_TRUE(c.ok()) << c.error;
  EXPECT_EQ(c.image.type(), CV_8UC1);
}

TEST(RosConversions, UnexpectedIntensityEncodingsAreNamed) {
  for (const auto& [encoding, bytes] :
       std::vector<std::pair<std::string, int>>{{enc::MONO16, 2},
                                                {enc::TYPE_32FC1, 4},
                                                {enc::BAYER_RGGB8, 1},
                                                {"yuv422", 2},
                                                {"no_such_encoding", 1}}) {
    const ImageConversion c = intensity_image(make_image(encoding, 4, 2, bytes));
    EXPECT_FALSE(c.ok()) << encoding;
    EXPECT_NE(c.error.find("unexpected encoding '" + encoding + "'"), std::string::npos) << c.error;
  }
}

TEST(RosConversions, DepthInMetresOrMillimetres) {
  sensor_msgs::Image metres = make_image(enc::TYPE_32FC1, 2, 1, 4);
  const float d = 1.25f;
  std::memcpy(metres.data.data(), &d, sizeof d);
  ImageConversion c = depth_image(metres, 0.001);
  ASSERT_TRUE(c.ok()) << c.error;
  EXPECT_EQ(c.image.type(), CV_32FC1);
  EXPECT_EQ(c.image.at<float>(0, 0), 1.25f);
  EXPECT_EQ(c.image.at<float>(0, 1), 0.0f);

  sensor_msgs::Image mm = make_image(enc::TYPE_16UC1, 2, 1, 2);
  const std::uint16_t v = 1250;
  std::memcpy(mm.data.data(), &v, sizeof v);
  c = depth_image(mm, 0.001);
  ASSERT_TRUE(c.ok()) << c.error;
  EXPECT_FLOAT_EQ(c.image.at<float>(0, 0), 1.25f);
  EXPECT_EQ(c.image.at<float>(0, 1), 0.0f);  // 0 = no depth stays 0

  for (const auto& [encoding, bytes] : std::vector<std::pair<std::string, int>>{
           {"8UC1", 1}, {enc::RGB8, 3}, {enc::TYPE_64FC1, 8}}) {
    c = depth_image(make_image(encoding, 2, 1, bytes), 0.001);
    EXPECT_FALSE(c.ok()) << encoding;
    EXPECT_NE(c.error.find("unexpected encoding '" + encoding + "'"), std::string::npos) << c.error;
  }
}

TEST(RosConversions, InconsistentLayoutsAreRejectedBeforeReading) {
  sensor_msgs::Image shortened = make_image(enc::RGB8, 640, 480, 3);
  shortened.data.resize(shortened.data.size() / 2);
  ImageConversion c = intensity_image(shortened);
  EXPECT_FALSE(c.ok());
  EXPECT_NE(c.error.find("460800 bytes of data, 921600 expected"), std::string::npos) << c.error;

  sensor_msgs::Image narrow_step = make_image(enc::TYPE_32FC1, 10, 2, 4);
  narrow_step.step = 20;
  c = depth_image(narrow_step, 0.001);
  EXPECT_FALSE(c.ok());
  EXPECT_NE(c.error.find("step 20 is less than a row (40 bytes)"), std::string::npos) << c.error;

  c = intensity_image(make_image(enc::RGB8, 0, 0, 3));
  EXPECT_FALSE(c.ok());
  EXPECT_NE(c.error.find("empty image"), std::string::npos) << c.error;

  sensor_msgs::Image swapped = make_image(enc::TYPE_16UC1, 2, 2, 2);
  swapped.is_bigendian = 1;
  c = depth_image(swapped, 0.001);
  EXPECT_FALSE(c.ok());
  EXPECT_NE(c.error.find("byte order"), std::string::npos) << c.error;

  // A padded step (rows longer than the pixels) is fine.
  sensor_msgs::Image padded = make_image(enc::MONO8, 3, 2, 1);
  padded.step = 8;
  padded.data.assign(16, 7);
  c = intensity_image(padded);
  ASSERT_TRUE(c.ok()) << c.error;
  EXPECT_EQ(c.image.cols, 3);
  EXPECT_EQ(c.image.at<std::uint8_t>(1, 2), 7);
}

TEST(RosConversions, CameraInfoRoundTripAndRejections) {
  CameraModel fr1;
  fr1.width = 640;
  fr1.height = 480;
  fr1.fx = 517.3;
  fr1.fy = 516.5;
  fr1.cx = 318.6;
  fr1.cy = 255.3;
  fr1.distortion = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  const sensor_msgs::CameraInfo info = camera_info_from_model(fr1);
  std::string error;
  const auto back = camera_from_info(info, error);
  ASSERT_TRUE(back) << error;
  EXPECT_EQ(back->fx, fr1.fx);
  EXPECT_EQ(back->cy, fr1.cy);
  EXPECT_EQ(back->distortion, fr1.distortion);

  sensor_msgs::CameraInfo zero = info;
  zero.K = {};
  EXPECT_FALSE(camera_from_info(zero, error));
  EXPECT_NE(error.find("K is zero"), std::string::npos) << error;
  sensor_msgs::CameraInfo fisheye = info;
  fisheye.distortion_model = "equidistant";
  EXPECT_FALSE(camera_from_info(fisheye, error));
  EXPECT_NE(error.find("'equidistant' is not supported"), std::string::npos) << error;
  sensor_msgs::CameraInfo no_size = info;
  no_size.width = 0;
  EXPECT_FALSE(camera_from_info(no_size, error));
  EXPECT_NE(error.find("no image size"), std::string::npos) << error;
}

TEST(RosConversions, OdometryMessageCarriesPoseCovarianceAndTwist) {
  OdometryOutput out;
  out.t_ns = 1305031229'728464000;
  out.ok = true;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 0, 1)).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, 2, 3);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) out.pose_covariance(r, c) = 10 * r + c;
  }
  out.has_twist = true;
  out.twist << 0.1, 0.2, 0.3, 0.4, 0.5, 0.6;
  out.twist_covariance = 2.0 * Eigen::Matrix<double, 6, 6>::Identity();
  const nav_msgs::Odometry msg = odometry_message(out, T, "odom", "camera");
  EXPECT_EQ(msg.header.stamp.sec, 1305031229u);
  EXPECT_EQ(msg.header.stamp.nsec, 728464000u);
  EXPECT_EQ(msg.header.frame_id, "odom");
  EXPECT_EQ(msg.child_frame_id, "camera");
  EXPECT_DOUBLE_EQ(msg.pose.pose.position.y, 2.0);
  EXPECT_NEAR(msg.pose.pose.orientation.z, std::sin(0.15), 1e-15);
  EXPECT_EQ(msg.pose.covariance[6 * 2 + 4], 24.0);  // row-major, [x y z rx ry rz]
  EXPECT_EQ(msg.twist.twist.angular.z, 0.6);
  EXPECT_EQ(msg.twist.covariance[7], 2.0);
  const geometry_msgs::TransformStamped tf = transform_message(T, out.t_ns, "odom", "camera");
  EXPECT_EQ(tf.header.frame_id, "odom");
  EXPECT_EQ(tf.child_frame_id, "camera");
  EXPECT_DOUBLE_EQ(tf.transform.translation.z, 3.0);
  EXPECT_NEAR(tf.transform.rotation.w, std::cos(0.15), 1e-15);

  OdometryOutput first = out;
  first.has_twist = false;
  EXPECT_EQ(odometry_message(first, T, "odom", "camera").twist.covariance[0], -1.0)
      << "unknown velocity is marked";
}

TEST(RosConversions, TimesAndFrameIds) {
  EXPECT_EQ(to_ns(to_ros_time(1305031229'728464123)), 1305031229'728464123);
  EXPECT_EQ(clean_frame_id("/openni_rgb_optical_frame"), "openni_rgb_optical_frame");
  EXPECT_EQ(clean_frame_id("base_link"), "base_link");
}

}  // namespace
}  // namespace kestrel::ros
