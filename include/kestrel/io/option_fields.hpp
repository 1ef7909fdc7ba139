// The one options mechanism of Kestrel: an options struct lists its fields once, in a
// `visit_fields(visitor)` member, and printing, loading with unknown-key rejection, and the
// file/field error messages all derive from that table, so they cannot disagree.
//
// A field may be a number (any arithmetic type), bool, std::string, a fixed-size Eigen vector,
// an enum whose namespace declares `std::string_view to_string(E)` and `void
// parse_option(std::string_view, E&)` (found by argument-dependent lookup; the parser throws on
// an unknown name), or a nested options struct with its own visit_fields (a YAML map; its
// fields are named "outer.inner" in messages).
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

struct NoOpVisitor {
  template <typename T>
  void operator()(const char* /*name*/, T& /*value*/) const {}
};

}  // namespace detail

/// A nested options struct: it has its own field table.
template <typename T>
concept NestedOptions = requires(T& t) {
  t.visit_fields(detail::NoOpVisitor{});
};

inline std::string value_text(bool v) { return v ? "true" : "false"; }
inline std::string value_text(const std::string& v) { return v; }
template <typename T>
requires(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) std::string value_text(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    return io::format_double(static_cast<double>(v));
  } else {
    return std::to_string(v);
  }
}
template <int N>
std::string value_text(const Eigen::Matrix<double, N, 1>& v) {
  std::string s = "[";
  for (int i = 0; i < N; ++i) s += (i ? ", " : "") + io::format_double(v[i]);
  return s + "]";
}
template <typename E>
requires std::is_enum_v<E> std::string value_text(E v) { return std::string(to_string(v)); }

/// Reads one plain field's value from its YAML node; throws (any std::exception) on a wrong
/// type.
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

namespace detail {

template <typename Options>
void write_fields(std::ostringstream& out, Options& options, const std::string& indent) {
  options.visit_fields([&](const char* name, const auto& value) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (NestedOptions<T>) {
      out << indent << name << ":\n";
      T copy = value;
      write_fields(out, copy, indent + "  ");
    } else {
      out << indent << name << ": " << value_text(value) << "\n";
    }
  });
}

}  // namespace detail

/// "name: value" lines, one per field, in table order, nested structs as indented maps (valid
/// YAML that read_fields() loads back to the same values).
template <typename Options>
std::string to_yaml(const Options& options) {
  std::ostringstream out;
  Options copy = options;
  detail::write_fields(out, copy, "");
  return out.str();
}

/// Fields present in `node` override those of `options`; unknown keys and wrong types are
/// InputErrors naming `source` and the field ("prefix" + name; nested fields "outer.inner").
/// `what` names the options in messages ("controller", "tracker").
template <typename Options>
void read_fields(const YAML::Node& node, const std::string& source, const char* what,
                 Options& options, const std::string& prefix = "") {
  if (!node || node.IsNull()) return;
  if (!node.IsMap()) {
    if (prefix.empty()) throw InputError(source + ": " + what + " options must be a YAML map");
    throw InputError(source, prefix.substr(0, prefix.size() - 1), "must be a YAML map");
  }
  std::set<std::string> known;
  options.visit_fields([&](const char* name, auto& value) {
    known.insert(name);
    const YAML::Node v = node[name];
    if (!v) return;
    using T = std::decay_t<decltype(value)>;
    if constexpr (NestedOptions<T>) {
      read_fields(v, source, what, value, prefix + name + ".");
    } else {
      try {
        read_value(v, value);
      } catch (const std::exception& e) {
        throw InputError(source, prefix + name,
                         std::string("has the wrong type or value (") + e.what() + ")");
      }
    }
  });
  for (const auto& kv : node) {
    const auto key = kv.first.as<std::string>();
    if (known.count(key) == 0) {
      throw InputError(source, prefix + key, std::string("is not a ") + what + " option");
    }
  }
}

}  // namespace kestrel::io::option_fields
