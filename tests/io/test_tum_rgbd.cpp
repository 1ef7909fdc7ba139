// TUM RGB-D reader: association as the benchmark does it, decoding, and bad input.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "test_data.hpp"

namespace kestrel::io {
namespace {
namespace fs = std::filesystem;

TEST(AssociateByTime, GreedyClosestFirstEachUsedOnce) {
  const TimeNs ms = 1'000'000;
  // b[1] is the closest to both a[0] (5 ms) and a[1] (1 ms): a[1] wins it, a[0] falls back
  // to b[0] (15 ms); a[2] has nothing within 20 ms.
  const std::vector<TimeNs> a{100 * ms, 106 * ms, 300 * ms};
  const std::vector<TimeNs> b{85 * ms, 105 * ms, 200 * ms};
  const auto pairs = associate_by_time(a, b, 20 * ms);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0], std::make_pair(std::size_t{0}, std::size_t{0}));
  EXPECT_EQ(pairs[1], std::make_pair(std::size_t{1}, std::size_t{1}));
  // Exactly max_diff apart is not a match (the benchmark uses a strict <).
  EXPECT_TRUE(associate_by_time({0}, {20 * ms}, 20 * ms).empty());
}

TEST(AssociateByTime, AHugeToleranceOrStampsNearTheLimitsDoNotOverflow) {
  // `kestrel evaluate --max-diff 1e10` reached here as 1e19 ns: a - max_diff overflowed (UBSan).
  constexpr TimeNs kMax = std::numeric_limits<TimeNs>::max();
  const std::vector<TimeNs> a = {0, 10, kMax - 5};
  const std::vector<TimeNs> b = {1, 12, kMax - 4};
  const auto pairs = associate_by_time(a, b, kMax);
  ASSERT_EQ(pairs.size(), 3U);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(pairs[i], std::make_pair(i, i));
  EXPECT_EQ(associate_by_time({kMax - 1}, {kMax}, 2).size(), 1U);
  EXPECT_TRUE(associate_by_time({1}, {1}, 0).empty());
  EXPECT_TRUE(associate_by_time({1}, {1}, -5).empty());
}

TEST(TumRgbdSequence, RealFreiburg1RpyPart1) {
  KESTREL_REQUIRE_DATA("tum/rgbd_dataset_freiburg1_rpy_part1/rgb.txt");
  const TumRgbdSequence seq(test::shared_data_dir() / "tum/rgbd_dataset_freiburg1_rpy_part1");
  // 250 colour frames; each must find a depth image within 20 ms except at most a few.
  EXPECT_GE(seq.size(), 245u);
  EXPECT_LE(seq.size(), 250u);
  for (std::size_t i = 1; i < seq.size(); ++i) ASSERT_GT(seq.timestamp(i), seq.timestamp(i - 1));
  const RgbdImages f = seq.load(0);
  EXPECT_EQ(f.bgr.type(), CV_8UC3);
  EXPECT_EQ(f.depth_m.type(), CV_32FC1);
  EXPECT_EQ(f.bgr.size(), cv::Size(640, 480));
  EXPECT_LT(std::abs(f.t_ns - f.depth_t_ns), 20'000'000);
  // An office desk seen by a Kinect: most pixels have depth between 0.4 and 5 m.
  int valid = 0;
  for (int v = 0; v < f.depth_m.rows; ++v) {
    for (int u = 0; u < f.depth_m.cols; ++u) {
      const float z = f.depth_m.at<float>(v, u);
      if (z > 0) {
        ++valid;
        ASSERT_GT(z, 0.3f);
        ASSERT_LT(z, 10.0f);
      }
    }
  }
  EXPECT_GT(valid, 640 * 480 / 2);
  const auto gt = seq.groundtruth();
  ASSERT_TRUE(gt);
  EXPECT_GT(gt->size(), 700u);  // 100 Hz over 8.3 s
}

class TumBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("tum");
    fs::create_directories(dir_ / "rgb");
    fs::create_directories(dir_ / "depth");
    cv::imwrite((dir_ / "rgb/1.png").string(), cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((dir_ / "depth/1.png").string(), cv::Mat(4, 6, CV_16UC1, cv::Scalar(5000)));
    write_lists("1.000 rgb/1.png\n", "1.001 depth/1.png\n");
  }
  void write_lists(const std::string& rgb, const std::string& depth) {
    std::ofstream(dir_ / "rgb.txt") << "# colour images\n# file: x\n# timestamp filename\n" << rgb;
    std::ofstream(dir_ / "depth.txt") << "# depth images\n" << depth;
  }
  std::string error_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(TumBadInput, GoodFolderLoads) {
  const TumRgbdSequence seq(dir_);
  ASSERT_EQ(seq.size(), 1u);
  const auto f = seq.load(0);
  EXPECT_FLOAT_EQ(f.depth_m.at<float>(0, 0), 1.0f);
  EXPECT_FALSE(seq.groundtruth());
}

TEST_F(TumBadInput, MalformedListLineNamesFileAndLine) {
  write_lists("1.000 rgb/1.png\n1.5x rgb/2.png\n", "1.001 depth/1.png\n");
  const std::string msg = error_of([&] { TumRgbdSequence s(dir_); });
  EXPECT_NE(msg.find("rgb.txt:5:"), std::string::npos) << msg;
  write_lists("1.000 rgb/1.png extra\n", "1.001 depth/1.png\n");
  EXPECT_NE(error_of([&] { TumRgbdSequence s(dir_); }).find("rgb.txt:4:"), std::string::npos);
  write_lists("2.000 rgb/1.png\n1.000 rgb/1.png\n", "1.001 depth/1.png\n");
  EXPECT_NE(error_of([&] { TumRgbdSequence s(dir_); }).find("increase"), std::string::npos);
}

TEST_F(TumBadInput, MissingOrUndecodableImageIsNamed) {
  write_lists("1.000 rgb/missing.png\n", "1.001 depth/1.png\n");
  const TumRgbdSequence seq(dir_);
  const std::string msg = error_of([&] { (void)seq.load(0); });
  EXPECT_NE(msg.find("missing.png"), std::string::npos) << msg;
  EXPECT_NE(msg.find("rgb.txt:4"), std::string::npos) << msg;
  std::ofstream(dir_ / "rgb/junk.png") << "not a png";
  write_lists("1.000 rgb/junk.png\n", "1.001 depth/1.png\n");
  const TumRgbdSequence seq2(dir_);
  EXPECT_NE(error_of([&] { (void)seq2.load(0); }).find("junk.png"), std::string::npos);
}

TEST_F(TumBadInput, DepthOfWrongSizeOrTypeIsAnError) {
  cv::imwrite((dir_ / "depth/small.png").string(), cv::Mat(3, 6, CV_16UC1, cv::Scalar(1)));
  cv::imwrite((dir_ / "depth/8bit.png").string(), cv::Mat(4, 6, CV_8UC1, cv::Scalar(1)));
  write_lists("1.000 rgb/1.png\n", "1.001 depth/small.png\n");
  const std::string size_msg = error_of([&] { (void)TumRgbdSequence(dir_).load(0); });
  EXPECT_NE(size_msg.find("small.png"), std::string::npos) << size_msg;
  EXPECT_NE(size_msg.find("6x3"), std::string::npos) << size_msg;
  write_lists("1.000 rgb/1.png\n", "1.001 depth/8bit.png\n");
  const std::string type_msg = error_of([&] { (void)TumRgbdSequence(dir_).load(0); });
  EXPECT_NE(type_msg.find("16-bit"), std::string::npos) << type_msg;
}

TEST_F(TumBadInput, NotAFolderOrMissingLists) {
  EXPECT_THROW(TumRgbdSequence(dir_ / "nope"), InputError);
  fs::remove(dir_ / "depth.txt");
  EXPECT_NE(error_of([&] { TumRgbdSequence s(dir_); }).find("depth.txt"), std::string::npos);
}

TEST_F(TumBadInput, FramesWithoutDepthAreSkippedAndCounted) {
  write_lists("1.000 rgb/1.png\n1.500 rgb/1.png\n", "1.001 depth/1.png\n");
  const TumRgbdSequence seq(dir_);
  EXPECT_EQ(seq.size(), 1u);
  EXPECT_EQ(seq.unmatched_rgb(), 1u);
}

}  // namespace
}  // namespace kestrel::io
