// Scenario paths: where they start and end, and that their velocity and acceleration
// feed-forward are the derivatives of their position (what the controller relies on).
#include <gtest/gtest.h>

#include "kestrel/core/error.hpp"
#include "kestrel/flight/scenario.hpp"

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
    EXPECT_TRUE(s.path.at(0.0).p_world.isApprox(kStart.translation())) << s.name;
    EXPECT_GE(s.default_duration_s, s.path.end_time_s()) << s.name;
  }
  const Scenario square = make_scenario("square", kStart);
  // Four 2 m sides (plus the two half sides from and back to the start on the centre line).
  double length = 0.0;
  const auto& w = square.path.waypoints();
  for (std::size_t i = 1; i < w.size(); ++i) length += (w[i] - w[i - 1]).norm();
  EXPECT_NEAR(length, 8.0, 1e-12);
}

TEST(Scenario, UnknownNameListsTheValidOnes) {
  try {
    (void)make_scenario("hoover", kStart);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("hoover"), std::string::npos) << what;
    EXPECT_NE(what.find("hover, square, corridor"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace kestrel::flight
