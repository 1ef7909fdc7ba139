// An IMU synthesised from a ground-truth trajectory (the control experiment of docs/fusion.md).
#include "kestrel/lab/ground_truth_imu.hpp"

#include <algorithm>
#include <cmath>

#include "kestrel/core/error.hpp"
#include "kestrel/lab/fusion_simulation.hpp"

namespace kestrel::lab {

using Eigen::Vector3d;

GroundTruthSpline::GroundTruthSpline(const std::vector<GroundTruthSample>& gt) {
  if (gt.size() < 3) throw InputError("ground-truth spline: fewer than 3 samples");
  const std::size_t n = gt.size();
  t_.reserve(n);
  p_.reserve(n);
  r_.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0 && gt[i].t_ns <= gt[i - 1].t_ns) {
      throw InputError("ground-truth spline: time stamps not increasing at sample " +
                       std::to_string(i));
    }
    t_.push_back(gt[i].t_ns);
    p_.push_back(gt[i].T_world_body.translation());
    r_.push_back(gt[i].T_world_body.so3());
  }
  std::vector<double> h(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) h[i] = ns_to_s(t_[i + 1] - t_[i]);
  // Natural cubic spline: the second derivatives M solve the tridiagonal system
  // h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (d_i - d_{i-1}), M_0 = M_{n-1} = 0,
  // d_i the slope of interval i (Thomas algorithm, forward sweep then back substitution).
  m_.assign(n, Vector3d::Zero());
  std::vector<double> c(n, 0.0);
  std::vector<Vector3d> d(n, Vector3d::Zero());
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Vector3d rhs = 6.0 * ((p_[i + 1] - p_[i]) / h[i] - (p_[i] - p_[i - 1]) / h[i - 1]);
    const double lower = i > 1 ? h[i - 1] : 0.0;  // M_0 = 0 drops the first lower term
    const double diag = 2.0 * (h[i - 1] + h[i]) - lower * c[i - 1];
    c[i] = h[i] / diag;
    d[i] = (rhs - lower * d[i - 1]) / diag;
  }
  for (std::size_t i = n - 2; i >= 1; --i) {
    m_[i] = d[i] - c[i] * m_[i + 1];  // m_[n - 1] = 0 (natural end)
  }
  w_.resize(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) w_[i] = (r_[i].inverse() * r_[i + 1]).log() / h[i];
}

std::size_t GroundTruthSpline::interval(TimeNs t, double& s) const {
  t = std::clamp(t, t_.front(), t_.back());
  auto it = std::upper_bound(t_.begin(), t_.end(), t);
  auto i = static_cast<std::size_t>(it - t_.begin());
  i = std::min(i == 0 ? 0 : i - 1, t_.size() - 2);
  s = ns_to_s(t - t_[i]);
  return i;
}

Vector3d GroundTruthSpline::position(TimeNs t) const {
  double b = 0.0;
  const std::size_t i = interval(t, b);
  const double h = ns_to_s(t_[i + 1] - t_[i]), a = h - b;
  return m_[i] * (a * a * a / (6.0 * h)) + m_[i + 1] * (b * b * b / (6.0 * h)) +
         (p_[i] / h - m_[i] * (h / 6.0)) * a + (p_[i + 1] / h - m_[i + 1] * (h / 6.0)) * b;
}

Vector3d GroundTruthSpline::velocity(TimeNs t) const {
  double b = 0.0;
  const std::size_t i = interval(t, b);
  const double h = ns_to_s(t_[i + 1] - t_[i]), a = h - b;
  return -m_[i] * (a * a / (2.0 * h)) + m_[i + 1] * (b * b / (2.0 * h)) + (p_[i + 1] - p_[i]) / h -
         (m_[i + 1] - m_[i]) * (h / 6.0);
}

Vector3d GroundTruthSpline::acceleration(TimeNs t) const {
  double b = 0.0;
  const std::size_t i = interval(t, b);
  const double h = ns_to_s(t_[i + 1] - t_[i]), a = h - b;
  return (m_[i] * a + m_[i + 1] * b) / h;
}

SO3 GroundTruthSpline::orientation(TimeNs t) const {
  double s = 0.0;
  const std::size_t i = interval(t, s);
  return r_[i] * SO3::exp(w_[i] * s);
}

Vector3d GroundTruthSpline::body_rate(TimeNs t) const {
  double s = 0.0;
  const std::size_t i = interval(t, s);
  // On an inner sample the rate jumps; the mean of the two sides makes the trapezoidal
  // integration of IMU samples (the filter's) cancel the jump to first order. Without it the
  // synthetic gyro errs well beyond its white noise, about as much as the real one (docs/fusion.md,
  // "The control experiment").
  if (t == t_[i] && i > 0) return 0.5 * (w_[i - 1] + w_[i]);
  return w_[i];
}

std::vector<io::ImuSample> imu_from_ground_truth(std::vector<GroundTruthSample>& gt,
                                                 const std::vector<TimeNs>& stamps,
                                                 const GroundTruthImuOptions& options,
                                                 std::mt19937_64& rng) {
  const GroundTruthSpline spline(gt);
  const Vector3d g_world(0.0, 0.0, -options.gravity_m_s2);
  const bool start_biased = options.noise_on && gt.front().has_bias;
  Vector3d bg = start_biased ? gt.front().gyro_bias : Vector3d::Zero();
  Vector3d ba = start_biased ? gt.front().accel_bias : Vector3d::Zero();
  std::vector<io::ImuSample> imu;
  std::vector<std::pair<Vector3d, Vector3d>> biases;
  imu.reserve(stamps.size());
  biases.reserve(stamps.size());
  for (const TimeNs t : stamps) {
    if (t < spline.t_begin() || t > spline.t_end()) continue;
    if (!imu.empty() && t <= imu.back().t_ns) {
      throw InputError("synthetic IMU: time stamps not increasing at " + std::to_string(t));
    }
    const double dt = imu.empty() ? 0.0 : ns_to_s(t - imu.back().t_ns);
    // The spline's state as a simulated flight's: the simulator's ideal IMU reads it.
    const FlightPoint point{SE3(spline.orientation(t), spline.position(t)), spline.velocity(t),
                            spline.acceleration(t), spline.body_rate(t)};
    io::ImuSample s = ideal_imu_sample(point, t, g_world);
    if (options.noise_on && dt > 0.0) {
      add_imu_errors(s, bg, ba, options.noise, dt, true, rng);  // the simulator's sensor model
    } else {  // the first sample: its biases, no interval for noise or walk
      s.gyro_rad_s += bg;
      s.accel_m_s2 += ba;
    }
    imu.push_back(s);
    biases.emplace_back(bg, ba);
  }
  if (imu.size() < 2)
    throw InputError("synthetic IMU: fewer than 2 stamps inside the ground truth");
  for (auto& g : gt) {
    g.v_world = spline.velocity(g.t_ns);
    const auto it = std::lower_bound(imu.begin(), imu.end(), g.t_ns,
                                     [](const io::ImuSample& s, TimeNs t) { return s.t_ns < t; });
    const auto k = static_cast<std::size_t>(
        std::min(it - imu.begin(), static_cast<std::ptrdiff_t>(imu.size() - 1)));
    g.gyro_bias = biases[k].first;
    g.accel_bias = biases[k].second;
    g.has_bias = true;
  }
  return imu;
}

}  // namespace kestrel::lab
