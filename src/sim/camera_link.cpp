// Dropped frames and latency jitter.
#include "kestrel/sim/camera_link.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"

namespace kestrel::sim {

CameraLink::CameraLink(double drop_probability, double latency_jitter_s, std::uint64_t seed)
    : drop_probability_(drop_probability), jitter_s_(latency_jitter_s), rng_(seed ^ 0x6c696e6bULL) {
  if (!(drop_probability >= 0.0 && drop_probability < 1.0)) {
    throw InputError("camera link: drop probability must be in [0, 1)");
  }
  if (!(latency_jitter_s >= 0.0 && std::isfinite(latency_jitter_s))) {
    throw InputError("camera link: latency jitter must be >= 0");
  }
}

bool CameraLink::drop() { return uniform_(rng_) < drop_probability_; }

double CameraLink::latency_s(double nominal_s) {
  const double u = uniform_(rng_);  // drawn even without jitter: the stream stays aligned
  return std::max(0.0, nominal_s + jitter_s_ * (2.0 * u - 1.0));
}

}  // namespace kestrel::sim
