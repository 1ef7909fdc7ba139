// The sensor noise model: measured statistics match the model's sigma, quantisation, dropout
// rates, range and incidence limits; options load and save as YAML.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/sim/renderer.hpp"
#include "test_data.hpp"

namespace kestrel::sim {
namespace {

/// An exact depth map and incidence map: a plane at depth z seen head-on.
struct Buffers {
  cv::Mat depth;
  cv::Mat cos_incidence;
};
Buffers flat(double z, int w = 200, int h = 150, double cos_i = 1.0) {
  return {cv::Mat(h, w, CV_32F, cv::Scalar(z)), cv::Mat(h, w, CV_32F, cv::Scalar(cos_i))};
}

TEST(SensorNoise, DepthNoiseHasTheModelsSigmaGrowingWithZSquared) {
  SensorNoiseOptions o;
  o.depth_sigma_a_m = 0.0012;
  o.depth_sigma_b_per_m = 0.0019;
  o.depth_sigma_z0_m = 0.4;
  SensorNoise noise(o, 7);
  for (const double z : {1.0, 2.0, 4.0}) {
    Buffers b = flat(z);
    noise.apply_depth(b.depth, b.cos_incidence);
    cv::Mat err;
    b.depth.convertTo(err, CV_64F, 1.0, -z);
    cv::Scalar mean, sd;
    cv::meanStdDev(err, mean, sd);
    const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
    EXPECT_NEAR(o.depth_sigma_m(z), sigma, 1e-15);
    const double n = static_cast<double>(err.total());
    EXPECT_NEAR(sd[0], sigma, 0.02 * sigma) << z;  // 30000 samples: ~0.4 % s.e.
    EXPECT_NEAR(mean[0], 0.0, 4.0 * sigma / std::sqrt(n)) << z;
    // Gaussian tails: 4.55 % beyond 2 sigma, 0.27 % beyond 3 sigma (4 binomial s.e.).
    const cv::Mat abs_err = cv::abs(err);
    const double beyond2 = cv::countNonZero(abs_err > 2.0 * sigma) / n;
    const double beyond3 = cv::countNonZero(abs_err > 3.0 * sigma) / n;
    EXPECT_NEAR(beyond2, 0.0455, 4.0 * std::sqrt(0.0455 * 0.9545 / n)) << z;
    EXPECT_NEAR(beyond3, 0.0027, 4.0 * std::sqrt(0.0027 * 0.9973 / n)) << z;
  }
}

TEST(SensorNoise, QuantisesInverseDepth) {
  SensorNoiseOptions o;
  o.inverse_depth_step_per_m = 0.01;
  SensorNoise noise(o, 1);
  for (const double z : {0.77, 1.234, 3.3}) {
    Buffers b = flat(z, 4, 4);
    noise.apply_depth(b.depth, b.cos_incidence);
    const double inv = 1.0 / static_cast<double>(b.depth.at<float>(0, 0));
    EXPECT_NEAR(inv / 0.01, std::round(inv / 0.01), 1e-4) << z;
    EXPECT_LE(std::abs(inv - 1.0 / z), 0.005 + 1e-9) << z;  // rounded to the nearest step
  }
}

TEST(SensorNoise, DropsTheExpectedFractionOfPixels) {
  SensorNoiseOptions o;
  o.missing_probability = 0.1;
  SensorNoise noise(o, 3);
  Buffers b = flat(2.0);
  noise.apply_depth(b.depth, b.cos_incidence);
  const double n = static_cast<double>(b.depth.total());
  const double missing = n - cv::countNonZero(b.depth);
  EXPECT_NEAR(missing / n, 0.1, 4.0 * std::sqrt(0.1 * 0.9 / n));
  // The depth that remains is untouched (no Gaussian term).
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(b.depth, &lo, &hi, nullptr, nullptr, b.depth > 0.0F);
  EXPECT_EQ(lo, 2.0);
  EXPECT_EQ(hi, 2.0);
}

TEST(SensorNoise, DropsDepthOutOfRangeAndAtGrazingAngles) {
  SensorNoiseOptions o;
  o.min_range_m = 0.5;
  o.max_range_m = 5.0;
  o.max_incidence_deg = 75.0;
  SensorNoise noise(o, 3);
  for (const double z : {0.3, 6.0}) {
    Buffers b = flat(z, 8, 8);
    noise.apply_depth(b.depth, b.cos_incidence);
    EXPECT_EQ(cv::countNonZero(b.depth), 0) << z;
  }
  Buffers grazing = flat(2.0, 8, 8, std::cos(80.0 * kPi / 180.0));
  noise.apply_depth(grazing.depth, grazing.cos_incidence);
  EXPECT_EQ(cv::countNonZero(grazing.depth), 0);
  Buffers oblique = flat(2.0, 8, 8, std::cos(60.0 * kPi / 180.0));
  noise.apply_depth(oblique.depth, oblique.cos_incidence);
  EXPECT_EQ(cv::countNonZero(oblique.depth), 64);
  // Missing stays missing.
  Buffers none = flat(0.0, 8, 8);
  noise.apply_depth(none.depth, none.cos_incidence);
  EXPECT_EQ(cv::countNonZero(none.depth), 0);
}

TEST(SensorNoise, IntensityNoiseHasItsSigma) {
  SensorNoiseOptions o;
  o.intensity_sigma = 3.0;
  SensorNoise noise(o, 5);
  cv::Mat color(150, 200, CV_32FC3, cv::Scalar(0.5, 0.4, 0.6));
  const cv::Mat clean = color.clone();
  noise.apply_intensity(color);
  cv::Mat err = (color - clean) * 255.0;
  cv::Scalar mean, sd;
  cv::meanStdDev(err, mean, sd);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sd[c], 3.0, 0.06) << c;
    EXPECT_NEAR(mean[c], 0.0, 0.1) << c;
  }
}

TEST(SensorNoise, IntensityNoiseIsGaussianToItsTails) {
  // 3 million deviates (far from the clamps at 0 and 1): mean, sigma, the two-sided tail
  // fractions and the kurtosis of a normal, each within 4 standard errors, and values beyond
  // 4 sigma (a normal gives ~190 of 3 million there).
  SensorNoiseOptions o;
  o.intensity_sigma = 2.0;
  SensorNoise noise(o, 11);
  cv::Mat color(1000, 1000, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  noise.apply_intensity(color);
  const double sigma = 2.0 / 255.0;
  double s1 = 0.0, s2 = 0.0, s4 = 0.0, largest = 0.0;
  double beyond2 = 0.0, beyond3 = 0.0;
  const cv::Mat flat_view = color.reshape(1, 1);
  const auto n = static_cast<double>(flat_view.total());
  for (int i = 0; i < flat_view.cols; ++i) {
    const double z = (static_cast<double>(flat_view.at<float>(0, i)) - 0.5) / sigma;
    s1 += z;
    s2 += z * z;
    s4 += z * z * z * z;
    largest = std::max(largest, std::abs(z));
    beyond2 += std::abs(z) > 2.0 ? 1.0 : 0.0;
    beyond3 += std::abs(z) > 3.0 ? 1.0 : 0.0;
  }
  const double mean = s1 / n;
  const double variance = s2 / n - mean * mean;
  EXPECT_NEAR(mean, 0.0, 4.0 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(variance), 1.0, 4.0 * std::sqrt(0.5 / n));  // s.e. of sd: 1/sqrt(2n)
  EXPECT_NEAR(beyond2 / n, 0.0455, 4.0 * std::sqrt(0.0455 * 0.9545 / n));
  EXPECT_NEAR(beyond3 / n, 0.0027, 4.0 * std::sqrt(0.0027 * 0.9973 / n));
  EXPECT_NEAR(s4 / n / (variance * variance), 3.0, 4.0 * std::sqrt(24.0 / n));  // kurtosis
  EXPECT_GT(largest, 4.0);
}

TEST(SensorNoise, RenderedGrazingFloorLosesDepthWithTheKinectModel) {
  // A floor seen from 1 m height: far rows meet it beyond 75 degrees and lose their depth.
  const PinholeCamera camera({131.25, 131.25, 79.5, 59.5, 160, 120});
  Scene scene;
  scene.add(InfinitePlane{
      SE3(SO3(), {0, 0, -1.0}),
      {std::make_shared<const Texture>(Texture::constant({0.5F, 0.5F, 0.5F})), {1, 1, 1}}});
  SensorNoiseOptions o;
  o.max_incidence_deg = 75.0;
  RenderOptions options;
  options.noise = o;
  Renderer renderer(camera, options);
  // Camera looking along +x, level: optical frame x right = -y, y down = -z, z forward = +x.
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const RenderedFrame f = renderer.render(scene, SE3(SO3::from_matrix(R), {0, 0, 0}));
  const cv::Mat& exact = renderer.exact_depth_m();
  for (int v = 60; v < 120; v += 3) {
    const double z = exact.at<float>(v, 80);
    ASSERT_GT(z, 0.0);
    // Ray angle below the horizon: tan = (v - cy) / f; incidence = 90 deg - that angle.
    const double incidence = 90.0 - std::atan((v - 59.5) / 131.25) * 180.0 / kPi;
    EXPECT_EQ(f.depth_m.at<float>(v, 80) > 0.0F, incidence <= 75.0) << v;
  }
}

TEST(SensorNoiseOptions, KinectPresetAndDescriptions) {
  const SensorNoiseOptions k = SensorNoiseOptions::kinect();
  EXPECT_TRUE(k.enabled());
  EXPECT_NEAR(k.depth_sigma_m(3.0), 0.0012 + 0.0019 * 2.6 * 2.6, 1e-12);
  EXPECT_NE(k.describe().find("depth sigma"), std::string::npos);
  EXPECT_FALSE(SensorNoiseOptions::none().enabled());
  EXPECT_EQ(SensorNoiseOptions::none().describe(), "none");
  EXPECT_EQ(SensorNoiseOptions::from_name_or_file("kinect").depth_sigma_b_per_m, 0.0019);
  SensorNoiseOptions bad;
  bad.missing_probability = 1.5;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  try {
    (void)SensorNoiseOptions::from_name_or_file("kinekt");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("kinect"), std::string::npos);
  }
}

TEST(SensorNoiseOptions, YamlRoundTripAndErrorsNameTheField) {
  const auto dir = test::fresh_temp_dir("noise_yaml");
  SensorNoiseOptions o = SensorNoiseOptions::kinect();
  o.intensity_sigma = 1.25;
  o.save_yaml(dir / "noise.yaml", "test");
  const SensorNoiseOptions back = SensorNoiseOptions::load_yaml(dir / "noise.yaml");
  EXPECT_EQ(back.depth_sigma_a_m, o.depth_sigma_a_m);
  EXPECT_EQ(back.inverse_depth_step_per_m, o.inverse_depth_step_per_m);
  EXPECT_EQ(back.max_range_m, o.max_range_m);
  EXPECT_EQ(back.intensity_sigma, 1.25);
  // Infinite range survives too.
  SensorNoiseOptions inf;
  inf.save_yaml(dir / "none.yaml", "test");
  EXPECT_TRUE(std::isinf(SensorNoiseOptions::load_yaml(dir / "none.yaml").max_range_m));

  std::ofstream(dir / "bad.yaml") << "intensity_sigma: 2\ndepth_sigma: 0.1\n";
  try {
    (void)SensorNoiseOptions::load_yaml(dir / "bad.yaml");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("depth_sigma"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "render.yaml") << "edge_supersampling: 2\nnoise:\n  intensity_sigma: 4\n";
  const RenderOptions r = RenderOptions::load_yaml(dir / "render.yaml");
  EXPECT_EQ(r.edge_supersampling, 2);
  EXPECT_EQ(r.noise.intensity_sigma, 4.0);
  std::ofstream(dir / "render_bad.yaml") << "noise:\n  intensity_sigma: lots\n";
  try {
    (void)RenderOptions::load_yaml(dir / "render_bad.yaml");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("noise.intensity_sigma"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel::sim
