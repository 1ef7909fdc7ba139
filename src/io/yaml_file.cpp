// YAML loading shared by every option and calibration file.
#include "kestrel/io/yaml_file.hpp"

#include <fstream>
#include <sstream>

#include "kestrel/core/error.hpp"

namespace kestrel::io {

YAML::Node load_yaml_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open file for reading");
  std::stringstream text;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    text << (first && line.rfind("%YAML", 0) == 0 ? std::string() : line) << "\n";
    first = false;
  }
  try {
    return YAML::Load(text.str());
  } catch (const YAML::Exception& e) {
    throw InputError(path, static_cast<std::size_t>(e.mark.line + 1),
                     std::string("invalid YAML: ") + e.msg);
  }
}

YAML::Node load_yaml_map(const std::filesystem::path& path, const std::string& what) {
  YAML::Node root = load_yaml_file(path);
  if (!root.IsMap()) {
    throw InputError(path.string() + ": expected a YAML map of " + what + " options");
  }
  return root;
}

}  // namespace kestrel::io
