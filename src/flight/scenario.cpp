// The flight scenarios and their reference paths.
#include "kestrel/flight/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "kestrel/core/error.hpp"

namespace kestrel::flight {
namespace {

const std::vector<sim::CatalogueEntry> kScenarios = {
    {"hover", "hold the start pose in the office: the thesis' position-hold experiment"},
    {"square", "a 2 m square in the office at 0.5 m/s cruise, stopping at each corner, facing +x"},
    {"corridor",
     "6 m down the low-texture corridor and back at 0.5 m/s: only the projector's pattern "
     "gives depth on its walls"},
    {"figure8",
     "two laps of a 3 x 1.2 m figure of eight in the office at 1.5 m/s peak speed, facing +x, "
     "from and back to rest at the start pose"},
    {"mission",
     "take off from the office floor, fly five waypoints around the furniture at 1-1.6 m "
     "height at 0.5 m/s, land on the floor"},
};

/// Smoothstep s(tau) = 3 tau^2 - 2 tau^3 on [0, 1], its integral and derivative.
double smoothstep(double tau) { return tau * tau * (3.0 - 2.0 * tau); }
double smoothstep_integral(double tau) { return tau * tau * tau * (1.0 - 0.5 * tau); }
double smoothstep_rate(double tau) { return 6.0 * tau * (1.0 - tau); }

}  // namespace

WaypointPath::WaypointPath(std::vector<Eigen::Vector3d> waypoints, double yaw_rad,
                           double cruise_speed_m_s, double acceleration_m_s2, double initial_hold_s)
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

FigureEightPath::FigureEightPath(const Eigen::Vector3d& centre, const Eigen::Vector3d& long_axis,
                                 const Eigen::Vector3d& short_axis, double half_length_m,
                                 double half_width_m, double yaw_rad, double peak_speed_m_s,
                                 int laps, double ramp_s, double initial_hold_s)
    : centre_(centre),
      e_long_(long_axis.normalized()),
      e_short_(short_axis.normalized()),
      half_length_(half_length_m),
      half_width_(half_width_m),
      yaw_rad_(yaw_rad),
      peak_speed_(peak_speed_m_s),
      ramp_s_(ramp_s),
      initial_hold_s_(initial_hold_s) {
  if (!(half_length_m > 0.0) || !(half_width_m > 0.0) || !(peak_speed_m_s > 0.0) ||
      !(ramp_s > 0.0) || laps < 1 || !(initial_hold_s >= 0.0)) {
    throw std::invalid_argument(
        "FigureEightPath: sizes, peak speed, ramp and laps must be positive, the hold "
        "non-negative");
  }
  if (!(long_axis.norm() > 0.0) || !(short_axis.norm() > 0.0) ||
      std::abs(e_long_.dot(e_short_)) > 1e-9) {
    throw std::invalid_argument("FigureEightPath: the axes must be non-zero and orthogonal");
  }
  // |p_phi| = |(L cos phi, 2 H cos 2 phi)| is largest, sqrt(L^2 + 4 H^2), at phi = k pi.
  rate_ = peak_speed_m_s / std::hypot(half_length_m, 2.0 * half_width_m);
  total_phase_ = 2.0 * std::numbers::pi * laps;
  // Each ramp covers w ramp / 2 of phase (the smoothstep's mean is 1/2). The peak speed is only
  // flown if a crossing (phi = k pi) lies in the cruise between the ramps.
  const double ramp_phase = 0.5 * rate_ * ramp_s;
  if (ramp_phase >= std::numbers::pi || total_phase_ - 2.0 * ramp_phase < std::numbers::pi) {
    throw std::invalid_argument(
        "FigureEightPath: the ramps are too long for the laps (no cruise through a crossing)");
  }
  cruise_s_ = (total_phase_ - 2.0 * ramp_phase) / rate_;
}

double FigureEightPath::end_time_s() const { return initial_hold_s_ + 2.0 * ramp_s_ + cruise_s_; }

Eigen::Vector3d FigureEightPath::point(double phi_rad) const {
  return centre_ + half_length_ * std::sin(phi_rad) * e_long_ +
         half_width_ * std::sin(2.0 * phi_rad) * e_short_;
}

control::PositionReference FigureEightPath::at(double t_s) const {
  // The phase and its first two derivatives.
  double phi = 0.0, dphi = 0.0, ddphi = 0.0;
  const double tau = t_s - initial_hold_s_;
  const double w = rate_, T = ramp_s_;
  if (tau <= 0.0) {
    // holding at the crossing
  } else if (tau < T) {
    phi = w * T * smoothstep_integral(tau / T);
    dphi = w * smoothstep(tau / T);
    ddphi = w / T * smoothstep_rate(tau / T);
  } else if (tau < T + cruise_s_) {
    phi = 0.5 * w * T + w * (tau - T);
    dphi = w;
  } else if (tau < 2.0 * T + cruise_s_) {
    const double left = (2.0 * T + cruise_s_ - tau) / T;  // 1 -> 0 over the last ramp
    phi = total_phase_ - w * T * smoothstep_integral(left);
    dphi = w * smoothstep(left);
    ddphi = -w / T * smoothstep_rate(left);
  } else {
    phi = total_phase_;
  }
  const double L = half_length_, H = half_width_;
  const Eigen::Vector3d p_phi =
      L * std::cos(phi) * e_long_ + 2.0 * H * std::cos(2.0 * phi) * e_short_;
  const Eigen::Vector3d p_phiphi =
      -L * std::sin(phi) * e_long_ - 4.0 * H * std::sin(2.0 * phi) * e_short_;
  control::PositionReference r;
  r.yaw_rad = yaw_rad_;
  r.p_world = point(phi);
  r.v_world = p_phi * dphi;
  r.a_world = p_phiphi * dphi * dphi + p_phi * ddphi;
  return r;
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
  auto scenario = [&](std::string scene, ReferencePath path, double duration_s) {
    Scenario s{std::string(name),
               std::move(scene),
               std::move(path),
               duration_s,
               2.0,
               Eigen::Vector3d::Zero(),
               false};
    s.start_world = s.path.at(0.0).p_world;
    return s;
  };
  if (name == "hover") {
    return scenario("office", WaypointPath({p0}, yaw, kCruise, kAccel, 0.0), 60.0);
  }
  if (name == "square") {
    // Centred on the start line: the office is 6 x 5 m and the start 0.5 m behind its centre.
    const std::vector<Eigen::Vector3d> corners = {p0,     p0 + y, p0 + 2 * x + y, p0 + 2 * x - y,
                                                  p0 - y, p0};
    WaypointPath path(corners, yaw, kCruise, kAccel, kHold);
    const double duration = std::ceil(path.end_time_s() + 4.0);
    return scenario("office", std::move(path), duration);
  }
  if (name == "corridor") {
    WaypointPath path({p0, p0 + 6.0 * x, p0}, yaw, kCruise, kAccel, kHold);
    const double duration = std::ceil(path.end_time_s() + 3.0);
    return scenario("corridor", std::move(path), duration);
  }
  if (name == "figure8") {
    // Long axis across the room (y; the side walls are 2.5 m from the start line), lobes
    // 0.6 m to either side of the start along x: from the start (-0.5, 0, 1.2) the path stays
    // 1 m from the side walls, 1.9 m from the back wall and 1.4 m from the desk.
    FigureEightPath path(p0, y, x, 1.5, 0.6, yaw, 1.5, 2, 3.0, kHold);
    const double duration = std::ceil(path.end_time_s() + 3.0);
    return scenario("office", std::move(path), duration);
  }
  if (name == "mission") {
    // From the floor below the start pose, up to it, around the desk, the crate and the
    // cabinet (scenes.cpp) at 1-1.6 m, and down to the floor; each waypoint is 0.55 m or more
    // from the furniture and 1 m or more from the walls (tests/flight/test_scenario.cpp).
    const Eigen::Vector3d ground(p0.x(), p0.y(), kStandingHeightM);
    const Eigen::Vector3d landing = p0 + Eigen::Vector3d(0.0, -1.0, 0.0);
    const std::vector<Eigen::Vector3d> waypoints = {
        ground,
        p0,
        p0 + Eigen::Vector3d(1.4, -1.0, 0.0),
        p0 + Eigen::Vector3d(1.4, 1.0, 0.3),
        p0 + Eigen::Vector3d(-1.3, 1.5, -0.2),
        p0 + Eigen::Vector3d(-1.3, -1.5, 0.4),
        landing,
        Eigen::Vector3d(landing.x(), landing.y(), kStandingHeightM)};
    WaypointPath path(waypoints, yaw, kCruise, kAccel, kHold);
    const double duration = std::ceil(path.end_time_s() + 4.0);
    Scenario s = scenario("office", std::move(path), duration);
    s.starts_on_ground = true;
    return s;
  }
  throw InputError("unknown scenario '" + std::string(name) +
                   "' (valid: " + sim::catalogue_names(kScenarios) + ")");
}

}  // namespace kestrel::flight
