// Loading YAML files (option files, calibrations) with errors that name the file and line.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>

namespace kestrel::io {

/// Parses `path`. Files written by OpenCV's FileStorage (EuRoC sensor.yaml) start with a
/// "%YAML:1.0" directive that yaml-cpp rejects; it is skipped, keeping line numbers right.
/// Throws InputError "FILE:LINE: invalid YAML: ..." or "FILE: cannot open".
YAML::Node load_yaml_file(const std::filesystem::path& path);

}  // namespace kestrel::io
