// `kestrel_ros bag` (odometry over a TUM RGB-D .bag read with the rosbag C++ API) and
// `kestrel_ros make-bag` (a .bag in TUM's topic layout from a TUM folder). C++17 (ROS headers).
#pragma once

#include <cstddef>
#include <string>

namespace kestrel::ros {

/// TUM's topic names in its published bags.
inline constexpr const char* kTumRgbTopic = "/camera/rgb/image_color";
inline constexpr const char* kTumDepthTopic = "/camera/depth/image";
inline constexpr const char* kTumRgbInfoTopic = "/camera/rgb/camera_info";
inline constexpr const char* kTumDepthInfoTopic = "/camera/depth/camera_info";

struct BagOdometryArgs {
  std::string bag;
  std::string out;
  std::string camera;  ///< preset or file; empty: from the bag's name (freiburgN), else camera_info
  std::string config;  ///< tracker options YAML
  bool force = false;
  std::string rgb_topic = kTumRgbTopic;
  std::string depth_topic = kTumDepthTopic;
  std::string camera_info_topic = kTumRgbInfoTopic;
  double depth_unit_m = 0.001;  ///< metres per unit of a 16UC1 depth image (OpenNI: mm)
};

/// Runs the RGB-D odometry over the bag and writes a TUM trajectory. Prints progress and,
/// as the last stderr line, `kestrel odometry`'s SUMMARY line. Throws std::exception with a
/// message naming the file or topic on bad input.
void run_bag_odometry(const BagOdometryArgs& args);

struct MakeBagArgs {
  std::string tum;     ///< TUM RGB-D folder
  std::string out;     ///< .bag to write
  std::string camera;  ///< for camera_info; empty: the folder's camera.yaml, else its freiburgN
  std::size_t max_frames = 0;       ///< 0: every associated frame
  std::string compression = "lz4";  ///< none, lz4, bz2
  bool force = false;
};

/// Writes the folder's associated rgb/depth frames (and camera_info) in TUM's bag layout:
/// rgb8 colour, 32FC1 depth in metres, stamps = the list files' time stamps.
void run_make_bag(const MakeBagArgs& args);

}  // namespace kestrel::ros
