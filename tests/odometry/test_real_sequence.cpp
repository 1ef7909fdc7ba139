// The odometry's accuracy targets on the two real development sequences, with the default
// options (issue 26): fr1/rpy part 1 (250 frames, fast rotation, fr1 Kinect) RPE <= 0.025 m/s and
// <= 1.8 deg/s; fr3/teddy part 1 (100 frames, close range, fr3 Xtion) at most the best peer's
// figures (OpenCV RgbdOdometry, deterministic: scripts/bench_odometry.sh); 0 failures on both.
// Needs the shared data; ~1 minute in an optimised build, so unoptimised and sanitizer builds
// skip it unless KESTREL_LONG_TESTS=1. Measured figures: docs/odometry.md.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

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

struct SequenceRun {
  eval::Evaluation e;
  int failures = 0, fallbacks = 0;
};

// The default tracker over a TUM folder of the shared data, evaluated against its ground truth.
SequenceRun track_sequence(const std::string& folder, const char* camera) {
  const io::TumRgbdSequence seq(test::shared_data_dir() / folder);
  DirectTracker tracker(*io::camera_preset(camera));
  Trajectory est;
  SequenceRun run;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const io::RgbdImages im = seq.load(i);
    const TrackResult r = tracker.track(RgbdFrame{im.t_ns, im.bgr, im.depth_m});
    run.failures += r.ok() ? 0 : 1;
    run.fallbacks += r.geometric_fallback ? 1 : 0;
    EXPECT_TRUE(r.T_world_cam.translation().allFinite()) << folder << " frame " << i;
    est.push_back({im.t_ns, r.T_world_cam});
  }
  const auto gt = seq.groundtruth();
  EXPECT_TRUE(gt.has_value()) << folder;
  if (gt) run.e = eval::evaluate(*gt, est, eval::EvaluationOptions{});
  ::testing::Test::RecordProperty("rpe_trans_m_s", std::to_string(run.e.rpe.trans_rmse_m_s()));
  ::testing::Test::RecordProperty("rpe_rot_deg_s", std::to_string(run.e.rpe.rot_rmse_deg_s()));
  std::cout << folder << ": RPE " << run.e.rpe.trans_rmse_m_s() << " m/s, "
            << run.e.rpe.rot_rmse_deg_s() << " deg/s, ATE " << run.e.ate.stats_m.rmse
            << " m, failures " << run.failures << ", geometric fallbacks " << run.fallbacks << "\n";
  return run;
}

// Bounds of a sequence's regression: RPE m/s and deg/s, ATE m, and no failed frame.
struct AccuracyBounds {
  double rpe_m_s = 0.0, rpe_deg_s = 0.0, ate_m = 0.0;
};

void expect_within(const SequenceRun& run, const AccuracyBounds& bounds) {
  EXPECT_LE(run.e.rpe.trans_rmse_m_s(), bounds.rpe_m_s);
  EXPECT_LE(run.e.rpe.rot_rmse_deg_s(), bounds.rpe_deg_s);
  EXPECT_LE(run.e.ate.stats_m.rmse, bounds.ate_m);
  EXPECT_EQ(run.failures, 0);
}

TEST(RealSequence, Freiburg1RpyPart1AccuracyRegression) {
  KESTREL_REQUIRE_DATA("tum/rgbd_dataset_freiburg1_rpy_part1");
  if (!long_tests_wanted()) {
    GTEST_SKIP() << "debug or sanitizer build: set KESTREL_LONG_TESTS=1 to run this regression";
  }
  // Issue 26's targets; ATE also below the best peer's (RgbdICPOdometry 0.0441 m, 0.0444 m/s,
  // 2.036 deg/s).
  expect_within(track_sequence("tum/rgbd_dataset_freiburg1_rpy_part1", "fr1"),
                {.rpe_m_s = 0.025, .rpe_deg_s = 1.8, .ate_m = 0.0441});
}

TEST(RealSequence, Freiburg3TeddyPart1AccuracyRegression) {
  KESTREL_REQUIRE_DATA("tum/rgbd_dataset_freiburg3_teddy_part1");
  if (!long_tests_wanted()) {
    GTEST_SKIP() << "debug or sanitizer build: set KESTREL_LONG_TESTS=1 to run this regression";
  }
  // At most the best peer's figures on this sequence (RgbdOdometry: ATE 0.0109 m, RPE 0.0172
  // m/s, 1.214 deg/s).
  expect_within(track_sequence("tum/rgbd_dataset_freiburg3_teddy_part1", "fr3"),
                {.rpe_m_s = 0.0172, .rpe_deg_s = 1.214, .ate_m = 0.0109});
}

}  // namespace
}  // namespace kestrel::odometry
