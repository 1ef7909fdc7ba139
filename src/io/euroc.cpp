// EuRoC ASL folder reader: camera lists, stereo pairing, IMU streaming, ground truth.
#include "kestrel/io/euroc.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

namespace {

double positive_field(const YAML::Node& root, const char* key, const fs::path& path) {
  // A scalar or list has no fields (and operator[] on a scalar throws yaml-cpp's BadSubscript,
  // whose message names no file: found by fuzz/sensor_yaml.cpp).
  if (!root.IsMap()) throw InputError(path.string() + ": expected a YAML map of IMU fields");
  if (!root[key]) throw InputError(path, key, "is missing");
  double v = 0.0;
  try {
    v = root[key].as<double>();
  } catch (const YAML::Exception&) {
    throw InputError(path, key, "is not a number");
  }
  if (!(v > 0.0) || !std::isfinite(v)) throw InputError(path, key, "must be positive");
  return v;
}

}  // namespace

ImuNoise load_imu_noise(const fs::path& sensor_yaml) {
  if (!fs::exists(sensor_yaml))
    throw InputError(sensor_yaml.string() + ": no such IMU sensor file");
  const YAML::Node root = load_yaml_file(sensor_yaml);
  ImuNoise n;
  n.gyro_noise_density = positive_field(root, "gyroscope_noise_density", sensor_yaml);
  n.gyro_random_walk = positive_field(root, "gyroscope_random_walk", sensor_yaml);
  n.accel_noise_density = positive_field(root, "accelerometer_noise_density", sensor_yaml);
  n.accel_random_walk = positive_field(root, "accelerometer_random_walk", sensor_yaml);
  n.rate_hz = positive_field(root, "rate_hz", sensor_yaml);
  if (root["accelerometer_range_m_s2"]) {
    n.accel_range_m_s2 = positive_field(root, "accelerometer_range_m_s2", sensor_yaml);
  }
  if (root["gyroscope_range_rad_s"]) {
    n.gyro_range_rad_s = positive_field(root, "gyroscope_range_rad_s", sensor_yaml);
  }
  if (root["in_flight_noise_inflation"]) {
    n.in_flight_noise_inflation = positive_field(root, "in_flight_noise_inflation", sensor_yaml);
  }
  if (root["T_BS"]) {
    std::vector<double> m;
    try {
      m = root["T_BS"]["data"].as<std::vector<double>>();
    } catch (const YAML::Exception&) {
      throw InputError(sensor_yaml, "T_BS.data", "must be a list of 16 numbers");
    }
    if (m.size() != 16) throw InputError(sensor_yaml, "T_BS.data", "must hold 16 numbers");
    Eigen::Matrix4d T;
    for (int i = 0; i < 16; ++i) T(i / 4, i % 4) = m[static_cast<std::size_t>(i)];
    n.T_body_imu = SE3::from_matrix(T);
  }
  return n;
}

ImuCsvReader::ImuCsvReader(const fs::path& csv) : reader_(csv) {}

bool ImuCsvReader::next(ImuSample& s) {
  std::string line;
  if (!reader_.next(line)) return false;
  const auto f = split_fields(line, ",");
  if (f.size() != 7) {
    reader_.fail("expected 7 comma-separated fields (timestamp, 3 gyro, 3 accel), found " +
                 std::to_string(f.size()));
  }
  s.t_ns = parse_int64(f[0], reader_, 0);
  for (int k = 0; k < 3; ++k) {
    s.gyro_rad_s[k] = parse_double(f[static_cast<std::size_t>(1 + k)], reader_, 1 + k);
    s.accel_m_s2[k] = parse_double(f[static_cast<std::size_t>(4 + k)], reader_, 4 + k);
  }
  if (last_t_ns_ && s.t_ns <= *last_t_ns_) {
    reader_.fail("time stamp " + std::to_string(s.t_ns) + " does not increase");
  }
  last_t_ns_ = s.t_ns;
  return true;
}

std::vector<GroundTruthState> read_euroc_state_groundtruth(const fs::path& csv) {
  TextLineReader reader(csv);
  std::vector<GroundTruthState> out;
  std::string line;
  while (reader.next(line)) {
    const auto f = split_fields(line, ",");
    if (f.size() < 17) {
      reader.fail("expected 17 fields (t, p, q wxyz, v, gyro bias, accel bias), found " +
                  std::to_string(f.size()));
    }
    double v[17];
    for (std::size_t k = 1; k < 17; ++k) v[k] = parse_double(f[k], reader, k);
    GroundTruthState s;
    s.t_ns = parse_int64(f[0], reader, 0);
    const Eigen::Quaterniond q(v[4], v[5], v[6], v[7]);
    if (std::abs(q.norm() - 1.0) > 1e-3) reader.fail("quaternion is not of unit norm");
    s.T_world_body = SE3(q, Eigen::Vector3d(v[1], v[2], v[3]));
    s.v_world = {v[8], v[9], v[10]};
    s.gyro_bias = {v[11], v[12], v[13]};
    s.accel_bias = {v[14], v[15], v[16]};
    if (!out.empty() && s.t_ns <= out.back().t_ns) reader.fail("time stamp does not increase");
    out.push_back(s);
  }
  return out;
}

std::vector<TimedFile> read_euroc_camera_csv(const fs::path& csv) {
  TextLineReader reader(csv);
  std::vector<TimedFile> out;
  std::string line;
  while (reader.next(line)) {
    const auto f = split_fields(line, ",");
    if (f.size() != 2) {
      reader.fail("expected 'timestamp [ns],filename', found " + std::to_string(f.size()) +
                  " fields");
    }
    const TimeNs t = parse_int64(f[0], reader, 0);
    if (!out.empty() && t <= out.back().t_ns) reader.fail("time stamp does not increase");
    out.push_back({t, csv.parent_path() / "data" / std::string(f[1]), reader.line_number()});
  }
  return out;
}

cv::Mat read_gray_image(const fs::path& file) {
  if (!fs::exists(file)) throw InputError(file.string() + ": image file does not exist");
  cv::Mat img = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw InputError(file.string() + ": cannot decode image");
  return img;
}

EurocSequence::EurocSequence(const fs::path& folder) {
  mav0_ = fs::is_directory(folder / "mav0") ? folder / "mav0" : folder;
  if (!fs::is_directory(mav0_ / "cam0")) {
    throw InputError(folder.string() + ": not an EuRoC folder (no mav0/cam0)");
  }
  cam0_ = read_euroc_camera_csv(mav0_ / "cam0" / "data.csv");
  if (fs::exists(mav0_ / "cam1" / "data.csv")) {
    cam1_ = read_euroc_camera_csv(mav0_ / "cam1" / "data.csv");
  }
  // EuRoC's cameras are hardware-synchronised: a stereo pair shares one time stamp.
  std::size_t j = 0;
  for (std::size_t i = 0; i < cam0_.size(); ++i) {
    while (j < cam1_.size() && cam1_[j].t_ns < cam0_[i].t_ns) ++j;
    if (j < cam1_.size() && cam1_[j].t_ns == cam0_[i].t_ns) pairs_.emplace_back(i, j);
  }
}

StereoImages EurocSequence::load_stereo(std::size_t i) const {
  const auto [a, b] = pairs_.at(i);
  StereoImages out{cam0_[a].t_ns, read_gray_image(cam0_[a].file), read_gray_image(cam1_[b].file)};
  if (out.left.size() != out.right.size()) {
    throw InputError(cam1_[b].file.string() + ": size differs from the cam0 image " +
                     cam0_[a].file.string());
  }
  return out;
}

cv::Mat EurocSequence::load_cam0(std::size_t i) const { return read_gray_image(cam0_.at(i).file); }

CameraFile EurocSequence::cam0_calibration() const {
  return load_camera_file(mav0_ / "cam0" / "sensor.yaml");
}
CameraFile EurocSequence::cam1_calibration() const {
  return load_camera_file(mav0_ / "cam1" / "sensor.yaml");
}

bool EurocSequence::has_imu() const { return fs::exists(imu_csv()); }

std::optional<fs::path> EurocSequence::groundtruth_csv() const {
  for (const char* dir : {"groundtruth_cam0", "state_groundtruth_estimate0", "gt0", "leica0"}) {
    const fs::path p = mav0_ / dir / "data.csv";
    if (fs::exists(p)) return p;
  }
  return std::nullopt;
}

}  // namespace kestrel::io
