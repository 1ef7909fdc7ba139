// Scenario paths: where they start and end, and that their velocity and acceleration
// feed-forward are the derivatives of their position (what the controller relies on).
#include <gtest/gtest.h>

#include <algorithm>
#include <variant>

#include "kestrel/core/error.hpp"
#include "kestrel/flight/scenario.hpp"
#include "kestrel/sim/scenes.hpp"

namespace kestrel::flight {
namespace {

const SE3 kStart(SO3(), Eigen::Vector3d(-0.5, 0.0, 1.2));

TEST(WaypointPath, HoldsTheFirstWaypointThenStopsAtTheLast) {
  const WaypointPath path({{0, 0, 1}, {2, 0, 1}, {2, 1, 1}}, 0.3, 0.5, 0.5, 3.0);
  EXPECT_TRUE(path.at(0.0).p_world.isApprox(Eigen::Vector3d(0, 0, 1)));
  EXPECT_TRUE(path.at(2.99).p_world.isApprox(Eigen::Vector3d(0, 0, 1)));
  EXPECT_DOUBLE_EQ(path.at(1.0).yaw_rad, 0.3);
  // 2 m leg: 1 s ramp (0.25 m), 3 s cruise, 1 s ramp = 5 s; 1 m leg: 1 + 1 + 1 = 3 s.
  EXPECT_NEAR(path.end_time_s(), 3.0 + 5.0 + 3.0, 1e-12);
  EXPECT_TRUE(path.at(8.0).p_world.isApprox(Eigen::Vector3d(2, 0, 1), 1e-12));
  EXPECT_TRUE(path.at(100.0).p_world.isApprox(Eigen::Vector3d(2, 1, 1)));
  EXPECT_LT(path.at(100.0).v_world.norm(), 1e-12);
}

TEST(WaypointPath, FeedForwardIsTheDerivativeOfThePosition) {
  const WaypointPath path({{0, 0, 1}, {2, 0, 1}, {2, 0.3, 1.5}, {0, 0, 1}}, 0.0, 0.5, 0.5, 1.0);
  const double h = 1e-5;
  for (double t = 0.0; t < path.end_time_s() + 1.0; t += 0.0173) {
    const auto r = path.at(t);
    const Eigen::Vector3d v_num = (path.at(t + h).p_world - path.at(t - h).p_world) / (2 * h);
    EXPECT_LT((v_num - r.v_world).norm(), 1e-5) << "t=" << t;
    EXPECT_LE(r.v_world.norm(), 0.5 + 1e-12) << "t=" << t;
    EXPECT_LE(r.a_world.norm(), 0.5 + 1e-12);
  }
  // The acceleration jumps at the ramp ends, so it is checked by integration: the integral of
  // the acceleration feed-forward gives the velocity back.
  Eigen::Vector3d v = path.at(0.0).v_world;
  const double dt = 1e-4;
  for (int k = 0; k * dt < path.end_time_s() + 1.0; ++k) {
    const double t = k * dt;
    v += 0.5 * (path.at(t).a_world + path.at(t + dt).a_world) * dt;
    if (k % 997 == 0) {
      EXPECT_LT((v - path.at(t + dt).v_world).norm(), 1e-3) << "t=" << t;
    }
  }
}

TEST(WaypointPath, ShortLegsBecomeTriangles) {
  const WaypointPath path({{0, 0, 0}, {0.1, 0, 0}}, 0.0, 0.5, 0.5, 0.0);
  const double peak = std::sqrt(0.5 * 0.1);  // sqrt(a L) < cruise
  EXPECT_NEAR(path.end_time_s(), 2.0 * peak / 0.5, 1e-12);
  EXPECT_NEAR(path.at(peak / 0.5).v_world.norm(), peak, 1e-9);
}

TEST(WaypointPath, RejectsInvalidProfiles) {
  EXPECT_THROW(WaypointPath({}, 0.0, 0.5, 0.5, 0.0), std::invalid_argument);
  EXPECT_THROW(WaypointPath({{0, 0, 0}}, 0.0, 0.0, 0.5, 0.0), std::invalid_argument);
  EXPECT_THROW(WaypointPath({{0, 0, 0}}, 0.0, 0.5, -1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(WaypointPath({{0, 0, 0}}, 0.0, 0.5, 0.5, -1.0), std::invalid_argument);
}

TEST(Scenario, EveryCatalogueEntryBuildsAndStartsAtTheStartPose) {
  for (const auto& entry : scenario_catalogue()) {
    const Scenario s = make_scenario(entry.name, kStart);
    EXPECT_EQ(s.name, entry.name);
    EXPECT_TRUE(s.path.at(0.0).p_world.isApprox(s.start_world)) << s.name;
    EXPECT_GE(s.default_duration_s, s.path.end_time_s()) << s.name;
    // In the air at the start pose, or standing on the floor below it.
    Eigen::Vector3d expected = kStart.translation();
    if (s.starts_on_ground) expected.z() = kStandingHeightM;
    EXPECT_TRUE(s.start_world.isApprox(expected)) << s.name;
  }
  const Scenario square = make_scenario("square", kStart);
  // Four 2 m sides (plus the two half sides from and back to the start on the centre line).
  double length = 0.0;
  const auto& w = square.path.waypoints();
  for (std::size_t i = 1; i < w.size(); ++i) length += (w[i] - w[i - 1]).norm();
  EXPECT_NEAR(length, 8.0, 1e-12);
}

/// Largest |f(t + h) - f(t)| over the path's duration: a jump shows as a step of the size of
/// the jump, a continuous function as O(h).
template <typename F>
double largest_step(const ReferencePath& path, double h, F f) {
  double worst = 0.0;
  for (double t = -0.5; t < path.end_time_s() + 0.5; t += h) {
    worst = std::max(worst, (f(path.at(t + h)) - f(path.at(t))).norm());
  }
  return worst;
}

TEST(FigureEight, PeakSpeedClosedPathAndContinuousFeedForward) {
  const Scenario s = make_scenario("figure8", kStart);
  const ReferencePath& path = s.path;
  const double end = path.end_time_s();
  // Starts and ends at rest on the start pose.
  for (const double t : {0.0, end, end + 5.0}) {
    const auto r = path.at(t);
    EXPECT_LT((r.p_world - kStart.translation()).norm(), 1e-9) << "t=" << t;
    EXPECT_LT(r.v_world.norm(), 1e-9) << "t=" << t;
    EXPECT_LT(r.a_world.norm(), 1e-9) << "t=" << t;
  }
  double peak = 0.0;
  for (double t = 0.0; t <= end; t += 1e-3) peak = std::max(peak, path.at(t).v_world.norm());
  EXPECT_NEAR(peak, 1.5, 0.02 * 1.5);
  // Continuous velocity and acceleration: steps of 1 ms change them by O(1 ms), also across
  // the ramps' ends.
  const double h = 1e-3;
  EXPECT_LT(largest_step(path, h, [](const auto& r) { return r.v_world; }), 5.0 * h);
  EXPECT_LT(largest_step(path, h, [](const auto& r) { return r.a_world; }), 20.0 * h);
  // The feed-forward is the derivative of the position and of the velocity.
  const double d = 1e-5;
  for (double t = 0.0; t < end + 1.0; t += 0.0131) {
    const auto r = path.at(t);
    const Eigen::Vector3d v_num = (path.at(t + d).p_world - path.at(t - d).p_world) / (2 * d);
    const Eigen::Vector3d a_num = (path.at(t + d).v_world - path.at(t - d).v_world) / (2 * d);
    EXPECT_LT((v_num - r.v_world).norm(), 1e-6) << "t=" << t;
    EXPECT_LT((a_num - r.a_world).norm(), 1e-5) << "t=" << t;
    EXPECT_DOUBLE_EQ(r.yaw_rad, 0.0);
  }
  // Two lobes: it reaches both ends of its long axis (y) on each side of the start.
  double y_lo = 0.0, y_hi = 0.0;
  for (double t = 0.0; t <= end; t += 1e-2) {
    y_lo = std::min(y_lo, path.at(t).p_world.y());
    y_hi = std::max(y_hi, path.at(t).p_world.y());
  }
  EXPECT_NEAR(y_lo, -1.5, 1e-3);
  EXPECT_NEAR(y_hi, 1.5, 1e-3);
}

TEST(FigureEight, RejectsInvalidShapes) {
  const Eigen::Vector3d c(0, 0, 1), x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY();
  EXPECT_THROW(FigureEightPath(c, y, x, 0.0, 0.5, 0.0, 1.0, 1, 2.0, 0.0), std::invalid_argument);
  EXPECT_THROW(FigureEightPath(c, y, y, 1.0, 0.5, 0.0, 1.0, 1, 2.0, 0.0), std::invalid_argument);
  EXPECT_THROW(FigureEightPath(c, y, x, 1.0, 0.5, 0.0, 1.0, 0, 2.0, 0.0), std::invalid_argument);
  // Ramps so long that no crossing is flown at the cruise rate.
  EXPECT_THROW(FigureEightPath(c, y, x, 1.0, 0.5, 0.0, 1.0, 1, 30.0, 0.0), std::invalid_argument);
}

/// Distance from p to an oriented box (0 inside).
double distance_to_box(const sim::OrientedBox& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d local = box.T_world_box.inverse() * p;
  const Eigen::Vector3d outside =
      (local.cwiseAbs() - box.half_extents_m).cwiseMax(Eigen::Vector3d::Zero());
  return outside.norm();
}

TEST(Mission, TakesOffFromAndLandsOnTheFloorClearOfTheOffice) {
  const Scenario s = make_scenario("mission", kStart);
  ASSERT_TRUE(s.starts_on_ground);
  const ReferencePath& path = s.path;
  const double end = path.end_time_s();
  EXPECT_NEAR(path.at(0.0).p_world.z(), kStandingHeightM, 1e-12);
  EXPECT_NEAR(path.at(end).p_world.z(), kStandingHeightM, 1e-12);
  EXPECT_LT(path.at(end).v_world.norm(), 1e-12);
  EXPECT_GE(path.waypoints().size(), 5U);

  // The office's room (its floor rectangle and ceiling height) and furniture (its boxes).
  const sim::Scene office = sim::make_scene(s.scene);
  Eigen::Vector3d room_lo = Eigen::Vector3d::Constant(1e9), room_hi = -room_lo;
  std::vector<sim::OrientedBox> furniture;
  for (const auto& primitive : office.primitives()) {
    if (const auto* box = std::get_if<sim::OrientedBox>(&primitive)) furniture.push_back(*box);
  }
  for (const auto& face : office.faces()) {
    if (face.one_sided) continue;  // a box's
    for (const double a : {0.0, face.size_s_m}) {
      for (const double b : {0.0, face.size_t_m}) {
        const Eigen::Vector3d corner = face.origin_world + a * face.axis_s + b * face.axis_t;
        room_lo = room_lo.cwiseMin(corner);
        room_hi = room_hi.cwiseMax(corner);
      }
    }
  }
  ASSERT_EQ(furniture.size(), 4U);
  constexpr double kWallMargin = 0.8, kFurnitureMargin = 0.5;
  // Every point of the path, not only the waypoints: the legs between them are straight.
  double closest_furniture = 1e9;
  for (double t = 0.0; t <= end; t += 0.01) {
    const auto r = path.at(t);
    const Eigen::Vector3d& p = r.p_world;
    for (int k = 0; k < 2; ++k) {
      EXPECT_GT(p[k] - room_lo[k], kWallMargin) << "t=" << t;
      EXPECT_GT(room_hi[k] - p[k], kWallMargin) << "t=" << t;
    }
    EXPECT_GE(p.z(), kStandingHeightM - 1e-12) << "t=" << t;
    EXPECT_GT(room_hi.z() - p.z(), kWallMargin) << "t=" << t;
    for (const auto& box : furniture)
      closest_furniture = std::min(closest_furniture, distance_to_box(box, p));
    // Speed and acceleration limits of the legs (0.5 m/s, 0.5 m/s^2).
    EXPECT_LE(r.v_world.norm(), 0.5 + 1e-12) << "t=" << t;
    EXPECT_LE(r.a_world.norm(), 0.5 + 1e-12) << "t=" << t;
  }
  EXPECT_GT(closest_furniture, kFurnitureMargin);
  // Lifts off and flies at a sensible height in between.
  double top = 0.0;
  for (const auto& w : path.waypoints()) top = std::max(top, w.z());
  EXPECT_GE(top, 1.0);
}

TEST(Scenario, UnknownNameListsTheValidOnes) {
  try {
    (void)make_scenario("hoover", kStart);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("hoover"), std::string::npos) << what;
    EXPECT_NE(what.find("hover, square, corridor, figure8, mission"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace kestrel::flight
