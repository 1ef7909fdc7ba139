// The one options mechanism of Kestrel: an options struct lists its fields once, in a
// `visit_fields(visitor)` member, and printing, loading with unknown-key rejection, and the
// file/field error messages all derive from that table, so they cannot disagree.
//
// A field may be a number (any arithmetic type; YAML's .inf and .nan included), bool,
// std::string, std::filesystem::path, a fixed-size Eigen vector, an enum whose namespace
// declares `std::string_view to_string(E)` and `void parse_option(std::string_view, E&)` (found
// by argument-dependent lookup; the parser throws on an unknown name), a std::optional of one of
// these (printed only when set), or a nested options struct with its own visit_fields (a YAML
// map; its fields are named "outer.inner" in messages).
//
// A field whose YAML form is not its C++ form (a set point given in degrees, axes given by
// name) passes a codec after the value: `v("setpoint", setpoint, SetpointField{})`. The codec
// has `void read(const YAML::Node&, T&) const`, throwing any std::exception on a bad value, and
// `std::string text(const T&) const`, YAML that read() takes back.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <optional>
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

template <typename T>
struct IsOptional : std::false_type {};
template <typename T>
struct IsOptional<std::optional<T>> : std::true_type {};

struct NoOpVisitor {
  template <typename T, typename... Codec>
  void operator()(const char* /*name*/, T& /*value*/, const Codec&... /*codec*/) const {}
};

}  // namespace detail

/// A nested options struct: it has its own field table.
template <typename T>
concept NestedOptions = requires(T& t) {
  t.visit_fields(detail::NoOpVisitor{});
};

inline std::string value_text(bool v) { return v ? "true" : "false"; }
/// Quoted where the plain text would read back as something else (an empty string, "a: b").
inline std::string value_text(const std::string& v) {
  YAML::Emitter out;
  out << v;
  return out.c_str();
}
inline std::string value_text(const std::filesystem::path& v) { return value_text(v.string()); }
template <typename T>
requires(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) std::string value_text(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    // YAML's spellings: yaml-cpp reads neither "inf" nor "nan".
    if (std::isnan(v)) return ".nan";
    if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
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
  } else if constexpr (detail::IsOptional<T>::value) {
    typename T::value_type v{};
    read_value(node, v);
    value = v;
  } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
    value = node.as<std::string>();
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

template <typename T>
std::string field_text(const T& value) {
  return value_text(value);
}
template <typename T, typename Codec>
std::string field_text(const T& value, const Codec& codec) {
  return codec.text(value);
}

template <typename T>
void read_field(const YAML::Node& node, T& value) {
  read_value(node, value);
}
template <typename T, typename Codec>
void read_field(const YAML::Node& node, T& value, const Codec& codec) {
  codec.read(node, value);
}

template <typename Options>
void write_fields(std::ostringstream& out, Options& options, const std::string& indent) {
  options.visit_fields([&](const char* name, const auto& value, const auto&... codec) {
    using T = std::decay_t<decltype(value)>;
    if constexpr (sizeof...(codec) == 0 && NestedOptions<T>) {
      out << indent << name << ":\n";
      T copy = value;
      write_fields(out, copy, indent + "  ");
    } else if constexpr (sizeof...(codec) == 0 && IsOptional<T>::value) {
      if (value) out << indent << name << ": " << value_text(*value) << "\n";
    } else {
      out << indent << name << ": " << field_text(value, codec...) << "\n";
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
  options.visit_fields([&](const char* name, auto& value, const auto&... codec) {
    known.insert(name);
    const YAML::Node v = node[name];
    if (!v) return;
    using T = std::decay_t<decltype(value)>;
    if constexpr (sizeof...(codec) == 0 && NestedOptions<T>) {
      read_fields(v, source, what, value, prefix + name + ".");
    } else {
      try {
        detail::read_field(v, value, codec...);
      } catch (const std::exception& e) {
        throw InputError(source, prefix + name,
                         std::string("has the wrong type or value (") + e.what() + ")");
      }
    }
  });
  for (const auto& kv : node) {
    // A key that is a list or map (`[a]: 1`) names no field; as<std::string>() would throw
    // yaml-cpp's BadConversion, whose message names no file.
    if (!kv.first.IsScalar()) {
      throw InputError(source + ": " + what + " options: a key must be a field name, not a " +
                       (kv.first.IsSequence() ? "list" : "map"));
    }
    const auto key = kv.first.as<std::string>();
    if (known.count(key) == 0) {
      throw InputError(source, prefix + key, std::string("is not a ") + what + " option");
    }
  }
}

}  // namespace kestrel::io::option_fields
