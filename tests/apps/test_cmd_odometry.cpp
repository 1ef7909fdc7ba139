// `kestrel odometry` end to end on a small rendered sequence: the trajectory, the SUMMARY
// line, the per-frame log (--frames) and its refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
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

  RunResult odometry(const std::string& extra) const { return odometry_with("small.yaml", extra); }
  RunResult odometry_with(const std::string& camera, const std::string& extra) const {
    return kestrel::test::run_kestrel(dir_, "odometry " + quoted((dir_ / "seq").string()) +
                                                " --camera " + quoted((dir_ / camera).string()) +
                                                " " + extra);
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

// Without --camera the folder's own camera.yaml is the camera (`kestrel render` writes the
// distortion-free model it rendered with; the freiburgN preset of a rendered fr1 folder would
// add a lens distortion the images do not have). With neither the file nor a freiburgN name the
// run stops before any work and says what to give.
TEST_F(CmdOdometry, TakesTheFoldersOwnCameraFileByDefault) {
  const RunResult named = odometry("--out " + path("named.txt"));
  ASSERT_EQ(named.exit_code, 0) << named.err;
  const RunResult own =
      kestrel::test::run_kestrel(dir_, "odometry " + path("seq") + " --out " + path("own.txt"));
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_NE(own.err.find("camera " + (dir_ / "seq" / "camera.yaml").string()), std::string::npos)
      << own.err;
  const auto a = kestrel::io::read_tum_trajectory(dir_ / "named.txt");
  const auto b = kestrel::io::read_tum_trajectory(dir_ / "own.txt");
  ASSERT_EQ(a.size(), 6U);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].t_ns, b[i].t_ns);
    EXPECT_LT((a[i].T_world_body.inverse() * b[i].T_world_body).log().norm(), 1e-12) << i;
  }

  // A named camera that is not the folder's own: the run goes on, with a warning naming both.
  kestrel::io::save_camera_yaml(
      dir_ / "distorted.yaml",
      kestrel::PinholeCamera({130.0, 130.0, 79.5, 59.5, 160, 120}, {0.1, 0.0, 0.0, 0.0, 0.0}),
      "test");
  const RunResult other = odometry_with("distorted.yaml", "--out " + path("other.txt"));
  ASSERT_EQ(other.exit_code, 0) << other.err;
  EXPECT_NE(other.err.find("warning: --camera"), std::string::npos) << other.err;
  EXPECT_NE(other.err.find((dir_ / "seq" / "camera.yaml").string()), std::string::npos)
      << other.err;
  EXPECT_EQ(named.err.find("warning: --camera"), std::string::npos) << named.err;

  fs::remove(dir_ / "seq" / "camera.yaml");
  const RunResult none =
      kestrel::test::run_kestrel(dir_, "odometry " + path("seq") + " --out " + path("none.txt"));
  EXPECT_NE(none.exit_code, 0);
  EXPECT_NE(none.err.find("camera.yaml"), std::string::npos) << none.err;
  EXPECT_NE(none.err.find("--camera"), std::string::npos) << none.err;
  EXPECT_FALSE(fs::exists(dir_ / "none.txt"));
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

// The camera file's time_offset_s: a frame stamped t was exposed at t + offset; the trajectory
// and the per-frame log carry the exposure times, the poses are those of the run without it.
TEST_F(CmdOdometry, CameraTimeOffsetMovesTheStampsNotThePoses) {
  const RunResult plain = odometry("--out " + path("plain.txt") + " --frames " + path("p.csv"));
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  { std::ofstream(dir_ / "small.yaml", std::ios::app) << "  time_offset_s: -0.0125\n"; }
  const RunResult moved = odometry("--out " + path("moved.txt") + " --frames " + path("m.csv"));
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  EXPECT_NE(moved.err.find("camera time offset: -0.0125 s"), std::string::npos) << moved.err;
  const auto a = kestrel::io::read_tum_trajectory(dir_ / "plain.txt");
  const auto b = kestrel::io::read_tum_trajectory(dir_ / "moved.txt");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(b[i].t_ns, a[i].t_ns - 12'500'000) << "pose " << i;
    EXPECT_EQ(b[i].T_world_body.matrix(), a[i].T_world_body.matrix()) << "pose " << i;
  }
  // The log's t_ns column (the second) moves alike.
  const auto plain_log = lines_of(slurp(dir_ / "p.csv"));
  const auto moved_log = lines_of(slurp(dir_ / "m.csv"));
  ASSERT_EQ(plain_log.size(), moved_log.size());
  const auto t_of = [](const std::string& row) {
    const auto first = row.find(',');
    return std::stoll(row.substr(first + 1, row.find(',', first + 1) - first - 1));
  };
  for (std::size_t i = 2; i < plain_log.size(); ++i) {
    EXPECT_EQ(t_of(moved_log[i]), t_of(plain_log[i]) - 12'500'000) << moved_log[i];
  }
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

// A copy of the rendered sequence whose rgb images can be spoilt, in the order of rgb.txt.
class CmdOdometryBadFrames : public CmdOdometry {
 protected:
  void SetUp() override {
    CmdOdometry::SetUp();
    if (HasFatalFailure()) return;
    fs::copy(dir_ / "seq", dir_ / "bad", fs::copy_options::recursive);
    for (const auto& entry : fs::directory_iterator(dir_ / "bad" / "rgb"))
      rgb_.push_back(entry.path());
    std::sort(rgb_.begin(), rgb_.end());  // the names are the time stamps
    ASSERT_EQ(rgb_.size(), 6U);
  }
  void spoil(std::size_t frame) const { std::ofstream(rgb_[frame]) << "not a PNG any more"; }
  RunResult odometry_bad(const std::string& extra) const {
    return kestrel::test::run_kestrel(dir_,
                                      "odometry " + quoted((dir_ / "bad").string()) + " --camera " +
                                          quoted((dir_ / "small.yaml").string()) + " " + extra);
  }
  std::vector<fs::path> rgb_;
};

// One unreadable frame mid-sequence: skipped, counted and named; every other frame is tracked
// and written. --strict stops there instead, with the frames before it written.
TEST_F(CmdOdometryBadFrames, AnUnreadableFrameIsSkippedAndCountedOrStopsWithStrict) {
  spoil(3);
  const RunResult r = odometry_bad("--out " + path("t.txt") + " --frames " + path("f.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("skipped unreadable frame 3"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(rgb_[3].filename().string()), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("1 unreadable frame skipped"), std::string::npos) << r.out;
  EXPECT_EQ(kestrel::io::read_tum_trajectory(dir_ / "t.txt").size(), 5U);
  const auto csv = lines_of(slurp(dir_ / "f.csv"));
  ASSERT_EQ(csv.size(), 2U + 5U);
  EXPECT_EQ(csv[5].rfind("4,", 0), 0U) << "frame 3 has no row: " << csv[5];

  const RunResult strict =
      odometry_bad("--strict --out " + path("s.txt") + " --frames " + path("s.csv"));
  EXPECT_NE(strict.exit_code, 0);
  EXPECT_NE(strict.err.find(rgb_[3].filename().string()), std::string::npos) << strict.err;
  EXPECT_NE(strict.err.find("--strict"), std::string::npos) << strict.err;
  EXPECT_EQ(kestrel::io::read_tum_trajectory(dir_ / "s.txt").size(), 3U);  // frames 0, 1, 2
  EXPECT_EQ(lines_of(slurp(dir_ / "s.csv")).size(), 2U + 3U);
}

TEST_F(CmdOdometryBadFrames, NoFrameReadIsAnError) {
  for (std::size_t i = 0; i < rgb_.size(); ++i) spoil(i);
  const RunResult r = odometry_bad("--out " + path("t.txt"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no frame was tracked"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("6 unreadable frames skipped"), std::string::npos) << r.err;
}

// Depth maps without a single valid depth: every frame is read but none can be tracked. The run
// is an error, and the per-frame log says what was measured: nothing (nan), not overlap 1.
TEST_F(CmdOdometryBadFrames, NoFrameTrackedIsAnErrorAndTheLogHoldsNoInventedRatios) {
  for (const auto& entry : fs::directory_iterator(dir_ / "bad" / "depth")) {
    cv::Mat depth = cv::imread(entry.path().string(), cv::IMREAD_ANYDEPTH);
    ASSERT_FALSE(depth.empty()) << entry.path();
    depth.setTo(0);
    ASSERT_TRUE(cv::imwrite(entry.path().string(), depth));
  }
  const RunResult r = odometry_bad("--out " + path("t.txt") + " --frames " + path("f.csv"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no frame was tracked (6 failures"), std::string::npos) << r.err;
  EXPECT_EQ(kestrel::io::read_tum_trajectory(dir_ / "t.txt").size(), 6U);  // still written
  const auto csv = lines_of(slurp(dir_ / "f.csv"));
  ASSERT_EQ(csv.size(), 2U + 6U);
  std::vector<std::string> header;
  {
    std::istringstream h(csv[1]);
    for (std::string x; std::getline(h, x, ',');) header.push_back(x);
  }
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  for (std::size_t i = 2; i < csv.size(); ++i) {
    std::vector<std::string> f;
    std::istringstream row(csv[i]);
    for (std::string x; std::getline(row, x, ',');) f.push_back(x);
    ASSERT_EQ(f.size(), header.size()) << csv[i];
    EXPECT_EQ(f[column("ok")], "0") << csv[i];
    EXPECT_EQ(f[column("failure")], "too_few_points") << csv[i];
    EXPECT_EQ(f[column("overlap")], "nan") << csv[i];
    EXPECT_EQ(f[column("inlier_ratio")], "nan") << csv[i];
  }
}

// An --out that cannot be written is found before the first frame, not after the last.
// --matcher and --sgm-options belong to --stereo; a bad matcher name is an error naming the
// flag, before any pair is matched.
TEST_F(CmdOdometry, MatcherFlagsNeedStereoAndAKnownName) {
  const RunResult rgbd = odometry("--matcher sgm --out " + path("a.txt"));
  EXPECT_NE(rgbd.exit_code, 0);
  EXPECT_NE(rgbd.err.find("--matcher and --sgm-options need --stereo"), std::string::npos)
      << rgbd.err;
  KESTREL_REQUIRE_DATA("euroc/V1_01_easy_part1");
  const RunResult bad = kestrel::test::run_kestrel(
      dir_, "odometry --stereo " +
                quoted((kestrel::test::shared_data_dir() / "euroc/V1_01_easy_part1").string()) +
                " --matcher sgbm --out " + path("b.txt"));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--matcher: must be sad, census or sgm, got 'sgbm'"), std::string::npos)
      << bad.err;
  EXPECT_EQ(bad.err.find("SUMMARY"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "b.txt"));
}

TEST_F(CmdOdometry, UnwritableOutIsFoundBeforeAnyWork) {
  ASSERT_TRUE(fs::is_directory("/proc/self")) << "needs procfs (which takes no new files)";
  const RunResult r = odometry("--out /proc/self/kestrel_traj.txt --frames " + path("frames.csv"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("/proc/self/kestrel_traj.txt"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("SUMMARY"), std::string::npos) << "frames were tracked first:\n" << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "frames.csv"));
}

}  // namespace
