// Uniform draws that are the same on every platform: std::uniform_real_distribution's
// algorithm is implementation-defined, and the renderer, the pattern and the sensor noise
// must give the same images from the same seed everywhere.
#pragma once

#include <random>

namespace kestrel {

/// Uniform double in [0, 1) from the generator's top 53 bits.
inline double uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// Uniform double in [lo, hi).
inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * uniform01(rng);
}

}  // namespace kestrel
