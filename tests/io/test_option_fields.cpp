// The options field table (io/option_fields.hpp): every kind of field round-trips through its
// printed YAML, and a bad file is an error naming the file and the (nested) field.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"

namespace kestrel::io {
namespace {

enum class Shape { kRound, kSquare };
std::string_view to_string(Shape s) { return s == Shape::kRound ? "round" : "square"; }
void parse_option(std::string_view name, Shape& s) {
  if (name == "round") {
    s = Shape::kRound;
  } else if (name == "square") {
    s = Shape::kSquare;
  } else {
    throw std::invalid_argument("unknown shape '" + std::string(name) + "' (round, square)");
  }
}

struct Inner {
  int count = 3;
  Shape shape = Shape::kRound;
  template <typename V>
  void visit_fields(V&& v) {
    v("count", count);
    v("shape", shape);
  }
};

struct Outer {
  double gain = 0.25;
  float scale = 1.5F;
  bool enabled = true;
  std::uint64_t seed = 7;
  std::string name = "kestrel";
  Eigen::Vector3d offset = Eigen::Vector3d(0.1, -0.2, 0.3);
  Inner inner;
  template <typename V>
  void visit_fields(V&& v) {
    v("gain", gain);
    v("scale", scale);
    v("enabled", enabled);
    v("seed", seed);
    v("name", name);
    v("offset", offset);
    v("inner", inner);
  }
};

/// A length written in centimetres: the codec hook for fields whose YAML is not their C++ form.
struct Centimetres {
  void read(const YAML::Node& node, double& metres) const {
    const double cm = node.as<double>();
    if (cm < 0) throw std::invalid_argument("must not be negative");
    metres = cm / 100.0;
  }
  [[nodiscard]] std::string text(double metres) const {
    return option_fields::value_text(metres * 100.0);
  }
};

struct Edges {
  double far_m = std::numeric_limits<double>::infinity();
  double low = -std::numeric_limits<double>::infinity();
  std::string empty;
  std::string spaced = "a: b #c";
  std::filesystem::path file = "dir/file name.yaml";
  std::optional<bool> maybe;
  std::optional<int> count = 4;
  double length_m = 0.25;
  template <typename V>
  void visit_fields(V&& v) {
    v("far_m", far_m);
    v("low", low);
    v("empty", empty);
    v("spaced", spaced);
    v("file", file);
    v("maybe", maybe);
    v("count", count);
    v("length_cm", length_m, Centimetres{});
  }
};

Outer read(const std::string& text, Outer o = {}) {
  option_fields::read_fields(YAML::Load(text), "opts.yaml", "test", o);
  return o;
}

std::string error_of(const std::string& text) {
  try {
    read(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(OptionFields, EveryKindOfFieldRoundTripsThroughItsYaml) {
  Outer changed;
  changed.gain = -1.0 / 3.0;
  changed.scale = 0.1F;
  changed.enabled = false;
  changed.seed = 18446744073709551615ULL;
  changed.name = "falcon";
  changed.offset = Eigen::Vector3d(1e-9, 2.5, -3e7);
  changed.inner.count = -4;
  changed.inner.shape = Shape::kSquare;
  const std::string yaml = option_fields::to_yaml(changed);
  const Outer back = read(yaml);
  EXPECT_EQ(back.gain, changed.gain) << yaml;
  EXPECT_EQ(back.scale, changed.scale);
  EXPECT_EQ(back.enabled, changed.enabled);
  EXPECT_EQ(back.seed, changed.seed);
  EXPECT_EQ(back.name, changed.name);
  EXPECT_EQ(back.offset, changed.offset);
  EXPECT_EQ(back.inner.count, changed.inner.count);
  EXPECT_EQ(back.inner.shape, changed.inner.shape);
  EXPECT_EQ(option_fields::to_yaml(back), yaml);
}

TEST(OptionFields, NestedStructsPrintAsIndentedMaps) {
  const std::string yaml = option_fields::to_yaml(Outer{});
  EXPECT_NE(yaml.find("inner:\n  count: 3\n  shape: round\n"), std::string::npos) << yaml;
}

TEST(OptionFields, AbsentFieldsKeepTheirValues) {
  Outer start;
  start.gain = 9.0;
  const Outer o = read("name: x\ninner:\n  count: 5\n", start);
  EXPECT_EQ(o.gain, 9.0);
  EXPECT_EQ(o.name, "x");
  EXPECT_EQ(o.inner.count, 5);
  EXPECT_EQ(o.inner.shape, Shape::kRound);
  EXPECT_EQ(read("").gain, Outer{}.gain);  // an empty file changes nothing
}

TEST(OptionFields, ErrorsNameTheFileAndTheField) {
  EXPECT_EQ(error_of("gian: 1"), "opts.yaml: field 'gian': is not a test option");
  EXPECT_EQ(error_of("inner:\n  cont: 1"), "opts.yaml: field 'inner.cont': is not a test option");
  EXPECT_NE(error_of("gain: fast").find("opts.yaml: field 'gain': has the wrong type"),
            std::string::npos);
  EXPECT_NE(error_of("inner:\n  count: 1.5").find("field 'inner.count': has the wrong type"),
            std::string::npos);
  const std::string shape = error_of("inner:\n  shape: oval");
  EXPECT_NE(shape.find("field 'inner.shape'"), std::string::npos) << shape;
  EXPECT_NE(shape.find("unknown shape 'oval' (round, square)"), std::string::npos) << shape;
  EXPECT_NE(error_of("offset: [1, 2]").find("field 'offset'"), std::string::npos);
  EXPECT_EQ(error_of("inner: 3"), "opts.yaml: field 'inner': must be a YAML map");
  EXPECT_EQ(error_of("- a\n- b"), "opts.yaml: test options must be a YAML map");
  // A key that is a list or a map: yaml-cpp's BadConversion escaped, naming no file.
  EXPECT_EQ(error_of("[gain]: 1"),
            "opts.yaml: test options: a key must be a field name, not a list");
  EXPECT_EQ(error_of("inner:\n  {count: 1}: 2"),
            "opts.yaml: test options: a key must be a field name, not a map");
}

TEST(OptionFields, InfinitiesStringsPathsOptionalsAndCodecsRoundTrip) {
  const std::string yaml = option_fields::to_yaml(Edges{});
  EXPECT_NE(yaml.find("far_m: .inf\nlow: -.inf\nempty: \"\"\n"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("maybe"), std::string::npos) << yaml;  // unset: not printed
  EXPECT_NE(yaml.find("count: 4\nlength_cm: 25\n"), std::string::npos) << yaml;
  Edges back;
  back.far_m = back.low = 0.0;
  back.empty = "x";
  back.spaced.clear();
  back.file.clear();
  back.count.reset();
  back.length_m = 9.0;
  option_fields::read_fields(YAML::Load(yaml), "edges.yaml", "test", back);
  EXPECT_EQ(option_fields::to_yaml(back), yaml);
  EXPECT_EQ(back.file, Edges{}.file);
  EXPECT_EQ(back.spaced, Edges{}.spaced);
  EXPECT_DOUBLE_EQ(back.length_m, 0.25);

  option_fields::read_fields(YAML::Load("maybe: false\nlength_cm: 50"), "edges.yaml", "test", back);
  EXPECT_EQ(back.maybe, std::optional<bool>(false));
  EXPECT_DOUBLE_EQ(back.length_m, 0.5);
  try {
    option_fields::read_fields(YAML::Load("length_cm: -1"), "edges.yaml", "test", back);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "edges.yaml: field 'length_cm': has the wrong type or value (must not be negative)");
  }
}

}  // namespace
}  // namespace kestrel::io
