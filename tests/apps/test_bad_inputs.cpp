// Every command against a table of bad inputs, as a hostile but fair user would give them: each
// row must end with its exit code (105/106: refused where parsed; 1: refused with an error), a
// message that names what is wrong, and no input or foreign file changed (every file of the
// workspace is compared byte for byte before and after the row).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "kestrel/io/camera_io.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;

// One bad invocation. In `args`, a word starting with '@' is a path in the workspace and one
// starting with '$' a path under the shared data (the row is skipped where it is absent).
struct BadInput {
  const char* args;
  int exit_code;
  const char* message;  // a part of stderr that says what is wrong
};

const BadInput kTable[] = {
    // odometry
    {"odometry @missing --out @o.txt", 105, "Directory does not exist"},
    {"odometry @seq --camera @cam.yaml --out @notes.txt", 1, "notes.txt: refusing to overwrite"},
    {"odometry @seq --camera @cam.yaml --out @seq/rgb.txt --force", 1,
     "refusing to write over an input"},
    {"odometry @seq --camera @cam.yaml --out @seq/rgb/1.000000.png --force", 1,
     "refusing to write over an input"},
    {"odometry @seq --camera @cam.yaml --out @o.txt --config @garbage.bin", 1, "garbage.bin"},
    {"odometry @seq --camera @garbage.bin --out @o.txt", 1, "garbage.bin"},
    {"odometry @seq --camera @cam.yaml --out @o.txt --depth-scale 0", 105, "--depth-scale"},
    {"odometry @seq --camera @cam.yaml --out @o.txt --depth-scale nan", 105, "--depth-scale"},
    {"odometry --stereo @seq --out @o.txt --max-disparity 0", 105, "--max-disparity"},
    {"odometry --stereo @seq --out @o.txt --block 0", 105, "--block"},
    // evaluate
    {"evaluate --est @garbage.bin --gt @seq/groundtruth.txt", 1, "garbage.bin"},
    {"evaluate --est @empty.txt --gt @seq/groundtruth.txt", 1, "empty.txt: holds no poses"},
    {"evaluate --est @badline.txt --gt @seq/groundtruth.txt", 1, "badline.txt:2"},
    {"evaluate --est @seq/groundtruth.txt --gt @seq/groundtruth.txt --max-diff 1e10", 105,
     "--max-diff"},
    {"evaluate --est @seq/groundtruth.txt --gt @seq/groundtruth.txt --plot @seq --force", 1,
     "folder of inputs"},
    // pattern, disparity, capture
    {"pattern --out @foreign.png", 1, "foreign.png: refusing to overwrite"},
    {"pattern --lines 2000000000 --out @p.png", 105, "--lines"},
    {"disparity --left @foreign.png --right @foreign.png --out @d.pfm --color @foreign.png --force",
     1, "refusing to write over an input"},
    {"capture --decode-file @adir", 105, "directory"},
    // render, fly
    {"render --frames -1 --out @r", 105, "--frames"},
    {"render --duration -1 --out @r", 105, "--duration"},
    {"fly --duration nan --out @f", 105, "--duration"},
    {"fly --duration inf --out @f", 105, "--duration"},
    {"fly --latency -1 --out @f", 105, "--latency"},
    // fuse
    {"fuse --vo @seq/groundtruth.txt --imu @empty.txt "
     "--calib $euroc/V1_01_easy_part1/mav0/imu0/sensor.yaml --out @fu.txt",
     1, "empty.txt: no IMU samples"},
    {"fuse --vo @seq/groundtruth.txt --imu @badline.txt "
     "--calib $euroc/V1_01_easy_part1/mav0/imu0/sensor.yaml --out @fu.txt",
     1, "badline.txt:1"},
    {"fuse --vo @seq/groundtruth.txt --imu $euroc/V1_01_easy_part1/mav0/imu0/data.csv "
     "--calib @garbage.bin --out @fu.txt",
     1, "garbage.bin"},
    // run
    {"run --config @garbage.bin", 1, "garbage.bin"},
    {"run --config @empty.txt", 1, "empty.txt"},
};

// Every regular file under `root` and its bytes.
std::map<std::string, std::string> snapshot(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    files[fs::relative(e.path(), root).string()] = bytes.str();
  }
  return files;
}

class BadInputs : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    scratch_ = kestrel::test::fresh_temp_dir("bad_inputs");
    ws_ = scratch_ / "ws";
    fs::create_directories(ws_ / "adir");
    kestrel::io::save_camera_yaml(
        ws_ / "cam.yaml", kestrel::PinholeCamera({130.0, 130.0, 79.5, 59.5, 160, 120}), "test");
    const RunResult r = kestrel::test::run_kestrel(
        scratch_, "render --scene office --trajectory handheld --seed 2 --frames 4 --camera " +
                      quoted((ws_ / "cam.yaml").string()) + " --out " +
                      quoted((ws_ / "seq").string()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    write(ws_ / "empty.txt", "");
    write(ws_ / "notes.txt", "my notes, not Kestrel's\n");
    write(ws_ / "badline.txt", "0.0 0 0 0 0 0 0 1\nhello world\n");
    std::string garbage;
    for (int i = 0; i < 300; ++i) garbage += static_cast<char>((i * 131 + 7) % 256);
    write(ws_ / "garbage.bin", garbage);
    cv::Mat image(48, 64, CV_8UC1);
    cv::randu(image, 0, 255);
    ASSERT_TRUE(cv::imwrite((ws_ / "foreign.png").string(), image));
  }
  void TearDown() override { fs::remove_all(scratch_); }

  static void write(const fs::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
  }

  // The row's words with '@' and '$' paths resolved and quoted; "" if it needs absent data.
  std::string arguments(const std::string& args) const {
    std::istringstream words(args);
    std::string out;
    for (std::string w; words >> w;) {
      if (w[0] == '@') {
        w = quoted((ws_ / w.substr(1)).string());
      } else if (w[0] == '$') {
        const fs::path p = kestrel::test::shared_data_dir() / w.substr(1);
        if (!fs::exists(p)) return "";
        w = quoted(p.string());
      }
      out += (out.empty() ? "" : " ") + w;
    }
    return out;
  }

  fs::path scratch_, ws_;
};

TEST_F(BadInputs, EveryRowIsRefusedClearlyAndChangesNoFile) {
  const auto before = snapshot(ws_);
  int skipped = 0;
  for (const BadInput& row : kTable) {
    SCOPED_TRACE(std::string("kestrel ") + row.args);
    const std::string args = arguments(row.args);
    if (args.empty()) {
      ++skipped;  // needs the shared data
      continue;
    }
    const RunResult r = kestrel::test::run_kestrel(scratch_, args);
    EXPECT_EQ(r.exit_code, row.exit_code) << r.err;
    EXPECT_NE(r.err.find(row.message), std::string::npos)
        << "stderr does not say \"" << row.message << "\":\n"
        << r.err;
    const auto after = snapshot(ws_);
    for (const auto& [name, bytes] : before) {
      const auto it = after.find(name);
      ASSERT_NE(it, after.end()) << name << " was removed";
      EXPECT_EQ(it->second, bytes) << name << " was changed";
    }
  }
  if (skipped > 0) {
    std::cout << "[ note ] " << skipped << " rows need " << kestrel::test::shared_data_dir()
              << "/euroc and were skipped\n";
  }
}

}  // namespace
