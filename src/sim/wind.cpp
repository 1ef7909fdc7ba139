// Dryden turbulence (MIL-F-8785C low-altitude forms) and the mean wind.
#include "kestrel/sim/wind.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {
namespace {
constexpr double kFtPerM = 1.0 / 0.3048;
}  // namespace

void WindOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& why) {
    throw InputError("world option 'wind." + field + "': " + why);
  };
  if (!mean_world_m_s.allFinite() || mean_world_m_s.norm() > 20.0) {
    fail("mean_world_m_s", "must be finite and at most 20 m/s");
  }
  if (!(turbulence_w20_m_s >= 0.0 && turbulence_w20_m_s <= 30.0)) {
    fail("turbulence_w20_m_s", "must be in [0, 30] m/s");
  }
  if (!(min_altitude_m > 0.0 && min_altitude_m < 300.0)) {
    fail("min_altitude_m", "must be in (0, 300) m");
  }
  if (!(min_airspeed_m_s > 0.0 && std::isfinite(min_airspeed_m_s))) {
    fail("min_airspeed_m_s", "must be positive");
  }
}

DrydenScales dryden_low_altitude(double altitude_m, double w20_m_s) {
  const double h_ft = altitude_m * kFtPerM;
  const double k = 0.177 + 0.000823 * h_ft;
  const double L_uv_ft = h_ft / std::pow(k, 1.2);
  DrydenScales s;
  s.length_m = Eigen::Vector3d(L_uv_ft, L_uv_ft, h_ft) / kFtPerM;
  const double sigma_w = 0.1 * w20_m_s;
  const double sigma_uv = sigma_w / std::pow(k, 0.4);
  s.sigma_m_s = Eigen::Vector3d(sigma_uv, sigma_uv, sigma_w);
  return s;
}

double DrydenComponent::step(double dt_s, double correlation_time_s, double unit_normal) {
  const double a = std::exp(-dt_s / correlation_time_s);
  const double y1_before = y1_;
  // Exact discretisation of the unit-variance Ornstein-Uhlenbeck process.
  y1_ = a * y1_ + std::sqrt(1.0 - a * a) * unit_normal;
  if (!second_order_) return y1_;
  y2_ = a * y2_ + (1.0 - a) * y1_before;
  // Var(y1) = 1, Var(y2) = Cov(y1, y2) = 1/2 (PSD integrals), so Var(out) = 2 before / sqrt(2).
  return (std::sqrt(3.0) * y1_ + (1.0 - std::sqrt(3.0)) * y2_) / std::sqrt(2.0);
}

WindModel::WindModel(WindOptions options, std::uint64_t seed)
    : options_(std::move(options)), rng_(seed ^ 0x77696e64ULL) {
  options_.validate();
}

Eigen::Vector3d WindModel::step(double dt_s, const Eigen::Vector3d& p_world,
                                const Eigen::Vector3d& v_world) {
  const Eigen::Vector3d& mean = options_.mean_world_m_s;
  if (options_.turbulence_w20_m_s <= 0.0) return mean;
  const DrydenScales s = dryden_low_altitude(std::max(p_world.z(), options_.min_altitude_m),
                                             options_.turbulence_w20_m_s);
  if (!started_) {
    // Start in the stationary distribution (no warm-up transient): y1 ~ N(0, 1), y2 given y1.
    started_ = true;
    u_.reset(normal_(rng_));
    for (DrydenComponent* c : {&v_, &w_}) {
      const double y1 = normal_(rng_);
      c->reset(y1, 0.5 * y1 + std::sqrt(0.25) * normal_(rng_));
    }
  }
  const double V = std::max((mean - v_world).norm(), options_.min_airspeed_m_s);
  const double gu = s.sigma_m_s.x() * u_.step(dt_s, s.length_m.x() / V, normal_(rng_));
  const double gv = s.sigma_m_s.y() * v_.step(dt_s, s.length_m.y() / V, normal_(rng_));
  const double gw = s.sigma_m_s.z() * w_.step(dt_s, s.length_m.z() / V, normal_(rng_));
  // u along the mean wind's horizontal direction (x when calm), v to its left, w up.
  Eigen::Vector2d along(mean.x(), mean.y());
  along = along.norm() > 1e-6 ? along.normalized() : Eigen::Vector2d::UnitX();
  gust_world_ =
      Eigen::Vector3d(along.x() * gu - along.y() * gv, along.y() * gu + along.x() * gv, gw);
  return mean + gust_world_;
}

}  // namespace kestrel::sim
