// Stereo calibration files and rectification maps (OpenCV calib3d).
#include "kestrel/sensor/rectification.hpp"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sensor {
namespace fs = std::filesystem;

namespace {

cv::Mat camera_matrix(const PinholeCamera& c) {
  return (cv::Mat_<double>(3, 3) << c.fx(), 0.0, c.cx(), 0.0, c.fy(), c.cy(), 0.0, 0.0, 1.0);
}

cv::Mat distortion_vector(const PinholeCamera& c) {
  const auto& d = c.distortion();
  return (cv::Mat_<double>(1, 5) << d.k1, d.k2, d.p1, d.p2, d.k3);
}

}  // namespace

StereoCalibration StereoCalibration::from_euroc_files(const fs::path& cam0_yaml,
                                                      const fs::path& cam1_yaml) {
  const io::CameraFile c0 = io::load_camera_file(cam0_yaml);
  const io::CameraFile c1 = io::load_camera_file(cam1_yaml);
  if (!c0.T_body_sensor) throw InputError(cam0_yaml, "T_BS", "is missing");
  if (!c1.T_body_sensor) throw InputError(cam1_yaml, "T_BS", "is missing");
  StereoCalibration calib{c0.camera, c1.camera, c0.T_body_sensor->inverse() * *c1.T_body_sensor};
  try {
    calib.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(cam0_yaml.string() + " + " + cam1_yaml.string() + ": " + e.what());
  }
  return calib;
}

StereoCalibration StereoCalibration::from_euroc(const io::EurocSequence& sequence) {
  return from_euroc_files(sequence.mav0() / "cam0" / "sensor.yaml",
                          sequence.mav0() / "cam1" / "sensor.yaml");
}

void StereoCalibration::validate() const {
  if (left.width() != right.width() || left.height() != right.height()) {
    throw std::invalid_argument("stereo calibration: the cameras have different image sizes");
  }
  if (left.width() <= 0) throw std::invalid_argument("stereo calibration: no cameras");
  if (!(T_left_right.translation().norm() > 1e-6)) {
    throw std::invalid_argument("stereo calibration: the baseline is zero");
  }
}

std::string StereoCalibration::describe() const {
  std::ostringstream os;
  os << "left " << left.describe() << "; right " << right.describe() << "; baseline "
     << T_left_right.translation().norm() << " m";
  return os.str();
}

StereoCalibration load_stereo_calibration(const fs::path& path) {
  if (!fs::exists(path)) throw InputError(path.string() + ": no such stereo calibration file");
  const YAML::Node root = io::load_yaml_file(path);
  const YAML::Node sp = io::yaml_require(root, "stereo_pair", path, "");
  StereoCalibration calib;
  calib.left = io::camera_from_yaml(io::yaml_require(sp, "left", path, "stereo_pair."), path,
                                    "stereo_pair.left");
  calib.right = io::camera_from_yaml(io::yaml_require(sp, "right", path, "stereo_pair."), path,
                                     "stereo_pair.right");
  const auto m = io::yaml_as<std::vector<double>>(
      io::yaml_require(sp, "T_left_right", path, "stereo_pair."), path, "stereo_pair.T_left_right");
  if (m.size() != 16)
    throw InputError(path, "stereo_pair.T_left_right", "needs 16 numbers (4x4, row-major)");
  Eigen::Matrix4d T;
  for (int i = 0; i < 16; ++i) T(i / 4, i % 4) = m[static_cast<std::size_t>(i)];
  try {
    calib.T_left_right = SE3::from_matrix(T);
    calib.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path, "stereo_pair", e.what());
  }
  return calib;
}

void save_stereo_calibration(const fs::path& path, const StereoCalibration& calib,
                             std::string_view command, bool force) {
  io::check_can_write_file(path, command, force);
  std::ostringstream os;
  os.precision(12);
  const auto cam = [&](const char* name, const PinholeCamera& c) {
    const auto& d = c.distortion();
    os << "  " << name << ": {width: " << c.width() << ", height: " << c.height()
       << ", fx: " << c.fx() << ", fy: " << c.fy() << ", cx: " << c.cx() << ", cy: " << c.cy()
       << ", distortion: [" << d.k1 << ", " << d.k2 << ", " << d.p1 << ", " << d.p2 << ", " << d.k3
       << "]}\n";
  };
  os << io::provenance_line(command)
     << "\nstereo_pair:  # raw pair; T_left_right maps right-camera points to the left camera\n";
  cam("left", calib.left);
  cam("right", calib.right);
  const Eigen::Matrix4d T = calib.T_left_right.matrix();
  os << "  T_left_right: [";
  for (int i = 0; i < 16; ++i) os << T(i / 4, i % 4) << (i < 15 ? ", " : "]\n");
  std::ofstream out(path);
  out << os.str();
  if (!out) throw InputError(path.string() + ": write failed");
}

StereoRectifier::StereoRectifier(const StereoCalibration& calibration, RectifyOptions options)
    : calibration_(calibration), options_(options) {
  calibration_.validate();
  const cv::Size size(calibration_.left.width(), calibration_.left.height());
  // OpenCV wants the pose of the second camera relative to the first: p_right = R p_left + T.
  const SE3 T_right_left = calibration_.T_left_right.inverse();
  cv::Mat R(3, 3, CV_64F), t(3, 1, CV_64F);
  const Eigen::Matrix3d Re = T_right_left.rotation_matrix();
  for (int i = 0; i < 3; ++i) {
    t.at<double>(i) = T_right_left.translation()(i);
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = Re(i, j);
  }
  cv::Mat Q;
  cv::stereoRectify(camera_matrix(calibration_.left), distortion_vector(calibration_.left),
                    camera_matrix(calibration_.right), distortion_vector(calibration_.right), size,
                    R, t, R1_, R2_, P1_, P2_, Q, cv::CALIB_ZERO_DISPARITY, options_.alpha, size);
  rig_.f = P1_.at<double>(0, 0);
  rig_.cu = P1_.at<double>(0, 2);
  rig_.cv = P1_.at<double>(1, 2);
  rig_.baseline_m = -P2_.at<double>(0, 3) / P2_.at<double>(0, 0);
  rig_.width = size.width;
  rig_.height = size.height;
  if (!(rig_.baseline_m > 0.0)) {
    throw InputError(
        "stereo calibration: after rectification the right camera is not to the "
        "right of the left one (baseline " +
        std::to_string(rig_.baseline_m) + " m): swap the cameras");
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R_rect_left_(i, j) = R1_.at<double>(i, j);
  }
  cv::initUndistortRectifyMap(camera_matrix(calibration_.left),
                              distortion_vector(calibration_.left), R1_, P1_, size, CV_16SC2,
                              map_l1_, map_l2_);
  cv::initUndistortRectifyMap(camera_matrix(calibration_.right),
                              distortion_vector(calibration_.right), R2_, P2_, size, CV_16SC2,
                              map_r1_, map_r2_);
}

void StereoRectifier::rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_rect,
                              cv::Mat& right_rect) const {
  const cv::Size size(rig_.width, rig_.height);
  if (left.size() != size || right.size() != size) {
    throw InputError("rectify: the images are " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " and " + std::to_string(right.cols) + "x" +
                     std::to_string(right.rows) + " but the calibration is for " +
                     std::to_string(size.width) + "x" + std::to_string(size.height));
  }
  const int interp = options_.bilinear ? cv::INTER_LINEAR : cv::INTER_NEAREST;
  cv::remap(left, left_rect, map_l1_, map_l2_, interp, cv::BORDER_CONSTANT);
  cv::remap(right, right_rect, map_r1_, map_r2_, interp, cv::BORDER_CONSTANT);
}

Eigen::Vector2d StereoRectifier::rectify_point(const Eigen::Vector2d& uv_raw, bool right) const {
  const PinholeCamera& cam = right ? calibration_.right : calibration_.left;
  std::vector<cv::Point2d> in{{uv_raw.x(), uv_raw.y()}}, out;
  cv::undistortPoints(in, out, camera_matrix(cam), distortion_vector(cam), right ? R2_ : R1_,
                      right ? P2_ : P1_);
  return {out[0].x, out[0].y};
}

}  // namespace kestrel::sensor
