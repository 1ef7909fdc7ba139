// The named trajectories. All are relative to a start pose (a scene's T_world_start), start
// there at t = 0, stay within about a metre of it, and are band-limited (< 4 Hz), so that they
// suit every named scene and a 30 Hz camera.
#include <cmath>
#include <random>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/core/random.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/sim/smooth_trajectory.hpp"

namespace kestrel::sim {

namespace {

/// A sinusoid that is 0 at t = 0: A sin(2 pi f t).
ScalarFunction sine(double amplitude, double frequency_hz) {
  return sum_of_sinusoids(0.0, 0.0, {{amplitude, frequency_hz, 0.0}});
}

/// A (1 - cos(2 pi f t)): starts at 0 with zero velocity, reaches 2A after half a period.
ScalarFunction one_minus_cos(double amplitude, double frequency_hz) {
  return sum_of_sinusoids(amplitude, 0.0, {{amplitude, frequency_hz, -kPi / 2.0}});
}

/// Random band-limited motion: `n` sinusoids with log-uniform frequencies in [f_lo, f_hi],
/// amplitudes falling as 1/f (slow motions are the large ones), scaled to the given RMS, plus
/// an offset so that the function is 0 at t = 0.
ScalarFunction random_motion(std::mt19937_64& rng, int n, double f_lo, double f_hi, double rms) {
  std::vector<SinusoidTerm> terms;
  double power = 0.0;
  for (int i = 0; i < n; ++i) {
    SinusoidTerm k;
    k.frequency_hz = f_lo * std::pow(f_hi / f_lo, uniform01(rng));
    k.amplitude = 1.0 / k.frequency_hz;
    k.phase_rad = 2.0 * kPi * uniform01(rng);
    power += 0.5 * k.amplitude * k.amplitude;
    terms.push_back(k);
  }
  const double scale = rms / std::sqrt(power);
  double at_zero = 0.0;
  for (SinusoidTerm& k : terms) {
    k.amplitude *= scale;
    at_zero += k.amplitude * std::sin(k.phase_rad);
  }
  return sum_of_sinusoids(-at_zero, 0.0, std::move(terms));
}

ScalarFunction add(ScalarFunction a, ScalarFunction b) {
  return [a = std::move(a), b = std::move(b)](double t) {
    const Jet x = a(t);
    const Jet y = b(t);
    return Jet{x.value + y.value, x.rate + y.rate, x.accel + y.accel};
  };
}

const std::vector<CatalogueEntry> kTrajectories = {
    {"still", "the body stays at the start pose (noise and drift tests)"},
    {"forward", "forward along the view direction and back: x = 1 m (1 - cos(2 pi t / 12 s))"},
    {"circle", "horizontal circle of 0.4 m radius in 6 s, heading nearly constant"},
    {"orbit", "swings +-25 deg around a point 2 m ahead, keeping it in view (period 8 s)"},
    {"rpy", "rotations about roll, pitch and yaw (12, 10, 15 deg) in place, as TUM fr1/rpy"},
    {"sway", "slow 6-DoF sinusoidal motion (15-20 cm, 4-8 deg)"},
    {"handheld",
     "random hand-held motion from the seed: band-limited (0.05-4 Hz) walk and "
     "tremor, 15 cm / 3-8 deg RMS"},
};

}  // namespace

const std::vector<CatalogueEntry>& trajectory_catalogue() { return kTrajectories; }

SmoothTrajectory make_trajectory(std::string_view name, const SE3& T_world_start,
                                 std::uint64_t seed) {
  const auto zero = [] { return constant_function(0.0); };
  const std::string n(name);
  if (name == "still") {
    return {n, T_world_start, {zero(), zero(), zero()}, {zero(), zero(), zero()}};
  }
  if (name == "forward") {
    return {n,
            T_world_start,
            {one_minus_cos(1.0, 1.0 / 12.0), zero(), sine(0.02, 0.5)},
            {zero(), zero(), sine(2.0 * kDegToRad, 0.2)}};
  }
  if (name == "circle") {
    constexpr double r = 0.4, f = 1.0 / 6.0;
    return {n,
            T_world_start,
            {sine(r, f), one_minus_cos(r, f), sine(0.05, 0.35)},
            {zero(), sine(2.0 * kDegToRad, 0.27), sine(5.0 * kDegToRad, 0.3)}};
  }
  if (name == "orbit") {
    constexpr double d = 2.0;  // distance to the point kept in view
    const ScalarFunction angle = sine(25.0 * kDegToRad, 1.0 / 8.0);
    // Body on a circle of radius d around (d, 0, 0), facing its centre: yaw = angle,
    // p = (d - d cos angle, -d sin angle); derivatives by the chain rule.
    ScalarFunction x = [angle](double t) {
      const Jet a = angle(t);
      const double s = std::sin(a.value), c = std::cos(a.value);
      return Jet{d - d * c, d * s * a.rate, d * (c * a.rate * a.rate + s * a.accel)};
    };
    ScalarFunction y = [angle](double t) {
      const Jet a = angle(t);
      const double s = std::sin(a.value), c = std::cos(a.value);
      return Jet{-d * s, -d * c * a.rate, -d * (-s * a.rate * a.rate + c * a.accel)};
    };
    return {n, T_world_start, {x, y, sine(0.1, 0.2)}, {zero(), zero(), angle}};
  }
  if (name == "rpy") {
    return {
        n,
        T_world_start,
        {sine(0.02, 0.37), sine(0.02, 0.29), sine(0.015, 0.43)},
        {sine(12.0 * kDegToRad, 0.4), sine(10.0 * kDegToRad, 0.31), sine(15.0 * kDegToRad, 0.23)}};
  }
  if (name == "sway") {
    return {
        n,
        T_world_start,
        {sine(0.15, 0.21), sine(0.2, 0.17), sine(0.1, 0.29)},
        {sine(4.0 * kDegToRad, 0.25), sine(5.0 * kDegToRad, 0.19), sine(8.0 * kDegToRad, 0.15)}};
  }
  if (name == "handheld") {
    std::mt19937_64 rng(seed ^ 0x4A1DE1DULL);
    // Slow wandering (0.05-1.5 Hz) plus a small tremor (2-4 Hz).
    auto axis = [&rng](double walk_rms, double tremor_rms) {
      ScalarFunction walk = random_motion(rng, 8, 0.05, 1.5, walk_rms);
      return add(std::move(walk), random_motion(rng, 4, 2.0, 4.0, tremor_rms));
    };
    ScalarFunction px = axis(0.15, 0.002), py = axis(0.15, 0.002), pz = axis(0.06, 0.002);
    ScalarFunction roll = axis(3.0 * kDegToRad, 0.2 * kDegToRad),
                   pitch = axis(4.0 * kDegToRad, 0.2 * kDegToRad),
                   yaw = axis(8.0 * kDegToRad, 0.2 * kDegToRad);
    return {n, T_world_start, {px, py, pz}, {roll, pitch, yaw}};
  }
  throw InputError("unknown trajectory '" + n + "' (valid: " + catalogue_names(kTrajectories) +
                   ")");
}

}  // namespace kestrel::sim
