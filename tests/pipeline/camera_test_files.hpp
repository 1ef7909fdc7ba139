// Files the camera-source tests write: a config, and a raw stereo pair's calibration in
// Kestrel's `stereo_pair:` YAML (no distortion, identical cameras, right camera 0.1 m along +x),
// so that rectification leaves the views as they are.
#pragma once

#include <filesystem>
#include <string>

#include "config_files.hpp"

namespace kestrel::test {

inline std::filesystem::path write_pinhole_pair(const std::filesystem::path& path, int width,
                                                int height, double f = 300.0) {
  const std::string cam = "{width: " + std::to_string(width) +
                          ", height: " + std::to_string(height) + ", fx: " + std::to_string(f) +
                          ", fy: " + std::to_string(f) + ", cx: " + std::to_string(width / 2.0) +
                          ", cy: " + std::to_string(height / 2.0) + "}";
  return write_text(path, "stereo_pair:\n  left: " + cam + "\n  right: " + cam +
                              "\n  T_left_right: [1, 0, 0, 0.1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, "
                              "1]\n");
}

}  // namespace kestrel::test
