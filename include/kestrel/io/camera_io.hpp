// Loading and saving camera models: Kestrel's own YAML, EuRoC sensor.yaml, and the standard
// presets of the TUM RGB-D benchmark (fr1, fr2, fr3, ros).
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "kestrel/geometry/pinhole_camera.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::io {

/// TUM RGB-D presets (values: shared/reference/README.md). fr1 carries its distortion;
/// fr3 images are already undistorted. Returns nullopt for an unknown name.
std::optional<PinholeCamera> camera_preset(std::string_view name);

/// A camera description from a file: Kestrel's YAML (a `camera:` map with width, height, fx,
/// fy, cx, cy, optional `distortion: [k1, k2, p1, p2, k3]` and the optional sensor facts below)
/// or an EuRoC sensor.yaml (intrinsics, resolution, distortion_coefficients, T_BS).
struct CameraFile {
  PinholeCamera camera;
  std::optional<SE3> T_body_sensor{};  ///< EuRoC T_BS, when the file has one
  /// RGB-D camera: depth image units per metre (`depth_scale`; TUM's PNGs: 5000); unset where
  /// the description does not say.
  std::optional<double> depth_scale{};
  /// Time from reading out the first image row to the last (`rolling_shutter_readout_s`, s): a
  /// rolling-shutter camera exposes its rows one after another. 0 = global shutter.
  double rolling_shutter_readout_s = 0.0;
  /// The camera's stamp offset (`time_offset_s`, s): a frame stamped t was exposed at t +
  /// time_offset_s on the reference clock (the IMU's or the motion capture's), the convention of
  /// the fusion's t_d (FusionOptions::time_offset_s). 0 where not measured.
  double time_offset_s = 0.0;
};

/// Loads either format (detected from the keys). Errors name the file and field.
CameraFile load_camera_file(const std::filesystem::path& path);
/// A preset name (TUM: depth scale 5000, readout 0) or a camera file.
CameraFile load_camera_description(const std::string& preset_or_path);

/// A camera from a YAML map with fx, fy, cx, cy, width, height and optional distortion
/// [k1, k2, p1, p2(, k3)]; errors name `field.<key>` in `path`.
PinholeCamera camera_from_yaml(const YAML::Node& map, const std::filesystem::path& path,
                               const std::string& field);
/// A preset name or a file path: the pinhole model alone (load_camera_description's camera).
PinholeCamera load_camera(const std::string& preset_or_path);

/// "fr1", "fr2" or "fr3" where a path names freiburg1/2/3 (TUM's folder and bag names), else "".
std::string camera_preset_in_path(const std::filesystem::path& path);

/// The camera a TUM-layout folder was recorded with, where the user named none: the folder's own
/// `camera.yaml` (what `kestrel render` writes, with the distortion-free model it rendered), else
/// the TUM preset its path names (freiburg1/2/3 -> fr1/fr2/fr3), else "" (the caller asks for one).
/// The file wins over the name: it describes this recording, the name only its camera family.
std::string camera_for_folder(const std::filesystem::path& folder);

/// Kestrel's YAML for a rectified stereo pair: `stereo:` map with f, cu, cv, baseline_m,
/// width, height.
RectifiedStereo load_rectified_stereo(const std::filesystem::path& path);

/// Writes Kestrel's camera YAML (with the provenance line of `command`).
void save_camera_yaml(const std::filesystem::path& path, const PinholeCamera& camera,
                      std::string_view command, bool force = false);
void save_rectified_stereo_yaml(const std::filesystem::path& path, const RectifiedStereo& stereo,
                                std::string_view command, bool force = false);

/// Writes an EuRoC-style sensor.yaml for a camera (so rendered stereo folders load like
/// real EuRoC ones).
void save_euroc_camera_yaml(const std::filesystem::path& path, const PinholeCamera& camera,
                            const SE3& T_body_sensor, double rate_hz, std::string_view command,
                            bool force = false);

}  // namespace kestrel::io
