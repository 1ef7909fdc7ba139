// Wind: a mean wind plus Dryden turbulence, the low-altitude forms of MIL-F-8785C (also
// MIL-HDBK-1797 3.7.3.2): gust components along the mean wind (u), across it (v) and vertical
// (w), each white noise through its shaping filter (u: first order, v and w: second order),
// advanced at the physics rate, deterministic from a seed. The quadrotor turns the air
// velocity into a force through its drag (Quadrotor::set_wind_world).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>

namespace kestrel::sim {

struct WindOptions {
  /// Mean wind in the world frame (m/s); its horizontal direction is the gusts' u axis.
  Eigen::Vector3d mean_world_m_s = Eigen::Vector3d::Zero();
  /// Wind speed at 20 ft (6.1 m), W20: the turbulence intensity sigma_w = 0.1 W20 (MIL-F-8785C
  /// low altitude; 15 kt = 7.7 m/s "light", 30 kt "moderate"). 0: no gusts.
  double turbulence_w20_m_s = 0.0;
  /// The Dryden forms hold from 10 ft (3.05 m) up; below it, its scales are used.
  double min_altitude_m = 3.048;
  /// Airspeed floor for the frozen-turbulence time scale L / V (a hovering vehicle in calm air
  /// still sees the turbulence change).
  double min_airspeed_m_s = 1.0;

  template <typename V>
  void visit_fields(V&& v) {
    v("mean_world_m_s", mean_world_m_s);
    v("turbulence_w20_m_s", turbulence_w20_m_s);
    v("min_altitude_m", min_altitude_m);
    v("min_airspeed_m_s", min_airspeed_m_s);
  }
  /// Throws InputError naming the field ("wind.FIELD").
  void validate() const;
  [[nodiscard]] bool calm() const { return mean_world_m_s.isZero() && turbulence_w20_m_s == 0.0; }
};

/// Dryden scale lengths (m) and intensities (m/s) at an altitude, MIL-F-8785C low altitude
/// (h in ft): L_w = h, L_u = L_v = h / (0.177 + 0.000823 h)^1.2, sigma_w = 0.1 W20,
/// sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4.
struct DrydenScales {
  Eigen::Vector3d length_m;   ///< L_u, L_v, L_w
  Eigen::Vector3d sigma_m_s;  ///< sigma_u, sigma_v, sigma_w
};
DrydenScales dryden_low_altitude(double altitude_m, double w20_m_s);

/// One gust component, unit variance, for a correlation time T = L / V:
/// first order  H(s) = sqrt(2T) / (1 + T s): autocorrelation exp(-tau/T);
/// second order H(s) = sqrt(T) (1 + sqrt(3) T s) / (1 + T s)^2: autocorrelation
/// (1 - tau / (2T)) exp(-tau/T) (MIL-F-8785C's u and v, w forms, scaled by sigma outside).
/// The second order is the cascade y1 = 1/(1 + T s) [white], y2 = 1/(1 + T s) y1,
/// out = (sqrt(3) y1 + (1 - sqrt(3)) y2) / sqrt(2) (T y2' = y1 - y2), y1 advanced exactly as an
/// Ornstein-Uhlenbeck process of unit variance, y2 with y1 held over the step.
class DrydenComponent {
 public:
  explicit DrydenComponent(bool second_order) : second_order_(second_order) {}
  /// Advances by dt with correlation time T; `unit_normal` is N(0, 1).
  double step(double dt_s, double correlation_time_s, double unit_normal);
  void reset(double y1 = 0.0, double y2 = 0.0) { y1_ = y1, y2_ = y2; }

 private:
  bool second_order_;
  double y1_ = 0.0, y2_ = 0.0;
};

/// The wind at the vehicle over time.
class WindModel {
 public:
  WindModel(WindOptions options, std::uint64_t seed);
  /// Advances by dt_s for a vehicle at p_world moving at v_world; returns the air velocity
  /// (world frame, m/s) for the next step.
  Eigen::Vector3d step(double dt_s, const Eigen::Vector3d& p_world, const Eigen::Vector3d& v_world);
  [[nodiscard]] const Eigen::Vector3d& gust_world() const { return gust_world_; }
  [[nodiscard]] const WindOptions& options() const { return options_; }

 private:
  WindOptions options_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  DrydenComponent u_{false}, v_{true}, w_{true};
  Eigen::Vector3d gust_world_ = Eigen::Vector3d::Zero();
  bool started_ = false;
};

}  // namespace kestrel::sim
