// The missions `kestrel fly` flies: a scene of the simulator, a reference path through it and
// a default duration. Paths are built from straight legs flown with a trapezoidal speed profile
// (accelerate, cruise, decelerate to a stop at each waypoint), so that the reference carries
// consistent position, velocity and acceleration feed-forward.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "kestrel/control/types.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/sim/catalogue.hpp"

namespace kestrel::flight {

/// A polyline flown leg by leg, stopping at each waypoint, at a fixed heading.
class WaypointPath {
 public:
  /// `waypoints[0]` is where the vehicle starts; it holds there for `initial_hold_s`, then
  /// flies each leg at up to `cruise_speed_m_s` with `acceleration_m_s2`, and holds the last
  /// waypoint forever. Throws std::invalid_argument for non-positive speed or acceleration,
  /// a negative hold or an empty list.
  WaypointPath(std::vector<Eigen::Vector3d> waypoints, double yaw_rad, double cruise_speed_m_s,
               double acceleration_m_s2, double initial_hold_s);

  /// The reference at t_s seconds after the start.
  [[nodiscard]] control::PositionReference at(double t_s) const;
  /// When the last leg ends.
  [[nodiscard]] double end_time_s() const;
  [[nodiscard]] const std::vector<Eigen::Vector3d>& waypoints() const { return waypoints_; }

 private:
  struct Leg {
    Eigen::Vector3d from, direction;  // unit direction
    double length = 0.0, start_s = 0.0, duration_s = 0.0;
    double ramp_s = 0.0, peak_speed = 0.0;  // trapezoid (or triangle when short)
  };
  std::vector<Eigen::Vector3d> waypoints_;
  std::vector<Leg> legs_;
  double yaw_rad_;
  double acceleration_;
  double initial_hold_s_;
};

/// A named mission.
struct Scenario {
  std::string name;
  std::string scene;  ///< a name of sim::scene_catalogue()
  WaypointPath path;
  double default_duration_s = 30.0;
  /// Tracking and estimate errors are scored from this time on (s): the first moments are
  /// the filter's and the controller's start-up, not flight.
  double settle_s = 2.0;
};

/// hover, square, corridor.
const std::vector<sim::CatalogueEntry>& scenario_catalogue();

/// Builds a named scenario starting at the scene's start pose. Throws InputError naming the
/// valid scenarios for an unknown name.
Scenario make_scenario(std::string_view name, const SE3& T_world_start);

}  // namespace kestrel::flight
