// Seeded random samples for the geometry tests: rotation vectors drawn from angle ranges
// that stress the series / closed-form switches (0, 1e-9 .. 1e-3, near pi, near 2 pi), poses.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <ostream>
#include <random>
#include <string>

#include "kestrel/core/units.hpp"
#include "kestrel/geometry/se3.hpp"
#include "kestrel/geometry/so3.hpp"

namespace kestrel::test {

/// Random samples of a property test that is not split by angle, and of the generic angle
/// range of one that is (the issue asks for >= 1000 per property).
inline constexpr int kSamples = 1000;
/// Samples from each of the special angle ranges, on top of the generic ones: enough to cross
/// every branch many times while keeping the Debug run of the suite within a few seconds.
inline constexpr int kSpecialSamples = 200;

/// Rotation angles in [lo, hi], uniform or log-uniform, and how many a test draws from it.
struct AngleRange {
  const char* name;
  double lo;
  double hi;
  bool log_uniform;
  int samples;
};

inline void PrintTo(const AngleRange& r, std::ostream* os) {
  *os << r.name << " [" << r.lo << ", " << r.hi << "]";
}

// tiny: the series branches, where closed forms divide ~0 by ~0.
inline constexpr AngleRange kTiny{"tiny", 0.0, 1e-9, false, kSpecialSamples};
// small: across the 1e-4 switch of SO3 and the series that take over below it.
inline constexpr AngleRange kSmall{"small", 1e-9, 1e-3, true, kSpecialSamples};
// switch: both the SO3 (1e-4) and SE3 (1e-2) series / closed-form switches.
inline constexpr AngleRange kSwitch{"switch", 1e-5, 1e-1, true, kSpecialSamples};
inline constexpr AngleRange kGeneric{"generic", 1e-3, kPi - 1e-3, false, kSamples};
// near pi: log's branch point; the quaternion's scalar part is ~0.
inline constexpr AngleRange kNearPi{"near_pi", kPi - 1e-9, kPi, false, kSpecialSamples};
/// The angle ranges of log: [0, pi].
inline constexpr std::array<AngleRange, 5> kLogRanges{kTiny, kSmall, kSwitch, kGeneric, kNearPi};

// exp accepts any angle; log then returns the equivalent one in [0, pi].
inline constexpr AngleRange kBeyondPi{"beyond_pi", kPi, 2.0 * kPi - 1e-3, false, kSpecialSamples};
inline constexpr AngleRange kNear2Pi{"near_2pi", 2.0 * kPi - 1e-6, 2.0 * kPi + 1e-6, false,
                                     kSpecialSamples};
inline constexpr std::array<AngleRange, 7> kExpRanges{kTiny,   kSmall,    kSwitch, kGeneric,
                                                      kNearPi, kBeyondPi, kNear2Pi};

/// A seed per (test, angle range), so that suites draw independent but reproducible samples.
inline std::uint32_t seed_for(const char* test, const AngleRange& r) {
  std::uint32_t h = 2166136261u;  // FNV-1a
  for (const char* s : {test, r.name}) {
    for (; *s != '\0'; ++s) h = (h ^ static_cast<unsigned char>(*s)) * 16777619u;
  }
  return h;
}

/// Test-name suffix for parameterised suites.
inline std::string range_name(const ::testing::TestParamInfo<AngleRange>& info) {
  return info.param.name;
}

class GeometrySampler {
 public:
  explicit GeometrySampler(std::uint32_t seed) : rng_(seed) {}

  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
  }

  double angle(const AngleRange& r) {
    if (r.log_uniform) return std::exp(uniform(std::log(r.lo), std::log(r.hi)));
    return uniform(r.lo, r.hi);
  }

  /// Uniform on the unit sphere (a normalised Gaussian vector).
  Eigen::Vector3d unit_vector() {
    std::normal_distribution<double> n(0.0, 1.0);
    for (;;) {
      const Eigen::Vector3d v(n(rng_), n(rng_), n(rng_));
      if (v.norm() > 1e-6) return v.normalized();
    }
  }

  Eigen::Vector3d rotation_vector(const AngleRange& r) { return angle(r) * unit_vector(); }

  /// Haar-uniform random rotation (a normalised Gaussian 4-vector).
  Eigen::Quaterniond unit_quaternion() {
    std::normal_distribution<double> n(0.0, 1.0);
    for (;;) {
      Eigen::Quaterniond q(n(rng_), n(rng_), n(rng_), n(rng_));
      if (q.norm() > 1e-6) return q.normalized();
    }
  }

  Eigen::Vector3d vector(double half_extent) {
    return {uniform(-half_extent, half_extent), uniform(-half_extent, half_extent),
            uniform(-half_extent, half_extent)};
  }

  /// Twist [v, w] with rotation angle from `r` and each translation component in +-max_v.
  Vector6d twist(const AngleRange& r, double max_v) {
    Vector6d xi;
    xi << vector(max_v), rotation_vector(r);
    return xi;
  }

  SE3 pose(const AngleRange& r, double max_t) {
    const Eigen::Vector3d t = vector(max_t);
    return {SO3::exp(rotation_vector(r)), t};
  }

  std::mt19937& engine() { return rng_; }

 private:
  std::mt19937 rng_;
};

}  // namespace kestrel::test
