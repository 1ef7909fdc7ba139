// Camera files: Kestrel YAML, EuRoC sensor.yaml, and the TUM RGB-D presets.
#include "kestrel/io/camera_io.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

std::optional<PinholeCamera> camera_preset(std::string_view name) {
  // Values from the TUM RGB-D benchmark documentation (shared/reference/README.md; the fr2
  // distortion coefficients are the benchmark's published ones).
  if (name == "fr1") {
    return PinholeCamera({517.3, 516.5, 318.6, 255.3, 640, 480},
                         {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  }
  if (name == "fr2") {
    return PinholeCamera({520.9, 521.0, 325.1, 249.7, 640, 480},
                         {0.2312, -0.7849, -0.0033, -0.0001, 0.9172});
  }
  if (name == "fr3") return PinholeCamera({535.4, 539.2, 320.1, 247.6, 640, 480});
  if (name == "ros") return PinholeCamera({525.0, 525.0, 319.5, 239.5, 640, 480});
  return std::nullopt;
}

namespace {

std::string number(double v) {
  std::ostringstream os;
  os << std::setprecision(12) << v;
  return os.str();
}

std::vector<double> as_numbers(const YAML::Node& node, const fs::path& path,
                               const std::string& field, std::size_t min_n, std::size_t max_n) {
  if (!node.IsSequence()) throw InputError(path, field, "must be a list of numbers");
  std::vector<double> out = yaml_as<std::vector<double>>(node, path, field);
  if (out.size() < min_n || out.size() > max_n) {
    throw InputError(path, field,
                     "has " + std::to_string(out.size()) + " values, expected " +
                         (min_n == max_n ? std::to_string(min_n)
                                         : std::to_string(min_n) + " to " + std::to_string(max_n)));
  }
  return out;
}

PinholeCamera make_camera(const PinholeIntrinsics& k, const RadTanDistortion& d,
                          const fs::path& path, const std::string& field) {
  try {
    return PinholeCamera(k, d);
  } catch (const std::invalid_argument& e) {
    throw InputError(path, field, e.what());
  }
}

CameraFile load_euroc(const YAML::Node& root, const fs::path& path) {
  const std::string model =
      yaml_as<std::string>(yaml_require(root, "camera_model", path, ""), path, "camera_model");
  if (model != "pinhole") {
    throw InputError(path, "camera_model", "'" + model + "' is not supported (only pinhole)");
  }
  const auto k = as_numbers(yaml_require(root, "intrinsics", path, ""), path, "intrinsics", 4, 4);
  const auto res = as_numbers(yaml_require(root, "resolution", path, ""), path, "resolution", 2, 2);
  for (const double r : res) {  // checked before the cast to int (out of range is undefined)
    if (!(r >= 1.0 && r <= 65536.0 && r == std::floor(r))) {
      throw InputError(
          path, "resolution",
          "expected [width, height], whole numbers of pixels from 1 to 65536; got " + number(r));
    }
  }
  RadTanDistortion d;
  if (root["distortion_coefficients"]) {
    const std::string dm = root["distortion_model"] ? yaml_as<std::string>(root["distortion_model"],
                                                                           path, "distortion_model")
                                                    : "radial-tangential";
    if (dm != "radial-tangential" && dm != "radtan" && dm != "plumb_bob") {
      throw InputError(path, "distortion_model",
                       "'" + dm + "' is not supported (radial-tangential only)");
    }
    const auto c =
        as_numbers(root["distortion_coefficients"], path, "distortion_coefficients", 4, 5);
    d = {c[0], c[1], c[2], c[3], c.size() == 5 ? c[4] : 0.0};
  }
  CameraFile out{.camera = make_camera(
                     {k[0], k[1], k[2], k[3], static_cast<int>(res[0]), static_cast<int>(res[1])},
                     d, path, "intrinsics")};
  if (root["T_BS"]) {
    const auto m =
        as_numbers(yaml_require(root["T_BS"], "data", path, "T_BS."), path, "T_BS.data", 16, 16);
    Eigen::Matrix4d T;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) T(r, c) = m[static_cast<std::size_t>(4 * r + c)];
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    if ((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-4 || R.determinant() < 0) {
      throw InputError(path, "T_BS.data", "rotation block is not a rotation matrix");
    }
    out.T_body_sensor = SE3::from_matrix(T);
  }
  return out;
}

// The optional sensor facts of Kestrel's `camera:` map (CameraFile).
void read_sensor_facts(const YAML::Node& map, const fs::path& path, CameraFile& out) {
  if (const YAML::Node n = map["depth_scale"]) {
    const auto scale = yaml_as<double>(n, path, "camera.depth_scale");
    if (!(std::isfinite(scale) && scale > 0.0)) {
      throw InputError(path, "camera.depth_scale",
                       "must be positive and finite (depth image units per metre)");
    }
    out.depth_scale = scale;
  }
  if (const YAML::Node n = map["rolling_shutter_readout_s"]) {
    const auto readout = yaml_as<double>(n, path, "camera.rolling_shutter_readout_s");
    if (!(readout >= 0.0 && readout <= 1.0)) {
      throw InputError(path, "camera.rolling_shutter_readout_s",
                       "must be in [0, 1] s (0: global shutter)");
    }
    out.rolling_shutter_readout_s = readout;
  }
  if (const YAML::Node n = map["time_offset_s"]) {
    const auto offset = yaml_as<double>(n, path, "camera.time_offset_s");
    if (!(offset >= -1.0 && offset <= 1.0)) {
      throw InputError(path, "camera.time_offset_s",
                       "must be in [-1, 1] s (a frame stamped t was exposed at t + offset)");
    }
    out.time_offset_s = offset;
  }
}

CameraFile load_kestrel(const YAML::Node& root, const fs::path& path) {
  const YAML::Node map = yaml_require(root, "camera", path, "");
  CameraFile out{.camera = camera_from_yaml(map, path, "camera")};
  read_sensor_facts(map, path, out);
  return out;
}

void write_text(const fs::path& path, const std::string& text, std::string_view command,
                bool force) {
  check_can_write_file(path, command, force);
  std::ofstream out(path);
  out << provenance_line(command) << "\n" << text;
  if (!out) throw InputError(path.string() + ": cannot write");
}

}  // namespace

PinholeCamera camera_from_yaml(const YAML::Node& map, const fs::path& path,
                               const std::string& field) {
  if (!map.IsMap()) throw InputError(path, field, "must be a map");
  const std::string prefix = field + ".";
  const auto num = [&](const char* key) {
    return yaml_as<double>(yaml_require(map, key, path, prefix), path, prefix + key);
  };
  PinholeIntrinsics k{
      num("fx"),
      num("fy"),
      num("cx"),
      num("cy"),
      yaml_as<int>(yaml_require(map, "width", path, prefix), path, prefix + "width"),
      yaml_as<int>(yaml_require(map, "height", path, prefix), path, prefix + "height")};
  RadTanDistortion d;
  if (map["distortion"]) {
    const auto c = as_numbers(map["distortion"], path, prefix + "distortion", 4, 5);
    d = {c[0], c[1], c[2], c[3], c.size() == 5 ? c[4] : 0.0};
  }
  return make_camera(k, d, path, field);
}

CameraFile load_camera_file(const fs::path& path) {
  if (!fs::exists(path)) throw InputError(path.string() + ": no such camera file");
  const YAML::Node root = load_yaml_file(path);
  if (!root.IsMap()) throw InputError(path.string() + ": expected a YAML map");
  if (root["intrinsics"]) return load_euroc(root, path);
  if (root["camera"]) return load_kestrel(root, path);
  throw InputError(path.string() +
                   ": not a camera file: expected a 'camera:' map (Kestrel) or 'intrinsics:' "
                   "(EuRoC sensor.yaml)");
}

CameraFile load_camera_description(const std::string& preset_or_path) {
  if (auto preset = camera_preset(preset_or_path)) {
    // TUM RGB-D depth PNGs; readout 0 (not measured for those Kinects).
    return CameraFile{.camera = *preset, .depth_scale = 5000.0};
  }
  if (!fs::exists(preset_or_path)) {
    throw InputError("camera '" + preset_or_path +
                     "': neither a preset (fr1, fr2, fr3, ros) nor an existing file");
  }
  return load_camera_file(preset_or_path);
}

PinholeCamera load_camera(const std::string& preset_or_path) {
  return load_camera_description(preset_or_path).camera;
}

std::string camera_preset_in_path(const fs::path& path) {
  const std::string name = fs::absolute(path).lexically_normal().string();
  if (name.find("freiburg1") != std::string::npos) return "fr1";
  if (name.find("freiburg2") != std::string::npos) return "fr2";
  if (name.find("freiburg3") != std::string::npos) return "fr3";
  return {};
}

std::string camera_for_folder(const fs::path& folder) {
  const fs::path own = folder / "camera.yaml";
  std::error_code ec;
  if (fs::is_regular_file(own, ec)) return own.string();
  return camera_preset_in_path(folder);
}

RectifiedStereo load_rectified_stereo(const fs::path& path) {
  if (!fs::exists(path)) throw InputError(path.string() + ": no such stereo calibration file");
  const YAML::Node root = load_yaml_file(path);
  const YAML::Node st = yaml_require(root, "stereo", path, "");
  const auto num = [&](const char* key) {
    return yaml_as<double>(yaml_require(st, key, path, "stereo."), path,
                           std::string("stereo.") + key);
  };
  RectifiedStereo s{
      num("f"),
      num("cu"),
      num("cv"),
      num("baseline_m"),
      yaml_as<int>(yaml_require(st, "width", path, "stereo."), path, "stereo.width"),
      yaml_as<int>(yaml_require(st, "height", path, "stereo."), path, "stereo.height")};
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path, "stereo", e.what());
  }
  return s;
}

void save_camera_yaml(const fs::path& path, const PinholeCamera& camera, std::string_view command,
                      bool force) {
  const auto& k = camera.intrinsics();
  const auto& d = camera.distortion();
  std::ostringstream os;
  os << "camera:\n  model: pinhole\n  width: " << k.width << "\n  height: " << k.height
     << "\n  fx: " << number(k.fx) << "\n  fy: " << number(k.fy) << "\n  cx: " << number(k.cx)
     << "\n  cy: " << number(k.cy) << "\n  distortion: [" << number(d.k1) << ", " << number(d.k2)
     << ", " << number(d.p1) << ", " << number(d.p2) << ", " << number(d.k3)
     << "]  # k1, k2, p1, p2, k3 (radial-tangential)\n";
  write_text(path, os.str(), command, force);
}

void save_rectified_stereo_yaml(const fs::path& path, const RectifiedStereo& s,
                                std::string_view command, bool force) {
  std::ostringstream os;
  os << "stereo:  # rectified pair: right camera at +baseline_m along the left camera's x\n"
     << "  f: " << number(s.f) << "\n  cu: " << number(s.cu) << "\n  cv: " << number(s.cv)
     << "\n  baseline_m: " << number(s.baseline_m) << "\n  width: " << s.width
     << "\n  height: " << s.height << "\n";
  write_text(path, os.str(), command, force);
}

void save_euroc_camera_yaml(const fs::path& path, const PinholeCamera& camera,
                            const SE3& T_body_sensor, double rate_hz, std::string_view command,
                            bool force) {
  const auto& k = camera.intrinsics();
  const auto& d = camera.distortion();
  const Eigen::Matrix4d T = T_body_sensor.matrix();
  std::ostringstream os;
  os << "sensor_type: camera\ncomment: rendered by Kestrel\nT_BS:\n  cols: 4\n  rows: 4\n"
        "  data: [";
  for (int i = 0; i < 16; ++i) os << (i ? ", " : "") << number(T(i / 4, i % 4));
  os << "]\nrate_hz: " << number(rate_hz) << "\nresolution: [" << k.width << ", " << k.height
     << "]\ncamera_model: pinhole\nintrinsics: [" << number(k.fx) << ", " << number(k.fy) << ", "
     << number(k.cx) << ", " << number(k.cy)
     << "]\ndistortion_model: radial-tangential\ndistortion_coefficients: [" << number(d.k1) << ", "
     << number(d.k2) << ", " << number(d.p1) << ", " << number(d.p2);
  if (d.k3 != 0.0) os << ", " << number(d.k3);  // EuRoC files carry 4; k3 only when used
  os << "]\n";
  write_text(path, os.str(), command, force);
}

}  // namespace kestrel::io
