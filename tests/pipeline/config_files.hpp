// Writing a pipeline test's files, and the error a pipeline config raises.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/pipeline/pipeline_options.hpp"

namespace kestrel::test {

inline std::filesystem::path write_text(const std::filesystem::path& path,
                                        const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

/// The message of the InputError that loading `config` raises; empty when it loads.
inline std::string config_error_of(const std::filesystem::path& config) {
  try {
    (void)pipeline::PipelineOptions::load_yaml(config);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace kestrel::test
