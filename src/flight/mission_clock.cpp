// The mission clock that eases to a stop in a hold and back when the mission resumes.
#include "kestrel/flight/mission_clock.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace kestrel::flight {

MissionClock::MissionClock(double ease_time_s) : ease_time_s_(ease_time_s) {
  if (!(ease_time_s > 0.0) || !std::isfinite(ease_time_s)) {
    throw std::invalid_argument("MissionClock: ease_time_s must be positive");
  }
}

void MissionClock::advance(double t_s, bool running) {
  if (!started_) {
    started_ = true;
    t_s_ = t_s;
    return;
  }
  const double dt = t_s - t_s_;
  t_s_ = t_s;
  if (!(dt > 0.0)) return;
  const double target = running ? 1.0 : 0.0;
  if (rate_ == target && rate_dot_ == 0.0) {
    lost_s_ += (1.0 - rate_) * dt;  // steady: exact, and nothing lost while running
    return;
  }
  // Exact step of e'' = -2 w e' - w^2 e for e = r - target: e(t) = (e0 + (e0' + w e0) t)
  // e^(-w t), e'(t) = (e0' - w (e0' + w e0) t) e^(-w t).
  const double w = 1.0 / ease_time_s_;
  const double e0 = rate_ - target;
  const double b = rate_dot_ + w * e0;
  const double decay = std::exp(-w * dt);
  const double previous = rate_;
  rate_ = target + (e0 + b * dt) * decay;
  rate_dot_ = (rate_dot_ - w * b * dt) * decay;
  // A rate that still falls when the mission resumes may dip a little further: the clock never
  // runs backwards nor ahead of the flight.
  if (rate_ < 0.0 || rate_ > 1.0) {
    rate_ = std::clamp(rate_, 0.0, 1.0);
    rate_dot_ = 0.0;
  }
  if (std::abs(rate_ - target) < 1e-9 && std::abs(rate_dot_) < 1e-9) {
    rate_ = target;
    rate_dot_ = 0.0;
  }
  lost_s_ += (1.0 - 0.5 * (previous + rate_)) * dt;
}

control::PositionReference MissionClock::reference(const ReferencePath& path) const {
  control::PositionReference r = path.at(time_s());
  if (rate_ == 1.0 && rate_dot_ == 0.0) return r;
  r.a_world = rate_ * rate_ * r.a_world + rate_dot_ * r.v_world;
  r.v_world *= rate_;
  r.yaw_rate_rad_s *= rate_;
  return r;
}

}  // namespace kestrel::flight
