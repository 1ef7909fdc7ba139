// The flight scenarios and their reference paths.
#include "kestrel/flight/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "kestrel/core/error.hpp"

namespace kestrel::flight {
namespace {

const std::vector<sim::CatalogueEntry> kScenarios = {
    {"hover", "hold the start pose in the office (60 s): the thesis' position-hold experiment"},
    {"square", "a 2 m square in the office at 0.5 m/s cruise, stopping at each corner, facing +x"},
    {"corridor",
     "6 m down the low-texture corridor and back at 0.5 m/s: only the projector's pattern "
     "gives depth on its walls"},
};

}  // namespace

WaypointPath::WaypointPath(std::vector<Eigen::Vector3d> waypoints, double yaw_rad,
                           double cruise_speed_m_s, double acceleration_m_s2,
                           double initial_hold_s)
    : waypoints_(std::move(waypoints)),
      yaw_rad_(yaw_rad),
      acceleration_(acceleration_m_s2),
      initial_hold_s_(initial_hold_s) {
  if (waypoints_.empty()) throw std::invalid_argument("WaypointPath: no waypoints");
  if (!(cruise_speed_m_s > 0.0) || !(acceleration_m_s2 > 0.0) || !(initial_hold_s >= 0.0)) {
    throw std::invalid_argument(
        "WaypointPath: speed and acceleration must be positive, the hold non-negative");
  }
  double t = initial_hold_s;
  for (std::size_t i = 1; i < waypoints_.size(); ++i) {
    Leg leg;
    leg.from = waypoints_[i - 1];
    const Eigen::Vector3d delta = waypoints_[i] - waypoints_[i - 1];
    leg.length = delta.norm();
    if (leg.length < 1e-9) continue;
    leg.direction = delta / leg.length;
    // Trapezoid: ramp to the cruise speed; a leg too short for it is a triangle whose peak
    // speed is sqrt(a L).
    leg.peak_speed = std::min(cruise_speed_m_s, std::sqrt(acceleration_m_s2 * leg.length));
    leg.ramp_s = leg.peak_speed / acceleration_m_s2;
    const double ramp_length = 0.5 * acceleration_m_s2 * leg.ramp_s * leg.ramp_s;
    leg.duration_s = 2.0 * leg.ramp_s + (leg.length - 2.0 * ramp_length) / leg.peak_speed;
    leg.start_s = t;
    t += leg.duration_s;
    legs_.push_back(leg);
  }
}

double WaypointPath::end_time_s() const {
  return legs_.empty() ? initial_hold_s_ : legs_.back().start_s + legs_.back().duration_s;
}

control::PositionReference WaypointPath::at(double t_s) const {
  control::PositionReference r;
  r.yaw_rad = yaw_rad_;
  r.p_world = waypoints_.back();
  if (legs_.empty() || t_s < legs_.front().start_s) {
    r.p_world = waypoints_.front();
    return r;
  }
  for (const Leg& leg : legs_) {
    const double tau = t_s - leg.start_s;
    if (tau >= leg.duration_s) continue;
    const double a = acceleration_;
    const double cruise_end = leg.duration_s - leg.ramp_s;
    double s = 0.0, v = 0.0, acc = 0.0;
    if (tau < leg.ramp_s) {  // accelerating
      s = 0.5 * a * tau * tau;
      v = a * tau;
      acc = a;
    } else if (tau < cruise_end) {  // cruising
      s = 0.5 * a * leg.ramp_s * leg.ramp_s + leg.peak_speed * (tau - leg.ramp_s);
      v = leg.peak_speed;
    } else {  // decelerating to a stop at the waypoint
      const double left = leg.duration_s - tau;
      s = leg.length - 0.5 * a * left * left;
      v = a * left;
      acc = -a;
    }
    r.p_world = leg.from + s * leg.direction;
    r.v_world = v * leg.direction;
    r.a_world = acc * leg.direction;
    return r;
  }
  return r;  // after the last leg: hold the last waypoint
}

const std::vector<sim::CatalogueEntry>& scenario_catalogue() { return kScenarios; }

Scenario make_scenario(std::string_view name, const SE3& T_world_start) {
  const Eigen::Vector3d p0 = T_world_start.translation();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d y = Eigen::Vector3d::UnitY();
  const double yaw = control::yaw_of(T_world_start.so3());
  constexpr double kCruise = 0.5;  // m/s, every scenario's (docs/flight.md, "Scenarios")
  constexpr double kAccel = 0.5;   // m/s^2: reaches cruise in 1 s
  constexpr double kHold = 3.0;    // s at the start before the first leg
  if (name == "hover") {
    return {"hover", "office", WaypointPath({p0}, yaw, kCruise, kAccel, 0.0), 60.0, 2.0};
  }
  if (name == "square") {
    // Centred on the start line: the office is 6 x 5 m and the start 0.5 m behind its centre.
    const std::vector<Eigen::Vector3d> corners = {p0,         p0 + y,     p0 + 2 * x + y,
                                                  p0 + 2 * x - y, p0 - y, p0};
    WaypointPath path(corners, yaw, kCruise, kAccel, kHold);
    const double duration = std::ceil(path.end_time_s() + 4.0);
    return {"square", "office", std::move(path), duration, 2.0};
  }
  if (name == "corridor") {
    WaypointPath path({p0, p0 + 6.0 * x, p0}, yaw, kCruise, kAccel, kHold);
    const double duration = std::ceil(path.end_time_s() + 3.0);
    return {"corridor", "corridor", std::move(path), duration, 2.0};
  }
  throw InputError("unknown scenario '" + std::string(name) +
                   "' (valid: " + sim::catalogue_names(kScenarios) + ")");
}

}  // namespace kestrel::flight
