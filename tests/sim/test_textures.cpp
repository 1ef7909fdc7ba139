// Textures: exact lookups at texel centres, periodic wrap, mip levels, procedural textures
// deterministic from their seeds and with the contrast they promise.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/sim/texture.hpp"
#include "test_data.hpp"

namespace kestrel::sim {
namespace {

float max_abs_diff(const ColorBgr& a, const ColorBgr& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

cv::Mat random_image(int w, int h, std::uint64_t seed) {
  cv::Mat img(h, w, CV_32FC3);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 0.0, 1.0);
  return img;
}

TEST(Texture, TexelCentresAreExactAndBilinearBetween) {
  const cv::Mat img = random_image(8, 6, 3);
  const double texel = 0.05;
  const Texture tex = Texture::from_image(img, texel);
  EXPECT_EQ(tex.width(), 8);
  EXPECT_EQ(tex.height(), 6);
  for (int y = 0; y < 6; ++y) {
    for (int x = 0; x < 8; ++x) {
      const ColorBgr c = tex.sample((x + 0.5) * texel, (y + 0.5) * texel);
      EXPECT_LT(max_abs_diff(c, img.at<cv::Vec3f>(y, x)), 1e-6F) << x << "," << y;
    }
  }
  // Halfway between texels (2, 1) and (3, 1): the mean of the two.
  const ColorBgr mid = tex.sample(3.0 * texel, 1.5 * texel);
  const ColorBgr expected = 0.5F * (img.at<cv::Vec3f>(1, 2) + img.at<cv::Vec3f>(1, 3));
  EXPECT_LT(max_abs_diff(mid, expected), 1e-6F);
}

TEST(Texture, RepeatsWithItsPeriodInBothDirections) {
  const Texture tex = Texture::from_image(random_image(16, 8, 5), 0.01);
  for (const double s : {0.0013, 0.0731, 0.155}) {
    for (const double t : {0.0021, 0.0444}) {
      const ColorBgr c = tex.sample(s, t);
      EXPECT_LT(max_abs_diff(c, tex.sample(s + 0.16, t)), 1e-5F);
      EXPECT_LT(max_abs_diff(c, tex.sample(s - 3 * 0.16, t + 0.08)), 1e-5F);
      EXPECT_LT(max_abs_diff(c, tex.sample(s, t - 0.08 * 7)), 1e-5F);
    }
  }
  // Far away (an infinite plane's horizon) it still returns a texture colour.
  const ColorBgr far = tex.sample(3.7e12, -1.1e11);
  for (int c = 0; c < 3; ++c) EXPECT_TRUE(far[c] >= 0.0F && far[c] <= 1.0F);
}

TEST(Texture, MipLevelsAverageAndFootprintSelectsThem) {
  const Texture tex = Texture::from_image(random_image(64, 64, 7), 0.01);
  ASSERT_EQ(tex.levels(), 7);  // 64, 32, ..., 1
  // Level 1 texel (i, j) is the mean of the 2x2 texels below it.
  const cv::Mat& l0 = tex.level(0);
  const cv::Mat& l1 = tex.level(1);
  const ColorBgr mean = 0.25F * (l0.at<cv::Vec3f>(4, 6) + l0.at<cv::Vec3f>(4, 7) +
                                 l0.at<cv::Vec3f>(5, 6) + l0.at<cv::Vec3f>(5, 7));
  EXPECT_LT(max_abs_diff(l1.at<cv::Vec3f>(2, 3), mean), 1e-5F);
  // The top level is the mean of the image.
  EXPECT_LT(max_abs_diff(tex.level(6).at<cv::Vec3f>(0, 0), tex.mean()), 1e-5F);
  // A footprint below a texel is plain bilinear; a huge one gives the mean.
  EXPECT_LT(max_abs_diff(tex.sample(0.123, 0.456, 0.005), tex.sample(0.123, 0.456)), 1e-7F);
  EXPECT_LT(max_abs_diff(tex.sample(0.123, 0.456, 10.0), tex.mean()), 1e-5F);
  // Exactly two texels: level 1.
  const ColorBgr on_level1 = tex.sample(0.1, 0.2, 0.02);
  EXPECT_LT(max_abs_diff(on_level1, tex.sample_lod(0.1, 0.2, 1.0F)), 1e-6F);
}

TEST(Texture, ConvertsEightBitGreyAndColourImages) {
  cv::Mat grey(2, 2, CV_8U, cv::Scalar(51));
  const Texture g = Texture::from_image(grey, 1.0);
  EXPECT_LT(max_abs_diff(g.sample(0.5, 0.5), ColorBgr(0.2F, 0.2F, 0.2F)), 1e-6F);
  cv::Mat bgr(1, 1, CV_8UC3, cv::Scalar(255, 0, 102));
  const Texture c = Texture::from_image(bgr, 1.0);
  EXPECT_LT(max_abs_diff(c.sample(0.3, 0.7), ColorBgr(1.0F, 0.0F, 0.4F)), 1e-6F);
  EXPECT_LT(max_abs_diff(Texture::constant({0.1F, 0.2F, 0.3F}).sample(5.0, -2.0),
                         ColorBgr(0.1F, 0.2F, 0.3F)),
            1e-7F);
  EXPECT_THROW((void)Texture::from_image(cv::Mat(), 1.0), std::invalid_argument);
  EXPECT_THROW((void)Texture::from_image(grey, 0.0), std::invalid_argument);
}

TEST(Texture, LoadsImageFilesAndNamesMissingOnes) {
  const auto dir = test::fresh_temp_dir("texture");
  cv::Mat img(4, 4, CV_8UC3, cv::Scalar(10, 20, 30));
  ASSERT_TRUE(cv::imwrite((dir / "t.png").string(), img));
  const Texture tex = Texture::load(dir / "t.png", 0.1);
  EXPECT_EQ(tex.width(), 4);
  EXPECT_NEAR(tex.sample(0.15, 0.15)[2], 30.0F / 255.0F, 1e-6F);
  try {
    (void)Texture::load(dir / "missing.png", 0.1);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos);
  }
}

TEST(ProceduralTextures, AreDeterministicFromTheirSeed) {
  ValueNoiseOptions o;
  o.size_px = 64;
  const Texture a = make_value_noise_texture(o, 11);
  const Texture b = make_value_noise_texture(o, 11);
  const Texture c = make_value_noise_texture(o, 12);
  EXPECT_EQ(cv::norm(a.level(0), b.level(0), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.level(0), c.level(0), cv::NORM_INF), 0.1);
  BlobTextureOptions bo;
  bo.size_px = 64;
  bo.count = 20;
  bo.max_radius_px = 8;
  EXPECT_EQ(
      cv::norm(make_blob_texture(bo, 3).level(0), make_blob_texture(bo, 3).level(0), cv::NORM_INF),
      0.0);
  EXPECT_GT(
      cv::norm(make_blob_texture(bo, 3).level(0), make_blob_texture(bo, 4).level(0), cv::NORM_INF),
      0.1);
}

TEST(ProceduralTextures, ValueNoiseSpansItsColoursAndTiles) {
  ValueNoiseOptions o;
  o.size_px = 128;
  o.dark = {0.0F, 0.0F, 0.0F};
  o.bright = {1.0F, 1.0F, 1.0F};
  const Texture tex = make_value_noise_texture(o, 5);
  cv::Scalar mean, sd;
  cv::meanStdDev(tex.level(0), mean, sd);
  EXPECT_NEAR(mean[0], 0.5, 0.02);
  EXPECT_NEAR(sd[0], 0.2, 0.02);
  // Periodic: the last column continues smoothly into the first (no seam).
  const cv::Mat& img = tex.level(0);
  double seam = 0.0, inner = 0.0;
  for (int y = 0; y < img.rows; ++y) {
    seam += static_cast<double>(
        std::abs(img.at<cv::Vec3f>(y, 0)[0] - img.at<cv::Vec3f>(y, img.cols - 1)[0]));
    inner += static_cast<double>(std::abs(img.at<cv::Vec3f>(y, 1)[0] - img.at<cv::Vec3f>(y, 0)[0]));
  }
  EXPECT_LT(seam, 3.0 * inner);
}

TEST(ProceduralTextures, LowContrastStaysWithinItsBand) {
  const ColorBgr base(0.7F, 0.75F, 0.8F);
  const Texture tex = make_low_contrast_texture(base, 0.01, 9);
  double lo = 1.0, hi = 0.0;
  cv::minMaxLoc(tex.level(0).reshape(1), &lo, &hi);
  EXPECT_GE(lo, 0.7 * 0.99 - 1e-6);
  EXPECT_LE(hi, 0.8 * 1.01 + 1e-6);
  cv::Scalar mean, sd;
  cv::meanStdDev(tex.level(0), mean, sd);
  EXPECT_LT(sd[2] * 255.0, 1.5);  // under 1.5 grey levels: "nearly textureless"
  EXPECT_GT(sd[2] * 255.0, 0.2);  // but not flat
}

TEST(ProceduralTextures, CheckerboardSquaresHaveTheirColours) {
  const ColorBgr a(0.1F, 0.2F, 0.3F), b(0.9F, 0.8F, 0.7F);
  const Texture tex = make_checkerboard_texture(0.25, a, b);
  EXPECT_DOUBLE_EQ(tex.texel_size_m(), 0.25 / 8);
  for (int i = -3; i < 3; ++i) {
    for (int j = -3; j < 3; ++j) {
      const ColorBgr c = tex.sample((i + 0.5) * 0.25, (j + 0.5) * 0.25);
      const bool even = ((i + j) % 2 + 2) % 2 == 0;
      EXPECT_LT(max_abs_diff(c, even ? a : b), 1e-6F) << i << "," << j;
    }
  }
}

}  // namespace
}  // namespace kestrel::sim
