// The stereo frame decoder against frames packed by hand from known images: the mosaics must
// round-trip exactly for every byte order, Bayer phase, size and row padding; demosaicing must
// give back a smooth colour image, and its grey level, within interpolation error.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/io/option_fields.hpp"
#include "stereo_test_frames.hpp"
#include "test_data.hpp"

namespace {

using kestrel::driver::BayerPhase;
using kestrel::driver::DemosaicMethod;
using kestrel::driver::FrameHealth;
using kestrel::driver::StereoDecoderOptions;
using kestrel::driver::StereoFrameDecoder;
using kestrel::driver::StereoMosaic;
using kestrel::driver::ViewKind;
using kestrel::test::identical;
using kestrel::test::max_abs_diff_inside;
using kestrel::test::mosaic_by_hand;
using kestrel::test::pack_by_hand;

const std::vector<std::string> kPhases{"GRBG", "RGGB", "BGGR", "GBRG"};

BayerPhase phase(const std::string& name) { return *kestrel::driver::parse_bayer_phase(name); }

StereoDecoderOptions options(int width, int height, int left_byte, const std::string& bayer,
                             DemosaicMethod method = DemosaicMethod::kBilinear) {
  StereoDecoderOptions o;
  o.width = width;
  o.height = height;
  o.left_byte = left_byte;
  o.phase = phase(bayer);
  o.demosaic = method;
  return o;
}

TEST(BayerPhase, NamesParseBackAndSpellTheTile) {
  for (const auto& name : kPhases) {
    const auto p = kestrel::driver::parse_bayer_phase(name);
    ASSERT_TRUE(p.has_value()) << name;
    EXPECT_EQ(kestrel::driver::bayer_phase_name(*p), name);
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 4; ++x) {
        EXPECT_EQ(kestrel::driver::bayer_channel(*p, x, y), kestrel::test::tile_channel(name, x, y))
            << name << " at " << x << "," << y;
      }
    }
  }
  EXPECT_EQ(kestrel::driver::parse_bayer_phase("grbg"), BayerPhase::kGRBG);
  EXPECT_FALSE(kestrel::driver::parse_bayer_phase("GRGB").has_value());
  EXPECT_FALSE(kestrel::driver::parse_bayer_phase("").has_value());
}

TEST(BayerPhase, MosaicOfAColourImageTakesTheTilesChannel) {
  const cv::Mat bgr = kestrel::test::smooth_bgr(31, 17);
  for (const auto& name : kPhases) {
    EXPECT_TRUE(
        identical(kestrel::driver::mosaic_from_bgr(bgr, phase(name)), mosaic_by_hand(bgr, name)))
        << name;
  }
}

// The exact round trip: random samples in both sensors, every packing variant.
TEST(StereoFrameDecoder, SplitRecoversBothMosaicsExactly) {
  const std::vector<cv::Size> sizes{{752, 480}, {37, 23}, {2, 2}};
  for (const cv::Size size : sizes) {
    const cv::Mat left = kestrel::test::random_mosaic(size.width, size.height, 1);
    const cv::Mat right = kestrel::test::random_mosaic(size.width, size.height, 2);
    for (int left_byte : {0, 1}) {
      for (const std::size_t padding : {std::size_t{0}, std::size_t{64}, std::size_t{3}}) {
        const std::size_t stride = 2 * static_cast<std::size_t>(size.width) + padding;
        const auto frame = pack_by_hand(left, right, left_byte, stride);
        const StereoFrameDecoder decoder(options(size.width, size.height, left_byte, "GRBG"));
        StereoMosaic out;
        const FrameHealth h = decoder.split(frame, stride, out);
        ASSERT_TRUE(h.ok()) << h.describe();
        EXPECT_TRUE(identical(out.left, left))
            << size << " left_byte " << left_byte << " padding " << padding;
        EXPECT_TRUE(identical(out.right, right))
            << size << " left_byte " << left_byte << " padding " << padding;
      }
    }
  }
}

TEST(StereoFrameDecoder, TheOtherByteOrderSwapsTheSensors) {
  const cv::Mat left = kestrel::test::random_mosaic(40, 30, 3);
  const cv::Mat right = kestrel::test::random_mosaic(40, 30, 4);
  const auto frame = pack_by_hand(left, right, 0);
  StereoMosaic out;
  ASSERT_TRUE(StereoFrameDecoder(options(40, 30, 1, "GRBG")).split(frame, 0, out).ok());
  EXPECT_TRUE(identical(out.left, right));
  EXPECT_TRUE(identical(out.right, left));
}

// A known colour image through a sensor of each phase, packed, split: the mosaic is exact, and
// demosaicing gives the image back within interpolation error away from the border.
TEST(StereoFrameDecoder, KnownColourImageRoundTripsThroughEveryPhase) {
  const int w = 752;
  const int h = 480;
  const cv::Mat left_bgr = kestrel::test::smooth_bgr(w, h);
  const cv::Mat right_bgr = kestrel::test::smooth_bgr(w, h, 37.0);
  cv::Mat left_swapped;  // the same image with red and blue exchanged
  cv::cvtColor(left_bgr, left_swapped, cv::COLOR_BGR2RGB);
  for (const auto& name : kPhases) {
    for (const DemosaicMethod method : {DemosaicMethod::kBilinear, DemosaicMethod::kEdgeAware}) {
      SCOPED_TRACE(name + " " + std::string(kestrel::driver::demosaic_method_name(method)));
      const cv::Mat left_mosaic = mosaic_by_hand(left_bgr, name);
      const cv::Mat right_mosaic = mosaic_by_hand(right_bgr, name);
      const auto frame = pack_by_hand(left_mosaic, right_mosaic, 0);
      const StereoFrameDecoder decoder(options(w, h, 0, name, method));
      StereoMosaic out;
      ASSERT_TRUE(decoder.split(frame, 0, out).ok());
      ASSERT_TRUE(identical(out.left, left_mosaic));
      ASSERT_TRUE(identical(out.right, right_mosaic));

      cv::Mat left_color;
      cv::Mat right_color;
      decoder.convert(out.left, ViewKind::kColor, left_color);
      decoder.convert(out.right, ViewKind::kColor, right_color);
      ASSERT_EQ(left_color.type(), CV_8UC3);
      // Slopes are at most ~1 grey level per pixel: interpolation errs by a few levels.
      EXPECT_LE(max_abs_diff_inside(left_color, left_bgr, 2), 4.0);
      EXPECT_LE(max_abs_diff_inside(right_color, right_bgr, 2), 4.0);
      // The check can fail: red and blue swapped (a wrong OpenCV code) would be far off.
      EXPECT_GT(max_abs_diff_inside(left_color, left_swapped, 2), 60.0);
    }
  }
}

TEST(StereoFrameDecoder, AWrongPhaseGivesWrongColours) {
  const cv::Mat bgr = kestrel::test::smooth_bgr(120, 80);
  const cv::Mat mosaic = mosaic_by_hand(bgr, "GRBG");
  for (const std::string wrong : {"RGGB", "BGGR", "GBRG"}) {
    const StereoFrameDecoder decoder(options(120, 80, 0, wrong));
    cv::Mat color;
    decoder.convert(mosaic, ViewKind::kColor, color);
    EXPECT_GT(max_abs_diff_inside(color, bgr, 2), 40.0) << wrong;
  }
}

TEST(StereoFrameDecoder, GreyIsTheIntensityOfTheColourImage) {
  const cv::Mat bgr = kestrel::test::smooth_bgr(200, 120);
  cv::Mat expected;
  cv::cvtColor(bgr, expected, cv::COLOR_BGR2GRAY);
  for (const auto& name : kPhases) {
    const StereoFrameDecoder decoder(options(200, 120, 0, name));
    cv::Mat gray;
    decoder.convert(mosaic_by_hand(bgr, name), ViewKind::kGray, gray);
    ASSERT_EQ(gray.type(), CV_8UC1);
    EXPECT_LE(max_abs_diff_inside(gray, expected, 2), 3.0) << name;
  }
  cv::Mat mosaic_copy;
  const cv::Mat mosaic = mosaic_by_hand(bgr, "GRBG");
  StereoFrameDecoder(options(200, 120, 0, "GRBG")).convert(mosaic, ViewKind::kMosaic, mosaic_copy);
  EXPECT_TRUE(identical(mosaic_copy, mosaic));
}

TEST(StereoFrameDecoder, PackIsTheInverseOfSplit) {
  const cv::Mat left = kestrel::test::random_mosaic(50, 20, 5);
  const cv::Mat right = kestrel::test::random_mosaic(50, 20, 6);
  for (int left_byte : {0, 1}) {
    const StereoFrameDecoder decoder(options(50, 20, left_byte, "GRBG"));
    EXPECT_EQ(decoder.pack(left, right), pack_by_hand(left, right, left_byte));
    const auto padded = decoder.pack(left, right, 128);
    ASSERT_EQ(padded.size(), 128U * 20U);
    StereoMosaic out;
    ASSERT_TRUE(decoder.split(padded, 128, out).ok());
    EXPECT_TRUE(identical(out.left, left));
    EXPECT_TRUE(identical(out.right, right));
  }
  EXPECT_THROW(
      (void)StereoFrameDecoder(options(50, 20, 0, "GRBG")).pack(left, right.colRange(0, 49)),
      std::invalid_argument);
}

TEST(StereoFrameDecoder, TruncatedAndEmptyFramesAreReportedAndLeaveTheOutputAlone) {
  const StereoFrameDecoder decoder(options(752, 480, 0, "GRBG"));
  EXPECT_EQ(decoder.frame_bytes(), 752U * 480U * 2U);
  const cv::Mat left = kestrel::test::random_mosaic(752, 480, 7);
  const auto frame = pack_by_hand(left, left, 0);
  StereoMosaic out;
  out.left = cv::Mat(3, 3, CV_8UC1, cv::Scalar(9));
  const std::span<const std::uint8_t> all(frame);

  const FrameHealth cut = decoder.split(all.first(frame.size() - 1), 0, out);
  EXPECT_EQ(cut.problem, FrameHealth::Problem::kTruncated);
  EXPECT_EQ(cut.describe(), "truncated: 721919 of 721920 bytes");
  EXPECT_EQ(out.left.rows, 3);  // untouched

  EXPECT_EQ(decoder.split(all.first(0), 0, out).problem, FrameHealth::Problem::kEmpty);

  // The last row needs no padding after it; a longer buffer (whole driver buffer) is fine.
  const std::size_t stride = 1600;
  EXPECT_EQ(decoder.frame_bytes(stride), stride * 479 + 1504);
  EXPECT_TRUE(decoder.check(stride * 479 + 1504, stride).ok());
  EXPECT_FALSE(decoder.check(stride * 479 + 1503, stride).ok());
  std::vector<std::uint8_t> longer(frame);
  longer.resize(frame.size() + 4096, 0);
  EXPECT_TRUE(decoder.split(longer, 0, out).ok());
  EXPECT_TRUE(identical(out.left, left));

  EXPECT_THROW((void)decoder.split(all, 1000, out), std::invalid_argument);  // stride < row
}

TEST(StereoDecoderOptions, ValidateNamesTheField) {
  StereoDecoderOptions o;
  EXPECT_NO_THROW(o.validate());
  o.left_byte = 2;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  o = {};
  o.width = 1;
  EXPECT_THROW(o.validate(), std::invalid_argument);
  EXPECT_THROW(StereoFrameDecoder{o}, std::invalid_argument);
  EXPECT_NE(StereoDecoderOptions{}.describe().find("752x480"), std::string::npos);
  EXPECT_NE(StereoDecoderOptions{}.describe().find("GRBG"), std::string::npos);
}

TEST(StereoDecoderOptions, LoadsYamlAndNamesBadFields) {
  const auto dir = kestrel::test::fresh_temp_dir("decoder_yaml");
  const auto good = dir / "good.yaml";
  std::ofstream(good)
      << "width: 640\nheight: 400\nleft_byte: 1\nbayer: rggb\ndemosaic: edge-aware\n";
  const StereoDecoderOptions o = StereoDecoderOptions::load_yaml(good);
  EXPECT_EQ(o.width, 640);
  EXPECT_EQ(o.height, 400);
  EXPECT_EQ(o.left_byte, 1);
  EXPECT_EQ(o.phase, BayerPhase::kRGGB);
  EXPECT_EQ(o.demosaic, DemosaicMethod::kEdgeAware);

  const auto expect_error = [&](const std::string& text, const std::string& needle) {
    const auto file = dir / "bad.yaml";
    std::ofstream(file) << text;
    try {
      (void)StereoDecoderOptions::load_yaml(file);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const kestrel::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(file.string()), std::string::npos) << what;
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  };
  expect_error("bayer: GGRB\n", "field 'bayer'");
  expect_error("demosaic: vng\n", "field 'demosaic'");
  expect_error("gain: 2\n", "field 'gain'");
  expect_error("width: wide\n", "field 'width'");
  expect_error("left_byte: 3\n", "left_byte");
  expect_error("", "expected a YAML map of stereo decoder options");
  std::filesystem::remove_all(dir);
}

TEST(StereoDecoderOptions, PrintedOptionsLoadBack) {
  const std::string defaults = StereoDecoderOptions{}.to_yaml();
  EXPECT_EQ(defaults, "width: 752\nheight: 480\nleft_byte: 0\nbayer: GRBG\ndemosaic: bilinear\n");
  StereoDecoderOptions back;
  back.phase = BayerPhase::kBGGR;
  back.left_byte = 1;
  kestrel::io::option_fields::read_fields(YAML::Load(defaults), "decoder.yaml", "stereo decoder",
                                          back);
  EXPECT_EQ(back.to_yaml(), defaults);

  const auto dir = kestrel::test::fresh_temp_dir("decoder_yaml");
  StereoDecoderOptions o;
  o.width = 376;
  o.phase = BayerPhase::kGBRG;
  o.demosaic = DemosaicMethod::kEdgeAware;
  std::ofstream(dir / "o.yaml") << o.to_yaml();
  EXPECT_EQ(StereoDecoderOptions::load_yaml(dir / "o.yaml").to_yaml(), o.to_yaml());
  std::filesystem::remove_all(dir);
}

}  // namespace
