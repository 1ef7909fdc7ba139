// The image outputs of `kestrel pattern` and `kestrel disparity`: an existing file is never
// replaced without --force, and an output that names an input is refused even with it.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

class CmdImageOutputs : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY)) << KESTREL_BINARY << " not found";
    dir_ = kestrel::test::fresh_temp_dir("cmd_images");
    // A stereo "pair" from the pattern generator: two small images, the right one a copy.
    const RunResult r = run("pattern --width 96 --height 64 --lines 40 --out " + path("left.png"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    fs::copy_file(dir_ / "left.png", dir_ / "right.png");
    std::ofstream(dir_ / "rig.yaml") << "stereo:\n  f: 80\n  cu: 48\n  cv: 32\n  baseline_m: 0.1\n"
                                        "  width: 96\n  height: 64\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult run(const std::string& arguments) const {
    return kestrel::test::run_kestrel(dir_, arguments);
  }
  std::string path(const std::string& name) const { return quoted((dir_ / name).string()); }
  std::string disparity(const std::string& extra) const {
    return "disparity --left " + path("left.png") + " --right " + path("right.png") +
           " --max-disparity 16 --block 5 " + extra;
  }

  fs::path dir_;
};

TEST_F(CmdImageOutputs, PatternRefusesAnExistingPngItDidNotWrite) {
  // A real PNG of the user's (here: one this test wrote by another name and renamed).
  fs::copy_file(dir_ / "left.png", dir_ / "photo.png");
  const std::string before = bytes_of(dir_ / "photo.png");
  const RunResult refused = run("pattern --seed 7 --out " + path("photo.png"));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.err.find("photo.png"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("--force"), std::string::npos) << refused.err;
  EXPECT_EQ(bytes_of(dir_ / "photo.png"), before);

  const RunResult forced = run("pattern --seed 7 --force --out " + path("photo.png"));
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_NE(bytes_of(dir_ / "photo.png"), before);  // seed 7 draws other lines than seed 1
}

TEST_F(CmdImageOutputs, DisparityRefusesForeignImagesForEachImageOutput) {
  for (const std::string option : {"--color", "--depth"}) {
    std::ofstream(dir_ / "mine.png") << "my picture";
    const std::string extra = option == "--depth" ? " --calib " + path("rig.yaml") : "";
    const RunResult r =
        run(disparity("--out " + path("d.pfm") + " " + option + " " + path("mine.png") + extra));
    EXPECT_NE(r.exit_code, 0) << option;
    EXPECT_NE(r.err.find("mine.png"), std::string::npos) << option << ": " << r.err;
    EXPECT_EQ(bytes_of(dir_ / "mine.png"), "my picture") << option;
    EXPECT_FALSE(fs::exists(dir_ / "d.pfm")) << option << ": refused before any work";
  }
}

// The case: `--color L.png` where L.png is --left destroyed the input image.
TEST_F(CmdImageOutputs, DisparityRefusesAnOutputThatIsAnInputEvenWithForce) {
  const std::string left = bytes_of(dir_ / "left.png");
  const std::string right = bytes_of(dir_ / "right.png");
  for (const auto& [output, input] :
       {std::pair<std::string, std::string>{"--color", "--left"}, {"--depth", "--right"}}) {
    const std::string target = input == "--left" ? "left.png" : "right.png";
    const RunResult r = run(disparity("--force --calib " + path("rig.yaml") + " --out " +
                                      path("d.pfm") + " " + output + " " + path(target)));
    EXPECT_NE(r.exit_code, 0) << output;
    EXPECT_NE(r.err.find(output + " "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(input), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "d.pfm")) << output << ": refused before any work";
  }
  // The same file under another name (./sub/../left.png) is the same input.
  fs::create_directories(dir_ / "sub");
  const RunResult dotted =
      run(disparity("--force --out " + path("d.pfm") + " --color " + path("sub/../left.png")));
  EXPECT_NE(dotted.exit_code, 0);
  EXPECT_EQ(bytes_of(dir_ / "left.png"), left);
  EXPECT_EQ(bytes_of(dir_ / "right.png"), right);

  // The same command with an output of its own name runs: the refusal above was the input's.
  const RunResult ok = run(disparity("--out " + path("d.pfm") + " --color " + path("c.png")));
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_TRUE(fs::exists(dir_ / "c.png"));
  // ... and a second run over its own outputs needs --force (images carry no provenance).
  const RunResult again = run(disparity("--out " + path("d.pfm") + " --color " + path("c.png")));
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.err.find("--force"), std::string::npos) << again.err;
}

}  // namespace
