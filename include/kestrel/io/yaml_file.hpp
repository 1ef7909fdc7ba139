// Loading YAML files (option files, calibrations) with errors that name the file and line.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <string>

#include "kestrel/core/error.hpp"

namespace kestrel::io {

/// Parses `path`. Files written by OpenCV's FileStorage (EuRoC sensor.yaml) start with a
/// "%YAML:1.0" directive that yaml-cpp rejects; it is skipped, keeping line numbers right.
/// Throws InputError "FILE:LINE: invalid YAML: ..." or "FILE: cannot open".
YAML::Node load_yaml_file(const std::filesystem::path& path);

/// load_yaml_file() of an options file, which must hold a map (an empty file is a mistake, not
/// the defaults). Throws InputError "FILE: expected a YAML map of <what> options".
YAML::Node load_yaml_map(const std::filesystem::path& path, const std::string& what);

/// A path written in the file `config`: a relative one is taken from the config file's folder,
/// so that a config and the files it names can move together.
inline std::filesystem::path path_in_config(const std::filesystem::path& config,
                                            const std::filesystem::path& value) {
  return value.is_absolute() ? value : config.parent_path() / value;
}

/// "FILE: field 'NAME': MESSAGE", or "field 'NAME': MESSAGE" for options that did not come from
/// a file (`file` empty).
inline InputError field_error(const std::filesystem::path& file, const std::string& field,
                              const std::string& message) {
  if (file.empty()) return InputError("field '" + field + "': " + message);
  return InputError(file, field, message);
}

/// map[key]; throws InputError "<path>: field '<prefix><key>' is missing" if absent (or if
/// `map` is not a map).
inline YAML::Node yaml_require(const YAML::Node& map, const std::string& key,
                               const std::filesystem::path& path, const std::string& prefix) {
  if (!map.IsMap() || !map[key]) throw InputError(path, prefix + key, "is missing");
  return map[key];
}

/// node.as<T>(); a conversion failure is an InputError naming `field`.
template <typename T>
T yaml_as(const YAML::Node& node, const std::filesystem::path& path, const std::string& field) {
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    throw InputError(path, field, "has the wrong type");
  }
}

}  // namespace kestrel::io
