// BlockMatcherOptions through the options table: printed defaults (an infinite depth range
// included) load back to the same text, and a bad options file is an error naming the file
// and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/sensor/block_matcher.hpp"
#include "test_data.hpp"

namespace kestrel::sensor {
namespace {

std::string matcher_options_error(const std::filesystem::path& file) {
  try {
    (void)BlockMatcherOptions::load_yaml(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(BlockMatcherOptionsYaml, DefaultsRoundTrip) {
  const std::string yaml = BlockMatcherOptions{}.to_yaml();
  EXPECT_NE(yaml.find("cost: sad\nprefilter: xsobel\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("max_depth_m: .inf\n"), std::string::npos) << yaml;
  BlockMatcherOptions back;
  back.max_depth_m = 3.0;
  back.cost = MatchingCost::kCensus;
  io::option_fields::read_fields(YAML::Load(yaml), "matcher.yaml", "block matcher", back);
  EXPECT_EQ(back.to_yaml(), yaml);
  EXPECT_TRUE(std::isinf(back.max_depth_m));
}

TEST(BlockMatcherOptionsYaml, PrintedFileLoads) {
  const auto dir = test::fresh_temp_dir("matcher_options_yaml");
  BlockMatcherOptions o;
  o.cost = MatchingCost::kCensus;
  o.prefilter = Prefilter::kNone;
  o.block_size = 7;
  o.max_depth_m = 8.5;
  std::ofstream(dir / "m.yaml") << o.to_yaml();
  EXPECT_EQ(BlockMatcherOptions::load_yaml(dir / "m.yaml").to_yaml(), o.to_yaml());
  std::filesystem::remove_all(dir);
}

TEST(BlockMatcherOptionsYaml, ErrorsNameTheFileAndField) {
  const auto dir = test::fresh_temp_dir("matcher_options_yaml");
  std::ofstream(dir / "typo.yaml") << "block: 9\n";
  EXPECT_EQ(matcher_options_error(dir / "typo.yaml"),
            (dir / "typo.yaml").string() + ": field 'block': is not a block matcher option");
  std::ofstream(dir / "cost.yaml") << "cost: ssd\n";
  const std::string cost = matcher_options_error(dir / "cost.yaml");
  EXPECT_NE(cost.find("field 'cost'"), std::string::npos) << cost;
  EXPECT_NE(cost.find("must be sad or census, got 'ssd'"), std::string::npos) << cost;
  std::ofstream(dir / "range.yaml") << "block_size: 8\n";
  const std::string range = matcher_options_error(dir / "range.yaml");
  EXPECT_NE(range.find("range.yaml"), std::string::npos) << range;
  EXPECT_NE(range.find("block_size must be odd"), std::string::npos) << range;
  std::ofstream(dir / "list.yaml") << "- 1\n";
  EXPECT_NE(matcher_options_error(dir / "list.yaml").find("expected a YAML map"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::sensor
