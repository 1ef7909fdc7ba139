// The camera's link to the filter: frames that never arrive (USB drops, a skipped capture)
// and the latency from exposure to the filter, which varies (transfer, matching and tracking
// time on a loaded CPU). Seeded, deterministic.
#pragma once

#include <cstdint>
#include <random>

namespace kestrel::sim {

class CameraLink {
 public:
  /// drop_probability in [0, 1): each frame is dropped independently (Bernoulli);
  /// latency_jitter_s: the latency is the nominal one plus a uniform draw from
  /// [-jitter, +jitter] (bounded, unlike a normal draw: a real pipeline has a deadline).
  CameraLink(double drop_probability, double latency_jitter_s, std::uint64_t seed);
  /// Whether the next frame is dropped.
  bool drop();
  /// The latency of the next delivered frame, never below zero.
  double latency_s(double nominal_s);

 private:
  double drop_probability_;
  double jitter_s_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace kestrel::sim
