// Sensor noise for rendered frames: Kinect-like depth noise that grows with Z^2, depth
// quantisation in disparity, missing depth (random, grazing angles, out of range) and Gaussian
// intensity noise. Everything is off by default and drawn from a seeded xoshiro256++.
#pragma once

#include <cstdint>
#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <string>
#include <string_view>

namespace YAML {
class Node;
}  // namespace YAML

namespace kestrel::sim {

struct SensorNoiseOptions {
  /// Axial depth noise sigma_z(Z) = depth_sigma_a_m + depth_sigma_b_per_m * (Z - z0)^2, with
  /// z0 = depth_sigma_z0_m (Nguyen, Izadi, Lovell 2012, "Modeling Kinect sensor noise":
  /// 0.0012 + 0.0019 (Z - 0.4)^2; Khoshelham & Elberink 2012 give 1.425e-3 Z^2).
  double depth_sigma_a_m = 0.0;
  double depth_sigma_b_per_m = 0.0;
  double depth_sigma_z0_m = 0.0;
  /// Quantisation of the measurement in inverse depth: 1/Z is rounded to multiples of this
  /// step (1/m). A structured-light sensor measures disparity in 1/8 pixel, so the step is
  /// 0.125 / (f B): 0.125 / (580 px * 0.075 m) = 2.87e-3 /m for the Kinect. 0 = none.
  double inverse_depth_step_per_m = 0.0;
  /// Probability that a pixel's depth is missing at random.
  double missing_probability = 0.0;
  /// Depth is missing where the angle between the ray and the surface normal exceeds this
  /// (grazing surfaces return no depth). 90 = never.
  double max_incidence_deg = 90.0;
  /// Depth is missing nearer than min_range_m or farther than max_range_m (true Z).
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();
  /// Gaussian noise added to each colour channel, in 8-bit grey levels (sigma).
  double intensity_sigma = 0.0;

  template <typename V>
  void visit_fields(V&& v) {
    v("depth_sigma_a_m", depth_sigma_a_m);
    v("depth_sigma_b_per_m", depth_sigma_b_per_m);
    v("depth_sigma_z0_m", depth_sigma_z0_m);
    v("inverse_depth_step_per_m", inverse_depth_step_per_m);
    v("missing_probability", missing_probability);
    v("max_incidence_deg", max_incidence_deg);
    v("min_range_m", min_range_m);
    v("max_range_m", max_range_m);
    v("intensity_sigma", intensity_sigma);
  }

  /// No noise at all (the default).
  static SensorNoiseOptions none() { return {}; }
  /// A Kinect v1 (the TUM RGB-D benchmark's sensor): Nguyen's axial noise, 1/8 px disparity
  /// quantisation, 0.4-8 m range, depth lost beyond 75 degrees incidence, 0.5 % random holes,
  /// intensity sigma 2 grey levels.
  static SensorNoiseOptions kinect();
  /// "none", "kinect", or a YAML file with any of the fields above (keys as the field names;
  /// max_range_m may be .inf). Throws InputError naming the file or the valid names.
  static SensorNoiseOptions from_name_or_file(const std::string& name_or_path);
  /// Loads a YAML file: a map with any of the field names; unknown keys are errors.
  static SensorNoiseOptions load_yaml(const std::filesystem::path& path);
  /// The same from a node of a larger file; errors name `file` and the field as
  /// `field_prefix` + key (e.g. "noise.intensity_sigma").
  static SensorNoiseOptions from_yaml(const YAML::Node& node, const std::filesystem::path& file,
                                      const std::string& field_prefix = {});
  /// The YAML fields, as load_yaml() reads them (max_range_m may be .inf).
  [[nodiscard]] std::string to_yaml() const;
  /// Writes the options as YAML (provenance line of `command` first).
  void save_yaml(const std::filesystem::path& path, std::string_view command,
                 bool force = false) const;

  [[nodiscard]] bool depth_noise_enabled() const;
  [[nodiscard]] bool enabled() const;
  [[nodiscard]] double depth_sigma_m(double z_m) const;
  /// One line for logs: "none" or the active terms.
  [[nodiscard]] std::string describe() const;
  /// Throws std::invalid_argument for negative sigmas, probabilities outside [0, 1] etc.
  void validate() const;
};

/// xoshiro256++ (Blackman and Vigna, "Scrambled linear pseudorandom number generators", ACM
/// TOMS 47(4), 2021): 256 bits of state, period 2^256 - 1, passes BigCrush; several times
/// faster than std::mt19937_64, which matters at three noisy views of 90k pixels x 3 channels
/// per 30 Hz frame. Seeded through splitmix64, as its authors advise. A standard
/// UniformRandomBitGenerator.
class Xoshiro256pp {
 public:
  using result_type = std::uint64_t;
  explicit Xoshiro256pp(std::uint64_t seed = 1) { this->seed(seed); }
  void seed(std::uint64_t seed) {
    for (std::uint64_t& word : s_) {
      seed += 0x9E3779B97F4A7C15ULL;  // splitmix64
      std::uint64_t z = seed;
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
      word = z ^ (z >> 31);
    }
  }
  static constexpr result_type min() { return 0; }
  static constexpr result_type max() { return ~result_type{0}; }
  result_type operator()() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4]{};
};

/// Applies SensorNoiseOptions to rendered buffers, drawing from its own generator: the same
/// seed and the same sequence of calls give the same noise.
class SensorNoise {
 public:
  explicit SensorNoise(SensorNoiseOptions options = {}, std::uint64_t seed = 1);

  [[nodiscard]] const SensorNoiseOptions& options() const { return options_; }
  void reseed(std::uint64_t seed) { rng_.seed(seed); }

  /// depth_m (CV_32F, 0 = no depth) in place, from the exact depth; cos_incidence (CV_32F)
  /// holds |cos| of the angle between each pixel's ray and the surface normal.
  void apply_depth(cv::Mat& depth_m, const cv::Mat& cos_incidence);
  /// Linear colour (CV_32FC3 in [0, 1]) in place; results are clamped to [0, 1]. The deviates
  /// come from a 2^16-quantile table of the normal (exact sigma and mean, tails to 4.3 sigma).
  void apply_intensity(cv::Mat& color);

 private:
  SensorNoiseOptions options_;
  Xoshiro256pp rng_;
};

}  // namespace kestrel::sim
