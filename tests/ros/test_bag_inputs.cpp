// `kestrel_ros bag` on bags written here with the rosbag API: a bag without the image topics,
// images of unexpected encodings in the middle of a sequence (dropped with a warning naming
// topic and encoding, the rest tracked), and streams that never pair.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/image_encodings.h>

#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "conversions.hpp"
#include "kestrel/ros/dataset_bridge.hpp"
#include "run_ros_cli.hpp"
#include "test_data.hpp"

namespace kestrel::test {
namespace {

namespace fs = std::filesystem;
namespace enc = sensor_msgs::image_encodings;

sensor_msgs::Image image_message(const cv::Mat& m, const std::string& encoding, std::int64_t t_ns) {
  sensor_msgs::Image msg;
  msg.header.stamp = ros::to_ros_time(t_ns);
  msg.header.frame_id = "/openni_rgb_optical_frame";
  msg.width = static_cast<std::uint32_t>(m.cols);
  msg.height = static_cast<std::uint32_t>(m.rows);
  msg.encoding = encoding;
  msg.step = static_cast<std::uint32_t>(m.cols * m.elemSize());
  msg.data.resize(static_cast<std::size_t>(msg.step) * msg.height);
  cv::Mat view(m.rows, m.cols, m.type(), msg.data.data(), msg.step);
  m.copyTo(view);
  return msg;
}

TEST(RosBagInputs, ABagWithoutTheImageTopicsIsNamed) {
  const fs::path scratch = fresh_temp_dir("ros_bag_inputs");
  const fs::path path = scratch / "imu_only.bag";
  {
    rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
    sensor_msgs::Imu imu;
    imu.header.stamp = ros::to_ros_time(1'000'000'000);
    bag.write("/imu", imu.header.stamp, imu);
  }
  const RunResult r =
      run_kestrel_ros(scratch, "bag --bag " + quoted(path.string()) + " --out " +
                                   quoted((scratch / "t.txt").string()) + " --camera fr1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(last_line_of(r.err),
            "kestrel_ros: error: " + path.string() +
                ": no topic /camera/rgb/image_color (colour images; the bag has /imu "
                "(sensor_msgs/Imu); choose another with the topic options)");
  EXPECT_FALSE(fs::exists(scratch / "t.txt"));
}

TEST(RosBagInputs, StreamsThatNeverPairAreAnError) {
  const fs::path scratch = fresh_temp_dir("ros_bag_inputs");
  const fs::path path = scratch / "apart.bag";
  {
    rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
    const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(0));
    const cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(1.0f));
    for (int i = 0; i < 3; ++i) {
      const std::int64_t t = 1'000'000'000 + i * 100'000'000;
      const auto rgb = image_message(grey, enc::MONO8, t);
      const auto d = image_message(depth, enc::TYPE_32FC1, t + 50'000'000);  // 50 ms apart
      bag.write("/camera/rgb/image_color", rgb.header.stamp, rgb);
      bag.write("/camera/depth/image", d.header.stamp, d);
    }
  }
  const RunResult r =
      run_kestrel_ros(scratch, "bag --bag " + quoted(path.string()) + " --out " +
                                   quoted((scratch / "t.txt").string()) + " --camera fr1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no colour/depth image pairs within 20 ms"), std::string::npos) << r.err;
  fs::remove(path);  // test bags are megabytes: not left in /tmp
}

TEST(RosBagInputs, UnexpectedEncodingsAreDroppedAndTheRestIsTracked) {
  KESTREL_REQUIRE_DATA(kTumRpyPart1);
  const fs::path scratch = fresh_temp_dir("ros_bag_inputs");
  const fs::path path = scratch / "mixed.bag";
  const ros::TumFolder tum((shared_data_dir() / kTumRpyPart1).string());
  constexpr std::size_t kFrames = 8;
  {
    rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
    for (std::size_t i = 0; i < kFrames; ++i) {
      const ros::TumFrame f = tum.load(i);
      sensor_msgs::Image rgb = image_message(f.bgr, enc::BGR8, f.t_ns);
      sensor_msgs::Image depth = image_message(f.depth_m, enc::TYPE_32FC1, f.depth_t_ns);
      if (i == 3) {  // colour as 16-bit grey
        cv::Mat grey, grey16;
        cv::cvtColor(f.bgr, grey, cv::COLOR_BGR2GRAY);
        grey.convertTo(grey16, CV_16UC1, 256.0);
        rgb = image_message(grey16, enc::MONO16, f.t_ns);
      }
      if (i == 5) {  // depth as 8-bit
        cv::Mat depth8;
        f.depth_m.convertTo(depth8, CV_8UC1, 40.0);
        depth = image_message(depth8, "8UC1", f.depth_t_ns);
      }
      bag.write("/camera/rgb/image_color", rgb.header.stamp, rgb);
      bag.write("/camera/depth/image", depth.header.stamp, depth);
    }
  }
  const fs::path out = scratch / "t.txt";
  const RunResult r = run_kestrel_ros(scratch, "bag --bag " + quoted(path.string()) + " --out " +
                                                   quoted(out.string()) + " --camera fr1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: /camera/rgb/image_color at t=" +
                       ros::format_seconds(tum.load(3).t_ns) + ": unexpected encoding 'mono16'"),
            std::string::npos)
      << r.err;
  EXPECT_NE(
      r.err.find("warning: /camera/depth/image at t=" +
                 ros::format_seconds(tum.load(5).depth_t_ns) + ": unexpected encoding '8UC1'"),
      std::string::npos)
      << r.err;
  EXPECT_NE(r.out.find("(6 poses, "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 frames dropped"), std::string::npos) << r.out;
  EXPECT_EQ(last_line_of(r.err).rfind("SUMMARY frames=6 failures=", 0), 0u) << r.err;
  fs::remove(path);
}

}  // namespace
}  // namespace kestrel::test
