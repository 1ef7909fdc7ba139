// kestrel_ros: Kestrel's ROS 1 adapter. `node` runs the live odometry node; `bag` runs the
// odometry over a TUM RGB-D .bag read directly; `make-bag` writes such a bag from a TUM folder.
// C++17 (ROS headers; see src/ros/CMakeLists.txt).
#include <CLI/CLI.hpp>
#include <cstring>
#include <exception>
#include <iostream>
#include <memory>

#include "bag_commands.hpp"
#include "odometry_node.hpp"

namespace {

constexpr const char* kNodeUsage =
    "Usage: kestrel_ros node [_param:=value ...] [topic:=remapped ...] [__name:=NAME]\n"
    "Live odometry node (needs a ROS master: ROS_MASTER_URI). Subscribes to\n"
    "  rgbd:   camera/rgb/image_color, camera/depth/image, camera/rgb/camera_info\n"
    "  stereo: stereo/left/image_raw, stereo/right/image_raw\n"
    "  imu (with _use_imu:=true)\n"
    "and publishes ~odometry (nav_msgs/Odometry), /tf, ~fused/odometry, ~fused/gyro_bias,\n"
    "~fused/accel_bias. Parameters and defaults: docs/ros.md, e.g.\n"
    "  kestrel_ros node _camera:=fr1 _odom_frame:=odom _base_frame:=base_link\n";

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "node") == 0) {
    for (int i = 2; i < argc; ++i) {
      if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
        std::cout << kNodeUsage;
        return 0;
      }
    }
    return kestrel::ros::run_odometry_node(argc, argv);
  }

  CLI::App app{"kestrel_ros: Kestrel's ROS 1 node, TUM bag odometry and bag writer"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "kestrel_ros 0.1.0");
  app.add_subcommand("node", "Live odometry node (kestrel_ros node --help)");

  auto bag_args = std::make_shared<kestrel::ros::BagOdometryArgs>();
  CLI::App* bag = app.add_subcommand(
      "bag",
      "Direct RGB-D odometry over a TUM RGB-D .bag (read with the rosbag API, no ROS master); "
      "writes camera poses in TUM format like `kestrel odometry`");
  bag->add_option("--bag", bag_args->bag, "the .bag file")->required();
  bag->add_option("--out", bag_args->out, "output trajectory (TUM format)")->required();
  bag->add_option("--camera", bag_args->camera,
                  "fr1|fr2|fr3|ros|FILE.yaml (default: from the bag's name, freiburgN, else "
                  "the camera_info topic)");
  bag->add_option("--config", bag_args->config, "tracker options YAML")->check(CLI::ExistingFile);
  bag->add_option("--rgb-topic", bag_args->rgb_topic, "colour images")->capture_default_str();
  bag->add_option("--depth-topic", bag_args->depth_topic, "depth images (32FC1 m, 16UC1)")
      ->capture_default_str();
  bag->add_option("--camera-info-topic", bag_args->camera_info_topic,
                  "camera_info used when neither --camera nor the name gives the camera")
      ->capture_default_str();
  bag->add_option("--depth-unit", bag_args->depth_unit_m,
                  "metres per unit of 16UC1 depth images (OpenNI: 0.001)")
      ->capture_default_str();
  bag->add_flag("--force", bag_args->force, "overwrite an output file written by something else");
  bag->callback([bag_args] { kestrel::ros::run_bag_odometry(*bag_args); });

  auto make_args = std::make_shared<kestrel::ros::MakeBagArgs>();
  CLI::App* make =
      app.add_subcommand("make-bag",
                         "Write a .bag in TUM's topic layout (rgb8 colour, 32FC1 depth in metres, "
                         "camera_info) from a TUM RGB-D folder");
  make->add_option("--tum", make_args->tum, "TUM RGB-D folder (rgb.txt, depth.txt, ...)")
      ->required();
  make->add_option("--out", make_args->out, "the .bag to write")->required();
  make->add_option("--camera", make_args->camera,
                   "fr1|fr2|fr3|ros|FILE.yaml for camera_info (default: the folder's camera.yaml, "
                   "else from the folder name)");
  make->add_option("--max-frames", make_args->max_frames, "0: every associated frame")
      ->capture_default_str();
  make->add_option("--compression", make_args->compression, "none, lz4 or bz2")
      ->capture_default_str();
  make->add_flag("--force", make_args->force, "overwrite an existing output file");
  make->callback([make_args] { kestrel::ros::run_make_bag(*make_args); });

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "kestrel_ros: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
