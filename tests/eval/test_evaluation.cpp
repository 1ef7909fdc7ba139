// A whole evaluation: results, report lines, and the files written for --plot.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "kestrel/core/error.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "synthetic_trajectory.hpp"
#include "test_data.hpp"

namespace kestrel::eval {
namespace {

namespace fs = std::filesystem;
// The synthetic trajectories start at t = 1e9 s (stamps of TUM magnitude).
constexpr TimeNs kStartNs = 1'000'000'000'000'000'000;

struct Pair {
  Trajectory gt, est;
};

/// Ground truth at 100 Hz; an estimate at 30 Hz, moved rigidly and drifting 5 cm/s in x.
Pair synthetic_pair() {
  Pair p;
  p.gt = test::sample_trajectory(1000, kStartNs, 10'000'000);
  p.est = test::sample_trajectory(300, kStartNs + 3'000'000, 33'333'333);
  const SE3 T_est_gt = SE3::exp((Vector6d() << 0.2, 0.1, -0.3, 0.1, 0.2, -0.5).finished());
  for (StampedPose& pose : p.est) {
    const double t = ns_to_s(pose.t_ns - kStartNs);
    pose.T_world_body = T_est_gt * SE3(SO3(), {0.05 * t, 0, 0}) * pose.T_world_body;
  }
  return p;
}

TEST(Evaluation, CombinesAteRpeAndAxes) {
  const Pair p = synthetic_pair();
  const Evaluation e = evaluate(p.gt, p.est, {});
  EXPECT_EQ(e.gt_poses, 1000u);
  EXPECT_EQ(e.est_poses, 300u);
  EXPECT_EQ(e.ate.pairs.size(), 300u);
  EXPECT_EQ(e.axes.size(), e.ate.pairs.size());
  EXPECT_EQ(e.t0_ns, kStartNs);
  EXPECT_GT(e.ate.stats_m.rmse, 0.01);  // drift that alignment cannot remove
  // The est stamps are 3 ms off the gt ones, so each window's gt motion is off by up to
  // 3 ms of motion: near, not exactly, 5 cm/s.
  EXPECT_NEAR(e.rpe.trans_rmse_m_s(), 0.05, 0.005);
}

TEST(Evaluation, SummaryLineHasSixSignificantDigits) {
  Evaluation e;
  e.ate.stats_m.rmse = 0.01347312345;
  e.rpe.delta_s = 2.0;
  e.rpe.trans_m.rmse = 0.04243456;
  e.rpe.rot_rad.rmse = 0.0163100;
  EXPECT_EQ(format_summary_line(e),
            "ate_rmse_m=0.0134731 rpe_trans_m_s=0.0212173 "
            "rpe_rot_deg_s=0.467247");
}

TEST(Evaluation, ReportNamesCountsAndFigures) {
  const Pair p = synthetic_pair();
  const std::string report = format_report(evaluate(p.gt, p.est, {}));
  for (const char* needle : {"1000 ground truth", "300 estimated", "associated pairs: 300",
                             "ATE [m]: rmse", "RPE over 1 s windows", "rotational [deg]"}) {
    EXPECT_NE(report.find(needle), std::string::npos) << needle << "\n" << report;
  }
}

TEST(Evaluation, WritesCsvsAlignedTrajectoryAndFigures) {
  const Pair p = synthetic_pair();
  const Evaluation e = evaluate(p.gt, p.est, {});
  const fs::path dir = test::fresh_temp_dir("evaluation");
  const auto written = write_evaluation_files(dir, p.gt, p.est, e, "evaluate", false);
  std::vector<std::string> names;
  for (const fs::path& path : written) {
    EXPECT_TRUE(fs::exists(path)) << path;
    names.push_back(path.filename().string());
  }
  EXPECT_EQ(names, (std::vector<std::string>{"axis_errors.csv", "rpe.csv", "est_aligned.txt",
                                             "x.png", "y.png", "z.png", "roll.png", "pitch.png",
                                             "yaw.png", "top_view.png", "rpe.png"}));
  const cv::Mat x = cv::imread((dir / "x.png").string());
  EXPECT_EQ(x.cols, 900);
  EXPECT_EQ(x.rows, 640);
  // The aligned estimate lies on the ground truth up to the drift.
  const Trajectory aligned = io::read_trajectory(dir / "est_aligned.txt");
  ASSERT_EQ(aligned.size(), p.est.size());
  EXPECT_NEAR(
      (aligned[150].T_world_body.translation() - p.gt[500].T_world_body.translation()).norm(), 0.0,
      0.2);
  // Re-running the same command over its own files is allowed.
  EXPECT_NO_THROW(write_evaluation_files(dir, p.gt, p.est, e, "evaluate", false));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::eval
