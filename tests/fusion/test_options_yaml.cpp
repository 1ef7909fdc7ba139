// FusionOptions through the options table: printed defaults load back to the same text, and a
// bad options file is an error naming the file and the field.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/io/option_fields.hpp"
#include "test_data.hpp"

namespace kestrel::fusion {
namespace {

std::string fusion_options_error(const std::filesystem::path& file) {
  try {
    (void)FusionOptions::load_yaml(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(FusionOptionsYaml, DefaultsRoundTrip) {
  const std::string yaml = FusionOptions{}.to_yaml();
  FusionOptions back;
  back.gravity_m_s2 = 1.0;
  back.reanchor_after_gate = false;
  io::option_fields::read_fields(YAML::Load(yaml), "fusion.yaml", "fusion", back);
  EXPECT_EQ(back.to_yaml(), yaml);
  EXPECT_NE(yaml.find("gyroscope_noise_density: "), std::string::npos) << yaml;
}

TEST(FusionOptionsYaml, PrintedFileLoads) {
  const auto dir = test::fresh_temp_dir("fusion_options_yaml");
  FusionOptions o;
  o.gate_probability = 0.99;
  o.noise.accel_walk = 2e-3;
  o.first_estimate_jacobians = false;
  o.estimate_extrinsic_rotation = true;
  o.init_sigma_extrinsic_rotation_rad = 0.01;
  std::ofstream(dir / "o.yaml") << o.to_yaml();
  EXPECT_EQ(FusionOptions::load_yaml(dir / "o.yaml").to_yaml(), o.to_yaml());
  std::filesystem::remove_all(dir);
}

TEST(FusionOptionsYaml, ErrorsNameTheFileAndField) {
  const auto dir = test::fresh_temp_dir("fusion_options_yaml");
  std::ofstream(dir / "typo.yaml") << "gate_probabilty: 0.99\n";
  EXPECT_EQ(fusion_options_error(dir / "typo.yaml"),
            (dir / "typo.yaml").string() + ": field 'gate_probabilty': is not a fusion option");
  std::ofstream(dir / "type.yaml") << "max_imu_gap_s: long\n";
  EXPECT_NE(
      fusion_options_error(dir / "type.yaml").find("field 'max_imu_gap_s': has the wrong type"),
      std::string::npos);
  std::ofstream(dir / "value.yaml") << "gate_probability: 1.5\n";
  const std::string value = fusion_options_error(dir / "value.yaml");
  EXPECT_NE(value.find("value.yaml"), std::string::npos) << value;
  EXPECT_NE(value.find("gate_probability"), std::string::npos) << value;
  std::ofstream(dir / "empty.yaml") << "";
  EXPECT_NE(fusion_options_error(dir / "empty.yaml").find("expected a YAML map of fusion options"),
            std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::fusion
