// The pipeline on the first pairs of EuRoC V1_01 (skipped without the shared data), and its
// config loading. Checks counts and their consistency across stages, never timings.
#include <gtest/gtest.h>

#include <fstream>

#include "kestrel/core/error.hpp"
#include "kestrel/pipeline/pipeline.hpp"
#include "test_data.hpp"

namespace kestrel::pipeline {
namespace {

namespace fs = std::filesystem;
constexpr const char* kV101 = "euroc/V1_01_easy_part1";

fs::path write_file(const fs::path& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

std::string error_of(const fs::path& config) {
  try {
    (void)PipelineOptions::load_yaml(config);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// 25 pairs at 20 Hz; the static IMU initialisation shortened to 0.3 s so that most pairs
// reach the filter after it has started.
PipelineOptions short_run(const fs::path& dir, Pace pace) {
  const fs::path fusion = write_file(dir / "fusion.yaml", "static_init_s: 0.3\n");
  const fs::path config =
      write_file(dir / "run.yaml", "input: " + (test::shared_data_dir() / kV101).string() +
                                       "\npace: " + (pace == Pace::kFast ? "fast" : "recorded") +
                                       "\nmax_frames: 25\nfusion_options: fusion.yaml\n");
  return PipelineOptions::load_yaml(config);
}

const StageStats& stage(const PipelineReport& r, const std::string& name) {
  for (const auto& s : r.stages) {
    if (s.name == name) return s;
  }
  throw std::runtime_error("no stage " + name);
}

TEST(PipelineOptions, UnknownKeyNamesFileAndField) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const fs::path f = write_file(dir / "bad.yaml", "input: x\nframe_queue_capacit: 2\n");
  const std::string e = error_of(f);
  EXPECT_NE(e.find(f.string()), std::string::npos) << e;
  EXPECT_NE(e.find("'frame_queue_capacit'"), std::string::npos) << e;
}

TEST(PipelineOptions, BadValuesNameTheirField) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  EXPECT_NE(error_of(write_file(dir / "a.yaml", "input: x\npace: realtime\n")).find("'pace'"),
            std::string::npos);
  EXPECT_NE(error_of(write_file(dir / "b.yaml", "input: x\nfusion_queue_capacity: 0\n"))
                .find("'fusion_queue_capacity'"),
            std::string::npos);
  EXPECT_NE(
      error_of(write_file(dir / "c.yaml", "input: x\ndrop_stale: maybe\n")).find("'drop_stale'"),
      std::string::npos);
  EXPECT_NE(error_of(write_file(dir / "d.yaml", "pace: fast\n")).find("'input'"),
            std::string::npos);
  EXPECT_NE(error_of(write_file(dir / "e.yaml", "input: x\ntracker:\n  no_such_option: 1\n"))
                .find("no_such_option"),
            std::string::npos);
}

TEST(PipelineOptions, RelativePathsAreTakenFromTheConfigFolder) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const PipelineOptions o = PipelineOptions::load_yaml(
      write_file(dir / "ok.yaml", "input: data/seq\npace: recorded\nframe_queue_capacity: 3\n"));
  EXPECT_EQ(o.input, dir / "data/seq");
  EXPECT_EQ(o.pace, Pace::kRecorded);
  EXPECT_TRUE(o.drops());  // recorded pace drops stale frames unless told otherwise
  EXPECT_EQ(o.frame_queue_capacity, 3u);
}

TEST(Pipeline, MissingFolderIsAnInputErrorNamingIt) {
  PipelineOptions o;
  o.input = "/nonexistent/kestrel_euroc_folder";
  try {
    (void)run_pipeline(o);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/kestrel_euroc_folder"), std::string::npos);
  }
}

TEST(Pipeline, FastPaceProcessesEveryPairThroughEveryStage) {
  KESTREL_REQUIRE_DATA(kV101);
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const PipelineReport r = run_pipeline(short_run(dir, Pace::kFast));
  ASSERT_EQ(r.stages.size(), 5u);
  EXPECT_EQ(r.stereo_pairs, 25u);
  EXPECT_FALSE(r.interrupted);
  // Blocking queues: nothing dropped, every pair through every stage.
  for (const char* name : {"depth", "tracker", "fusion"}) {
    EXPECT_EQ(stage(r, name).in, 25u) << name;
    EXPECT_EQ(stage(r, name).dropped, 0u) << name;
    EXPECT_EQ(stage(r, name).processing_ms.size(), 25u) << name;
  }
  EXPECT_EQ(stage(r, "source").out, 25u);
  EXPECT_EQ(stage(r, "depth").out, 25u);
  EXPECT_EQ(stage(r, "tracker").out, 25u);
  EXPECT_EQ(stage(r, "tracker").failed, 0u);  // V1_01 starts standing still
  // IMU up to the last pair at 200 Hz: ~24 intervals of 10 samples, plus the 0.4 s pre-roll
  // (none exists before the first pair in this recording).
  EXPECT_GT(r.imu_samples, 200u);
  // The filter starts after 0.3 s of IMU; the pairs after that give one state each.
  EXPECT_GT(r.states.size(), 10u);
  EXPECT_LT(r.states.size(), 25u);
  EXPECT_EQ(stage(r, "fusion").out, r.states.size());
  EXPECT_EQ(stage(r, "controller").in, r.states.size());
  EXPECT_EQ(r.end_to_end_ms.size(), r.states.size());
  EXPECT_GT(r.fusion_counters.updates_accepted, 5u);
  EXPECT_EQ(r.fusion_counters.measurements_dropped_late, 0u);  // the stage orders its inputs
  for (std::size_t i = 1; i < r.states.size(); ++i) {
    EXPECT_GT(r.states[i].t_ns, r.states[i - 1].t_ns);
  }
  // Latency grows along the chain for the same item; per-item work is non-negative.
  for (const auto& s : r.stages) {
    for (double ms : s.processing_ms) EXPECT_GE(ms, 0.0) << s.name;
    for (double ms : s.latency_ms) EXPECT_GE(ms, 0.0) << s.name;
  }
  // The MAV is standing: the fused position stays within a few centimetres of the first one.
  for (const auto& s : r.states) {
    EXPECT_LT((s.state.p_world - r.states.front().state.p_world).norm(), 0.05);
  }
}

TEST(Pipeline, RecordedPaceWithDropsKeepsItsCountsConsistent) {
  KESTREL_REQUIRE_DATA(kV101);
  const fs::path dir = test::fresh_temp_dir("pipeline");
  PipelineOptions o = short_run(dir, Pace::kRecorded);
  o.frame_queue_capacity = 1;
  const PipelineReport r = run_pipeline(o);
  EXPECT_EQ(r.stereo_pairs, 25u);
  const auto& src = stage(r, "source");
  const auto& depth = stage(r, "depth");
  const auto& tracker = stage(r, "tracker");
  const auto& fusion = stage(r, "fusion");
  const auto& controller = stage(r, "controller");
  // Whatever the machine's speed: every item handed on was either taken or dropped as stale.
  EXPECT_EQ(src.out, depth.in + depth.dropped);
  EXPECT_EQ(depth.out, tracker.in + tracker.dropped);
  EXPECT_LE(fusion.in, tracker.out);
  EXPECT_EQ(fusion.out, controller.in + controller.dropped);
  EXPECT_EQ(controller.in, r.states.size());
  EXPECT_GT(depth.in, 0u);
  EXPECT_GT(tracker.in, 0u);
  EXPECT_GT(fusion.in, 0u);
}

TEST(Pipeline, AStopRequestEndsTheRunCleanly) {
  KESTREL_REQUIRE_DATA(kV101);
  const fs::path dir = test::fresh_temp_dir("pipeline");
  std::atomic<bool> stop{true};  // already set: the source emits nothing, every stage ends
  const PipelineReport r = run_pipeline(short_run(dir, Pace::kRecorded), &stop);
  EXPECT_TRUE(r.interrupted);
  EXPECT_EQ(r.stereo_pairs, 0u);
  for (const auto& s : r.stages) EXPECT_EQ(s.out, 0u) << s.name;

  // A stop from another thread mid-run: the run returns (join) with consistent counts.
  std::atomic<bool> later{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    later = true;
  });
  const PipelineReport r2 = run_pipeline(short_run(dir, Pace::kRecorded), &later);
  stopper.join();
  EXPECT_LE(r2.stereo_pairs, 25u);
  EXPECT_EQ(stage(r2, "source").out, stage(r2, "depth").in + stage(r2, "depth").dropped);
}

}  // namespace
}  // namespace kestrel::pipeline
