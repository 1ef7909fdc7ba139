// DirectTrackerOptions: validation, YAML load and print.
#include "kestrel/odometry/direct_tracker_options.hpp"

#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::odometry {

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
  if (pyramid_levels < 1 || pyramid_levels > 10) fail("pyramid_levels", "must be 1 to 10");
  if (finest_level < 0 || finest_level >= pyramid_levels) {
    fail("finest_level", "must be within [0, pyramid_levels)");
  }
  if (fallback_rotation_coarsest_level < 0) {
    fail("fallback_rotation_coarsest_level",
         "must be >= 0 (levels above pyramid_levels are not iterated)");
  }
  if (!(depth_pyramid_max_relative_spread >= 0.0)) {
    fail("depth_pyramid_max_relative_spread", "must be >= 0");
  }
  finite_pos("min_depth_m", min_depth_m);
  finite_pos("max_depth_m", max_depth_m);
  if (max_depth_m <= min_depth_m) fail("max_depth_m", "must exceed min_depth_m");
  if (!(min_gradient >= 0.0)) fail("min_gradient", "must be >= 0");
  if (max_points_per_level < 0) fail("max_points_per_level", "must be >= 0 (0: no limit)");
  finite_pos("tukey_c", tukey_c);
  if (!(sigma_freeze_change >= 0.0)) fail("sigma_freeze_change", "must be >= 0");
  finite_pos("min_sigma", min_sigma);
  finite_pos("min_depth_sigma_m", min_depth_sigma_m);
  if (!(std::isfinite(depth_noise_per_m) && depth_noise_per_m >= 0.0)) {
    fail("depth_noise_per_m", "must be >= 0 and finite");
  }
  finite_pos("max_level_jump_px", max_level_jump_px);
  finite_pos("depth_residual_max_relative_spread", depth_residual_max_relative_spread);
  if (!(update_norm_tolerance >= 0.0)) fail("update_norm_tolerance", "must be >= 0");
  if (!(update_change_tolerance >= 0.0)) fail("update_change_tolerance", "must be >= 0");
  if (max_iterations_finest < 1) fail("max_iterations_finest", "must be >= 1");
  if (max_iterations_coarse < 1) fail("max_iterations_coarse", "must be >= 1");
  fraction("keyframe_min_overlap", keyframe_min_overlap);
  finite_pos("keyframe_max_rotation_deg", keyframe_max_rotation_deg);
  finite_pos("keyframe_max_translation_rel", keyframe_max_translation_rel);
  fraction("min_overlap", min_overlap);
  fraction("min_inlier_ratio", min_inlier_ratio);
  finite_pos("max_sigma", max_sigma);
  if (min_points < 8) fail("min_points", "must be >= 8");
  finite_pos("max_translation_m", max_translation_m);
  finite_pos("max_rotation_deg", max_rotation_deg);
}

std::string DirectTrackerOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

DirectTrackerOptions DirectTrackerOptions::from_yaml(const YAML::Node& node,
                                                     const std::string& source) {
  DirectTrackerOptions o;
  io::option_fields::read_fields(node, source, "tracker", o);
  o.validate();
  return o;
}

DirectTrackerOptions DirectTrackerOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["tracker"]) return from_yaml(root["tracker"], path.string());
  return from_yaml(root, path.string());
}

}  // namespace kestrel::odometry
