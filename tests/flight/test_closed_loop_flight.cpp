// Short closed-loop flights of the whole pipeline (render -> active stereo -> odometry -> EKF
// -> controller -> PWM -> flight-controller model -> dynamics) at a reduced image size so that
// they run in seconds: a hover, an odometry outage, and the logs `kestrel fly` writes.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "kestrel/flight/flight_report.hpp"
#include "kestrel/flight/flight_simulation.hpp"
#include "kestrel/sim/scenes.hpp"
#include "test_data.hpp"

namespace kestrel::flight {
namespace {

/// The default pipeline with half-size images (188 x 120, the same field of view).
FlightOptions small_options() {
  FlightOptions o;
  o.vision.width = 188;
  o.vision.height = 120;
  o.vision.f_px = 125.0;
  o.vision.matcher.max_disparity = 32;
  o.vision.tracker.pyramid.levels = 4;
  return o;
}

Scenario scenario(const std::string& name) {
  return make_scenario(name, sim::make_scene(make_scenario(name, SE3()).scene).T_world_start());
}

TEST(ClosedLoopFlight, HoversOnTheWholePipeline) {
  FlightSimulation simulation(scenario("hover"), small_options());
  const FlightResult r = simulation.run(6.0);
  EXPECT_FALSE(r.crashed);
  EXPECT_EQ(r.samples.size(), 6u * 200u + 1u);  // 200 Hz, both ends
  EXPECT_EQ(r.counters.frames, 6u * 30u + 1u);
  // Every frame is tracked and nearly every measurement accepted by the filter.
  EXPECT_EQ(r.counters.frames_tracked, r.counters.frames);
  EXPECT_GT(r.counters.fusion.updates_accepted, r.counters.frames * 9 / 10);
  // The issue's hover target (5 cm RMS over 60 s at full size) holds on this short flight.
  EXPECT_LT(r.rms_tracking_m(), 0.05);
  EXPECT_LT(r.rms_estimate_m(), 0.05);
  for (const FlightSample& s : r.samples) {
    EXPECT_EQ(s.mode, control::SafetyMode::kNominal) << "t=" << s.t_s;
    if (s.mode != control::SafetyMode::kNominal) break;
  }
}

// Every odometry measurement of a short hover against the truth the simulation knows: the
// reference is an earlier frame (or the keyframe), the errors are millimetres, and the
// covariance sent with them covers them (error / sigma RMS of order 1, not 10).
TEST(ClosedLoopFlight, OdometryChecksCompareEachMeasurementWithTheTruth) {
  FlightSimulation simulation(scenario("hover"), small_options());
  const FlightResult r = simulation.run(3.0);
  ASSERT_GT(r.odometry_checks.size(), 60u);  // ~30 Hz for 3 s, less the first frame
  Eigen::Vector3d error2 = Eigen::Vector3d::Zero(), normalised2 = Eigen::Vector3d::Zero();
  for (const OdometryCheck& c : r.odometry_checks) {
    EXPECT_LT(c.t_ref_s, c.t_s);
    EXPECT_TRUE((c.sigma_translation.array() > 0.0).all());
    const Eigen::Vector3d e = c.translation_error();
    error2 += e.cwiseAbs2();
    normalised2 += e.cwiseQuotient(c.sigma_translation).cwiseAbs2();
    EXPECT_LT(c.rotation_error_deg.norm(), 0.5);
  }
  const double n = static_cast<double>(r.odometry_checks.size());
  EXPECT_LT((error2 / n).cwiseSqrt().maxCoeff(), 0.005) << "translation error RMS (m)";
  EXPECT_LT((normalised2 / n).cwiseSqrt().maxCoeff(), 3.0) << "error / sigma RMS";
  const std::string summary = odometry_check_summary(r);
  EXPECT_NE(summary.find("translation error RMS"), std::string::npos) << summary;
}

TEST(ClosedLoopFlight, OdometryOutageHoldsOnTheImuAndRecovers) {
  FlightOptions o = small_options();
  o.vo_off_at_s = 2.0;
  o.vo_off_for_s = 2.0;
  FlightSimulation simulation(scenario("hover"), o);
  const FlightResult r = simulation.run(7.0);
  EXPECT_FALSE(r.crashed);
  EXPECT_EQ(r.counters.frames_off, 60u);
  bool held = false;
  for (const FlightSample& s : r.samples) {
    if (s.t_s >= 2.0 && s.t_s < 4.0) {
      EXPECT_FALSE(s.vo_ok) << "t=" << s.t_s;
    }
    held = held || s.mode == control::SafetyMode::kImuHold;
  }
  EXPECT_TRUE(held) << "the supervisor never switched to the IMU hold";
  // One relocalisation, on the first frame after the outage; trusted only if it is right.
  ASSERT_EQ(r.relocalizations.size(), 1u);
  EXPECT_NEAR(r.relocalizations[0].t_s, 4.0, 0.04);
  EXPECT_EQ(r.counters.relocalizations_tried, 1u);
  if (r.relocalizations[0].result.ok()) {
    EXPECT_LT(r.relocalizations[0].translation_error_m, 0.02);
  }
  const FlightSample& last = r.samples.back();
  EXPECT_EQ(last.mode, control::SafetyMode::kNominal);
  EXPECT_TRUE(last.vo_ok);
  // Recovered: at the end the vehicle is back near the reference.
  EXPECT_LT((last.p_true - last.p_ref).norm(), 0.10);
}

// An outage on the square's first leg: the supervisor holds, and the mission's clock eases to
// a stop with it (the hold flies the braking mission), so that the reference never steps: not
// when the hold starts, nor when it hands back (with the clock running on the reference would
// jump ~0.4 m further along the leg there). Largest step of the reference between two control
// steps, and its largest distance from where the hold started.
TEST(ClosedLoopFlight, MissionBrakesInTheHoldAndResumesWhereItStopped) {
  struct Steps {
    double largest_step_m = 0.0;
    double hold_travel_m = 0.0;
  };
  auto reference_steps = [](bool pause) {
    FlightOptions o = small_options();
    o.vo_off_at_s = 4.0;  // cruising along the first leg (it starts at 3 s)
    o.vo_off_for_s = 1.0;
    o.pause_mission_in_hold = pause;
    FlightSimulation simulation(scenario("square"), o);
    const FlightResult r = simulation.run(7.0);
    EXPECT_FALSE(r.crashed);
    Steps steps;
    std::optional<Eigen::Vector3d> hold_start;
    bool resumed = false;
    for (std::size_t i = 1; i < r.samples.size(); ++i) {
      const FlightSample& prev = r.samples[i - 1];
      const FlightSample& s = r.samples[i];
      steps.largest_step_m = std::max(steps.largest_step_m, (s.p_ref - prev.p_ref).norm());
      if (prev.mode == control::SafetyMode::kNominal && s.mode != control::SafetyMode::kNominal) {
        hold_start = prev.p_ref;
      }
      if (hold_start && s.mode != control::SafetyMode::kNominal) {
        steps.hold_travel_m = std::max(steps.hold_travel_m, (s.p_ref - *hold_start).norm());
      }
      resumed = resumed || (hold_start && s.mode == control::SafetyMode::kNominal);
    }
    EXPECT_TRUE(resumed) << "no hold and return to the mission";
    return steps;
  };
  const Steps eased = reference_steps(true);
  // 0.5 m/s over one 5 ms control step is 2.5 mm.
  EXPECT_LT(eased.largest_step_m, 0.004);
  // Braking from 0.5 m/s stops 2 T = 0.5 s of mission time (0.25 m) further along the leg.
  EXPECT_NEAR(eased.hold_travel_m, 0.25, 0.03);
  EXPECT_GT(reference_steps(false).largest_step_m, 0.2);
}

// The realistic world (wind, a heavier and weaker vehicle than the controller assumes, the
// in-flight IMU noise, an unknown camera-IMU offset, dropped, blurred, rolling-shutter frames
// with jittered latency) on a short hover: it flies, loosely; docs/flight.md has the figures.
TEST(ClosedLoopFlight, HoversInTheRealisticWorld) {
  FlightOptions o = small_options();
  o.world = sim::WorldOptions::realistic();
  FlightSimulation simulation(scenario("hover"), o);
  EXPECT_TRUE(simulation.options().fusion.estimate_time_offset);
  EXPECT_EQ(simulation.options().fusion.time_offset_s, 0.0);  // its prior, not the truth
  EXPECT_GE(simulation.options().fusion.reorder_window_s, 0.040 + 0.010 + 0.010);
  const FlightResult r = simulation.run(6.0);
  EXPECT_FALSE(r.crashed);
  const std::size_t taken = r.counters.frames + r.counters.frames_dropped;
  EXPECT_EQ(taken, 6u * 30u + 1u);
  EXPECT_GT(r.counters.frames_dropped, 0u);
  EXPECT_LT(r.counters.frames_dropped, taken / 5);
  EXPECT_GT(r.counters.fusion.updates_accepted, r.counters.frames * 7 / 10);
  EXPECT_LT(r.rms_tracking_m(), 0.15);
  EXPECT_LT(r.rms_estimate_m(), 0.10);
}

TEST(ClosedLoopFlight, TakesOffFromTheFloorAndLandsGently) {
  // The mission's take-off and landing without the waypoints between: up 0.7 m and down.
  Scenario s = scenario("mission");
  const Eigen::Vector3d ground = s.start_world;
  const Eigen::Vector3d up = ground + Eigen::Vector3d(0.0, 0.0, 0.7);
  s.path = WaypointPath({ground, up, ground}, 0.0, 0.5, 0.5, 1.0);
  const double end = s.path.end_time_s();
  FlightSimulation simulation(s, small_options());
  const FlightResult r = simulation.run(end + 2.0);
  EXPECT_FALSE(r.crashed);
  double top = 0.0;
  for (const FlightSample& f : r.samples) top = std::max(top, f.p_true.z());
  EXPECT_GT(top, up.z() - 0.1);
  // Standing on the floor again, not hopping: the last second stays on the ground height.
  for (const FlightSample& f : r.samples) {
    if (f.t_s > end + 1.0) {
      EXPECT_NEAR(f.p_true.z(), ground.z(), 0.01) << "t=" << f.t_s;
    }
  }
}

TEST(FlightReport, LogHasTheIssueColumnsAndOneRowPerControlStep) {
  FlightSimulation simulation(scenario("hover"), small_options());
  const FlightResult r = simulation.run(0.5);
  const auto dir = test::fresh_temp_dir("flight_report");
  const auto files = write_flight_logs(dir, r);
  ASSERT_EQ(files.size(), 4u);
  std::ifstream estimator(dir / "estimator.csv");
  std::string header;
  ASSERT_TRUE(std::getline(estimator, header));
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), 24) << header;
  // The filter's sigmas (the last 9 columns): "nan" (unknown) only before its first output, then
  // finite and non-negative.
  std::string row;
  bool filter_started = false;
  int rows_with_sigma = 0;
  while (std::getline(estimator, row)) {
    std::vector<std::string> cells;
    std::stringstream cells_in(row);
    for (std::string c; std::getline(cells_in, c, ',');) cells.push_back(c);
    ASSERT_EQ(cells.size(), 25u) << row;
    for (std::size_t k = 16; k < 25; ++k) {
      if (cells[k] == "nan") {
        EXPECT_FALSE(filter_started) << "a sigma unknown after the filter's first output: " << row;
        continue;
      }
      filter_started = true;
      EXPECT_GE(std::stod(cells[k]), 0.0) << row;
    }
    rows_with_sigma += filter_started ? 1 : 0;
  }
  EXPECT_GT(rows_with_sigma, 50) << "the filter output sigmas for most of the 0.5 s";
  std::ifstream log(dir / "log.csv");
  std::string line;
  ASSERT_TRUE(std::getline(log, line));
  EXPECT_EQ(line, "t,x_true,y_true,z_true,x_ref,y_ref,z_ref,x_est,y_est,z_est,vo_ok");
  std::size_t rows = 0;
  while (std::getline(log, line)) {
    ++rows;
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), 10) << line;
  }
  EXPECT_EQ(rows, r.samples.size());
  // odometry.csv: one row per odometry measurement against the truth, 20 columns.
  std::ifstream odometry(dir / "odometry.csv");
  ASSERT_TRUE(std::getline(odometry, line));
  EXPECT_EQ(line.rfind("t,t_ref,tx_true,", 0), 0u) << line;
  EXPECT_EQ(std::count(line.begin(), line.end(), ','), 19) << line;
  std::size_t odometry_rows = 0;
  while (std::getline(odometry, line)) {
    ++odometry_rows;
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), 19) << line;
  }
  EXPECT_EQ(odometry_rows, r.odometry_checks.size());
  const auto plots = write_flight_plots(dir, r);
  for (const auto& p : plots) EXPECT_GT(std::filesystem::file_size(p), 1000u) << p;
  const std::string summary = flight_summary_line(r);
  EXPECT_EQ(summary.rfind("rms_tracking_m=", 0), 0u) << summary;
  EXPECT_NE(summary.find(" crashed=0"), std::string::npos) << summary;
  std::filesystem::remove_all(dir);
}

// The flight's tracker is the library's (chosen on Kinect-like RGB-D) without its 6 m depth
// limit: the stereo head's depth is taken as far as its matcher gives it (docs/flight.md).
TEST(FlightOptions, TrackerTakesEveryDepthTheStereoHeadGives) {
  const odometry::DirectTrackerOptions flight = FlightOptions().vision.tracker;
  EXPECT_EQ(flight.selection.max_depth_m, std::numeric_limits<double>::infinity());
  EXPECT_EQ(flight.to_yaml(), odometry::stereo_head_tracker_options().to_yaml());
  odometry::DirectTrackerOptions library;
  library.selection.max_depth_m = flight.selection.max_depth_m;
  EXPECT_EQ(flight.to_yaml(), library.to_yaml()) << "only the depth limit differs";
  EXPECT_NE(FlightOptions().vision.describe().find("odometry depth 0.2-inf m"), std::string::npos)
      << FlightOptions().vision.describe();
}

TEST(FlightOptions, RejectsInconsistentRates) {
  FlightOptions o;
  o.control_rate_hz = 300.0;  // 1000 / 300 is not whole
  EXPECT_THROW(FlightSimulation(scenario("hover"), o), std::invalid_argument);
  o = FlightOptions();
  o.vision_latency_s = -0.1;
  EXPECT_THROW(FlightSimulation(scenario("hover"), o), std::invalid_argument);
  o = FlightOptions();
  o.vision.baseline_m = 0.0;
  EXPECT_THROW(FlightSimulation(scenario("hover"), o), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::flight
