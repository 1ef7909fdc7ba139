// Loading and checking the `controller:` block of a pipeline config. The control options
// themselves are the control module's own options tables, one section of the options file each.
#include "kestrel/pipeline/controller_options.hpp"

#include <cmath>
#include <sstream>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::pipeline {

namespace {

namespace fs = std::filesystem;

InputError controller_field_error(const fs::path& config, const std::string& key,
                                  const std::string& msg) {
  return io::field_error(config, "controller." + key, msg);
}

// The sections of a control options file (each optional), nothing else, so that a typo in a
// section name is not silently ignored.
struct ControlSections {
  control::PositionControllerOptions controller;
  control::PwmMapperOptions pwm;
  control::SafetyOptions safety;
  template <typename V>
  void visit_fields(V&& v) {
    v("controller", controller);
    v("pwm", pwm);
    v("safety", safety);
  }
};

void load_control_file(const fs::path& file, ControllerStageOptions& o) {
  ControlSections sections;
  io::option_fields::read_fields(io::load_yaml_map(file, "control"), file.string(), "control",
                                 sections);
  try {
    sections.controller.validate();
    sections.pwm.validate();
    sections.safety.validate();
  } catch (const InputError& e) {
    throw InputError(file.string() + ": " + e.what());
  }
  o.controller = sections.controller;
  o.pwm = sections.pwm;
  o.safety = sections.safety;
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
    throw InputError(
        "[forward, left, up] must be three different axes forming a right-handed "
        "frame (forward x left = up)");
  }
  return SO3::from_matrix(R);
}

void SetpointField::read(const YAML::Node& node, std::optional<Eigen::Vector4d>& setpoint) const {
  if (node.IsScalar() && node.as<std::string>() == "hold") {
    setpoint.reset();
    return;
  }
  if (!node.IsSequence() || node.size() != 4) {
    throw InputError("must be hold or [x_m, y_m, z_m, yaw_deg]");
  }
  Eigen::Vector4d p;
  for (std::size_t i = 0; i < 4; ++i) p[static_cast<int>(i)] = node[i].as<double>();
  if (!p.allFinite()) throw InputError("must be finite numbers");
  p[3] *= kDegToRad;
  setpoint = p;
}

std::string SetpointField::text(const std::optional<Eigen::Vector4d>& setpoint) const {
  if (!setpoint) return "hold";
  const Eigen::Vector4d& p = *setpoint;
  return "[" + io::format_double(p[0]) + ", " + io::format_double(p[1]) + ", " +
         io::format_double(p[2]) + ", " + io::format_double(p[3] / kDegToRad) + "]";
}

void VehicleAxesField::read(const YAML::Node& node, SO3& R_body_vehicle) const {
  R_body_vehicle = parse_vehicle_axes(node.as<std::vector<std::string>>());
}

std::string VehicleAxesField::text(const SO3& R_body_vehicle) const {
  const Eigen::Matrix3d R = R_body_vehicle.matrix();
  std::string s = "[";
  for (int c = 0; c < 3; ++c) {
    Eigen::Index axis = 0;
    R.col(c).cwiseAbs().maxCoeff(&axis);
    s += std::string(c ? ", " : "") + (R(axis, c) < 0 ? "-" : "+") + static_cast<char>('x' + axis);
  }
  return s + "]";
}

void ControllerStageOptions::load_files(const fs::path& config) {
  if (controller_options_file.empty()) return;
  controller_options_file = io::path_in_config(config, controller_options_file);
  try {
    load_control_file(controller_options_file, *this);
  } catch (const InputError& e) {
    throw controller_field_error(config, "controller_options", e.what());
  }
}

void ControllerStageOptions::validate() const {
  controller.validate();
  pwm.validate();
  safety.validate();
  if (!(silence_check_s > 0.0 && silence_check_s <= 1.0)) {
    throw InputError("field 'controller.silence_check_s': must be in (0, 1] s");
  }
  if (output.empty()) throw InputError("field 'controller.output': must name a file");
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

std::string ControllerStageOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

}  // namespace kestrel::pipeline
