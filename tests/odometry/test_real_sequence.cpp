// The odometry's accuracy targets on real data: fr1/rpy part 1 (250 frames, fast rotation) with the
// default options, RPE <= 0.035 m/s and <= 1.9 deg/s. Needs the shared data; takes ~1 minute in an
// optimised build, so unoptimised and sanitizer builds skip it unless KESTREL_LONG_TESTS=1.
#include <gtest/gtest.h>

#include <cstdlib>

#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"
#include "kestrel/odometry/direct_tracker.hpp"
#include "test_data.hpp"

namespace kestrel::odometry {
namespace {

bool long_tests_wanted() {
  if (const char* env = std::getenv("KESTREL_LONG_TESTS"); env != nullptr && *env == '1')
    return true;
#if defined(NDEBUG) && !defined(__SANITIZE_ADDRESS__)
  return true;
#else
  return false;
#endif
}

TEST(RealSequence, Freiburg1RpyPart1AccuracyRegression) {
  KESTREL_REQUIRE_DATA("tum/rgbd_dataset_freiburg1_rpy_part1");
  if (!long_tests_wanted()) {
    GTEST_SKIP() << "debug or sanitizer build: set KESTREL_LONG_TESTS=1 to run this regression";
  }
  const io::TumRgbdSequence seq(test::shared_data_dir() / "tum/rgbd_dataset_freiburg1_rpy_part1");
  DirectTracker tracker(*io::camera_preset("fr1"));
  Trajectory est;
  int failures = 0, fallbacks = 0;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const io::RgbdImages im = seq.load(i);
    const TrackResult r = tracker.track(RgbdFrame{im.t_ns, im.bgr, im.depth_m});
    failures += r.ok() ? 0 : 1;
    fallbacks += r.geometric_fallback ? 1 : 0;
    ASSERT_TRUE(r.T_world_cam.translation().allFinite());
    est.push_back({im.t_ns, r.T_world_cam});
  }
  const auto gt = seq.groundtruth();
  ASSERT_TRUE(gt.has_value());
  const eval::Evaluation e = eval::evaluate(*gt, est, eval::EvaluationOptions{});
  RecordProperty("rpe_trans_m_s", std::to_string(e.rpe.trans_rmse_m_s()));
  RecordProperty("rpe_rot_deg_s", std::to_string(e.rpe.rot_rmse_deg_s()));
  std::cout << "fr1/rpy part1: RPE " << e.rpe.trans_rmse_m_s() << " m/s, " << e.rpe.rot_rmse_deg_s()
            << " deg/s, ATE " << e.ate.stats_m.rmse << " m, failures " << failures
            << ", geometric fallbacks " << fallbacks << "\n";
  // Targets: RPE <= 0.035 m/s and <= 1.9 deg/s. Measured: 0.0266 m/s,
  // 1.766 deg/s, ATE 0.0291 m, 0 failures, 50 geometric fallbacks (2.063 deg/s before the
  // fallback's rotation from the previous frame; 3.14 deg/s and 18 failures before the fallback).
  EXPECT_LE(e.rpe.trans_rmse_m_s(), 0.035);
  EXPECT_LE(e.rpe.rot_rmse_deg_s(), 1.9);
  EXPECT_EQ(failures, 0);
  EXPECT_LE(e.ate.stats_m.rmse, 0.035);
}

}  // namespace
}  // namespace kestrel::odometry
