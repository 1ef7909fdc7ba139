// Simulated flights, IMU samples and odometry for the fusion's Monte-Carlo consistency tests.
#include "kestrel/lab/fusion_simulation.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace kestrel::lab {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d gaussian3(std::mt19937_64& rng, double sigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vector3d(n(rng), n(rng), n(rng)) * sigma;
}

template <int N>
Eigen::Matrix<double, N, 1> sample_gaussian(const Eigen::Matrix<double, N, N>& cov,
                                            std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix<double, N, 1> z;
  for (int i = 0; i < N; ++i) z(i) = n(rng);
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(cov);
  return llt.matrixL() * z;
}

}  // namespace

SimulatedFlight::SimulatedFlight(std::uint64_t seed) {
  if (seed == 0) return;  // at rest
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double two_pi = 2.0 * std::numbers::pi;
  // amplitude scale per channel, frequency range [Hz]
  const std::array<double, 6> amp = {1.5, 1.5, 0.5, 0.25, 0.25, 0.6};
  for (std::size_t c = 0; c < 6; ++c) {
    for (int k = 0; k < 3; ++k) {
      const double f = 0.05 + 0.35 * u(rng);
      terms_[c].push_back({amp[c] * (0.3 + 0.7 * u(rng)) / (k + 1.0), two_pi * f, two_pi * u(rng)});
    }
  }
  offset_ = {0.0, 0.0, 1.0, 0.0, 0.0, two_pi * u(rng)};
  yaw_rate_ = 0.2 * (u(rng) - 0.5);
}

FlightPoint SimulatedFlight::at(double t) const {
  std::array<double, 6> f{}, df{}, ddf{};
  for (std::size_t c = 0; c < 6; ++c) {
    f[c] = offset_[c];
    for (const Term& term : terms_[c]) {
      const double arg = term.omega * t + term.phase;
      f[c] += term.amplitude * std::sin(arg);
      df[c] += term.amplitude * term.omega * std::cos(arg);
      ddf[c] -= term.amplitude * term.omega * term.omega * std::sin(arg);
    }
  }
  f[5] += yaw_rate_ * t;
  df[5] += yaw_rate_;
  const double r = f[3], p = f[4], y = f[5], dr = df[3], dp = df[4], dy = df[5];
  const Matrix3d R =
      (Eigen::AngleAxisd(y, Vector3d::UnitZ()) * Eigen::AngleAxisd(p, Vector3d::UnitY()) *
       Eigen::AngleAxisd(r, Vector3d::UnitX()))
          .toRotationMatrix();
  FlightPoint pt;
  pt.T_world_body = SE3(SO3::from_matrix(R), Vector3d(f[0], f[1], f[2]));
  pt.v_world = Vector3d(df[0], df[1], df[2]);
  pt.a_world = Vector3d(ddf[0], ddf[1], ddf[2]);
  // Body rates of Z-Y-X Euler angles.
  pt.omega_body = Vector3d(dr - dy * std::sin(p), dp * std::cos(r) + dy * std::sin(r) * std::cos(p),
                           -dp * std::sin(r) + dy * std::cos(r) * std::cos(p));
  return pt;
}

io::ImuSample ideal_imu_sample(const FlightPoint& point, TimeNs t_ns, const Vector3d& g_world) {
  io::ImuSample s;
  s.t_ns = t_ns;
  s.gyro_rad_s = point.omega_body;
  s.accel_m_s2 = point.T_world_body.rotation_matrix().transpose() * (point.a_world - g_world);
  return s;
}

Matrix6d simulated_vo_covariance(const SimulationOptions& sim) {
  const double sr = sim.vo_sigma_rot_deg * std::numbers::pi / 180.0;
  Vector6d d;
  d << Vector3d::Constant(sim.vo_sigma_p_m * sim.vo_sigma_p_m), Vector3d::Constant(sr * sr);
  return d.asDiagonal();
}

void add_imu_errors(io::ImuSample& sample, Vector3d& gyro_bias, Vector3d& accel_bias,
                    const fusion::ImuNoiseDensities& noise, double dt, bool walk,
                    std::mt19937_64& rng) {
  if (walk) {
    gyro_bias += gaussian3(rng, noise.gyro_walk * std::sqrt(dt));
    accel_bias += gaussian3(rng, noise.accel_walk * std::sqrt(dt));
  }
  sample.gyro_rad_s += gyro_bias + gaussian3(rng, noise.gyro_noise / std::sqrt(dt));
  sample.accel_m_s2 += accel_bias + gaussian3(rng, noise.accel_noise / std::sqrt(dt));
}

SimulatedRun simulate_run(const SimulatedFlight& flight, const SimulationOptions& sim,
                          const fusion::FusionOptions& fusion, std::mt19937_64& rng) {
  if (!(sim.imu_rate_hz > 0.0) || !(sim.vo_rate_hz > 0.0) || !(sim.duration_s > 0.0)) {
    throw std::invalid_argument("simulate_run: rates and duration must be positive");
  }
  const Vector3d g(0.0, 0.0, -fusion.gravity_m_s2);
  const TimeNs period = s_to_ns(1.0 / sim.imu_rate_hz);
  const double dt = ns_to_s(period);
  const auto n = static_cast<std::size_t>(sim.duration_s * sim.imu_rate_hz) + 1;
  const auto every = static_cast<std::size_t>(std::llround(sim.imu_rate_hz / sim.vo_rate_hz));
  const fusion::ImuNoiseDensities& nd = fusion.noise;
  SimulatedRun run;
  run.imu.reserve(n);
  if (sim.imu_noise) {
    run.gyro_bias0 = gaussian3(rng, fusion.init_sigma_gyro_bias_rad_s);
    run.accel_bias0 = gaussian3(rng, fusion.init_sigma_accel_bias_m_s2);
  }
  Vector3d bg = run.gyro_bias0, ba = run.accel_bias0;
  const Matrix6d vo_cov = simulated_vo_covariance(sim);
  SE3 T_world_cam_prev;  // the reference frame: the previous one, or the keyframe
  TimeNs t_prev = 0;
  int frames_on_ref = 0;
  const double max_rot_rad = sim.vo_keyframe_max_rot_deg * std::numbers::pi / 180.0;
  for (std::size_t k = 0; k < n; ++k) {
    const TimeNs t_ns = static_cast<TimeNs>(k) * period;
    const FlightPoint pt = flight.at(ns_to_s(t_ns));
    io::ImuSample s = ideal_imu_sample(pt, t_ns, g);
    if (sim.imu_noise) add_imu_errors(s, bg, ba, nd, dt, k > 0, rng);
    run.imu.push_back(s);
    run.gyro_bias.push_back(bg);
    run.accel_bias.push_back(ba);
    if (k % every == 0) {
      const SE3 T_world_cam = pt.T_world_body * sim.T_body_cam;
      if (k > 0) {
        fusion::RelativePoseMeasurement m;
        m.t_ref_ns = t_prev;
        m.t_ns = t_ns;
        m.covariance = vo_cov;
        const Vector6d xi = sample_gaussian<6>(vo_cov, rng);
        const SE3 T_true = T_world_cam_prev.inverse() * T_world_cam;
        m.T_ref_cur = SE3::exp(-xi) * T_true;
        ++frames_on_ref;
        m.starts_new_reference = !sim.vo_keyframes || T_true.so3().log().norm() > max_rot_rad ||
                                 T_true.translation().norm() > sim.vo_keyframe_max_trans_m ||
                                 frames_on_ref >= sim.vo_keyframe_max_frames;
        run.odometry.push_back(m);
      }
      if (k == 0 || run.odometry.back().starts_new_reference) {
        T_world_cam_prev = T_world_cam;
        t_prev = t_ns;
        frames_on_ref = 0;
      }
    }
  }
  return run;
}

fusion::NominalState true_state(const SimulatedFlight& flight, const SimulatedRun& run, TimeNs t_ns,
                                double imu_rate_hz) {
  const FlightPoint pt = flight.at(ns_to_s(t_ns));
  fusion::NominalState x;
  x.t_ns = t_ns;
  x.p_world = pt.T_world_body.translation();
  x.q_world_body = pt.T_world_body.unit_quaternion();
  x.v_world = pt.v_world;
  const auto k = static_cast<std::size_t>(std::llround(ns_to_s(t_ns) * imu_rate_hz));
  if (k < run.gyro_bias.size()) {
    x.gyro_bias_rad_s = run.gyro_bias[k];
    x.accel_bias_m_s2 = run.accel_bias[k];
  }
  x.p_clone_world = x.p_world;
  x.q_world_clone = x.q_world_body;
  x.clone_t_ns = t_ns;
  return x;
}

NeesResult monte_carlo_nees(int runs, const SimulationOptions& sim,
                            const fusion::FusionOptions& fusion_in, std::uint64_t seed,
                            const std::atomic<bool>* stop) {
  if (runs < 1) throw std::invalid_argument("monte_carlo_nees: runs must be >= 1");
  fusion::FusionOptions fusion = fusion_in;
  fusion.T_body_cam = sim.T_body_cam;
  fusion.reorder_window_s = 0.0;
  NeesResult res;
  res.runs = runs;
  std::size_t steps = 0;
  double sq_err = 0.0;
  std::size_t n_err = 0;
  for (int r = 0; r < runs; ++r) {
    if (stop != nullptr && stop->load()) {
      res.runs = r;
      break;
    }
    std::mt19937_64 rng(seed * 1000003ULL + static_cast<std::uint64_t>(r));
    const SimulatedFlight flight(seed + 1 + static_cast<std::uint64_t>(r));
    const SimulatedRun run = simulate_run(flight, sim, fusion, rng);
    fusion::FusionEngine engine(fusion);
    // The initial estimate: the truth moved by a draw from the prior.
    const fusion::NominalState truth0 = true_state(flight, run, 0, sim.imu_rate_hz);
    const fusion::Vector15d e0 = sample_gaussian<15>(fusion.initial_covariance(), rng);
    fusion::VectorXs dx = fusion::VectorXs::Zero();
    dx.head<15>() = -e0;
    dx.segment<3>(fusion::idx::kBg).setZero();  // the bias prior is already in the simulated biases
    dx.segment<3>(fusion::idx::kBa).setZero();
    fusion::NominalState x0 = truth0.boxplus(dx);
    x0.gyro_bias_rad_s.setZero();
    x0.accel_bias_m_s2.setZero();
    engine.initialize(x0);
    if (r == 0) steps = run.odometry.size();
    std::size_t i = 0;
    for (std::size_t k = 0; k < run.odometry.size() && k < steps; ++k) {
      const auto& m = run.odometry[k];
      while (i < run.imu.size() && run.imu[i].t_ns <= m.t_ns) engine.add_imu(run.imu[i++]);
      engine.add_relative_pose(m);
      const auto out = engine.flush(false);
      const fusion::NominalState truth = true_state(flight, run, m.t_ns, sim.imu_rate_hz);
      const fusion::NominalState& est = engine.filter().state();
      const fusion::VectorXs e = truth.boxminus(est);
      const fusion::MatrixXs& P = engine.filter().covariance();
      auto nees = [&](int at) {
        const Eigen::Matrix3d B = P.block<3, 3>(at, at);
        const Vector3d v = e.segment<3>(at);
        return v.dot(B.ldlt().solve(v));
      };
      if (r == 0) {
        res.t_s.push_back(ns_to_s(m.t_ns));
        res.nees_p.push_back(0.0);
        res.nees_theta.push_back(0.0);
        res.nees_v.push_back(0.0);
      }
      res.nees_p[k] += nees(fusion::idx::kP) / runs;
      res.nees_theta[k] += nees(fusion::idx::kTheta) / runs;
      res.nees_v[k] += nees(fusion::idx::kV) / runs;
      sq_err += e.segment<3>(fusion::idx::kP).squaredNorm();
      ++n_err;
    }
  }
  if (res.runs == 0) return res;
  if (res.runs < runs) {  // stopped: the sums were divided by `runs`, not by the runs done
    const double scale = static_cast<double>(runs) / res.runs;
    for (auto* v : {&res.nees_p, &res.nees_theta, &res.nees_v}) {
      for (double& x : *v) x *= scale;
    }
  }
  res.lower_bound = fusion::chi_square_quantile(0.025, 3.0 * res.runs) / res.runs;
  res.upper_bound = fusion::chi_square_quantile(0.975, 3.0 * res.runs) / res.runs;
  auto summarise = [&](const std::vector<double>& v, double& mean, double& inside) {
    mean = 0.0;
    inside = 0.0;
    for (double x : v) {
      mean += x / static_cast<double>(v.size());
      if (x >= res.lower_bound && x <= res.upper_bound)
        inside += 1.0 / static_cast<double>(v.size());
    }
  };
  summarise(res.nees_p, res.mean_p, res.inside_p);
  summarise(res.nees_theta, res.mean_theta, res.inside_theta);
  summarise(res.nees_v, res.mean_v, res.inside_v);
  res.rmse_p_m = n_err ? std::sqrt(sq_err / static_cast<double>(n_err)) : 0.0;
  return res;
}

TimeOffsetRun time_offset_run(const SimulationOptions& sim, const fusion::FusionOptions& fusion_in,
                              double offset_s, std::uint64_t seed, double tolerance_s,
                              double compare_after_s) {
  fusion::FusionOptions fusion = fusion_in;
  fusion.T_body_cam = sim.T_body_cam;
  fusion.reorder_window_s = 0.0;
  std::mt19937_64 rng(seed * 1000003ULL);
  const SimulatedFlight flight(seed + 1);
  SimulatedRun run = simulate_run(flight, sim, fusion, rng);
  // The camera's clock: a frame taken at IMU time t carries the stamp t - t_d.
  const TimeNs shift = s_to_ns(offset_s);
  for (auto& m : run.odometry) {
    m.t_ns -= shift;
    m.t_ref_ns -= shift;
  }
  fusion::FusionEngine engine(fusion);
  fusion::NominalState x0 = true_state(flight, run, 0, sim.imu_rate_hz);
  x0.gyro_bias_rad_s.setZero();
  x0.accel_bias_m_s2.setZero();
  engine.initialize(x0);
  TimeOffsetRun res;
  res.true_offset_s = offset_s;
  double se = 0.0, se_after = 0.0;
  std::size_t n = 0, n_after = 0;
  std::size_t i = 0;
  double last_outside_s = 0.0;
  bool ever_inside = false;
  // The oracle's information about t_d (see TimeOffsetRun): h(d) = T_wc(t_ref + d)^-1 T_wc(t + d)
  // on the frames' stamps, differentiated on the left (the odometry's noise is exp(-xi) T) by a
  // central difference at the true offset.
  const Matrix6d vo_info = simulated_vo_covariance(sim).inverse();
  auto world_cam = [&](TimeNs t_ns, double d) {
    return flight.at(ns_to_s(t_ns) + d).T_world_body * sim.T_body_cam;
  };
  constexpr double kStep = 1e-4;  // s: the flight's fastest term (0.4 Hz) is smooth at this scale
  double information = 1.0 / (fusion.init_sigma_time_offset_s * fusion.init_sigma_time_offset_s);
  for (const auto& m : run.odometry) {
    {
      const SE3 h_plus =
          world_cam(m.t_ref_ns, offset_s + kStep).inverse() * world_cam(m.t_ns, offset_s + kStep);
      const SE3 h_minus =
          world_cam(m.t_ref_ns, offset_s - kStep).inverse() * world_cam(m.t_ns, offset_s - kStep);
      const Vector6d J = (h_plus * h_minus.inverse()).log() / (2.0 * kStep);
      information += J.dot(vo_info * J);
    }
    while (i < run.imu.size() && run.imu[i].t_ns <= m.t_ns) engine.add_imu(run.imu[i++]);
    engine.add_relative_pose(m);
    (void)engine.flush(false);
    if (m.t_ns <= 0) continue;  // before the filter's start
    const fusion::NominalState& est = engine.filter().state();
    const double t = ns_to_s(m.t_ns);
    const double e = (est.p_world - flight.at(t).T_world_body.translation()).squaredNorm();
    se += e;
    ++n;
    if (t >= compare_after_s) {
      se_after += e;
      ++n_after;
    }
    res.t_s.push_back(t);
    res.estimate_s.push_back(est.time_offset_s);
    res.sigma_s.push_back(
        std::sqrt(std::max(0.0, engine.filter().covariance()(fusion::idx::kTd, fusion::idx::kTd))));
    res.oracle_sigma_s.push_back(1.0 / std::sqrt(information));
    if (std::abs(est.time_offset_s - offset_s) >= tolerance_s) {
      last_outside_s = t;
      ever_inside = false;
    } else {
      ever_inside = true;
      if (res.first_within_s < 0.0) res.first_within_s = t;
    }
  }
  res.converged_after_s = ever_inside ? last_outside_s : -1.0;
  res.final_estimate_s = engine.filter().state().time_offset_s;
  res.final_sigma_s =
      std::sqrt(std::max(0.0, engine.filter().covariance()(fusion::idx::kTd, fusion::idx::kTd)));
  res.fused_rmse_m = n ? std::sqrt(se / static_cast<double>(n)) : 0.0;
  res.fused_rmse_after_m = n_after ? std::sqrt(se_after / static_cast<double>(n_after)) : 0.0;
  return res;
}

double value_at(const std::vector<double>& t_s, const std::vector<double>& values, double t) {
  double v = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < t_s.size() && k < values.size() && t_s[k] <= t; ++k) v = values[k];
  return v;
}

}  // namespace kestrel::lab
