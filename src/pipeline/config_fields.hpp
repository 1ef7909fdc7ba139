// Shared by the pipeline config loaders (pipeline, camera and controller blocks): paths written
// in a config, and errors that name the config file and the field.
#pragma once

#include <filesystem>
#include <string>

#include "kestrel/core/error.hpp"

namespace kestrel::pipeline::detail {

/// A path written in `config`: a relative one is taken from the config file's folder, so that a
/// config and its option files can move together.
inline std::filesystem::path path_in_config(const std::filesystem::path& config,
                                            const std::string& value) {
  const std::filesystem::path p = value;
  return p.is_absolute() ? p : config.parent_path() / p;
}

/// "run.yaml: field 'camera.x': message", or "field 'camera.x': message" when the options did not
/// come from a file (`config` empty).
inline InputError config_field_error(const std::filesystem::path& config, const std::string& field,
                                     const std::string& message) {
  if (config.empty()) return InputError("field '" + field + "': " + message);
  return InputError(config, field, message);
}

}  // namespace kestrel::pipeline::detail
