// `kestrel_ros bag` and `kestrel_ros make-bag` (see bag_commands.hpp). The bag is read twice:
// first the time stamps of the colour and depth images (to associate them exactly as
// `kestrel odometry` associates a TUM folder's lists), then the images, converted and tracked
// in colour-time order as soon as both halves of a pair have been read.
#include "bag_commands.hpp"

#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/query.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "conversions.hpp"
#include "kestrel/ros/dataset_bridge.hpp"
#include "kestrel/ros/odometry_core.hpp"

namespace kestrel::ros {
namespace fs = std::filesystem;

namespace {

constexpr const char* kBagCommand = "ros bag";

std::runtime_error bag_error(const std::string& bag, const std::string& message) {
  return std::runtime_error(bag + ": " + message);
}

void open_for_reading(rosbag::Bag& bag, const std::string& path) {
  if (!fs::exists(path)) throw bag_error(path, "no such bag file");
  if (fs::is_directory(path)) throw bag_error(path, "is a folder, not a bag file");
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw bag_error(path, std::string("cannot be read as a ROS bag: ") + e.what());
  }
}

/// topic -> message type of every connection in the bag.
std::map<std::string, std::string> bag_topics(const rosbag::Bag& bag) {
  rosbag::View view(bag);
  std::map<std::string, std::string> topics;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) topics[c->topic] = c->datatype;
  return topics;
}

std::string list_topics(const std::map<std::string, std::string>& topics) {
  if (topics.empty()) return "the bag has no topics";
  std::ostringstream os;
  os << "the bag has";
  bool first = true;
  for (const auto& [topic, type] : topics) {
    os << (first ? " " : ", ") << topic << " (" << type << ")";
    first = false;
  }
  return os.str();
}

void require_topic(const std::map<std::string, std::string>& topics, const std::string& path,
                   const std::string& topic, const std::string& type, const std::string& role) {
  const auto it = topics.find(topic);
  if (it == topics.end()) {
    throw bag_error(path, "no topic " + topic + " (" + role + "; " + list_topics(topics) +
                              "; choose another with the topic options)");
  }
  if (it->second != type) {
    throw bag_error(
        path, "topic " + topic + " holds " + it->second + ", expected " + type + " (" + role + ")");
  }
}

std::string summary_line(const std::vector<double>& ms, std::size_t frames, std::size_t failures) {
  double mean = 0.0, median = 0.0;
  if (!ms.empty()) {
    for (double v : ms) mean += v;
    mean /= static_cast<double>(ms.size());
    std::vector<double> sorted = ms;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t n = sorted.size();
    median = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  }
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << "SUMMARY frames=" << frames
     << " failures=" << failures << " mean_ms=" << mean << " median_ms=" << median;
  return os.str();
}

/// The camera for a bag: --camera, else the bag name's freiburgN preset, else its camera_info.
CameraModel bag_camera(const BagOdometryArgs& args, rosbag::Bag& bag,
                       const std::map<std::string, std::string>& topics, std::string& source) {
  std::string name = args.camera;
  if (name.empty()) name = camera_preset_for_name(args.bag);
  if (!name.empty()) {
    source = (args.camera.empty() ? "from the bag's name: " : "") + name;
    return load_camera_model(name);
  }
  const auto it = topics.find(args.camera_info_topic);
  if (it == topics.end()) {
    throw bag_error(args.bag,
                    "no camera model: no --camera, the file name does not say "
                    "freiburg1/2/3, and there is no topic " +
                        args.camera_info_topic + " (" + list_topics(topics) + ")");
  }
  rosbag::View view(bag, rosbag::TopicQuery(args.camera_info_topic));
  for (const rosbag::MessageInstance& m : view) {
    const auto info = m.instantiate<sensor_msgs::CameraInfo>();
    if (!info) break;
    std::string error;
    if (const auto camera = camera_from_info(*info, error)) {
      source = "from " + args.camera_info_topic;
      return *camera;
    }
    throw bag_error(args.bag, args.camera_info_topic + ": " + error);
  }
  throw bag_error(args.bag, "topic " + args.camera_info_topic + " holds no sensor_msgs/CameraInfo");
}

/// Header stamps of the images on `topic`, in bag order.
std::vector<std::int64_t> image_stamps(rosbag::Bag& bag, const std::string& topic) {
  std::vector<std::int64_t> stamps;
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  stamps.reserve(view.size());
  for (const rosbag::MessageInstance& m : view) {
    const auto image = m.instantiate<sensor_msgs::Image>();
    stamps.push_back(image ? to_ns(image->header.stamp) : std::int64_t{-1});
  }
  return stamps;
}

/// The colour and depth images of a bag, associated as `kestrel odometry` associates a TUM
/// folder's lists, and the pair each associated message belongs to.
struct BagPairs {
  // Header stamps, in bag order.
  std::vector<std::int64_t> rgb_t_ns, depth_t_ns;
  // (rgb index, depth index), sorted by rgb index.
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::map<std::size_t, std::size_t> pair_of_rgb, pair_of_depth;
};

BagPairs pair_images(rosbag::Bag& bag, const BagOdometryArgs& args) {
  BagPairs p;
  p.rgb_t_ns = image_stamps(bag, args.rgb_topic);
  p.depth_t_ns = image_stamps(bag, args.depth_topic);
  p.pairs = associate_stamps(p.rgb_t_ns, p.depth_t_ns, kTumMaxAssociationDiffNs);
  for (std::size_t k = 0; k < p.pairs.size(); ++k) {
    p.pair_of_rgb[p.pairs[k].first] = k;
    p.pair_of_depth[p.pairs[k].second] = k;
  }
  return p;
}

/// What the odometry made of a bag.
struct BagRun {
  std::vector<TrajectoryPose> trajectory;
  std::vector<double> processing_ms;       // of every tracked frame but the first
  std::vector<std::string> failure_lines;  // the first 20
  std::set<std::size_t> dropped;           // pairs with an image that could not be converted
  std::size_t failures = 0, keyframes = 0, processed = 0;
};

/// Tracks the pairs in colour-time order as their converted images come in, in any order: a
/// pair waits until both halves are in and every earlier pair is tracked or dropped.
class PairTracker {
 public:
  PairTracker(OdometryCore& core, const BagPairs& pairs) : core_(core), pairs_(pairs) {
    run_.trajectory.reserve(pairs.pairs.size());
  }

  void add(std::size_t pair, bool is_rgb, const cv::Mat& image) {
    (is_rgb ? rgb_ready_ : depth_ready_)[pair] = image;
  }
  void drop(std::size_t pair) { run_.dropped.insert(pair); }
  /// Tracks the pairs that can be, in order.
  void track_ready();
  [[nodiscard]] const BagRun& run() const { return run_; }

 private:
  void record(std::int64_t t_ns, const OdometryOutput& out);

  OdometryCore& core_;
  const BagPairs& pairs_;
  std::map<std::size_t, cv::Mat> rgb_ready_, depth_ready_;
  std::size_t next_ = 0;  // the next pair to track
  BagRun run_;
};

void PairTracker::track_ready() {
  while (next_ < pairs_.pairs.size()) {
    if (run_.dropped.count(next_) != 0) {
      rgb_ready_.erase(next_);
      depth_ready_.erase(next_);
      ++next_;
      continue;
    }
    const auto rgb = rgb_ready_.find(next_);
    const auto depth = depth_ready_.find(next_);
    if (rgb == rgb_ready_.end() || depth == depth_ready_.end()) return;
    const std::int64_t t_ns = pairs_.rgb_t_ns[pairs_.pairs[next_].first];
    const OdometryOutput out = core_.track_rgbd(t_ns, rgb->second, depth->second);
    rgb_ready_.erase(rgb);
    depth_ready_.erase(depth);
    record(t_ns, out);
    ++next_;
  }
}

// A frame the core refuses (invalid input) is reported and not counted.
void PairTracker::record(std::int64_t t_ns, const OdometryOutput& out) {
  if (out.invalid_input) {
    std::cerr << "kestrel_ros bag: warning: frame at t=" << format_seconds(t_ns)
              << " dropped: " << out.failure << "\n";
    return;
  }
  if (run_.processed > 0) run_.processing_ms.push_back(out.processing_ms);
  if (!out.ok) {
    ++run_.failures;
    if (run_.failure_lines.size() < 20) {
      run_.failure_lines.push_back("frame " + std::to_string(run_.processed) +
                                   " (t=" + format_seconds(t_ns) + "): " + out.failure);
    }
  }
  run_.keyframes += out.new_keyframe ? 1 : 0;
  run_.trajectory.push_back({t_ns, out.T_odom_child});
  ++run_.processed;
  if (run_.processed % 100 == 0) {
    std::cerr << "kestrel_ros bag: " << run_.processed << "/" << pairs_.pairs.size() << " frames\n";
  }
}

/// The message's image converted for the odometry; none, with a warning, if it is not an
/// image or has an encoding the odometry cannot take.
std::optional<cv::Mat> converted_image(const rosbag::MessageInstance& m, std::size_t index,
                                       bool is_rgb, double depth_unit_m) {
  const auto image = m.instantiate<sensor_msgs::Image>();
  if (!image) {
    std::cerr << "kestrel_ros bag: warning: " << m.getTopic() << ": message " << index
              << " is not a sensor_msgs/Image; frame dropped\n";
    return std::nullopt;
  }
  const ImageConversion c = is_rgb ? intensity_image(*image) : depth_image(*image, depth_unit_m);
  if (!c.ok()) {
    std::cerr << "kestrel_ros bag: warning: " << m.getTopic()
              << " at t=" << format_seconds(to_ns(image->header.stamp)) << ": " << c.error
              << "; frame dropped\n";
    return std::nullopt;
  }
  return c.image;
}

/// Reads the images in bag order and tracks each pair as soon as both of its halves are in.
void track_bag_images(rosbag::Bag& bag, const BagOdometryArgs& args, const BagPairs& pairs,
                      PairTracker& tracker) {
  std::size_t rgb_index = 0, depth_index = 0;
  rosbag::View view(bag,
                    rosbag::TopicQuery(std::vector<std::string>{args.rgb_topic, args.depth_topic}));
  for (const rosbag::MessageInstance& m : view) {
    const bool is_rgb = m.getTopic() == args.rgb_topic;
    const std::size_t index = is_rgb ? rgb_index++ : depth_index++;
    const auto& pair_of = is_rgb ? pairs.pair_of_rgb : pairs.pair_of_depth;
    const auto it = pair_of.find(index);
    if (it == pair_of.end()) continue;  // not associated
    if (const auto image = converted_image(m, index, is_rgb, args.depth_unit_m)) {
      tracker.add(it->second, is_rgb, *image);
    } else {
      tracker.drop(it->second);
    }
    tracker.track_ready();
  }
}

/// Writes the trajectory and reports the run: the result on stdout, then on stderr the
/// failures, the core's statistics and, as the last line, the SUMMARY line.
void report_bag_run(const BagOdometryArgs& args, const BagRun& run, const OdometryCore& core) {
  if (run.trajectory.empty()) {
    throw bag_error(args.bag, "no frame could be used (every pair had an unusable image)");
  }
  write_tum_trajectory(args.out, run.trajectory, kBagCommand, args.force);
  std::cout << "wrote " << args.out << " (" << run.trajectory.size() << " poses, " << run.keyframes
            << " keyframes, " << run.failures << " failures, " << run.dropped.size()
            << " frames dropped)\n";
  for (const auto& line : run.failure_lines) std::cerr << "failure: " << line << "\n";
  std::cout.flush();
  std::cerr << "kestrel_ros bag: " << core.statistics() << "\n";
  std::cerr << summary_line(run.processing_ms, run.processed, run.failures)
            << std::endl;  // the LAST stderr line
}

}  // namespace

void run_bag_odometry(const BagOdometryArgs& args) {
  if (args.bag.empty()) throw std::runtime_error("--bag: no bag file given");
  if (!(args.depth_unit_m > 0.0)) throw std::runtime_error("--depth-unit must be positive");
  rosbag::Bag bag;
  open_for_reading(bag, args.bag);
  const auto topics = bag_topics(bag);
  require_topic(topics, args.bag, args.rgb_topic, "sensor_msgs/Image", "colour images");
  require_topic(topics, args.bag, args.depth_topic, "sensor_msgs/Image", "depth images");
  // Refuse to overwrite someone else's file before doing the work.
  check_can_write_output(args.out, kBagCommand, args.force);

  std::string camera_source;
  const CameraModel camera = bag_camera(args, bag, topics, camera_source);
  OdometryCoreOptions options;
  options.tracker_options_file = args.config;
  OdometryCore core(options, camera);

  const BagPairs pairs = pair_images(bag, args);
  std::cerr << "kestrel_ros bag: bag=" << args.bag << " " << args.rgb_topic << ": "
            << pairs.rgb_t_ns.size() << " images, " << args.depth_topic << ": "
            << pairs.depth_t_ns.size() << " images, frames=" << pairs.pairs.size()
            << " (unmatched rgb: " << pairs.rgb_t_ns.size() - pairs.pairs.size() << ")\n"
            << "camera (" << camera_source << "): " << describe(camera) << "\n"
            << core.describe();
  if (pairs.pairs.empty()) {
    throw bag_error(args.bag, "no colour/depth image pairs within 20 ms on " + args.rgb_topic +
                                  " and " + args.depth_topic);
  }

  PairTracker tracker(core, pairs);
  track_bag_images(bag, args, pairs, tracker);
  bag.close();
  report_bag_run(args, tracker.run(), core);
}

void run_make_bag(const MakeBagArgs& args) {
  if (args.tum.empty()) throw std::runtime_error("--tum: no TUM folder given");
  if (!fs::is_directory(args.tum)) throw std::runtime_error(args.tum + ": no such folder");
  if (args.out.empty()) throw std::runtime_error("--out: no bag file given");
  if (fs::exists(args.out) && !args.force) {
    throw std::runtime_error(args.out + ": exists; give --force to overwrite it");
  }
  if (fs::is_directory(args.out)) throw std::runtime_error(args.out + ": is a folder");
  rosbag::CompressionType compression = rosbag::compression::LZ4;
  if (args.compression == "none") {
    compression = rosbag::compression::Uncompressed;
  } else if (args.compression == "bz2") {
    compression = rosbag::compression::BZ2;
  } else if (args.compression != "lz4") {
    throw std::runtime_error("--compression: none, lz4 or bz2, got '" + args.compression + "'");
  }
  std::string camera_name = args.camera;
  if (camera_name.empty()) camera_name = camera_for_tum_folder(args.tum);
  if (camera_name.empty()) {
    throw std::runtime_error(args.tum +
                             ": no camera.yaml in the folder and its name does not say which "
                             "camera (freiburg1/2/3): give --camera fr1|fr2|fr3|ros|FILE.yaml");
  }
  const CameraModel camera = load_camera_model(camera_name);
  const TumFolder folder(args.tum);
  if (folder.size() == 0) throw std::runtime_error(args.tum + ": no associated rgb/depth frames");
  const std::size_t n =
      args.max_frames == 0 ? folder.size() : std::min(args.max_frames, folder.size());

  // Written beside the output and renamed at the end: no half-written bag under its name.
  const fs::path out(args.out);
  if (!out.parent_path().empty()) fs::create_directories(out.parent_path());
  const fs::path partial = out.string() + ".partial";
  rosbag::Bag bag;
  try {
    bag.open(partial.string(), rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(partial.string() + ": cannot write: " + e.what());
  }
  bag.setCompression(compression);
  sensor_msgs::CameraInfo info = camera_info_from_model(camera);
  const std::string rgb_frame = "/openni_rgb_optical_frame";  // TUM's frame ids
  const std::string depth_frame = "/openni_depth_optical_frame";
  for (std::size_t i = 0; i < n; ++i) {
    const TumFrame f = folder.load(i);
    sensor_msgs::Image rgb;
    rgb.header.stamp = to_ros_time(f.t_ns);
    rgb.header.frame_id = rgb_frame;
    rgb.header.seq = static_cast<std::uint32_t>(i);
    rgb.height = static_cast<std::uint32_t>(f.bgr.rows);
    rgb.width = static_cast<std::uint32_t>(f.bgr.cols);
    rgb.encoding = sensor_msgs::image_encodings::RGB8;
    rgb.step = rgb.width * 3;
    rgb.data.resize(static_cast<std::size_t>(rgb.step) * rgb.height);
    cv::Mat rgb_view(f.bgr.rows, f.bgr.cols, CV_8UC3, rgb.data.data(), rgb.step);
    cv::cvtColor(f.bgr, rgb_view, cv::COLOR_BGR2RGB);

    sensor_msgs::Image depth;
    depth.header.stamp = to_ros_time(f.depth_t_ns);
    depth.header.frame_id = depth_frame;
    depth.header.seq = static_cast<std::uint32_t>(i);
    depth.height = static_cast<std::uint32_t>(f.depth_m.rows);
    depth.width = static_cast<std::uint32_t>(f.depth_m.cols);
    depth.encoding = sensor_msgs::image_encodings::TYPE_32FC1;
    depth.step = depth.width * 4;
    depth.data.resize(static_cast<std::size_t>(depth.step) * depth.height);
    cv::Mat depth_view(f.depth_m.rows, f.depth_m.cols, CV_32FC1, depth.data.data(), depth.step);
    f.depth_m.copyTo(depth_view);

    info.header = rgb.header;
    sensor_msgs::CameraInfo depth_info = info;
    depth_info.header = depth.header;
    // In time order, as a recording would have them.
    if (f.depth_t_ns < f.t_ns) {
      bag.write(kTumDepthTopic, depth.header.stamp, depth);
      bag.write(kTumDepthInfoTopic, depth.header.stamp, depth_info);
    }
    bag.write(kTumRgbTopic, rgb.header.stamp, rgb);
    bag.write(kTumRgbInfoTopic, rgb.header.stamp, info);
    if (f.depth_t_ns >= f.t_ns) {
      bag.write(kTumDepthTopic, depth.header.stamp, depth);
      bag.write(kTumDepthInfoTopic, depth.header.stamp, depth_info);
    }
  }
  bag.close();
  fs::rename(partial, out);
  std::cout << "wrote " << args.out << " (" << n << " frames of " << args.tum << ", camera "
            << camera_name << ": " << kTumRgbTopic << " rgb8, " << kTumDepthTopic
            << " 32FC1 metres, " << kTumRgbInfoTopic << ", " << kTumDepthInfoTopic << ")\n";
}

}  // namespace kestrel::ros
