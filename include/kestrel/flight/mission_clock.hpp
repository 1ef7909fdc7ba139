// The mission's clock in a flight: it eases to a stop while the safety supervisor holds and
// back to the flight's pace when it hands back, so that the mission reference brakes and
// starts again along its path instead of stepping its velocity (docs/flight.md, "2 s outage:
// where the drift comes from").
#pragma once

#include "kestrel/control/types.hpp"
#include "kestrel/flight/scenario.hpp"

namespace kestrel::flight {

/// The clock runs at a rate r in [0, 1] (mission seconds per flight second) that follows its
/// target (1 running, 0 held) as a critically damped second-order system of time constant
/// ease_time_s: from a steady run, r(t) = (1 + t/T) e^(-t/T) after a hold starts, so the
/// reference's velocity v r and its acceleration stay continuous (peak deceleration
/// v / (e T), stop 2 v T further along the path); a flight without holds has r = 1 and the
/// mission at exactly the flight's time.
class MissionClock {
 public:
  explicit MissionClock(double ease_time_s = 0.25);

  /// The clock at flight time t_s; `running`: the mission is flown (the rate eases towards
  /// 1), else it is held (towards 0). The first call starts the clock at t_s.
  void advance(double t_s, bool running);

  [[nodiscard]] double time_s() const { return t_s_ - lost_s_; }  ///< mission time
  [[nodiscard]] double rate() const { return rate_; }
  [[nodiscard]] double rate_change_per_s() const { return rate_dot_; }

  /// The path's reference at the mission time: velocity times the rate, acceleration times
  /// the rate squared plus the rate's change times the path's velocity (chain rule).
  [[nodiscard]] control::PositionReference reference(const ReferencePath& path) const;

 private:
  double ease_time_s_;
  bool started_ = false;
  double t_s_ = 0.0;
  double lost_s_ = 0.0;  // flight time minus mission time: what the holds cost
  double rate_ = 1.0;
  double rate_dot_ = 0.0;
};

}  // namespace kestrel::flight
