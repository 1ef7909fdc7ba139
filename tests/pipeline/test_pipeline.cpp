// The pipeline on the first pairs of EuRoC V1_01 (skipped without the shared data), and its
// config loading. Checks counts and their consistency across stages, never timings.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>

#include "config_files.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/pipeline/pipeline.hpp"
#include "pipeline_report.hpp"
#include "test_data.hpp"

namespace kestrel::pipeline {
namespace {

using test::stage;

namespace fs = std::filesystem;
constexpr const char* kV101 = "euroc/V1_01_easy_part1";

// 25 pairs at 20 Hz; the static IMU initialisation shortened to 0.3 s so that most pairs
// reach the filter after it has started.
PipelineOptions short_run(const fs::path& dir, Pace pace) {
  const fs::path fusion = test::write_text(dir / "fusion.yaml", "static_init_s: 0.3\n");
  const fs::path config = test::write_text(
      dir / "run.yaml", "input: " + (test::shared_data_dir() / kV101).string() +
                            "\npace: " + (pace == Pace::kFast ? "fast" : "recorded") +
                            "\nmax_frames: 25\nfusion_options: fusion.yaml\n");
  return PipelineOptions::load_yaml(config);
}

TEST(PipelineOptions, UnknownKeyNamesFileAndField) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const fs::path f = test::write_text(dir / "bad.yaml", "input: x\nframe_queue_capacit: 2\n");
  const std::string e = test::config_error_of(f);
  EXPECT_NE(e.find(f.string()), std::string::npos) << e;
  EXPECT_NE(e.find("'frame_queue_capacit'"), std::string::npos) << e;
}

TEST(PipelineOptions, BadValuesNameTheirField) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  EXPECT_NE(test::config_error_of(test::write_text(dir / "a.yaml", "input: x\npace: realtime\n"))
                .find("'pace'"),
            std::string::npos);
  EXPECT_NE(test::config_error_of(
                test::write_text(dir / "b.yaml", "input: x\nfusion_queue_capacity: 0\n"))
                .find("'fusion_queue_capacity'"),
            std::string::npos);
  EXPECT_NE(test::config_error_of(test::write_text(dir / "c.yaml", "input: x\ndrop_stale: maybe\n"))
                .find("'drop_stale'"),
            std::string::npos);
  EXPECT_NE(test::config_error_of(test::write_text(dir / "d.yaml", "pace: fast\n")).find("'input'"),
            std::string::npos);
  EXPECT_NE(test::config_error_of(
                test::write_text(dir / "e.yaml", "input: x\ntracker:\n  no_such_option: 1\n"))
                .find("no_such_option"),
            std::string::npos);
  const std::string ref =
      test::config_error_of(test::write_text(dir / "f.yaml", "input: x\nvo_reference: last\n"));
  EXPECT_NE(ref.find("'vo_reference'"), std::string::npos) << ref;
  EXPECT_NE(ref.find("keyframe, previous_frame"), std::string::npos) << ref;
}

TEST(PipelineOptions, RelativePathsAreTakenFromTheConfigFolder) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const PipelineOptions o = PipelineOptions::load_yaml(test::write_text(
      dir / "ok.yaml", "input: data/seq\npace: recorded\nframe_queue_capacity: 3\n"));
  EXPECT_EQ(o.input, dir / "data/seq");
  EXPECT_EQ(o.pace, Pace::kRecorded);
  EXPECT_TRUE(o.drops());  // recorded pace drops stale frames unless told otherwise
  EXPECT_EQ(o.frame_queue_capacity, 3u);
  EXPECT_EQ(o.vo_reference, fusion::OdometryReference::kKeyframe);  // the default
  const PipelineOptions p = PipelineOptions::load_yaml(
      test::write_text(dir / "prev.yaml", "input: data/seq\nvo_reference: previous_frame\n"));
  EXPECT_EQ(p.vo_reference, fusion::OdometryReference::kPreviousFrame);
}

TEST(PipelineOptions, MatcherKeySelectsTheStereoMatcher) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  // Unset: the block matcher with matcher_options' cost (what configs written before mean).
  const PipelineOptions unset =
      PipelineOptions::load_yaml(test::write_text(dir / "a.yaml", "input: x\n"));
  EXPECT_FALSE(unset.matcher_kind.has_value());
  EXPECT_NE(unset.describe_matcher().find("cost=sad"), std::string::npos)
      << unset.describe_matcher();
  test::write_text(dir / "block.yaml", "max_disparity: 48\nblock_size: 7\n");
  test::write_text(dir / "sgm.yaml", "paths: 4\np1: 9\n");
  const PipelineOptions sgm = PipelineOptions::load_yaml(test::write_text(
      dir / "b.yaml",
      "input: x\nmatcher: sgm\nmatcher_options: block.yaml\nsgm_options: sgm.yaml\n"));
  ASSERT_TRUE(sgm.matcher_kind.has_value());
  EXPECT_EQ(*sgm.matcher_kind, sensor::StereoMatcherKind::kSgm);
  EXPECT_EQ(sgm.sgm_options_file, dir / "sgm.yaml");  // from the config's folder
  EXPECT_EQ(sgm.sgm.paths, 4);
  EXPECT_EQ(sgm.sgm.p1, 9);
  EXPECT_EQ(sgm.matcher.max_disparity, 48);  // every matcher's range
  const sensor::StereoFrontEndOptions f = sgm.front_end_options();
  EXPECT_EQ(f.kind, sensor::StereoMatcherKind::kSgm);
  EXPECT_EQ(f.sgm.paths, 4);
  EXPECT_EQ(sgm.describe_matcher().rfind("sgm disparity=[0,48) ", 0), 0u) << sgm.describe_matcher();
  EXPECT_NE(sgm.to_yaml().find("\nmatcher: sgm\n"), std::string::npos) << sgm.to_yaml();
  const PipelineOptions census =
      PipelineOptions::load_yaml(test::write_text(dir / "c.yaml", "input: x\nmatcher: census\n"));
  EXPECT_EQ(census.front_end_options().kind, sensor::StereoMatcherKind::kCensus);
  EXPECT_NE(census.describe_matcher().find("cost=census"), std::string::npos);
}

TEST(PipelineOptions, BadMatcherChoicesNameTheFileAndKey) {
  const fs::path dir = test::fresh_temp_dir("pipeline");
  const fs::path unknown = test::write_text(dir / "a.yaml", "input: x\nmatcher: sgbm\n");
  const std::string e = test::config_error_of(unknown);
  EXPECT_EQ(e.rfind(unknown.string() + ": field 'matcher': ", 0), 0u) << e;
  EXPECT_NE(e.find("sad, census or sgm"), std::string::npos) << e;
  test::write_text(dir / "sgm.yaml", "paths: 4\n");
  const fs::path stray = test::write_text(dir / "b.yaml", "input: x\nsgm_options: sgm.yaml\n");
  EXPECT_EQ(test::config_error_of(stray).rfind(
                stray.string() + ": field 'sgm_options': is for matcher: sgm", 0),
            0u)
      << test::config_error_of(stray);
  test::write_text(dir / "census.yaml", "cost: census\n");
  const fs::path contradiction =
      test::write_text(dir / "c.yaml", "input: x\nmatcher: sad\nmatcher_options: census.yaml\n");
  EXPECT_EQ(test::config_error_of(contradiction)
                .rfind(contradiction.string() + ": field 'matcher': sad contradicts", 0),
            0u)
      << test::config_error_of(contradiction);
  // The range is the block matcher's: an SGM file with another one is an error naming it.
  const fs::path range_file = test::write_text(dir / "range.yaml", "max_disparity: 128\n");
  const std::string range = test::config_error_of(
      test::write_text(dir / "d.yaml", "input: x\nmatcher: sgm\nsgm_options: range.yaml\n"));
  EXPECT_EQ(range.rfind(range_file.string() + ": field 'max_disparity': 128 differs", 0), 0u)
      << range;
  // ... the same range is fine, and so is a bad value inside the file, named there.
  test::write_text(dir / "same.yaml", "max_disparity: 64\n");
  EXPECT_NO_THROW(PipelineOptions::load_yaml(
      test::write_text(dir / "e.yaml", "input: x\nmatcher: sgm\nsgm_options: same.yaml\n")));
  const fs::path bad_file = test::write_text(dir / "bad.yaml", "paths: 6\n");
  const std::string bad = test::config_error_of(
      test::write_text(dir / "f.yaml", "input: x\nmatcher: sgm\nsgm_options: bad.yaml\n"));
  EXPECT_NE(bad.find(bad_file.string()), std::string::npos) << bad;
  EXPECT_NE(bad.find("paths must be 4 or 8"), std::string::npos) << bad;
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

// `matcher: sgm` runs the semi-global matcher: the report names it, and its fill on V1_01
// (every pixel gets a disparity, docs/stereo.md) is far above the block matcher's (~72 %).
TEST(Pipeline, MatcherSgmRunsTheSemiGlobalMatcher) {
  KESTREL_REQUIRE_DATA(kV101);
  const fs::path dir = test::fresh_temp_dir("pipeline");
  PipelineOptions o = short_run(dir, Pace::kFast);
  o.max_frames = 5;
  const PipelineReport sad = run_pipeline(o);
  o.matcher_kind = sensor::StereoMatcherKind::kSgm;
  const PipelineReport sgm = run_pipeline(o);
  EXPECT_NE(sad.matcher.find("cost=sad"), std::string::npos) << sad.matcher;
  EXPECT_EQ(sgm.matcher.rfind("sgm ", 0), 0u) << sgm.matcher;
  EXPECT_EQ(stage(sgm, "depth").out, 5u);
  EXPECT_EQ(stage(sgm, "tracker").failed, 0u);
  EXPECT_GT(sgm.mean_disparity_fill, 0.9);
  EXPECT_LT(sad.mean_disparity_fill, 0.85);
  std::cout << "V1_01, 5 pairs: mean fill sad " << 100.0 * sad.mean_disparity_fill << " %, sgm "
            << 100.0 * sgm.mean_disparity_fill << " %\n";
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

// V1_01 part 1 stands still on the floor (the MAV takes off later in the sequence). Holding
// the first fused pose, the position and velocity errors stay near zero, so the controller
// commands its gravity feed-forward: thrust near the weight of the configured vehicle
// (mass_kg 1.2 by default: 11.8 N, throttle ~1420 us), level, no yaw rate, nominal mode.
TEST(Pipeline, ControllerHoldsTheStandingMavAtHoverThrust) {
  KESTREL_REQUIRE_DATA(kV101);
  const fs::path dir = test::fresh_temp_dir("pipeline");
  PipelineOptions o = short_run(dir, Pace::kFast);
  o.controller.R_body_vehicle = parse_vehicle_axes({"+z", "-y", "+x"});  // EuRoC's IMU axes
  const PipelineReport r = run_pipeline(o);
  ASSERT_GT(r.states.size(), 10u);
  EXPECT_FALSE(r.controller_disarmed);
  const control::PwmMapper mapper(o.controller.pwm);
  const double weight = o.controller.controller.mass_kg * control::kGravity;
  std::size_t per_state = 0, flown = 0;
  for (const ControllerRecord& c : r.controller) {
    for (std::size_t ch = 0; ch < 4; ++ch) {
      EXPECT_GE(c.pwm.us[ch], mapper.options().channels[ch].min_us);
      EXPECT_LE(c.pwm.us[ch], mapper.options().channels[ch].max_us);
    }
    if (c.input == ControllerInput::kNoState) continue;
    EXPECT_EQ(c.state_t_ns, r.states[per_state].t_ns);
    ++per_state;
    // A state that spent longer than the watchdog's timeout in the pipeline is not flown: in
    // an optimised build a fast run's states are ~0.1 s old, under the sanitizers (~10x slower)
    // most are older. That rule has its own test (test_controller_stage.cpp); here only the
    // flown states are checked against the physics.
    if (c.input == ControllerInput::kStaleState) continue;
    ASSERT_EQ(c.input, ControllerInput::kState);
    ++flown;
    EXPECT_EQ(c.mode, control::SafetyMode::kNominal);
    EXPECT_FALSE(c.motors_off);
    EXPECT_NEAR(c.command.thrust_N, weight, 0.1 * weight);
    EXPECT_LT(std::abs(c.command.roll_rad), 5.0 * kDegToRad);
    EXPECT_LT(std::abs(c.command.pitch_rad), 5.0 * kDegToRad);
    EXPECT_LT(std::abs(c.command.yaw_rate_rad_s), 5.0 * kDegToRad);
    EXPECT_EQ(c.pwm, mapper.map(c.command));
    EXPECT_NEAR(c.pwm.us[control::PwmChannels::kThrottle],
                mapper.map({0.0, 0.0, 0.0, weight}).us[control::PwmChannels::kThrottle], 40);
    EXPECT_EQ(c.p_ref, r.states.front().state.p_world);  // the first fused pose is held
  }
  EXPECT_EQ(per_state, r.states.size());  // one output per fused state
  if (flown == 0) {
    GTEST_SKIP() << "every fused state was older than the watchdog timeout (a slow build, e.g. "
                    "the sanitizers): the hover commands were not checked";
  }
}

std::vector<std::string> lines_of(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(Pipeline, TheCommandWritesOneControllerRowPerFusedState) {
  KESTREL_REQUIRE_DATA(kV101);
  ASSERT_TRUE(fs::exists(KESTREL_BINARY)) << KESTREL_BINARY << " not found: build `kestrel`";
  const fs::path dir = test::fresh_temp_dir("pipeline");
  (void)short_run(dir, Pace::kFast);  // writes run.yaml and fusion.yaml
  std::ofstream(dir / "run.yaml", std::ios::app) << "controller:\n  vehicle_axes: [+z, -y, +x]\n";
  const std::string cmd = std::string(KESTREL_BINARY) + " run --config " +
                          (dir / "run.yaml").string() + " --out " + (dir / "out").string() + " > " +
                          (dir / "stdout.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const auto trajectory = lines_of(dir / "out" / "trajectory.txt");
  const auto csv = lines_of(dir / "out" / "controller.csv");
  ASSERT_GE(csv.size(), 2u);
  EXPECT_EQ(csv[0], "# written by kestrel run");
  std::string header;
  for (const auto& c : controller_csv_columns()) header += (header.empty() ? "" : ",") + c;
  EXPECT_EQ(csv[1], header);
  std::size_t state_rows = 0;
  for (std::size_t i = 2; i < csv.size(); ++i) {
    std::vector<std::string> cells;
    std::stringstream row(csv[i]);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), controller_csv_columns().size()) << csv[i];
    if (cells[2] != "none") ++state_rows;
    for (std::size_t k = cells.size() - 4; k < cells.size(); ++k) {
      const int us = std::stoi(cells[k]);
      EXPECT_GE(us, 1000) << csv[i];
      EXPECT_LE(us, 2000) << csv[i];
    }
  }
  // The trajectory holds one pose per fused state (after its '#' lines).
  std::size_t poses = 0;
  for (const auto& line : trajectory) poses += !line.empty() && line[0] != '#';
  ASSERT_GT(poses, 10u);
  EXPECT_EQ(state_rows, poses);
  const auto out = lines_of(dir / "stdout.txt");
  bool said = false;
  for (const auto& line : out) said |= line.find("PWM NOT SENT") != std::string::npos;
  EXPECT_TRUE(said) << "the report says that no flight controller is driven";
}

}  // namespace
}  // namespace kestrel::pipeline
