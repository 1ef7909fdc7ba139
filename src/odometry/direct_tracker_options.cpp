// DirectTrackerOptions: validation, YAML load and print.
#include "kestrel/odometry/direct_tracker_options.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::odometry {

std::string_view to_string(GeometricTerm term) {
  switch (term) {
    case GeometricTerm::kOff:
      return "off";
    case GeometricTerm::kFallback:
      return "fallback";
    case GeometricTerm::kAlways:
      return "always";
  }
  return "unknown";
}

void parse_option(std::string_view name, GeometricTerm& term) {
  if (name == "off") {
    term = GeometricTerm::kOff;
  } else if (name == "fallback") {
    term = GeometricTerm::kFallback;
  } else if (name == "always") {
    term = GeometricTerm::kAlways;
  } else {
    throw std::invalid_argument("'" + std::string(name) + "': expected off, fallback or always");
  }
}

void DirectTrackerOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw InputError("tracker option '" + field + "': " + why);
  };
  auto finite_pos = [&](const char* name, double v) {
    if (!(std::isfinite(v) && v > 0.0)) fail(name, "must be positive and finite");
  };
  auto fraction = [&](const char* name, double v) {
    if (!(v >= 0.0 && v <= 1.0)) fail(name, "must be within [0, 1]");
  };
  const PyramidOptions& p = pyramid;
  if (p.levels < 1 || p.levels > 10) fail("pyramid.levels", "must be 1 to 10");
  if (p.finest_level < 0 || p.finest_level >= p.levels) {
    fail("pyramid.finest_level", "must be within [0, pyramid.levels)");
  }
  if (!(p.depth_max_relative_spread >= 0.0)) {
    fail("pyramid.depth_max_relative_spread", "must be >= 0");
  }

  const SelectionOptions& s = selection;
  finite_pos("selection.min_depth_m", s.min_depth_m);
  // .inf is allowed: no far limit, every depth the sensor gives.
  if (!(s.max_depth_m > 0.0)) fail("selection.max_depth_m", "must be positive (.inf: no limit)");
  if (s.max_depth_m <= s.min_depth_m) {
    fail("selection.max_depth_m", "must exceed selection.min_depth_m");
  }
  if (!(s.min_gradient >= 0.0)) fail("selection.min_gradient", "must be >= 0");
  if (s.max_points < 0) fail("selection.max_points", "must be >= 0 (0: no limit)");

  finite_pos("robust.tukey_c", robust.tukey_c);
  if (!(robust.sigma_freeze_change >= 0.0)) fail("robust.sigma_freeze_change", "must be >= 0");
  finite_pos("robust.min_sigma", robust.min_sigma);

  finite_pos("terms.min_depth_sigma_m", terms.min_depth_sigma_m);
  if (!(std::isfinite(terms.depth_noise_per_m) && terms.depth_noise_per_m >= 0.0)) {
    fail("terms.depth_noise_per_m", "must be >= 0 and finite");
  }
  finite_pos("terms.depth_max_relative_spread", terms.depth_max_relative_spread);

  if (!(std::isfinite(solver.step_tolerance_px) && solver.step_tolerance_px >= 0.0)) {
    fail("solver.step_tolerance_px", "must be >= 0 and finite");
  }
  if (!(std::isfinite(solver.step_change_tolerance_px) && solver.step_change_tolerance_px >= 0.0)) {
    fail("solver.step_change_tolerance_px", "must be >= 0 and finite");
  }
  if (solver.max_iterations_finest < 1) fail("solver.max_iterations_finest", "must be >= 1");
  if (solver.max_iterations_coarse < 1) fail("solver.max_iterations_coarse", "must be >= 1");

  fraction("keyframes.min_overlap", keyframes.min_overlap);
  finite_pos("keyframes.max_rotation_deg", keyframes.max_rotation_deg);
  finite_pos("keyframes.max_translation_rel", keyframes.max_translation_rel);

  if (fallback.rotation_coarsest_level < 0) {
    fail("fallback.rotation_coarsest_level",
         "must be >= 0 (levels above pyramid.levels are not iterated)");
  }
  finite_pos("fallback.max_level_jump_px", fallback.max_level_jump_px);

  fraction("health.min_overlap", health.min_overlap);
  fraction("health.min_inlier_ratio", health.min_inlier_ratio);
  finite_pos("health.max_sigma", health.max_sigma);
  if (health.min_points < 8) fail("health.min_points", "must be >= 8");
  finite_pos("health.max_translation_m", health.max_translation_m);
  finite_pos("health.max_rotation_deg", health.max_rotation_deg);
}

std::string DirectTrackerOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

DirectTrackerOptions DirectTrackerOptions::from_yaml(const YAML::Node& node,
                                                     const std::string& source,
                                                     const DirectTrackerOptions& base) {
  DirectTrackerOptions o = base;
  io::option_fields::read_fields(node, source, "tracker", o);
  try {
    o.validate();
  } catch (const InputError& e) {
    throw InputError(source + ": " + e.what());  // the file, then the field
  }
  return o;
}

DirectTrackerOptions DirectTrackerOptions::load(const std::filesystem::path& path,
                                                const DirectTrackerOptions& base) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["tracker"]) return from_yaml(root["tracker"], path.string(), base);
  return from_yaml(root, path.string(), base);
}

DirectTrackerOptions stereo_head_tracker_options() {
  DirectTrackerOptions o;
  o.selection.max_depth_m = std::numeric_limits<double>::infinity();
  return o;
}

}  // namespace kestrel::odometry
