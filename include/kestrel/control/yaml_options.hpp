// Helpers shared by the control and vehicle option structs: each struct lists its fields once
// (a visit_fields table), and print, load and the unknown-key check are derived from it.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>

#include "kestrel/core/error.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::control::yaml_options {

inline std::string value_text(double v) { return io::format_double(v); }
inline std::string value_text(int v) { return std::to_string(v); }
inline std::string value_text(bool v) { return v ? "true" : "false"; }
template <int N>
std::string value_text(const Eigen::Matrix<double, N, 1>& v) {
  std::string s = "[";
  for (int i = 0; i < N; ++i) s += (i ? ", " : "") + io::format_double(v[i]);
  return s + "]";
}

/// "name: value" lines, one per field, in table order (valid YAML).
template <typename Options>
std::string to_yaml(const Options& options) {
  std::ostringstream out;
  Options copy = options;
  copy.visit_fields([&](const char* name, const auto& value) {
    out << name << ": " << value_text(value) << "\n";
  });
  return out.str();
}

/// Fields present in `node` override those of `options`; unknown keys and wrong types are
/// InputErrors naming `source` and the field.
template <typename Options>
void read_fields(const YAML::Node& node, const std::string& source, const char* what,
                 Options& options) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw InputError(source + ": " + what + " must be a YAML map");
  std::set<std::string> known;
  options.visit_fields([&](const char* name, auto& value) {
    known.insert(name);
    const YAML::Node v = node[name];
    if (!v) return;
    using T = std::decay_t<decltype(value)>;
    try {
      if constexpr (std::is_same_v<T, double> || std::is_same_v<T, int> ||
                    std::is_same_v<T, bool>) {
        value = v.as<T>();
      } else {
        const auto list = v.as<std::vector<double>>();
        if (static_cast<int>(list.size()) != T::RowsAtCompileTime) {
          throw InputError("expected " + std::to_string(T::RowsAtCompileTime) + " numbers");
        }
        for (int i = 0; i < T::RowsAtCompileTime; ++i) value[i] = list[static_cast<std::size_t>(i)];
      }
    } catch (const std::exception& e) {
      throw InputError(source, name, std::string("has the wrong type or value (") + e.what() + ")");
    }
  });
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    if (known.count(key) == 0) throw InputError(source, key, std::string("is not a ") + what + " option");
  }
}

}  // namespace kestrel::control::yaml_options
