// `kestrel capture` end to end (the built binary): listing, the error for a missing camera, and
// offline decoding of a raw packed frame built by hand from known mosaics.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "cli_test.hpp"
#include "kestrel/driver/v4l2_camera.hpp"
#include "stereo_test_frames.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

class CmdCapture : public kestrel::test::CliTest {
 protected:
  std::string path(const std::string& name) const { return quoted((dir_ / name).string()); }
};

TEST_F(CmdCapture, ListNamesEveryVideoNodeOrSaysThereIsNone) {
  const RunResult r = run("capture --list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto nodes = kestrel::driver::list_video_devices();
  if (nodes.empty()) {
    EXPECT_NE(r.out.find("no video devices"), std::string::npos) << r.out;
  }
  for (const auto& node : nodes) {
    EXPECT_NE(r.out.find(node.string()), std::string::npos) << r.out;
  }
}

TEST_F(CmdCapture, AMissingCameraIsAClearErrorAndWritesNothing) {
  const std::string device = (dir_ / "video9").string();
  const RunResult r =
      run("capture --device " + quoted(device) + " --frames 5 --out " + path("rec"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("kestrel: error: " + device + ": no such video device"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("kestrel capture --list"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "rec"));

  const RunResult listed = run("capture --list --device " + quoted(device));
  EXPECT_EQ(listed.exit_code, 0);
  EXPECT_NE(listed.out.find("no such video device"), std::string::npos) << listed.out;
}

TEST_F(CmdCapture, BadOptionsAreNamed) {
  RunResult r = run("capture --device /dev/null --bayer XYZW --out " + path("rec"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--bayer must be GRBG, RGGB, BGGR or GBRG"), std::string::npos) << r.err;
  // Refused where the option is parsed (CLI11's validation exit code), before any work.
  r = run("capture --device /dev/null --left-byte 2 --out " + path("rec"));
  EXPECT_EQ(r.exit_code, 105);
  EXPECT_NE(r.err.find("--left-byte: got 2; expected 0 or 1"), std::string::npos) << r.err;
  r = run("capture --device /dev/null --out " + path("rec"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("/dev/null: not a V4L2 video device"), std::string::npos) << r.err;
}

TEST_F(CmdCapture, DecodesARawFrameExactly) {
  const int w = 96;
  const int h = 64;
  const cv::Mat left = kestrel::test::random_mosaic(w, h, 21);
  const cv::Mat right = kestrel::test::random_mosaic(w, h, 22);
  const auto bytes = kestrel::test::pack_by_hand(left, right, 1);
  {
    std::ofstream out(dir_ / "frame.bin", std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),  // NOLINT(*-reinterpret-cast)
              static_cast<std::streamsize>(bytes.size()));
  }
  const std::string common = "capture --decode-file " + path("frame.bin") + " --width " +
                             std::to_string(w) + " --height " + std::to_string(h) +
                             " --left-byte 1 ";
  RunResult r = run(common + "--images mosaic --out " + path("mosaic"));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_TRUE(kestrel::test::identical(
      cv::imread((dir_ / "mosaic" / "left.png").string(), cv::IMREAD_UNCHANGED), left));
  EXPECT_TRUE(kestrel::test::identical(
      cv::imread((dir_ / "mosaic" / "right.png").string(), cv::IMREAD_UNCHANGED), right));

  r = run(common + "--images color --bayer RGGB --out " + path("color"));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const cv::Mat color = cv::imread((dir_ / "color" / "left.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(color.type(), CV_8UC3);
  EXPECT_EQ(color.size(), cv::Size(w, h));

  // One byte short: named as truncated, with the sizes.
  fs::resize_file(dir_ / "frame.bin", bytes.size() - 1);
  r = run(common + "--out " + path("short"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("truncated: 12287 of 12288 bytes"), std::string::npos) << r.err;
}

}  // namespace
