// The live node (see odometry_node.hpp). One thread: callbacks run in ros::spin(), so a frame
// being tracked delays the next callbacks; the image subscribers' queues (queue_size) then
// drop the oldest images, which keeps the node on the freshest frames.
#include "odometry_node.hpp"

#include <ros/callback_queue.h>
#include <tf2/exceptions.h>

#include <cmath>
#include <csignal>
#include <sstream>
#include <stdexcept>

#include "conversions.hpp"
#include "kestrel/ros/dataset_bridge.hpp"

namespace kestrel::ros {

namespace {

template <typename T>
void read_param(const ::ros::NodeHandle& nh, const std::string& name, T& value,
                const char* expected) {
  if (!nh.hasParam(name)) return;
  if (!nh.getParam(name, value)) {
    throw std::runtime_error("parameter " + nh.resolveName(name) + ": expected " + expected);
  }
}

// Numbers given as integers (`_depth_unit:=1`) are ints to the parameter server.
void read_double(const ::ros::NodeHandle& nh, const std::string& name, double& value) {
  if (!nh.hasParam(name)) return;
  if (nh.getParam(name, value)) return;
  int as_int = 0;
  if (nh.getParam(name, as_int)) {
    value = as_int;
    return;
  }
  throw std::runtime_error("parameter " + nh.resolveName(name) + ": expected a number");
}

void require_positive(const std::string& name, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::runtime_error("parameter ~" + name + ": must be a positive number, got " +
                             std::to_string(value));
  }
}

Eigen::Isometry3d to_isometry(const Eigen::Matrix4d& T) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = T.block<3, 3>(0, 0);
  iso.translation() = T.block<3, 1>(0, 3);
  return iso;
}

std::string seconds(std::int64_t t_ns) { return format_seconds(t_ns); }

}  // namespace

NodeParameters NodeParameters::load(const ::ros::NodeHandle& pnh) {
  NodeParameters p;
  read_param(pnh, "mode", p.mode, "rgbd or stereo");
  read_param(pnh, "camera", p.camera, "a string (preset or file)");
  read_param(pnh, "tracker_options", p.tracker_options, "a file name");
  read_param(pnh, "stereo_calibration", p.stereo_calibration, "a file or EuRoC folder");
  read_param(pnh, "matcher_options", p.matcher_options, "a file name");
  read_param(pnh, "matcher", p.matcher, "sad, census or sgm");
  read_param(pnh, "sgm_options", p.sgm_options, "a file name");
  read_param(pnh, "use_imu", p.use_imu, "true or false");
  read_param(pnh, "imu_noise", p.imu_noise, "a file name");
  read_param(pnh, "fusion_options", p.fusion_options, "a file name");
  read_param(pnh, "T_body_cam", p.T_body_cam, "a list of 16 numbers (row-major 4x4)");
  read_double(pnh, "vo_covariance_scale", p.vo_covariance_scale);
  read_param(pnh, "vo_from_keyframe", p.vo_from_keyframe, "true or false");
  read_double(pnh, "max_imu_hold", p.max_imu_hold);
  read_double(pnh, "sync_tolerance", p.sync_tolerance);
  read_double(pnh, "depth_unit", p.depth_unit);
  read_param(pnh, "queue_size", p.queue_size, "an integer");
  read_param(pnh, "odom_frame", p.odom_frame, "a frame id");
  read_param(pnh, "camera_frame", p.camera_frame, "a frame id");
  read_param(pnh, "base_frame", p.base_frame, "a frame id");
  read_param(pnh, "publish_tf", p.publish_tf, "true or false");
  read_param(pnh, "world_frame", p.world_frame, "a frame id");
  read_param(pnh, "body_frame", p.body_frame, "a frame id");
  read_double(pnh, "warn_period", p.warn_period);

  if (p.mode != "rgbd" && p.mode != "stereo") {
    throw std::runtime_error("parameter ~mode: rgbd or stereo, got '" + p.mode + "'");
  }
  if (!p.T_body_cam.empty() && p.T_body_cam.size() != 16) {
    throw std::runtime_error("parameter ~T_body_cam: 16 numbers (row-major 4x4), got " +
                             std::to_string(p.T_body_cam.size()));
  }
  require_positive("vo_covariance_scale", p.vo_covariance_scale);
  require_positive("max_imu_hold", p.max_imu_hold);
  require_positive("sync_tolerance", p.sync_tolerance);
  require_positive("depth_unit", p.depth_unit);
  require_positive("warn_period", p.warn_period);
  if (p.queue_size < 1) throw std::runtime_error("parameter ~queue_size: must be at least 1");
  p.odom_frame = clean_frame_id(p.odom_frame);
  p.camera_frame = clean_frame_id(p.camera_frame);
  p.base_frame = clean_frame_id(p.base_frame);
  p.world_frame = clean_frame_id(p.world_frame);
  p.body_frame = clean_frame_id(p.body_frame);
  if (p.odom_frame.empty()) throw std::runtime_error("parameter ~odom_frame: empty");
  return p;
}

std::string NodeParameters::describe() const {
  std::ostringstream os;
  os << "mode: " << mode << "\ncamera: " << (camera.empty() ? "(from camera_info)" : camera)
     << "\ntracker_options: " << (tracker_options.empty() ? "(defaults)" : tracker_options)
     << "\nstereo_calibration: " << stereo_calibration
     << "\nmatcher_options: " << (matcher_options.empty() ? "(defaults)" : matcher_options)
     << "\nmatcher: " << (matcher.empty() ? "(matcher_options' cost)" : matcher)
     << "\nsgm_options: " << (sgm_options.empty() ? "(defaults)" : sgm_options)
     << "\nuse_imu: " << (use_imu ? "true" : "false") << "\nimu_noise: " << imu_noise
     << "\nfusion_options: " << fusion_options
     << "\nT_body_cam: " << (T_body_cam.empty() ? "(default)" : "(16 numbers)")
     << "\nvo_covariance_scale: " << vo_covariance_scale
     << "\nvo_from_keyframe: " << (vo_from_keyframe ? "true" : "false")
     << "\nmax_imu_hold: " << max_imu_hold << "\nsync_tolerance: " << sync_tolerance
     << "\ndepth_unit: " << depth_unit << "\nqueue_size: " << queue_size
     << "\nodom_frame: " << odom_frame
     << "\ncamera_frame: " << (camera_frame.empty() ? "(from the images)" : camera_frame)
     << "\nbase_frame: " << (base_frame.empty() ? "(none: TF of the camera)" : base_frame)
     << "\npublish_tf: " << (publish_tf ? "true" : "false") << "\nworld_frame: " << world_frame
     << "\nbody_frame: " << (body_frame.empty() ? "(from the IMU)" : body_frame)
     << "\nwarn_period: " << warn_period;
  return os.str();
}

OdometryNode::OdometryNode(::ros::NodeHandle nh, ::ros::NodeHandle private_nh)
    : nh_(nh),
      pnh_(private_nh),
      params_(NodeParameters::load(private_nh)),
      it_(nh),
      pairing_(static_cast<std::int64_t>(std::llround(params_.sync_tolerance * 1e9))) {
  OdometryCoreOptions options;
  options.mode = params_.mode == "stereo" ? OdometryMode::kStereo : OdometryMode::kRgbd;
  options.tracker_options_file = params_.tracker_options;
  options.stereo_calibration = params_.stereo_calibration;
  options.matcher_options_file = params_.matcher_options;
  options.matcher = params_.matcher;
  options.sgm_options_file = params_.sgm_options;
  options.use_imu = params_.use_imu;
  options.imu_noise_file = params_.imu_noise;
  options.fusion_options_file = params_.fusion_options;
  if (!params_.T_body_cam.empty()) {
    options.T_body_cam =
        Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(params_.T_body_cam.data());
  }
  options.vo_covariance_scale = params_.vo_covariance_scale;
  options.vo_from_keyframe = params_.vo_from_keyframe;
  options.max_imu_hold_s = params_.max_imu_hold;
  std::optional<CameraModel> camera;
  if (options.mode == OdometryMode::kRgbd && !params_.camera.empty()) {
    camera = load_camera_model(params_.camera);
  }
  core_ = std::make_unique<OdometryCore>(options, camera);

  ROS_INFO_STREAM("kestrel_ros: parameters of " << pnh_.getNamespace() << ":\n"
                                                << params_.describe());
  ROS_INFO_STREAM("kestrel_ros: " << core_->describe());

  const auto queue = static_cast<std::uint32_t>(params_.queue_size);
  if (options.mode == OdometryMode::kRgbd) {
    sub_a_ = it_.subscribe("camera/rgb/image_color", queue, &OdometryNode::on_colour, this);
    sub_b_ = it_.subscribe("camera/depth/image", queue, &OdometryNode::on_depth, this);
    if (params_.camera.empty()) {
      sub_info_ = nh_.subscribe("camera/rgb/camera_info", 2, &OdometryNode::on_camera_info, this);
    }
  } else {
    sub_a_ = it_.subscribe("stereo/left/image_raw", queue, &OdometryNode::on_left, this);
    sub_b_ = it_.subscribe("stereo/right/image_raw", queue, &OdometryNode::on_right, this);
  }
  if (params_.use_imu) sub_imu_ = nh_.subscribe("imu", 1000, &OdometryNode::on_imu, this);
  pub_odom_ = pnh_.advertise<nav_msgs::Odometry>("odometry", 10);
  if (params_.use_imu) {
    pub_fused_ = pnh_.advertise<nav_msgs::Odometry>("fused/odometry", 10);
    pub_gyro_bias_ = pnh_.advertise<geometry_msgs::Vector3Stamped>("fused/gyro_bias", 10);
    pub_accel_bias_ = pnh_.advertise<geometry_msgs::Vector3Stamped>("fused/accel_bias", 10);
  }
  if (!params_.base_frame.empty()) {
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);
  }
  std::ostringstream topics;
  topics << "kestrel_ros: subscribed to " << sub_a_.getTopic() << " and " << sub_b_.getTopic();
  if (sub_info_) topics << ", " << sub_info_.getTopic();
  if (sub_imu_) topics << ", " << sub_imu_.getTopic();
  topics << "; publishing " << pub_odom_.getTopic();
  if (params_.publish_tf) topics << ", /tf";
  if (pub_fused_) topics << ", " << pub_fused_.getTopic() << " (+ gyro_bias, accel_bias)";
  ROS_INFO_STREAM(topics.str());
}

std::string OdometryNode::statistics() const {
  std::ostringstream os;
  os << "published=" << published_ << " dropped=" << dropped_ << " failures=" << failures_
     << " resets=" << resets_ << " pairs=" << pairing_.pairs()
     << " unpaired_images=" << pairing_.unpaired() << " imu_rejected=" << imu_rejected_
     << "; core: " << core_->statistics();
  return os.str();
}

void OdometryNode::warn_throttled(const std::string& kind, const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(params_.warn_period);
  auto [it, first] = throttles_.try_emplace(kind);
  Throttle& t = it->second;
  if (!first && now - t.last < period) {
    ++t.suppressed;
    return;
  }
  if (t.suppressed > 0) {
    ROS_WARN_STREAM("kestrel_ros: " << message << " (and " << t.suppressed
                                    << " more like it since the last report)");
  } else {
    ROS_WARN_STREAM("kestrel_ros: " << message);
  }
  t.last = now;
  t.suppressed = 0;
}

void OdometryNode::drop(const std::string& kind, const std::string& why) {
  ++dropped_;
  warn_throttled(kind,
                 "frame dropped: " + why + " (" + std::to_string(dropped_) + " dropped so far)");
}

void OdometryNode::on_colour(const ImagePtr& msg) {
  if (auto pair = pairing_.add_a(to_ns(msg->header.stamp), msg)) process_rgbd(pair->a, pair->b);
}
void OdometryNode::on_depth(const ImagePtr& msg) {
  if (auto pair = pairing_.add_b(to_ns(msg->header.stamp), msg)) process_rgbd(pair->a, pair->b);
}
void OdometryNode::on_left(const ImagePtr& msg) {
  if (auto pair = pairing_.add_a(to_ns(msg->header.stamp), msg)) process_stereo(pair->a, pair->b);
}
void OdometryNode::on_right(const ImagePtr& msg) {
  if (auto pair = pairing_.add_b(to_ns(msg->header.stamp), msg)) process_stereo(pair->a, pair->b);
}

void OdometryNode::on_camera_info(const sensor_msgs::CameraInfoConstPtr& msg) {
  std::string error;
  const auto camera = camera_from_info(*msg, error);
  if (!camera) {
    warn_throttled("camera_info", sub_info_.getTopic() + ": " + error + "; ignored");
    return;
  }
  const auto current = core_->camera();
  if (current && current->width == camera->width && current->height == camera->height &&
      current->fx == camera->fx && current->fy == camera->fy && current->cx == camera->cx &&
      current->cy == camera->cy && current->distortion == camera->distortion) {
    return;
  }
  if (current) {
    ROS_WARN_STREAM("kestrel_ros: the camera_info changed: odometry restarts with "
                    << describe(*camera));
    ++resets_;
  } else {
    ROS_INFO_STREAM("kestrel_ros: camera from " << sub_info_.getTopic() << ": "
                                                << describe(*camera));
  }
  core_->set_camera(*camera);
  last_frame_ns_.reset();
}

void OdometryNode::on_imu(const sensor_msgs::ImuConstPtr& msg) {
  const Eigen::Vector3d gyro(msg->angular_velocity.x, msg->angular_velocity.y,
                             msg->angular_velocity.z);
  const Eigen::Vector3d accel(msg->linear_acceleration.x, msg->linear_acceleration.y,
                              msg->linear_acceleration.z);
  if (imu_frame_.empty()) imu_frame_ = clean_frame_id(msg->header.frame_id);
  if (!core_->add_imu(to_ns(msg->header.stamp), gyro, accel)) {
    ++imu_rejected_;
    warn_throttled("imu", "IMU sample at t=" + seconds(to_ns(msg->header.stamp)) +
                              " ignored (not finite, or not after the previous one)");
    return;
  }
  last_gyro_ = gyro;
}

bool OdometryNode::prepare_frame(std::int64_t t_ns, const std::string& image_frame_id) {
  if (last_frame_ns_ && t_ns <= *last_frame_ns_) {
    ROS_WARN_STREAM("kestrel_ros: image time went back from t=" << seconds(*last_frame_ns_)
                                                                << " to t=" << seconds(t_ns)
                                                                << " (a bag restarted?): the "
                                                                   "odometry restarts");
    core_->reset();
    ++resets_;
    child_resolved_ = false;
  }
  if (child_resolved_) return true;
  std::string camera_frame = params_.camera_frame;
  if (camera_frame.empty()) camera_frame = clean_frame_id(image_frame_id);
  if (camera_frame.empty()) camera_frame = "camera";
  if (params_.base_frame.empty() || params_.base_frame == camera_frame) {
    child_frame_ = camera_frame;
    core_->set_child_from_camera(Eigen::Matrix4d::Identity());
  } else {
    geometry_msgs::TransformStamped T;
    try {
      T = tf_buffer_.lookupTransform(params_.base_frame, camera_frame, ::ros::Time(0));
    } catch (const tf2::TransformException& e) {
      drop("tf",
           "no transform " + params_.base_frame + " <- " + camera_frame + " yet: " + e.what());
      return false;
    }
    const Eigen::Quaterniond q(T.transform.rotation.w, T.transform.rotation.x,
                               T.transform.rotation.y, T.transform.rotation.z);
    Eigen::Matrix4d T_base_cam = Eigen::Matrix4d::Identity();
    T_base_cam.block<3, 3>(0, 0) = q.normalized().toRotationMatrix();
    T_base_cam.block<3, 1>(0, 3) = Eigen::Vector3d(
        T.transform.translation.x, T.transform.translation.y, T.transform.translation.z);
    core_->set_child_from_camera(T_base_cam);
    core_->reset();
    child_frame_ = params_.base_frame;
    ROS_INFO_STREAM("kestrel_ros: odometry of " << child_frame_ << " (camera " << camera_frame
                                                << " in it from TF)");
  }
  child_resolved_ = true;
  return true;
}

void OdometryNode::process_rgbd(const ImagePtr& colour, const ImagePtr& depth) {
  const std::int64_t t_ns = to_ns(colour->header.stamp);
  if (!core_->has_camera()) {
    drop("camera",
         "no camera model yet: waiting for " + sub_info_.getTopic() + " (or set ~camera)");
    return;
  }
  const ImageConversion c = intensity_image(*colour);
  if (!c.ok()) {
    drop("colour", sub_a_.getTopic() + " at t=" + seconds(t_ns) + ": " + c.error);
    return;
  }
  const ImageConversion d = depth_image(*depth, params_.depth_unit);
  if (!d.ok()) {
    drop("depth",
         sub_b_.getTopic() + " at t=" + seconds(to_ns(depth->header.stamp)) + ": " + d.error);
    return;
  }
  if (!prepare_frame(t_ns, colour->header.frame_id)) return;
  const OdometryOutput out = core_->track_rgbd(t_ns, c.image, d.image);
  publish(out);
}

void OdometryNode::process_stereo(const ImagePtr& left, const ImagePtr& right) {
  const std::int64_t t_ns = to_ns(left->header.stamp);
  const ImageConversion l = intensity_image(*left);
  if (!l.ok()) {
    drop("left", sub_a_.getTopic() + " at t=" + seconds(t_ns) + ": " + l.error);
    return;
  }
  const ImageConversion r = intensity_image(*right);
  if (!r.ok()) {
    drop("right",
         sub_b_.getTopic() + " at t=" + seconds(to_ns(right->header.stamp)) + ": " + r.error);
    return;
  }
  if (!prepare_frame(t_ns, left->header.frame_id)) return;
  publish(core_->track_stereo(t_ns, l.image, r.image));
}

void OdometryNode::publish(const OdometryOutput& out) {
  if (out.invalid_input) {
    drop("invalid", "t=" + seconds(out.t_ns) + ": " + out.failure);
    return;
  }
  last_frame_ns_ = out.t_ns;
  if (!out.ok) {
    ++failures_;
    warn_throttled("tracking", "tracking failed at t=" + seconds(out.t_ns) + ": " + out.failure +
                                   " (" + std::to_string(failures_) +
                                   " so far; nothing published for this frame)");
  } else {
    const Eigen::Isometry3d T = to_isometry(out.T_odom_child);
    pub_odom_.publish(odometry_message(out, T, params_.odom_frame, child_frame_));
    if (params_.publish_tf) {
      tf_broadcaster_.sendTransform(
          transform_message(T, out.t_ns, params_.odom_frame, child_frame_));
    }
    ++published_;
  }
  const std::string body = !params_.body_frame.empty() ? params_.body_frame
                           : !imu_frame_.empty()       ? imu_frame_
                                                       : std::string("imu");
  for (const FusedOutput& s : out.fused) {
    pub_fused_.publish(fused_message(s, last_gyro_, params_.world_frame, body));
    geometry_msgs::Vector3Stamped bias;
    bias.header.stamp = to_ros_time(s.t_ns);
    bias.header.frame_id = body;
    bias.vector.x = s.gyro_bias_rad_s.x();
    bias.vector.y = s.gyro_bias_rad_s.y();
    bias.vector.z = s.gyro_bias_rad_s.z();
    pub_gyro_bias_.publish(bias);
    bias.vector.x = s.accel_bias_m_s2.x();
    bias.vector.y = s.accel_bias_m_s2.y();
    bias.vector.z = s.accel_bias_m_s2.z();
    pub_accel_bias_.publish(bias);
  }
  ROS_INFO_STREAM_THROTTLE(30.0, "kestrel_ros: " << statistics());
}

namespace {

volatile std::sig_atomic_t g_stop_requested = 0;
extern "C" void request_stop(int) { g_stop_requested = 1; }

}  // namespace

int run_odometry_node(int argc, char** argv) {
  // Until the node runs, roscpp's own SIGINT handling applies (it also ends its waits for a
  // master); ros::init itself may already wait for one when given _param:=value arguments.
  ::ros::init(argc, argv, "kestrel_odometry");
  // What ros::init left are not ROS arguments: refuse them rather than ignore a typo.
  for (int i = 2; i < argc; ++i) {
    std::cerr << "kestrel_ros node: error: unknown argument '" << argv[i]
              << "' (parameters: _name:=value; remappings: from:=to)\n";
    return 2;
  }
  if (!::ros::master::check()) {
    ROS_WARN_STREAM("kestrel_ros: no ROS master at " << ::ros::master::getURI()
                                                     << " yet; waiting for it");
  }
  // This handle lives until the end: destroying the last NodeHandle shuts roscpp (and its
  // logging) down, which would swallow the messages below.
  ::ros::NodeHandle nh;
  if (!::ros::ok()) return 0;  // stopped while waiting for the master
  // From here SIGINT/SIGTERM only ask the loop below to stop, so that the node can still log
  // its statistics before roscpp shuts down.
  std::signal(SIGINT, request_stop);
  std::signal(SIGTERM, request_stop);
  int code = 0;
  try {
    OdometryNode node(nh, ::ros::NodeHandle("~"));
    while (g_stop_requested == 0 && ::ros::ok()) {
      ::ros::getGlobalCallbackQueue()->callAvailable(::ros::WallDuration(0.05));
    }
    ROS_INFO_STREAM("kestrel_ros: stopped: " << node.statistics());
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("kestrel_ros: " << e.what());
    code = 1;
  }
  ::ros::shutdown();
  return code;
}

}  // namespace kestrel::ros
