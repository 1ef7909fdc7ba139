// Writing rendered sequences in the TUM RGB-D and EuRoC layouts, one frame at a time.
#include "kestrel/sim/sequence_writer.hpp"

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::sim {

namespace fs = std::filesystem;

namespace {

/// True if `dir` holds the marker of a previous `kestrel render` (output_guard.hpp).
bool holds_previous_render(const fs::path& dir) {
  std::ifstream in(dir / ".kestrel-output");
  std::string line;
  return in && std::getline(in, line) && line == SequenceWriter::kCommand;
}

std::ofstream open_list(const fs::path& path, std::initializer_list<const char*> header) {
  std::ofstream out(path);
  if (!out) throw InputError(path.string() + ": cannot open file for writing");
  out << io::provenance_line(SequenceWriter::kCommand) << "\n";
  for (const char* line : header) out << line << "\n";
  return out;
}

void write_png(const fs::path& path, const cv::Mat& image) {
  // Fast deflate: rendering, not compression, should dominate a render run.
  static const std::vector<int> params{cv::IMWRITE_PNG_COMPRESSION, 1};
  if (!cv::imwrite(path.string(), image, params)) {
    throw InputError(path.string() + ": cannot write image");
  }
}

void check_stream(std::ofstream& out, const fs::path& path) {
  out.flush();
  if (!out) throw InputError(path.string() + ": write failed (disk full?)");
}

}  // namespace

FrameClock FrameClock::from_rate(double rate_hz, TimeNs epoch_ns) {
  if (!(rate_hz > 0.0) || !(rate_hz <= 1e6)) {
    throw std::invalid_argument("FrameClock: rate must be in (0, 1e6] Hz");
  }
  return {epoch_ns, static_cast<TimeNs>(std::llround(1e9 / rate_hz))};
}

cv::Mat depth_to_png16(const cv::Mat& depth_m, double units_per_m) {
  CV_Assert(depth_m.type() == CV_32F);
  cv::Mat out(depth_m.size(), CV_16U);
  for (int v = 0; v < depth_m.rows; ++v) {
    const auto* z = depth_m.ptr<float>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      const double units = std::round(static_cast<double>(z[u]) * units_per_m);
      o[u] = (units > 0.0 && units <= 65535.0) ? static_cast<std::uint16_t>(units) : 0;
    }
  }
  return out;
}

cv::Mat disparity_to_png16(const cv::Mat& disparity_px) {
  return depth_to_png16(disparity_px, 256.0);
}

SequenceWriter::SequenceWriter(fs::path dir, SequenceLayout layout, bool force)
    : dir_(std::move(dir)), layout_(std::move(layout)), force_(force) {
  if (layout_.camera.has_distortion()) {
    throw std::invalid_argument("SequenceWriter: rendered cameras are distortion-free");
  }
  if (layout_.stereo) layout_.stereo->validate();
  const bool previous = fs::exists(dir_) && holds_previous_render(dir_);
  io::claim_output_dir(dir_, kCommand, force_);
  if (previous) {
    // Our own earlier output: drop its frames so that a shorter run leaves no stale images.
    for (const char* sub : {"rgb", "depth", "mav0", "stereo.yaml"}) fs::remove_all(dir_ / sub);
  }
  fs::create_directories(dir_ / "rgb");
  fs::create_directories(dir_ / "depth");
  // The folder is claimed: files in it are ours to (over)write.
  io::save_camera_yaml(dir_ / "camera.yaml", layout_.camera, kCommand, true);
  rgb_list_ = open_list(dir_ / "rgb.txt", {"# color images", "# timestamp filename"});
  depth_list_ = open_list(
      dir_ / "depth.txt",
      {"# depth maps (16-bit PNG, 5000 units per metre, 0 = no depth)", "# timestamp filename"});
  if (layout_.stereo) {
    const RectifiedStereo& rig = *layout_.stereo;
    const fs::path mav0 = dir_ / "mav0";
    for (const char* sub :
         {"cam0/data", "cam1/data", "cam0/disparity", "state_groundtruth_estimate0"}) {
      fs::create_directories(mav0 / sub);
    }
    const SE3 T_left_right(SO3(), Eigen::Vector3d(rig.baseline_m, 0.0, 0.0));
    io::save_euroc_camera_yaml(mav0 / "cam0" / "sensor.yaml", rig.left(), layout_.T_body_cam,
                               layout_.rate_hz, kCommand, true);
    io::save_euroc_camera_yaml(mav0 / "cam1" / "sensor.yaml", rig.left(),
                               layout_.T_body_cam * T_left_right, layout_.rate_hz, kCommand, true);
    io::save_rectified_stereo_yaml(dir_ / "stereo.yaml", rig, kCommand, true);
    cam0_csv_ = open_list(mav0 / "cam0" / "data.csv", {"#timestamp [ns],filename"});
    cam1_csv_ = open_list(mav0 / "cam1" / "data.csv", {"#timestamp [ns],filename"});
    state_csv_ = open_list(
        mav0 / "state_groundtruth_estimate0" / "data.csv",
        {"#timestamp,p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],"
         "q_RS_z [],v_RS_R_x [m s^-1],v_RS_R_y [m s^-1],v_RS_R_z [m s^-1],b_w_RS_S_x [rad s^-1],"
         "b_w_RS_S_y [rad s^-1],b_w_RS_S_z [rad s^-1],b_a_RS_S_x [m s^-2],b_a_RS_S_y [m s^-2],"
         "b_a_RS_S_z [m s^-2]"});
  }
}

SequenceWriter::~SequenceWriter() {
  if (finished_) return;
  try {
    finish();
  } catch (...) {  // NOLINT(bugprone-empty-catch): a destructor must not throw
  }
}

void SequenceWriter::check_open() const {
  if (finished_) throw std::logic_error("SequenceWriter: write after finish()");
}

void SequenceWriter::write_rgbd(TimeNs t_ns, const KinematicState& body,
                                const RenderedFrame& frame) {
  check_open();
  if (frame.color_bgr.cols != layout_.camera.width() ||
      frame.color_bgr.rows != layout_.camera.height()) {
    throw std::invalid_argument("SequenceWriter: frame size differs from the camera's");
  }
  if (!groundtruth_cam_.empty() && t_ns <= groundtruth_cam_.back().t_ns) {
    throw std::invalid_argument("SequenceWriter: time stamps must increase");
  }
  const std::string stamp = io::format_seconds(t_ns);
  const std::string rgb_name = "rgb/" + stamp + ".png";
  const std::string depth_name = "depth/" + stamp + ".png";
  write_png(dir_ / rgb_name, frame.color_bgr);
  depth16_ = depth_to_png16(frame.depth_m, kDepthUnitsPerMetre);
  write_png(dir_ / depth_name, depth16_);
  rgb_list_ << stamp << ' ' << rgb_name << '\n';
  depth_list_ << stamp << ' ' << depth_name << '\n';
  groundtruth_cam_.push_back({t_ns, body.T_world_body * layout_.T_body_cam});
  ++frames_;
}

void SequenceWriter::write(TimeNs t_ns, const KinematicState& body, const RenderedFrame& frame) {
  if (layout_.stereo) {
    throw std::logic_error("SequenceWriter: a stereo layout needs stereo frames");
  }
  write_rgbd(t_ns, body, frame);
}

void SequenceWriter::write(TimeNs t_ns, const KinematicState& body, const StereoFrame& frame) {
  if (!layout_.stereo) throw std::logic_error("SequenceWriter: not a stereo layout");
  write_rgbd(t_ns, body, frame.left);
  const fs::path mav0 = dir_ / "mav0";
  const std::string name = std::to_string(t_ns) + ".png";
  frame.left.gray.convertTo(gray8_, CV_8U);
  write_png(mav0 / "cam0" / "data" / name, gray8_);
  frame.right.gray.convertTo(gray8_, CV_8U);
  write_png(mav0 / "cam1" / "data" / name, gray8_);
  write_png(mav0 / "cam0" / "disparity" / name, disparity_to_png16(frame.disparity_px));
  cam0_csv_ << t_ns << ',' << name << '\n';
  cam1_csv_ << t_ns << ',' << name << '\n';
  const Eigen::Vector3d& p = body.T_world_body.translation();
  const Eigen::Quaterniond& q = body.T_world_body.unit_quaternion();
  const auto& v = body.v_world;
  state_csv_ << t_ns;
  for (const double x : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z(), v.x(), v.y(), v.z()}) {
    state_csv_ << ',' << io::format_double(x);
  }
  state_csv_ << ",0,0,0,0,0,0\n";
}

void SequenceWriter::finish() {
  if (finished_) return;
  finished_ = true;
  check_stream(rgb_list_, dir_ / "rgb.txt");
  check_stream(depth_list_, dir_ / "depth.txt");
  rgb_list_.close();
  depth_list_.close();
  io::write_tum_trajectory(dir_ / "groundtruth.txt", groundtruth_cam_, kCommand, true);
  if (layout_.stereo) {
    const fs::path mav0 = dir_ / "mav0";
    check_stream(cam0_csv_, mav0 / "cam0" / "data.csv");
    check_stream(cam1_csv_, mav0 / "cam1" / "data.csv");
    check_stream(state_csv_, mav0 / "state_groundtruth_estimate0" / "data.csv");
    cam0_csv_.close();
    cam1_csv_.close();
    state_csv_.close();
  }
}

}  // namespace kestrel::sim
