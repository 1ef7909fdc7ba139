// The missions `kestrel fly` flies: a scene of the simulator, a reference path through it and
// a default duration. Paths are straight legs flown with a trapezoidal speed profile
// (accelerate, cruise, decelerate to a stop at each waypoint) or a figure of eight flown with a
// smooth time-scaling, so that the reference carries consistent position, velocity and
// acceleration feed-forward.
#pragma once

#include <string>
#include <string_view>
#include <variant>
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

/// A lemniscate of Gerono, p(phi) = centre + L sin(phi) e_long + H sin(2 phi) e_short, flown
/// `laps` times from its crossing point (phi = 0) at a fixed heading. The phase phi(t) is held
/// at 0 for `initial_hold_s`, then its rate rises from 0 to w over `ramp_s` as the smoothstep
/// 3 tau^2 - 2 tau^3 (so that phi'' is continuous and 0 at both ends), stays at w, and falls
/// back to 0 over the last `ramp_s`, ending at rest on the crossing point. Velocity
/// p_phi phi' and acceleration p_phiphi phi'^2 + p_phi phi'' are therefore continuous. The speed
/// at a constant rate w is w |p_phi| <= w sqrt(L^2 + 4 H^2), with equality at the crossing
/// (phi = k pi), so w = peak_speed / sqrt(L^2 + 4 H^2) makes peak_speed the largest speed.
class FigureEightPath {
 public:
  /// Throws std::invalid_argument for non-positive sizes, speed, ramp or laps, a negative
  /// hold, non-orthogonal axes, or ramps that leave no cruise through a crossing.
  FigureEightPath(const Eigen::Vector3d& centre, const Eigen::Vector3d& long_axis,
                  const Eigen::Vector3d& short_axis, double half_length_m, double half_width_m,
                  double yaw_rad, double peak_speed_m_s, int laps, double ramp_s,
                  double initial_hold_s);

  [[nodiscard]] control::PositionReference at(double t_s) const;
  [[nodiscard]] double end_time_s() const;
  [[nodiscard]] double peak_speed_m_s() const { return peak_speed_; }
  /// The point of phase phi.
  [[nodiscard]] Eigen::Vector3d point(double phi_rad) const;

 private:
  Eigen::Vector3d centre_, e_long_, e_short_;
  double half_length_, half_width_, yaw_rad_, peak_speed_;
  double rate_;  // w, rad/s
  double ramp_s_, initial_hold_s_, cruise_s_, total_phase_;
};

/// One of the path kinds, with their common interface.
class ReferencePath {
 public:
  ReferencePath(WaypointPath path) : path_(std::move(path)) {}     // NOLINT: implicit on purpose
  ReferencePath(FigureEightPath path) : path_(std::move(path)) {}  // NOLINT: implicit on purpose

  [[nodiscard]] control::PositionReference at(double t_s) const {
    return std::visit([t_s](const auto& p) { return p.at(t_s); }, path_);
  }
  [[nodiscard]] double end_time_s() const {
    return std::visit([](const auto& p) { return p.end_time_s(); }, path_);
  }
  /// The waypoints of a WaypointPath; empty for other kinds.
  [[nodiscard]] std::vector<Eigen::Vector3d> waypoints() const {
    const auto* w = std::get_if<WaypointPath>(&path_);
    return w != nullptr ? w->waypoints() : std::vector<Eigen::Vector3d>{};
  }

 private:
  std::variant<WaypointPath, FigureEightPath> path_;
};

/// A named mission.
struct Scenario {
  std::string name;
  std::string scene;  ///< a name of sim::scene_catalogue()
  ReferencePath path;
  double default_duration_s = 30.0;
  /// Tracking and estimate errors are scored from this time on (s): the first moments are
  /// the filter's and the controller's start-up, not flight.
  double settle_s = 2.0;
  /// Where the vehicle starts (path.at(0)), level, at the path's heading.
  Eigen::Vector3d start_world = Eigen::Vector3d::Zero();
  /// The vehicle starts standing on the floor (motors idling at hover speed, not flying):
  /// start_world's z is then the height of its body origin on its landing gear, which the
  /// flight uses as the vehicle's and the supervisor's ground height.
  bool starts_on_ground = false;
};

/// The office floor (z = 0) plus the landing gear: where the body origin of a vehicle standing
/// on the floor is (a Phantom-class frame's legs hold it about 8 cm up).
inline constexpr double kStandingHeightM = 0.08;

/// hover, square, corridor, figure8, mission.
const std::vector<sim::CatalogueEntry>& scenario_catalogue();

/// Builds a named scenario from the scene's start pose (hover, square, corridor and figure8
/// start there; mission starts on the floor below it). Throws InputError naming the valid
/// scenarios for an unknown name.
Scenario make_scenario(std::string_view name, const SE3& T_world_start);

}  // namespace kestrel::flight
