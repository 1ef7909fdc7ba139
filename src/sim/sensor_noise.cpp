// Sensor noise model: Kinect-like depth noise, quantisation, missing depth, intensity noise.
#include "kestrel/sim/sensor_noise.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::sim {

namespace {

/// Uniform in [0, 1) from the top 53 bits.
double unit_uniform(Xoshiro256pp& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

/// Standard normal deviates by Marsaglia and Tsang's ziggurat ("The Ziggurat Method for
/// Generating Random Variables", J. Stat. Software 5(8), 2000; 128 layers), about five times
/// faster than std::normal_distribution, for the depth noise, whose tails it keeps exactly. As
/// advised by Leong et al. (2005), the layer index and the value come from different bits of
/// one 64-bit draw.
class Ziggurat {
 public:
  Ziggurat() {
    constexpr double m1 = 2147483648.0;  // 2^31
    double dn = kR, tn = dn;
    const double vn = 9.91256303526217e-3;  // area of each layer
    const double q = vn / std::exp(-0.5 * dn * dn);
    kn_[0] = static_cast<std::uint32_t>((dn / q) * m1);
    kn_[1] = 0;
    wn_[0] = q / m1;
    wn_[127] = dn / m1;
    fn_[0] = 1.0;
    fn_[127] = std::exp(-0.5 * dn * dn);
    for (int i = 126; i >= 1; --i) {
      dn = std::sqrt(-2.0 * std::log(vn / dn + std::exp(-0.5 * dn * dn)));
      kn_[i + 1] = static_cast<std::uint32_t>((dn / tn) * m1);
      tn = dn;
      fn_[i] = std::exp(-0.5 * dn * dn);
      wn_[i] = dn / m1;
    }
  }

  double operator()(Xoshiro256pp& rng) const {
    for (;;) {
      const std::uint64_t bits = rng();
      const auto hz = static_cast<std::int32_t>(static_cast<std::uint32_t>(bits));
      const auto iz = static_cast<int>((bits >> 32) & 127U);
      const double x = hz * wn_[iz];
      if (static_cast<std::uint32_t>(std::abs(static_cast<std::int64_t>(hz))) < kn_[iz]) return x;
      if (iz == 0) {  // the base strip: sample the tail beyond kR
        double tx, ty;
        do {
          tx = -std::log(uniform_open(rng)) / kR;
          ty = -std::log(uniform_open(rng));
        } while (ty + ty < tx * tx);
        return hz > 0 ? kR + tx : -kR - tx;
      }
      // The wedge: accept under the density, else draw again.
      if (fn_[iz] + unit_uniform(rng) * (fn_[iz - 1] - fn_[iz]) < std::exp(-0.5 * x * x)) return x;
    }
  }

  static const Ziggurat& instance() {
    static const Ziggurat z;
    return z;
  }

 private:
  static constexpr double kR = 3.442619855899;
  static double uniform_open(Xoshiro256pp& rng) {  // (0, 1]
    return (static_cast<double>(rng() >> 11) + 1.0) * 0x1.0p-53;
  }
  std::uint32_t kn_[128]{};
  double wn_[128]{};
  double fn_[128]{};
};

/// Standard normal deviates for image noise, four per 64-bit draw: each 16-bit field of one
/// xoshiro256++ output picks one of 2^16 equally likely values, the normal quantiles at the
/// stratum midpoints (i + 1/2) / 2^16. A realistic flight's frame holds about 800k noisy
/// values, and at the ziggurat's ~60 instructions per value the noise was one of the flight's
/// largest costs; a table look-up is a shift, a mask and a load. The price is the far tails: the
/// largest value is 4.32 sigma (the normal puts 1.5e-5 of its mass beyond), and the values
/// are scaled to unit variance so that intensity_sigma stays the exact standard deviation.
/// Mean, sigma, tail fractions and kurtosis are tested (test_sensor_noise.cpp).
class NormalTable {
 public:
  static constexpr int kBits = 16;
  static constexpr std::uint32_t kSize = 1U << kBits;

  NormalTable() : values_(kSize) {
    // Upper half by Newton's method on the upper tail Q(z) = erfc(z / sqrt 2) / 2, each
    // quantile starting from the previous one; the lower half mirrors it, so the mean is 0.
    std::vector<double> z(kSize);
    double x = 0.0;
    for (std::uint32_t i = kSize / 2; i < kSize; ++i) {
      const double q = (static_cast<double>(kSize - i) - 0.5) / kSize;
      for (int iteration = 0; iteration < 100; ++iteration) {
        const double step = (0.5 * std::erfc(x / std::numbers::sqrt2) - q) /
                            (std::exp(-0.5 * x * x) / std::sqrt(2.0 * kPi));
        x += step;
        if (std::abs(step) < 1e-14 * (1.0 + std::abs(x))) break;
      }
      z[i] = x;
      z[kSize - 1 - i] = -x;
    }
    double variance = 0.0;
    for (const double v : z) variance += v * v;
    variance /= kSize;  // 0.99998: the tails beyond the last stratum's midpoint are missing
    const double scale = 1.0 / std::sqrt(variance);
    for (std::uint32_t i = 0; i < kSize; ++i) values_[i] = static_cast<float>(z[i] * scale);
  }

  /// The deviate picked by the low kBits bits of `bits`.
  [[nodiscard]] float operator()(std::uint64_t bits) const {
    return values_[static_cast<std::size_t>(bits & (kSize - 1))];
  }

  static const NormalTable& instance() {
    static const NormalTable table;
    return table;
  }

 private:
  std::vector<float> values_;
};

}  // namespace

SensorNoiseOptions SensorNoiseOptions::kinect() {
  SensorNoiseOptions o;
  o.depth_sigma_a_m = 0.0012;  // Nguyen et al. 2012, axial noise for 10-60 degrees incidence
  o.depth_sigma_b_per_m = 0.0019;
  o.depth_sigma_z0_m = 0.4;
  o.inverse_depth_step_per_m = 0.125 / (580.0 * 0.075);  // 1/8 px disparity, f 580, B 7.5 cm
  o.missing_probability = 0.005;
  o.max_incidence_deg = 75.0;
  o.min_range_m = 0.4;
  o.max_range_m = 8.0;
  o.intensity_sigma = 2.0;
  return o;
}

SensorNoiseOptions SensorNoiseOptions::from_name_or_file(const std::string& name_or_path) {
  if (name_or_path == "none") return none();
  if (name_or_path == "kinect") return kinect();
  if (!std::filesystem::exists(name_or_path)) {
    throw InputError("noise model '" + name_or_path +
                     "': neither a model name (none, kinect) nor an existing YAML file");
  }
  return load_yaml(name_or_path);
}

SensorNoiseOptions SensorNoiseOptions::from_yaml(const YAML::Node& node,
                                                 const std::filesystem::path& file,
                                                 const std::string& field_prefix) {
  SensorNoiseOptions o;
  io::option_fields::read_fields(node, file.string(), "sensor noise", o, field_prefix);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(file.string() + ": " + e.what());
  }
  return o;
}

SensorNoiseOptions SensorNoiseOptions::load_yaml(const std::filesystem::path& path) {
  return from_yaml(io::load_yaml_file(path), path);
}

std::string SensorNoiseOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

void SensorNoiseOptions::save_yaml(const std::filesystem::path& path, std::string_view command,
                                   bool force) const {
  io::check_can_write_file(path, command, force);
  std::ofstream out(path);
  out << io::provenance_line(command)
      << "\n# sensor noise model (kestrel::sim::SensorNoiseOptions)\n"
      << to_yaml();
  if (!out) throw InputError(path.string() + ": cannot write");
}

bool SensorNoiseOptions::depth_noise_enabled() const {
  return depth_sigma_a_m > 0.0 || depth_sigma_b_per_m > 0.0 || inverse_depth_step_per_m > 0.0 ||
         missing_probability > 0.0 || max_incidence_deg < 90.0 || min_range_m > 0.0 ||
         std::isfinite(max_range_m);
}

bool SensorNoiseOptions::enabled() const { return depth_noise_enabled() || intensity_sigma > 0.0; }

double SensorNoiseOptions::depth_sigma_m(double z_m) const {
  const double dz = z_m - depth_sigma_z0_m;
  return depth_sigma_a_m + depth_sigma_b_per_m * dz * dz;
}

std::string SensorNoiseOptions::describe() const {
  if (!enabled()) return "none";
  std::ostringstream os;
  const char* sep = "";
  if (depth_sigma_a_m > 0.0 || depth_sigma_b_per_m > 0.0) {
    os << "depth sigma = " << depth_sigma_a_m << " + " << depth_sigma_b_per_m << " (Z - "
       << depth_sigma_z0_m << ")^2 m";
    sep = ", ";
  }
  if (inverse_depth_step_per_m > 0.0) {
    os << sep << "1/Z step " << inverse_depth_step_per_m << " /m";
    sep = ", ";
  }
  if (missing_probability > 0.0) {
    os << sep << "missing " << 100.0 * missing_probability << " %";
    sep = ", ";
  }
  if (max_incidence_deg < 90.0) {
    os << sep << "no depth beyond " << max_incidence_deg << " deg incidence";
    sep = ", ";
  }
  if (min_range_m > 0.0 || std::isfinite(max_range_m)) {
    os << sep << "range " << min_range_m << "-" << max_range_m << " m";
    sep = ", ";
  }
  if (intensity_sigma > 0.0) os << sep << "intensity sigma " << intensity_sigma << " levels";
  return os.str();
}

void SensorNoiseOptions::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("SensorNoiseOptions: ") + what);
  };
  require(depth_sigma_a_m >= 0.0 && depth_sigma_b_per_m >= 0.0, "depth sigma terms must be >= 0");
  require(std::isfinite(depth_sigma_z0_m), "depth_sigma_z0_m must be finite");
  require(inverse_depth_step_per_m >= 0.0, "inverse_depth_step_per_m must be >= 0");
  require(missing_probability >= 0.0 && missing_probability <= 1.0,
          "missing_probability must be in [0, 1]");
  require(max_incidence_deg > 0.0 && max_incidence_deg <= 90.0,
          "max_incidence_deg must be in (0, 90]");
  require(min_range_m >= 0.0 && max_range_m > min_range_m, "need 0 <= min_range_m < max_range_m");
  require(intensity_sigma >= 0.0, "intensity_sigma must be >= 0");
}

SensorNoise::SensorNoise(SensorNoiseOptions options, std::uint64_t seed)
    : options_(options), rng_(seed) {
  options_.validate();
}

void SensorNoise::apply_depth(cv::Mat& depth_m, const cv::Mat& cos_incidence) {
  CV_Assert(depth_m.type() == CV_32F && cos_incidence.type() == CV_32F &&
            depth_m.size() == cos_incidence.size());
  const SensorNoiseOptions& o = options_;
  const double cos_min =
      o.max_incidence_deg < 90.0 ? std::cos(o.max_incidence_deg * kPi / 180.0) : -1.0;
  const bool gaussian = o.depth_sigma_a_m > 0.0 || o.depth_sigma_b_per_m > 0.0;
  const double step = o.inverse_depth_step_per_m;
  const Ziggurat& normal = Ziggurat::instance();
  for (int v = 0; v < depth_m.rows; ++v) {
    auto* z_row = depth_m.ptr<float>(v);
    const auto* c_row = cos_incidence.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      double z = z_row[u];
      if (!(z > 0.0)) continue;
      if (z < o.min_range_m || z > o.max_range_m || static_cast<double>(c_row[u]) < cos_min ||
          (o.missing_probability > 0.0 && unit_uniform(rng_) < o.missing_probability)) {
        z_row[u] = 0.0F;
        continue;
      }
      if (gaussian) z += o.depth_sigma_m(z) * normal(rng_);
      if (step > 0.0 && z > 0.0) {
        const double inv = std::round(1.0 / (z * step)) * step;
        z = inv > 0.0 ? 1.0 / inv : 0.0;
      }
      z_row[u] = z > 0.0 ? static_cast<float>(z) : 0.0F;
    }
  }
}

void SensorNoise::apply_intensity(cv::Mat& color) {
  CV_Assert(color.type() == CV_32FC3);
  const auto sigma = static_cast<float>(options_.intensity_sigma / 255.0);
  const NormalTable& normal = NormalTable::instance();
  constexpr int kPerDraw = 64 / NormalTable::kBits;
  auto add = [&](float& value, std::uint64_t bits) {
    value = std::clamp(value + sigma * normal(bits), 0.0F, 1.0F);
  };
  for (int v = 0; v < color.rows; ++v) {
    auto* row = color.ptr<float>(v);
    const int n = 3 * color.cols;
    int i = 0;
    for (; i + kPerDraw <= n; i += kPerDraw) {
      const std::uint64_t bits = rng_();
      for (int k = 0; k < kPerDraw; ++k) add(row[i + k], bits >> (k * NormalTable::kBits));
    }
    if (i < n) {  // the row's last few values share one more draw
      const std::uint64_t bits = rng_();
      for (int k = 0; i < n; ++i, ++k) add(row[i], bits >> (k * NormalTable::kBits));
    }
  }
}

}  // namespace kestrel::sim
