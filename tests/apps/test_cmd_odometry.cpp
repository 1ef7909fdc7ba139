// `kestrel odometry` end to end on a small rendered sequence: the trajectory, the SUMMARY
// line, the per-frame log (--frames) and its refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "run_cli.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
using kestrel::test::quoted;
using kestrel::test::RunResult;
using kestrel::test::slurp;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

class CmdOdometry : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(KESTREL_BINARY))
        << KESTREL_BINARY << " not found: build the `kestrel` target first";
    dir_ = kestrel::test::fresh_temp_dir("cmd_odometry");
    kestrel::io::save_camera_yaml(
        dir_ / "small.yaml", kestrel::PinholeCamera({130.0, 130.0, 79.5, 59.5, 160, 120}), "test");
    const RunResult r = kestrel::test::run_kestrel(
        dir_, "render --scene office --trajectory handheld --seed 2 --frames 6 --camera " +
                  quoted((dir_ / "small.yaml").string()) + " --out " +
                  quoted((dir_ / "seq").string()));
    ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunResult odometry(const std::string& extra) const {
    return kestrel::test::run_kestrel(dir_,
                                      "odometry " + quoted((dir_ / "seq").string()) + " --camera " +
                                          quoted((dir_ / "small.yaml").string()) + " " + extra);
  }
  std::string path(const std::string& name) const { return quoted((dir_ / name).string()); }

  fs::path dir_;
};

TEST_F(CmdOdometry, WritesTrajectorySummaryAndPerFrameLog) {
  const RunResult r = odometry("--out " + path("t.txt") + " --frames " + path("frames.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto err_lines = lines_of(r.err);
  ASSERT_FALSE(err_lines.empty());
  EXPECT_EQ(err_lines.back().rfind("SUMMARY frames=6 failures=", 0), 0U) << err_lines.back();
  EXPECT_EQ(kestrel::io::read_tum_trajectory(dir_ / "t.txt").size(), 6U);

  const auto csv = lines_of(slurp(dir_ / "frames.csv"));
  ASSERT_EQ(csv.size(), 2U + 6U);  // provenance, header, one row per frame
  EXPECT_EQ(csv[0], "# written by kestrel odometry");
  EXPECT_EQ(csv[1].rfind("frame,t_ns,ref_t_ns,ok,failure,converged,iterations,sigma,", 0), 0U)
      << csv[1];
  const auto columns = std::count(csv[1].begin(), csv[1].end(), ',');
  for (std::size_t i = 2; i < csv.size(); ++i) {
    EXPECT_EQ(std::count(csv[i].begin(), csv[i].end(), ','), columns) << csv[i];
    EXPECT_EQ(csv[i].rfind(std::to_string(i - 2) + ",", 0), 0U) << csv[i];
  }
  // The rendered motion is smooth: every frame is tracked (column "ok" is 1) ...
  for (std::size_t i = 2; i < csv.size(); ++i) {
    std::vector<std::string> f;
    std::istringstream s(csv[i]);
    for (std::string x; std::getline(s, x, ',');) f.push_back(x);
    ASSERT_GE(f.size(), 5U);
    EXPECT_EQ(f[3], "1") << csv[i];
    EXPECT_EQ(f[4], "") << csv[i];
  }
}

TEST_F(CmdOdometry, RefusesAFramesLogThatIsTheTrajectoryOrAForeignFile) {
  const RunResult same = odometry("--out " + path("same.txt") + " --frames " + path("same.txt"));
  EXPECT_NE(same.exit_code, 0);
  EXPECT_NE(same.err.find("the same file as --out"), std::string::npos) << same.err;

  { std::ofstream(dir_ / "notes.csv") << "my notes\n"; }
  const RunResult foreign = odometry("--out " + path("t2.txt") + " --frames " + path("notes.csv"));
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.err.find("notes.csv"), std::string::npos) << foreign.err;
  EXPECT_EQ(slurp(dir_ / "notes.csv"), "my notes\n");
}

// --depth-scale: the depth PNGs' units per metre. The rendered folder is written in TUM's 5000;
// read as 10000 every depth halves, and so does every translation (the rotations stay).
TEST_F(CmdOdometry, DepthScaleScalesTheTranslations) {
  const RunResult tum = odometry("--out " + path("tum.txt"));
  ASSERT_EQ(tum.exit_code, 0) << tum.err;
  const RunResult half = odometry("--out " + path("half.txt") + " --depth-scale 10000");
  ASSERT_EQ(half.exit_code, 0) << half.err;
  EXPECT_NE(half.err.find("depth: 10000 PNG units per metre"), std::string::npos) << half.err;
  const auto a = kestrel::io::read_tum_trajectory(dir_ / "tum.txt");
  const auto b = kestrel::io::read_tum_trajectory(dir_ / "half.txt");
  ASSERT_EQ(a.size(), b.size());
  double length_a = 0.0, length_b = 0.0, max_rotation_diff = 0.0;
  for (std::size_t i = 1; i < a.size(); ++i) {
    length_a += (a[i].T_world_body.translation() - a[i - 1].T_world_body.translation()).norm();
    length_b += (b[i].T_world_body.translation() - b[i - 1].T_world_body.translation()).norm();
    max_rotation_diff =
        std::max(max_rotation_diff,
                 (a[i].T_world_body.so3().inverse() * b[i].T_world_body.so3()).log().norm());
  }
  ASSERT_GT(length_a, 1e-3);
  EXPECT_NEAR(length_b / length_a, 0.5, 0.05);
  EXPECT_LT(max_rotation_diff, 0.01);  // rad

  const RunResult zero = odometry("--out " + path("z.txt") + " --depth-scale 0");
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.err.find("--depth-scale"), std::string::npos) << zero.err;
  EXPECT_FALSE(fs::exists(dir_ / "z.txt"));
}

// --plot DIR: the evaluation's files (as `kestrel evaluate --plot`) next to the run; refused,
// before any work, without ground truth or over a folder Kestrel did not write.
TEST_F(CmdOdometry, PlotWritesTheEvaluationFilesAndNeedsGroundTruth) {
  // The fixture's 6 frames span 0.17 s: too short for the 1 s RPE windows, an error with --plot.
  const RunResult short_run = odometry("--out " + path("s.txt") + " --plot " + path("plots"));
  EXPECT_NE(short_run.exit_code, 0);
  EXPECT_NE(short_run.err.find("--plot"), std::string::npos) << short_run.err;
  EXPECT_NE(short_run.err.find("RPE"), std::string::npos) << short_run.err;
  EXPECT_TRUE(fs::exists(dir_ / "s.txt"));

  const RunResult render = kestrel::test::run_kestrel(
      dir_, "render --scene office --trajectory handheld --seed 2 --frames 40 --camera " +
                path("small.yaml") + " --out " + path("seq40"));
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const RunResult r = kestrel::test::run_kestrel(
      dir_, "odometry " + path("seq40") + " --camera " + path("small.yaml") + " --out " +
                path("p.txt") + " --plot " + path("plots"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* name :
       {"axis_errors.csv", "rpe.csv", "est_aligned.txt", "rpe.png", "top_view.png", "yaw.png"}) {
    EXPECT_TRUE(fs::exists(dir_ / "plots" / name)) << name;
    EXPECT_NE(r.out.find((dir_ / "plots" / name).string()), std::string::npos) << r.out;
  }
  EXPECT_NE(r.out.find("ate_rmse_m="), std::string::npos) << r.out;

  fs::create_directories(dir_ / "mine");
  { std::ofstream(dir_ / "mine" / "keep.txt") << "mine\n"; }
  const RunResult foreign = odometry("--out " + path("f.txt") + " --plot " + path("mine"));
  EXPECT_NE(foreign.exit_code, 0);
  EXPECT_NE(foreign.err.find("mine"), std::string::npos) << foreign.err;
  EXPECT_EQ(slurp(dir_ / "mine" / "keep.txt"), "mine\n");
  EXPECT_FALSE(fs::exists(dir_ / "f.txt"));

  ASSERT_TRUE(fs::exists(dir_ / "seq" / "groundtruth.txt"));
  fs::remove(dir_ / "seq" / "groundtruth.txt");
  const RunResult no_gt = odometry("--out " + path("n.txt") + " --plot " + path("plots2"));
  EXPECT_NE(no_gt.exit_code, 0);
  EXPECT_NE(no_gt.err.find("--plot"), std::string::npos) << no_gt.err;
  EXPECT_NE(no_gt.err.find("no ground truth"), std::string::npos) << no_gt.err;
  EXPECT_FALSE(fs::exists(dir_ / "plots2"));
  EXPECT_FALSE(fs::exists(dir_ / "n.txt"));
}

}  // namespace
