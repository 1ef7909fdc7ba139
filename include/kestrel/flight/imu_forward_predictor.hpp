// The controller's estimate "now": the fusion's output lags real time by its reorder window
// (it waits for late camera measurements), so the newest fused state is carried forward to the
// present by integrating the IMU samples that came after it with the filter's bias estimates.
// This is the output predictor of flight-control estimators (e.g. PX4's EKF2); it is reset to
// every new fused state, so its drift is bounded by the lag (tens of milliseconds).
#pragma once

#include <deque>
#include <optional>

#include "kestrel/control/types.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/io/euroc.hpp"

namespace kestrel::flight {

class ImuForwardPredictor {
 public:
  /// The window of the specific-force mean: the 200 Hz control period.
  static constexpr TimeNs kSpecificForceWindowNs = 5'000'000;

  explicit ImuForwardPredictor(double gravity_m_s2 = control::kGravity);

  /// Every IMU sample, in time order (kept until a fused state newer than it arrives).
  void add_imu(const io::ImuSample& sample);
  /// A new fused state (the filter's time): samples up to it are dropped.
  void set_fused(const fusion::FusedState& fused);

  /// The fused state integrated to the newest IMU sample with the filter's nominal step
  /// (StochasticCloningEkf::propagate_nominal, biases held); nullopt before the first fused
  /// state. Body = IMU frame. Its specific_force_body is the mean bias-corrected
  /// accelerometer reading over the last kSpecificForceWindowNs.
  [[nodiscard]] std::optional<control::VehicleStateEstimate> predict() const;
  /// How far predict() reaches past the fused state (0 before the first).
  [[nodiscard]] double lag_s() const;

 private:
  Eigen::Vector3d gravity_world_;
  std::optional<fusion::FusedState> fused_;
  std::deque<io::ImuSample> samples_;
};

}  // namespace kestrel::flight
