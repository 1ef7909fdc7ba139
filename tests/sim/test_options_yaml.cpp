// SensorNoiseOptions and RenderOptions through the options table: printed options (an infinite
// range included) load back to the same text, and a bad file is an error naming the file and the
// (nested) field.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/sim/renderer.hpp"
#include "kestrel/sim/sensor_noise.hpp"
#include "test_data.hpp"

namespace kestrel::sim {
namespace {

template <typename Options>
std::string sim_options_error(const std::filesystem::path& file) {
  try {
    (void)Options::load_yaml(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SensorNoiseOptionsYaml, DefaultsAndKinectRoundTrip) {
  for (const SensorNoiseOptions& o : {SensorNoiseOptions{}, SensorNoiseOptions::kinect()}) {
    const std::string yaml = o.to_yaml();
    SensorNoiseOptions back;
    back.max_range_m = 1.0;
    back.intensity_sigma = 7.0;
    io::option_fields::read_fields(YAML::Load(yaml), "noise.yaml", "sensor noise", back);
    EXPECT_EQ(back.to_yaml(), yaml);
  }
  EXPECT_NE(SensorNoiseOptions{}.to_yaml().find("max_range_m: .inf\n"), std::string::npos);
}

TEST(RenderOptionsYaml, DefaultsRoundTripWithTheNoiseNested) {
  const std::string yaml = RenderOptions{}.to_yaml();
  EXPECT_NE(yaml.find("mipmapping: true\nnoise:\n  depth_sigma_a_m: 0\n"), std::string::npos)
      << yaml;
  RenderOptions back;
  back.edge_supersampling = 1;
  back.noise = SensorNoiseOptions::kinect();
  io::option_fields::read_fields(YAML::Load(yaml), "render.yaml", "render", back);
  EXPECT_EQ(back.to_yaml(), yaml);

  const auto dir = test::fresh_temp_dir("render_options_yaml");
  RenderOptions o;
  o.far_m = 40.0;
  o.noise = SensorNoiseOptions::kinect();
  std::ofstream(dir / "r.yaml") << o.to_yaml();
  EXPECT_EQ(RenderOptions::load_yaml(dir / "r.yaml").to_yaml(), o.to_yaml());
  std::filesystem::remove_all(dir);
}

TEST(RenderOptionsYaml, ErrorsNameTheFileAndField) {
  const auto dir = test::fresh_temp_dir("render_options_yaml");
  std::ofstream(dir / "a.yaml") << "near: 0.1\n";
  EXPECT_EQ(sim_options_error<RenderOptions>(dir / "a.yaml"),
            (dir / "a.yaml").string() + ": field 'near': is not a render option");
  std::ofstream(dir / "b.yaml") << "noise:\n  depth_sigma: 0.1\n";
  EXPECT_EQ(sim_options_error<RenderOptions>(dir / "b.yaml"),
            (dir / "b.yaml").string() + ": field 'noise.depth_sigma': is not a render option");
  std::ofstream(dir / "c.yaml") << "depth_sigma: 0.1\n";
  EXPECT_EQ(sim_options_error<SensorNoiseOptions>(dir / "c.yaml"),
            (dir / "c.yaml").string() + ": field 'depth_sigma': is not a sensor noise option");
  std::ofstream(dir / "d.yaml") << "noise:\n  missing_probability: 2\n";
  const std::string range = sim_options_error<RenderOptions>(dir / "d.yaml");
  EXPECT_NE(range.find("d.yaml"), std::string::npos) << range;
  EXPECT_NE(range.find("missing_probability"), std::string::npos) << range;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::sim
