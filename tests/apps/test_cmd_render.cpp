// `kestrel render` end to end: runs the built binary (KESTREL_BINARY) on a tiny camera and
// checks its files, its listing and its errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/sim/scenes.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;
using kestrel::test::slurp;

class CmdRender : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    dir_ = kestrel::test::fresh_temp_dir("cmd_render");
    // A small camera keeps the run short in Debug builds.
    kestrel::io::save_camera_yaml(dir_ / "tiny.yaml",
                                  kestrel::PinholeCamera({60.0, 60.0, 39.5, 29.5, 80, 60}), "test");
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& arguments) const {
    return kestrel::test::run_kestrel(dir_, arguments);
  }
  std::string tiny() const { return "--camera " + quoted((dir_ / "tiny.yaml").string()); }
  std::string out(const std::string& name) const { return quoted((dir_ / name).string()); }

  fs::path dir_;
};

TEST_F(CmdRender, ListShowsEverySceneAndTrajectory) {
  const RunResult r = run("render --list");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& e : kestrel::sim::scene_catalogue()) {
    EXPECT_NE(r.out.find(std::string(e.name)), std::string::npos) << e.name;
  }
  for (const auto& e : kestrel::sim::trajectory_catalogue()) {
    EXPECT_NE(r.out.find(std::string(e.name)), std::string::npos) << e.name;
  }
}

TEST_F(CmdRender, WritesATumSequenceAndLogsItsOptions) {
  const RunResult r = run("render --scene office --trajectory handheld --seed 3 --frames 3 " +
                          tiny() + " --noise kinect --out " + out("seq"));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("handheld (seed 3)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("depth sigma"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrote 3 frames"), std::string::npos) << r.out;
  const kestrel::io::TumRgbdSequence seq(dir_ / "seq");
  ASSERT_EQ(seq.size(), 3U);
  ASSERT_TRUE(seq.groundtruth());
  EXPECT_EQ(seq.groundtruth()->size(), 3U);
  const auto images = seq.load(1);
  EXPECT_EQ(images.bgr.cols, 80);
  EXPECT_GT(cv::countNonZero(images.depth_m), 80 * 60 / 2);
  EXPECT_TRUE(fs::exists(dir_ / "seq" / "render.txt"));
  EXPECT_TRUE(fs::exists(dir_ / "seq" / "noise.yaml"));
  EXPECT_FALSE(fs::exists(dir_ / "seq" / "mav0"));

  // Deterministic: the same command writes the same images (same folder: a re-run).
  const cv::Mat first = images.bgr.clone();
  ASSERT_EQ(run("render --scene office --trajectory handheld --seed 3 --frames 3 " + tiny() +
                " --noise kinect --out " + out("seq"))
                .exit_code,
            0);
  EXPECT_EQ(cv::norm(kestrel::io::TumRgbdSequence(dir_ / "seq").load(1).bgr, first, cv::NORM_INF),
            0.0);
}

TEST_F(CmdRender, StereoWritesAnEurocFolderToo) {
  const RunResult r = run("render --scene wall --trajectory still --duration 0.1 --rate 20 " +
                          tiny() + " --stereo --baseline 0.05 --out " + out("st"));
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  const kestrel::io::EurocSequence seq(dir_ / "st");
  EXPECT_EQ(seq.stereo_size(), 2U);  // 0.1 s at 20 Hz
  EXPECT_TRUE(fs::exists(dir_ / "st" / "stereo.yaml"));
  EXPECT_EQ(kestrel::io::TumRgbdSequence(dir_ / "st").size(), 2U);
}

TEST_F(CmdRender, UnknownNamesAndMissingOptionsAreClearErrors) {
  RunResult r = run("render --scene ofice --trajectory still " + tiny() + " --out " + out("x"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("ofice"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("corridor"), std::string::npos) << r.err;  // lists the valid ones
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  r = run("render --scene office --trajectory spiral " + tiny() + " --out " + out("x"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("handheld"), std::string::npos) << r.err;
  r = run("render --scene office --out " + out("x"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--trajectory"), std::string::npos) << r.err;
  r = run("render --scene office --trajectory still --frames 2 --duration 1 --out " + out("x"));
  EXPECT_NE(r.exit_code, 0);
  // A folder holding someone else's files is refused without --force.
  fs::create_directories(dir_ / "busy");
  std::ofstream(dir_ / "busy" / "keep.txt") << "x\n";
  r = run("render --scene checker --trajectory still --frames 1 " + tiny() + " --out " +
          out("busy"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--force"), std::string::npos) << r.err;
}

}  // namespace
