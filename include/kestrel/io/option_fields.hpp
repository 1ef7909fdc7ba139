// The one options mechanism of Kestrel: an options struct lists its fields once, in a
// `visit_fields(visitor)` member, and printing, loading with unknown-key rejection, and the
// file/field error messages all derive from that table, so they cannot disagree.
//
// A field may be double, int, bool, std::string, a fixed-size Eigen vector, or an enum whose
// namespace declares `std::string_view to_string(E)` and `void parse_option(std::string_view,
// E&)` (found by argument-dependent lookup; the parser throws on an unknown name).
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::io::option_fields {

namespace detail {

template <typename T>
struct IsEigenVector : std::false_type {};
template <int N>
struct IsEigenVector<Eigen::Matrix<double, N, 1>> : std::true_type {};

}  // namespace detail

inline std::string value_text(double v) { return io::format_double(v); }
inline std::string value_text(int v) { return std::to_string(v); }
inline std::string value_text(bool v) { return v ? "true" : "false"; }
inline std::string value_text(const std::string& v) { return v; }
template <int N>
std::string value_text(const Eigen::Matrix<double, N, 1>& v) {
  std::string s = "[";
  for (int i = 0; i < N; ++i) s += (i ? ", " : "") + io::format_double(v[i]);
  return s + "]";
}
template <typename E>
requires std::is_enum_v<E> std::string value_text(E v) { return std::string(to_string(v)); }

/// Reads one field's value from its YAML node; throws (any std::exception) on a wrong type.
template <typename T>
void read_value(const YAML::Node& node, T& value) {
  if constexpr (std::is_enum_v<T>) {
    parse_option(node.as<std::string>(), value);
  } else if constexpr (detail::IsEigenVector<T>::value) {
    const auto list = node.as<std::vector<double>>();
    if (static_cast<int>(list.size()) != T::RowsAtCompileTime) {
      throw InputError("expected " + std::to_string(T::RowsAtCompileTime) + " numbers");
    }
    for (int i = 0; i < T::RowsAtCompileTime; ++i) value[i] = list[static_cast<std::size_t>(i)];
  } else {
    value = node.as<T>();
  }
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
/// InputErrors naming `source` and the field. `what` names the options in messages
/// ("controller", "tracker").
template <typename Options>
void read_fields(const YAML::Node& node, const std::string& source, const char* what,
                 Options& options) {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) throw InputError(source + ": " + what + " options must be a YAML map");
  std::set<std::string> known;
  options.visit_fields([&](const char* name, auto& value) {
    known.insert(name);
    const YAML::Node v = node[name];
    if (!v) return;
    try {
      read_value(v, value);
    } catch (const std::exception& e) {
      throw InputError(source, name, std::string("has the wrong type or value (") + e.what() + ")");
    }
  });
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    if (known.count(key) == 0)
      throw InputError(source, key, std::string("is not a ") + what + " option");
  }
}

}  // namespace kestrel::io::option_fields
