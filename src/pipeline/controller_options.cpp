// Loading and checking the `controller:` block of a pipeline config. The control options
// themselves are read by the control module's own loaders (from_yaml of each section).
#include "kestrel/pipeline/controller_options.hpp"

#include <cmath>
#include <sstream>

#include "config_fields.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

InputError controller_field_error(const fs::path& config, const std::string& key,
                                  const std::string& msg) {
  return detail::config_field_error(config, "controller." + key, msg);
}

// The control options file: its `controller:`, `pwm:` and `safety:` sections (each optional),
// nothing else, so that a typo in a section name is not silently ignored.
void load_control_file(const fs::path& file, ControllerStageOptions& o) {
  const YAML::Node root = io::load_yaml_file(file);
  if (!root.IsMap()) throw InputError(file.string() + ": expected a YAML map of control options");
  for (const auto& kv : root) {
    const auto key = kv.first.as<std::string>();
    if (key != "controller" && key != "pwm" && key != "safety") {
      throw InputError(file, key, "is not a control section (controller, pwm, safety)");
    }
  }
  if (root["controller"]) {
    o.controller = control::PositionControllerOptions::from_yaml(root["controller"], file.string());
  }
  if (root["pwm"]) o.pwm = control::PwmMapperOptions::from_yaml(root["pwm"], file.string());
  if (root["safety"]) o.safety = control::SafetyOptions::from_yaml(root["safety"], file.string());
}

std::optional<Eigen::Vector4d> parse_setpoint(const YAML::Node& v) {
  if (v.IsScalar() && v.as<std::string>() == "hold") return std::nullopt;
  if (!v.IsSequence() || v.size() != 4) {
    throw InputError("must be hold or [x_m, y_m, z_m, yaw_deg]");
  }
  Eigen::Vector4d p;
  for (std::size_t i = 0; i < 4; ++i) p[static_cast<int>(i)] = v[i].as<double>();
  if (!p.allFinite()) throw InputError("must be finite numbers");
  p[3] *= kDegToRad;
  return p;
}

Eigen::Vector3d axis_of(const std::string& name) {
  if (name.size() != 2 || (name[0] != '+' && name[0] != '-') || name[1] < 'x' || name[1] > 'z') {
    throw InputError("axis '" + name + "' is not one of +x -x +y -y +z -z");
  }
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  a[name[1] - 'x'] = name[0] == '+' ? 1.0 : -1.0;
  return a;
}

}  // namespace

SO3 parse_vehicle_axes(const std::vector<std::string>& axes) {
  if (axes.size() != 3) {
    throw InputError("expected three axes [forward, left, up], got " + std::to_string(axes.size()));
  }
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i) R.col(i) = axis_of(axes[static_cast<std::size_t>(i)]);
  if (std::abs(R.determinant() - 1.0) > 1e-9) {
    throw InputError("[forward, left, up] must be three different axes forming a right-handed "
                     "frame (forward x left = up)");
  }
  return SO3::from_matrix(R);
}

ControllerStageOptions ControllerStageOptions::from_yaml(const YAML::Node& node,
                                                         const fs::path& config) {
  ControllerStageOptions o;
  if (!node || node.IsNull()) return o;
  if (!node.IsMap()) throw InputError(config, "controller", "must be a YAML map");
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    try {
      if (key == "setpoint") {
        o.setpoint = parse_setpoint(v);
      } else if (key == "allow_unfused") {
        o.allow_unfused = v.as<bool>();
      } else if (key == "vehicle_axes") {
        o.R_body_vehicle = parse_vehicle_axes(v.as<std::vector<std::string>>());
      } else if (key == "silence_check_s") {
        o.silence_check_s = v.as<double>();
        if (!(o.silence_check_s > 0.0 && o.silence_check_s <= 1.0)) {
          throw InputError("must be in (0, 1] s");
        }
      } else if (key == "controller_options") {
        o.controller_options_file = detail::path_in_config(config, v.as<std::string>());
        load_control_file(o.controller_options_file, o);
      } else if (key == "output") {
        o.output = v.as<std::string>();
        if (o.output.empty()) throw InputError("must name a file");
      } else {
        throw InputError("unknown controller option");
      }
    } catch (const YAML::Exception&) {
      throw controller_field_error(config, key, "has the wrong type");
    } catch (const InputError& e) {
      throw controller_field_error(config, key, e.what());
    }
  }
  o.validate();
  return o;
}

void ControllerStageOptions::validate() const {
  controller.validate();
  pwm.validate();
  safety.validate();
  if (!(silence_check_s > 0.0)) throw InputError("controller.silence_check_s must be positive");
  if (output.empty()) throw InputError("controller.output must name a file");
}

std::string ControllerStageOptions::describe() const {
  std::ostringstream s;
  if (setpoint) {
    s << "setpoint=[" << (*setpoint)[0] << ", " << (*setpoint)[1] << ", " << (*setpoint)[2]
      << " m, " << (*setpoint)[3] / kDegToRad << " deg]";
  } else {
    s << "setpoint=hold (the first fused pose)";
  }
  s << " allow_unfused=" << (allow_unfused ? "true" : "false") << " control_options="
    << (controller_options_file.empty() ? std::string("defaults")
                                        : controller_options_file.string())
    << " mass_kg=" << controller.mass_kg << " output=" << output.string();
  return s.str();
}

}  // namespace kestrel::pipeline
