// DirectTrackerOptions: validation, YAML load and print.
#include "kestrel/odometry/direct_tracker_options.hpp"

#include <cmath>
#include <set>
#include <sstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::odometry {

namespace {

// One table drives print, load and the unknown-key check, so they cannot disagree.
template <typename Visitor>
void visit_fields(DirectTrackerOptions& o, Visitor&& v) {
  v("pyramid_levels", o.pyramid_levels);
  v("finest_level", o.finest_level);
  v("pyramid_filter", o.pyramid_filter);
  v("depth_pyramid_max_relative_spread", o.depth_pyramid_max_relative_spread);
  v("min_depth_m", o.min_depth_m);
  v("max_depth_m", o.max_depth_m);
  v("min_gradient", o.min_gradient);
  v("max_points_per_level", o.max_points_per_level);
  v("tukey_c", o.tukey_c);
  v("sigma_freeze_change", o.sigma_freeze_change);
  v("min_sigma", o.min_sigma);
  v("estimate_gain_bias", o.estimate_gain_bias);
  v("use_depth_residual", o.use_depth_residual);
  v("depth_residual_weight", o.depth_residual_weight);
  v("min_depth_sigma_m", o.min_depth_sigma_m);
  v("depth_noise_per_m", o.depth_noise_per_m);
  v("depth_residual_max_relative_spread", o.depth_residual_max_relative_spread);
  v("compensate_depth_time_offset", o.compensate_depth_time_offset);
  v("rolling_shutter_readout_s", o.rolling_shutter_readout_s);
  v("update_norm_tolerance", o.update_norm_tolerance);
  v("update_change_tolerance", o.update_change_tolerance);
  v("max_iterations_finest", o.max_iterations_finest);
  v("max_iterations_coarse", o.max_iterations_coarse);
  v("stop_on_cost_increase", o.stop_on_cost_increase);
  v("bicubic_finest_level", o.bicubic_finest_level);
  v("bicubic_coarse_levels", o.bicubic_coarse_levels);
  v("constant_velocity_prior", o.constant_velocity_prior);
  v("use_keyframes", o.use_keyframes);
  v("keyframe_min_overlap", o.keyframe_min_overlap);
  v("keyframe_max_rotation_deg", o.keyframe_max_rotation_deg);
  v("keyframe_max_translation_rel", o.keyframe_max_translation_rel);
  v("retry_previous_frame", o.retry_previous_frame);
  v("geometric_fallback", o.geometric_fallback);
  v("fallback_rotation_from_previous_frame", o.fallback_rotation_from_previous_frame);
  v("fallback_rotation_coarsest_level", o.fallback_rotation_coarsest_level);
  v("max_level_jump_px", o.max_level_jump_px);
  v("min_overlap", o.min_overlap);
  v("min_inlier_ratio", o.min_inlier_ratio);
  v("max_sigma", o.max_sigma);
  v("min_points", o.min_points);
  v("max_translation_m", o.max_translation_m);
  v("max_rotation_deg", o.max_rotation_deg);
}

std::string value_text(double v) { return io::format_double(v); }
std::string value_text(int v) { return std::to_string(v); }
std::string value_text(bool v) { return v ? "true" : "false"; }
std::string value_text(image::PyramidFilter v) { return std::string(image::to_string(v)); }

}  // namespace

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
  if (!(rolling_shutter_readout_s >= 0.0) || !std::isfinite(rolling_shutter_readout_s) ||
      rolling_shutter_readout_s > 1.0) {
    fail("rolling_shutter_readout_s", "must be in [0, 1] s");
  }

  if (max_points_per_level < 0) fail("max_points_per_level", "must be >= 0 (0: no limit)");
  finite_pos("tukey_c", tukey_c);
  if (!(sigma_freeze_change >= 0.0)) fail("sigma_freeze_change", "must be >= 0");
  finite_pos("min_sigma", min_sigma);
  if (!(std::isfinite(depth_residual_weight) && depth_residual_weight >= 0.0)) {
    fail("depth_residual_weight", "must be >= 0 and finite");
  }
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

std::string DirectTrackerOptions::to_yaml() const {
  std::ostringstream out;
  auto copy = *this;
  visit_fields(copy, [&](const char* name, const auto& value) {
    out << name << ": " << value_text(value) << "\n";
  });
  return out.str();
}

DirectTrackerOptions DirectTrackerOptions::from_yaml(const YAML::Node& node,
                                                     const std::string& source) {
  DirectTrackerOptions o;
  if (!node || node.IsNull()) return o;
  if (!node.IsMap()) throw InputError(source + ": tracker options must be a YAML map");
  std::set<std::string> known;
  visit_fields(o, [&](const char* name, auto& value) {
    known.insert(name);
    const YAML::Node v = node[name];
    if (!v) return;
    using T = std::decay_t<decltype(value)>;
    try {
      if constexpr (std::is_same_v<T, image::PyramidFilter>) {
        value = image::pyramid_filter_from_string(v.as<std::string>());
      } else {
        value = v.as<T>();
      }
    } catch (const std::exception& e) {
      throw InputError(source, name, std::string("has the wrong type or value (") + e.what() +
                                         ")");
    }
  });
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    if (known.count(key) == 0) throw InputError(source, key, "is not a tracker option");
  }
  o.validate();
  return o;
}

DirectTrackerOptions DirectTrackerOptions::load(const std::filesystem::path& path) {
  const YAML::Node root = io::load_yaml_file(path);
  if (root.IsMap() && root["tracker"]) return from_yaml(root["tracker"], path.string());
  return from_yaml(root, path.string());
}

}  // namespace kestrel::odometry
