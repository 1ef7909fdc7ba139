// The fusion's target experiments on the real EuRoC IMU (see docs/fusion.md).
#include "kestrel/lab/fusion_experiments.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/lab/ground_truth_imu.hpp"

namespace kestrel::lab {
namespace {

using Eigen::Vector3d;
namespace fs = std::filesystem;

constexpr const char* kSyntheticBiasReference = "the synthetic IMU's own (walking) gyro bias";

std::vector<io::ImuSample> read_imu(const fs::path& csv) {
  io::ImuCsvReader reader(csv);
  std::vector<io::ImuSample> out;
  io::ImuSample s;
  while (reader.next(s)) out.push_back(s);
  return out;
}

fusion::FusionOptions with_sensor_noise(fusion::FusionOptions fusion, const fs::path& imu_yaml) {
  fusion.set_imu_noise(io::load_imu_noise(imu_yaml));
  return fusion;
}

// The ground truth nearest to t (within 2.5 ms), or nullptr.
const GroundTruthSample* gt_at(const std::map<TimeNs, std::size_t>& index,
                               const std::vector<GroundTruthSample>& gt, TimeNs t) {
  auto it = index.lower_bound(t - 2'500'000);
  if (it == index.end() || std::llabs(it->first - t) > 2'500'000) return nullptr;
  return &gt[it->second];
}

double rotation_error_deg(const SE3& a, const SE3& b) {
  return (a.so3().inverse() * b.so3()).angle() * kRadToDeg;
}

// The largest position error against the ground truth of IMU-only dead reckoning from x over
// (x.t_ns, t_end], integrated as the filter does (the mean of consecutive samples).
double dead_reckoning_max_error(fusion::NominalState x, TimeNs t_end,
                                const std::vector<io::ImuSample>& imu,
                                const std::map<TimeNs, std::size_t>& index,
                                const std::vector<GroundTruthSample>& gt, const Vector3d& g_world) {
  auto k = static_cast<std::size_t>(
      std::upper_bound(imu.begin(), imu.end(), x.t_ns,
                       [](TimeNs t, const io::ImuSample& s) { return t < s.t_ns; }) -
      imu.begin());
  if (k == 0) return 0.0;
  --k;  // imu[k].t_ns <= x.t_ns < imu[k + 1].t_ns
  double max_error = 0.0;
  for (; k + 1 < imu.size() && imu[k + 1].t_ns <= t_end; ++k) {
    const double dt = ns_to_s(imu[k + 1].t_ns - std::max(imu[k].t_ns, x.t_ns));
    if (dt <= 0.0) continue;
    const fusion::ImuReading m{0.5 * (imu[k].gyro_rad_s + imu[k + 1].gyro_rad_s),
                               0.5 * (imu[k].accel_m_s2 + imu[k + 1].accel_m_s2)};
    x = fusion::StochasticCloningEkf::propagate_nominal(x, m, dt, g_world);
    x.t_ns = imu[k + 1].t_ns;
    if (const GroundTruthSample* g = gt_at(index, gt, x.t_ns)) {
      max_error = std::max(max_error, (x.p_world - g->T_world_body.translation()).norm());
    }
  }
  return max_error;
}

// The IMU against the ground truth over consecutive windows of window_s (see ImuConsistency).
EurocExperimentResult::ImuConsistency imu_consistency(const std::vector<io::ImuSample>& imu,
                                                      const std::vector<GroundTruthSample>& gt,
                                                      const fusion::ImuNoiseDensities& yaml,
                                                      const Vector3d& g_world, double window_s) {
  EurocExperimentResult::ImuConsistency c;
  const GroundTruthSpline spline(gt);
  const TimeNs window = s_to_ns(window_s);
  double se_a = 0.0, se_g = 0.0;
  std::size_t k = 0;
  for (TimeNs t0 = spline.t_begin(); t0 + window <= spline.t_end(); t0 += window) {
    const TimeNs t1 = t0 + window;
    while (k < imu.size() && imu[k].t_ns < t0) ++k;
    if (k + 1 >= imu.size() || imu[k + 1].t_ns > t1) break;
    // The biases of the ground truth sample nearest the window's start (zero without them).
    const auto it = std::lower_bound(
        gt.begin(), gt.end(), t0, [](const GroundTruthSample& g, TimeNs t) { return g.t_ns < t; });
    const GroundTruthSample& ref = it == gt.end() ? gt.back() : *it;
    const Vector3d bg = ref.has_bias ? ref.gyro_bias : Vector3d::Zero();
    const Vector3d ba = ref.has_bias ? ref.accel_bias : Vector3d::Zero();
    SO3 R = spline.orientation(imu[k].t_ns);
    Vector3d dv = Vector3d::Zero();
    std::size_t j = k;
    for (; j + 1 < imu.size() && imu[j + 1].t_ns <= t1; ++j) {
      const double dt = ns_to_s(imu[j + 1].t_ns - imu[j].t_ns);
      const Vector3d w = 0.5 * (imu[j].gyro_rad_s + imu[j + 1].gyro_rad_s) - bg;
      const Vector3d a = 0.5 * (imu[j].accel_m_s2 + imu[j + 1].accel_m_s2) - ba;
      // The specific force rotated by the ground truth's own midpoint attitude, so that only
      // the accelerometer is compared here (the gyro separately below).
      const SO3 R_mid = spline.orientation(imu[j].t_ns + (imu[j + 1].t_ns - imu[j].t_ns) / 2);
      dv += (R_mid * a + g_world) * dt;
      R = R * SO3::exp(w * dt);
    }
    const double span = ns_to_s(imu[j].t_ns - imu[k].t_ns);
    if (span < 0.5 * window_s) break;
    const Vector3d ea = (dv - (spline.velocity(imu[j].t_ns) - spline.velocity(imu[k].t_ns))) / span;
    const Vector3d eg = (spline.orientation(imu[j].t_ns).inverse() * R).log() / span;
    se_a += ea.squaredNorm();
    se_g += eg.squaredNorm();
    ++c.windows;
    k = j;
  }
  if (c.windows > 0) {
    c.accel_rms_m_s2 = std::sqrt(se_a / c.windows);
    c.gyro_rms_rad_s = std::sqrt(se_g / c.windows);
  }
  c.accel_yaml_m_s2 = std::sqrt(3.0) * yaml.accel_noise / std::sqrt(window_s);
  c.gyro_yaml_rad_s = std::sqrt(3.0) * yaml.gyro_noise / std::sqrt(window_s);
  return c;
}

// The state run_euroc_experiment's steps pass on: the IMU and ground truth the run uses (the
// real ones, or the synthetic IMU's), the filter's options, the odometry's frames and noise,
// and the filter's start.
struct EurocRun {
  EurocRun(const std::vector<io::ImuSample>& imu, const std::vector<GroundTruthSample>& gt,
           fusion::FusionOptions fusion_options, const EurocExperimentOptions& options)
      : real_imu(imu), real_gt(gt), fusion(std::move(fusion_options)), opt(options) {}

  [[nodiscard]] const std::vector<io::ImuSample>& imu() const {
    return opt.synthetic_imu ? synthetic_imu : real_imu;
  }
  [[nodiscard]] const std::vector<GroundTruthSample>& gt() const {
    return opt.synthetic_imu ? synthetic_gt : real_gt;
  }
  [[nodiscard]] const GroundTruthSample& first_frame() const { return gt()[frames[0]]; }

  const std::vector<io::ImuSample>& real_imu;
  const std::vector<GroundTruthSample>& real_gt;
  fusion::FusionOptions fusion;
  const EurocExperimentOptions& opt;
  std::vector<io::ImuSample> synthetic_imu;
  std::vector<GroundTruthSample> synthetic_gt;
  fusion::ImuNoiseDensities yaml_noise;  // the filter's, before the options' scales
  std::map<TimeNs, std::size_t> index;   // ground truth by time stamp
  std::vector<std::size_t> frames;       // the odometry's frames (ground-truth samples)
  std::vector<Vector6d> noise;           // the odometry's noise per frame
  Matrix6d cov;                          // and its covariance
  fusion::NominalState x0;
  TimeNs gap_lo = 0, gap_hi = 0;
};

// The IMU and ground truth the run uses, the filter's noise as the options scale it, and the
// ground truth's index.
void load_inputs(EurocRun& run) {
  const EurocExperimentOptions& opt = run.opt;
  fusion::FusionOptions& fusion = run.fusion;
  // The control experiment swaps in an IMU synthesised from the ground truth, with its own
  // random stream (the odometry's noise is drawn from `seed` as with the real IMU).
  if (opt.synthetic_imu) {
    std::vector<TimeNs> stamps;
    stamps.reserve(run.real_imu.size());
    for (const auto& s : run.real_imu) stamps.push_back(s.t_ns);
    run.synthetic_gt = run.real_gt;
    GroundTruthImuOptions gio;
    gio.noise = fusion.noise;
    gio.gravity_m_s2 = fusion.gravity_m_s2;
    std::seed_seq seq{opt.seed, std::uint64_t{0x1A2B3C4D}};
    std::mt19937_64 imu_rng(seq);
    run.synthetic_imu = imu_from_ground_truth(run.synthetic_gt, stamps, gio, imu_rng);
  }
  run.yaml_noise = fusion.noise;  // before the scales below
  fusion.reorder_window_s = 0.0;
  // The white noise: the in-flight inflation set_imu_noise() gave the real IMU, a given scale
  // in its place, or none for the synthetic IMU (it draws exactly the YAML's densities).
  if (opt.imu_noise_scale > 0.0) {
    fusion.imu_noise_inflation = opt.imu_noise_scale;
  } else if (opt.synthetic_imu) {
    fusion.imu_noise_inflation = 1.0;
  }
  fusion.noise.gyro_walk *= opt.imu_walk_scale;
  fusion.noise.accel_walk *= opt.imu_walk_scale;
  const std::vector<GroundTruthSample>& gt = run.gt();
  for (std::size_t i = 0; i < gt.size(); ++i) run.index.emplace(gt[i].t_ns, i);
}

// Measurement frames: ground-truth samples at vo_rate_hz inside the IMU's span.
void select_frames(EurocRun& run, const std::string& name) {
  const std::vector<io::ImuSample>& imu = run.imu();
  const std::vector<GroundTruthSample>& gt = run.gt();
  const double gt_dt =
      ns_to_s(gt[gt.size() - 1].t_ns - gt[0].t_ns) / static_cast<double>(gt.size() - 1);
  const auto step = std::max<std::size_t>(
      1, static_cast<std::size_t>(std::llround(1.0 / (gt_dt * run.opt.vo_rate_hz))));
  for (std::size_t i = 0; i < gt.size(); i += step) {
    if (gt[i].t_ns > imu.front().t_ns && gt[i].t_ns <= imu.back().t_ns) run.frames.push_back(i);
  }
  if (run.frames.size() < 3) throw InputError(name + ": ground truth and IMU hardly overlap");
}

// Noisy camera relative poses, T_meas = exp(-xi) T_true, xi ~ N(0, Sigma), one draw per
// frame (the same draws with and without the gap).
void draw_odometry_noise(EurocRun& run) {
  std::mt19937_64 rng(run.opt.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sr = run.opt.vo_sigma_rot_deg / kRadToDeg;
  Vector6d sigma;
  sigma << Vector3d::Constant(run.opt.vo_sigma_p_m), Vector3d::Constant(sr);
  run.cov = sigma.array().square().matrix().asDiagonal();
  run.noise.resize(run.frames.size());
  for (auto& xi : run.noise) {
    for (int j = 0; j < 6; ++j) xi(j) = sigma(j) * normal(rng);
  }
}

// The odometry's measurements, skipping frames in [gap_lo, gap_hi) when given: after a gap
// the odometry restarts, its first frame only becomes the reference (t_ref = t, as the
// pipeline reports a first frame).
std::vector<fusion::RelativePoseMeasurement> make_measurements(const EurocRun& run, TimeNs gap_lo,
                                                               TimeNs gap_hi) {
  const EurocExperimentOptions& opt = run.opt;
  const std::vector<GroundTruthSample>& gt = run.gt();
  const std::vector<std::size_t>& frames = run.frames;
  const SE3& T_bc = run.fusion.T_body_cam;
  const double max_rot_rad = opt.vo_keyframe_max_rot_deg / kRadToDeg;
  std::vector<fusion::RelativePoseMeasurement> out;
  std::size_t ref = 0;
  int frames_on_ref = 0;
  bool restart = false;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    const TimeNs t = gt[frames[k]].t_ns;
    if (t > gap_lo && t <= gap_hi) {
      restart = true;
      continue;
    }
    fusion::RelativePoseMeasurement m;
    m.t_ns = t;
    m.covariance = run.cov;
    if (restart) {
      m.t_ref_ns = t;
      m.T_ref_cur = SE3();
      out.push_back(m);
      ref = k;
      frames_on_ref = 0;
      restart = false;
      continue;
    }
    const std::size_t r = opt.vo_keyframes ? ref : k - 1;
    const SE3 T_true =
        (gt[frames[r]].T_world_body * T_bc).inverse() * (gt[frames[k]].T_world_body * T_bc);
    m.t_ref_ns = gt[frames[r]].t_ns;
    m.T_ref_cur = SE3::exp(-run.noise[k]) * T_true;
    ++frames_on_ref;
    m.starts_new_reference = !opt.vo_keyframes || T_true.so3().log().norm() > max_rot_rad ||
                             T_true.translation().norm() > opt.vo_keyframe_max_trans_m ||
                             frames_on_ref >= opt.vo_keyframe_max_frames;
    if (m.starts_new_reference) {
      ref = k;
      frames_on_ref = 0;
    }
    out.push_back(m);
  }
  return out;
}

// The filter's start: the first frame's ground-truth pose and velocity, and the gap's span
// after it.
void initial_state(EurocRun& run) {
  const GroundTruthSample& g0 = run.first_frame();
  fusion::NominalState& x0 = run.x0;
  x0.t_ns = g0.t_ns;
  x0.p_world = g0.T_world_body.translation();
  x0.q_world_body = g0.T_world_body.unit_quaternion();
  x0.v_world = g0.v_world;
  // Static start: the gyro bias is the mean rate over the IMU samples before the first pose,
  // when they pass the still test; the ground truth is not used for it. Otherwise zero biases
  // with the wide prior of `fusion`.
  if (run.opt.static_gyro_bias_init) {
    std::vector<io::ImuSample> still;
    for (const auto& s : run.imu()) {
      if (s.t_ns <= g0.t_ns) still.push_back(s);
    }
    if (const auto xs = fusion::static_initial_state(still, run.fusion)) {
      x0.gyro_bias_rad_s = xs->gyro_bias_rad_s;
      run.fusion.init_sigma_gyro_bias_rad_s = run.opt.static_gyro_bias_sigma_rad_s;
    }
  }
  run.gap_lo = g0.t_ns + s_to_ns(run.opt.gap_start_s);
  run.gap_hi = run.gap_lo + s_to_ns(run.opt.gap_s);
}

// The filter on the whole IMU and the measurements: its states at the odometry's time stamps,
// or at the IMU's rate.
std::vector<fusion::FusedState> run_filter(const EurocRun& run,
                                           const std::vector<fusion::RelativePoseMeasurement>& meas,
                                           bool imu_rate, fusion::FusionCounters* counters) {
  fusion::FusionEngine engine(run.fusion);
  engine.initialize(run.x0);
  for (const auto& s : run.imu()) engine.add_imu(s);
  for (const auto& m : meas) engine.add_relative_pose(m);
  auto out = engine.flush(imu_rate);
  if (counters) *counters = engine.counters();
  return out;
}

// What the run is: its name, the IMU's agreement with the ground truth, the measurements and
// the span of the frames.
EurocExperimentResult summarise_run(const EurocRun& run, const std::string& name,
                                    std::size_t measurements) {
  EurocExperimentResult r;
  r.name = name;
  r.imu_consistency = imu_consistency(run.imu(), run.gt(), run.yaml_noise,
                                      Vector3d(0.0, 0.0, -run.fusion.gravity_m_s2), 1.0);
  r.measurements = measurements;
  r.duration_s = ns_to_s(run.gt()[run.frames.back()].t_ns - run.first_frame().t_ns);
  return r;
}

// The fused run's position and rotation RMSE at the odometry time stamps.
void score_fused(const EurocRun& run, const std::vector<fusion::FusedState>& fused,
                 EurocExperimentResult& r) {
  double se = 0.0, re = 0.0;
  std::size_t n = 0;
  for (const fusion::FusedState& f : fused) {
    if (!f.at_odometry) continue;
    const GroundTruthSample* g = gt_at(run.index, run.gt(), f.t_ns);
    if (g == nullptr) continue;
    const SE3 T_fused = f.state.T_world_body();
    se += (T_fused.translation() - g->T_world_body.translation()).squaredNorm();
    re += std::pow(rotation_error_deg(T_fused, g->T_world_body), 2);
    ++n;
  }
  r.fused_rmse_m = std::sqrt(se / static_cast<double>(n));
  r.fused_rot_rmse_deg = std::sqrt(re / static_cast<double>(n));
}

// The baseline: the same measurements chained, scored where the fused run is. The camera pose
// is the chained reference times the latest relative pose; the chain moves to a frame when it
// becomes the reference.
void score_chained(const EurocRun& run, const std::vector<fusion::FusedState>& fused,
                   const std::vector<fusion::RelativePoseMeasurement>& meas,
                   EurocExperimentResult& r) {
  const SE3& T_bc = run.fusion.T_body_cam;
  SE3 chain_ref_w_c = run.first_frame().T_world_body * T_bc;
  SE3 chain_w_c = chain_ref_w_c;
  double se = 0.0, re = 0.0;
  std::size_t n = 0;
  std::size_t mi = 0;
  for (const fusion::FusedState& f : fused) {
    if (!f.at_odometry) continue;
    while (mi < meas.size() && meas[mi].t_ns <= f.t_ns) {
      chain_w_c = chain_ref_w_c * meas[mi].T_ref_cur;
      if (meas[mi++].starts_new_reference) chain_ref_w_c = chain_w_c;
    }
    const GroundTruthSample* g = gt_at(run.index, run.gt(), f.t_ns);
    if (g == nullptr) continue;
    const SE3 T_chain = chain_w_c * T_bc.inverse();
    se += (T_chain.translation() - g->T_world_body.translation()).squaredNorm();
    re += std::pow(rotation_error_deg(T_chain, g->T_world_body), 2);
    ++n;
  }
  r.chained_rmse_m = std::sqrt(se / static_cast<double>(n));
  r.chained_rot_rmse_deg = std::sqrt(re / static_cast<double>(n));
}

// The fused run's gyro bias against the ground truth's, from bias_check_after_s on, and its
// last value.
void check_gyro_bias(const EurocRun& run, const std::vector<fusion::FusedState>& fused,
                     EurocExperimentResult& r) {
  const TimeNs t_check = run.first_frame().t_ns + s_to_ns(run.opt.bias_check_after_s);
  bool checked = false;
  for (const fusion::FusedState& f : fused) {
    if (!f.at_odometry) continue;
    const GroundTruthSample* g = gt_at(run.index, run.gt(), f.t_ns);
    if (g == nullptr) continue;
    if (g->has_bias && f.t_ns >= t_check) {
      const double e = (f.state.gyro_bias_rad_s - g->gyro_bias).norm();
      if (!checked) {
        r.gyro_bias_error_at_check = e;
        r.gyro_bias_sigma_at_check = f.sigma_gyro_bias.norm();
      }
      checked = true;
      r.gyro_bias_error_max_after = std::max(r.gyro_bias_error_max_after, e);
    }
    r.gyro_bias_final = f.state.gyro_bias_rad_s;
    r.time_offset_final_s = f.state.time_offset_s;
    r.time_offset_sigma_final_s = f.sigma_time_offset_s;
    r.extrinsic_rotation_final_deg = SO3(f.state.q_body_odom).log() * kRadToDeg;
    r.extrinsic_rotation_sigma_final_deg = f.sigma_extrinsic_rotation_rad * kRadToDeg;
  }
  r.gyro_bias_checked = checked;
}

// The gap run (IMU-rate output): errors wherever a ground-truth sample exists, in the gap and
// over the whole run.
void score_gap(const EurocRun& run, const std::vector<fusion::FusedState>& gapped,
               EurocExperimentResult& r) {
  double error_at_start = -1.0;
  for (const fusion::FusedState& f : gapped) {
    const GroundTruthSample* g = gt_at(run.index, run.gt(), f.t_ns);
    if (g == nullptr || std::llabs(g->t_ns - f.t_ns) > 1'000'000) continue;
    const double e = (f.state.p_world - g->T_world_body.translation()).norm();
    r.gap_run_max_error_m = std::max(r.gap_run_max_error_m, e);
    if (f.t_ns >= run.gap_lo && error_at_start < 0.0) error_at_start = e;
    if (f.t_ns >= run.gap_lo && f.t_ns <= run.gap_hi) {
      r.gap_max_error_m = std::max(r.gap_max_error_m, e);
      r.gap_max_sigma_p_m = std::max(r.gap_max_sigma_p_m, f.sigma.head<3>().norm());
      const Vector3d e3 = (f.state.p_world - g->T_world_body.translation()).cwiseAbs();
      ++r.gap_samples;
      if ((e3.array() <= 3.0 * f.sigma.head<3>().array()).all()) ++r.gap_samples_inside_3sigma;
      if (f.flags & fusion::kFlagVoDropout) r.gap_flag_raised = true;
    }
  }
  r.gap_error_growth_m = r.gap_max_error_m - std::max(0.0, error_at_start);
}

// Where the gap's error comes from: the first IMU-rate state after the last update before the
// gap (one IMU step into it) that has a ground-truth sample with biases.
void decompose_gap(const EurocRun& run, const std::vector<fusion::FusedState>& gapped,
                   EurocExperimentResult& r) {
  const std::vector<GroundTruthSample>& gt = run.gt();
  const fusion::FusedState* start = nullptr;
  const GroundTruthSample* truth = nullptr;
  for (const fusion::FusedState& f : gapped) {
    if (f.t_ns < run.gap_lo + 5'000'000) continue;
    truth = gt_at(run.index, gt, f.t_ns);
    if (truth != nullptr) {
      start = &f;
      break;
    }
  }
  if (start == nullptr || !truth->has_bias || start->t_ns >= run.gap_hi) return;
  auto& d = r.gap_decomposition;
  const fusion::NominalState& xf = start->state;
  fusion::NominalState xt = xf;
  xt.p_world = truth->T_world_body.translation();
  xt.q_world_body = truth->T_world_body.unit_quaternion();
  xt.v_world = truth->v_world;
  xt.gyro_bias_rad_s = truth->gyro_bias;
  xt.accel_bias_m_s2 = truth->accel_bias;
  d.measured = true;
  d.dp = xf.p_world - xt.p_world;
  d.dv = xf.v_world - xt.v_world;
  d.dtheta_deg = (SO3(xt.q_world_body).inverse() * SO3(xf.q_world_body)).log() * kRadToDeg;
  d.d_accel_bias = xf.accel_bias_m_s2 - xt.accel_bias_m_s2;
  d.sigma_v = start->sigma.segment<3>(6);
  d.sigma_theta_deg = start->sigma.segment<3>(3) * kRadToDeg;
  const Vector3d g_world(0.0, 0.0, -run.fusion.gravity_m_s2);
  auto dead_reckon = [&](const fusion::NominalState& x) {
    return dead_reckoning_max_error(x, run.gap_hi, run.imu(), run.index, gt, g_world);
  };
  d.truth = dead_reckon(xt);
  fusion::NominalState x = xt;
  x.p_world = xf.p_world;
  d.with_position = dead_reckon(x);
  x = xt;
  x.v_world = xf.v_world;
  d.with_velocity = dead_reckon(x);
  x = xt;
  x.q_world_body = xf.q_world_body;
  d.with_attitude = dead_reckon(x);
  x = xt;
  x.gyro_bias_rad_s = xf.gyro_bias_rad_s;
  x.accel_bias_m_s2 = xf.accel_bias_m_s2;
  d.with_biases = dead_reckon(x);
  d.filter = dead_reckon(xf);
}

}  // namespace

EurocExperimentResult run_euroc_experiment(const std::string& name,
                                           const std::vector<io::ImuSample>& real_imu,
                                           const std::vector<GroundTruthSample>& real_gt,
                                           fusion::FusionOptions fusion,
                                           const EurocExperimentOptions& opt) {
  if (real_imu.size() < 2 || real_gt.size() < 3) {
    throw InputError(name + ": not enough IMU or ground truth");
  }
  // The diagnostics' IMU and ground truth (EurocExperimentOptions): copies, only when asked.
  std::vector<io::ImuSample> imu_mod;
  std::vector<GroundTruthSample> gt_mod;
  const bool modify_imu = !opt.imu_rotation_deg.isZero() || opt.gyro_scale != Vector3d::Ones();
  if (modify_imu) {
    const Eigen::Matrix3d R = SO3::exp(opt.imu_rotation_deg / kRadToDeg).matrix();
    imu_mod = real_imu;
    for (auto& s : imu_mod) {
      s.gyro_rad_s = R * opt.gyro_scale.cwiseProduct(s.gyro_rad_s);
      s.accel_m_s2 = R * s.accel_m_s2;
    }
  }
  if (!opt.world_rotation_deg.isZero()) {
    const SO3 Rw = SO3::exp(opt.world_rotation_deg / kRadToDeg);
    gt_mod = real_gt;
    for (auto& g : gt_mod) {
      g.T_world_body = SE3(Rw, Vector3d::Zero()) * g.T_world_body;
      g.v_world = Rw * g.v_world;
    }
  }
  EurocRun run(modify_imu ? imu_mod : real_imu, gt_mod.empty() ? real_gt : gt_mod,
               std::move(fusion), opt);
  load_inputs(run);
  select_frames(run, name);
  draw_odometry_noise(run);
  const std::vector<fusion::RelativePoseMeasurement> meas = make_measurements(run, 0, 0);
  initial_state(run);
  EurocExperimentResult r = summarise_run(run, name, meas.size());

  // 1. No gap: errors at the odometry time stamps, fused and chained.
  const auto fused = run_filter(run, meas, false, &r.counters);
  score_fused(run, fused, r);
  score_chained(run, fused, meas, r);
  check_gyro_bias(run, fused, r);

  // 2. A gap: IMU-rate output, errors wherever a ground-truth sample exists.
  const auto gapped =
      run_filter(run, make_measurements(run, run.gap_lo, run.gap_hi), true, nullptr);
  score_gap(run, gapped, r);
  decompose_gap(run, gapped, r);
  return r;
}

EurocExperimentResult run_v1_02(const fs::path& seq, const fusion::FusionOptions& fusion_in,
                                const EurocExperimentOptions& options) {
  const fs::path mav0 = fs::exists(seq / "mav0") ? seq / "mav0" : seq;
  fusion::FusionOptions fusion = with_sensor_noise(fusion_in, mav0 / "imu0" / "sensor.yaml");
  fusion.T_body_cam = SE3();  // relative poses of the body itself
  const auto imu = read_imu(mav0 / "imu0" / "data.csv");
  std::vector<GroundTruthSample> gt;
  for (const auto& s : io::read_euroc_state_groundtruth(mav0 / "gt0" / "data.csv")) {
    gt.push_back({s.t_ns, s.T_world_body, s.v_world, s.gyro_bias, s.accel_bias, true});
  }
  auto r = run_euroc_experiment("V1_02_medium (gt0 state, body relative poses)", imu, gt, fusion,
                                options);
  r.bias_reference =
      options.synthetic_imu ? kSyntheticBiasReference : "gt0 gyro bias (EuRoC state ground truth)";
  return r;
}

EurocExperimentResult run_v1_01(const fs::path& seq, const fusion::FusionOptions& fusion_in,
                                const EurocExperimentOptions& options) {
  const fs::path mav0 = fs::exists(seq / "mav0") ? seq / "mav0" : seq;
  fusion::FusionOptions fusion = with_sensor_noise(fusion_in, mav0 / "imu0" / "sensor.yaml");
  const io::CameraFile cam = io::load_camera_file(mav0 / "cam0" / "sensor.yaml");
  if (!cam.T_body_sensor) throw InputError(mav0 / "cam0" / "sensor.yaml", "T_BS", "missing");
  fusion.T_body_cam = *cam.T_body_sensor;
  const auto imu = read_imu(mav0 / "imu0" / "data.csv");
  const Trajectory cam_gt = io::read_euroc_trajectory(mav0 / "groundtruth_cam0" / "data.csv");
  // The file's columns are p_x p_y p_z q_w q_x q_y q_z as documented, p the position of cam0
  // in the world, but the quaternion read as a Hamilton (w, x, y, z) is R_cam_world, the
  // INVERSE of the camera's orientation (equivalently: a JPL quaternion of R_world_cam).
  // With q^-1 and T_BS the relative rotations agree with the integrated gyro and the specific
  // force from the positions' second differences with the accelerometer; read as R_world_cam
  // neither does (docs/fusion.md, "V1_01 ground truth", has the figures). Body ground truth
  // T_w_b = T_w_c T_BS^-1; velocity by central differences.
  std::vector<GroundTruthSample> gt(cam_gt.size());
  for (std::size_t i = 0; i < cam_gt.size(); ++i) {
    gt[i].t_ns = cam_gt[i].t_ns;
    const SE3 T_world_cam(cam_gt[i].T_world_body.so3().inverse(),
                          cam_gt[i].T_world_body.translation());
    gt[i].T_world_body = T_world_cam * fusion.T_body_cam.inverse();
  }
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(i + 1, gt.size() - 1);
    gt[i].v_world = (gt[b].T_world_body.translation() - gt[a].T_world_body.translation()) /
                    ns_to_s(gt[b].t_ns - gt[a].t_ns);
  }
  // Bias reference: the mean rate over the still samples before the ground truth starts
  // (the MAV stands on the floor before take-off), when they pass the static test.
  std::vector<io::ImuSample> still;
  for (const auto& s : imu) {
    if (s.t_ns < gt.front().t_ns) still.push_back(s);
  }
  std::string reference = "none (IMU not still before the ground truth starts)";
  if (const auto x = fusion::static_initial_state(still, fusion)) {
    for (auto& g : gt) {
      g.gyro_bias = x->gyro_bias_rad_s;
      g.has_bias = true;
    }
    std::ostringstream s;
    s << "mean gyro over the " << still.size() << " still IMU samples before the ground truth ("
      << x->gyro_bias_rad_s.transpose() << " rad/s)";
    reference = s.str();
  }
  auto r = run_euroc_experiment("V1_01_easy (cam0 ground truth, camera relative poses via T_BS)",
                                imu, gt, fusion, options);
  r.bias_reference = options.synthetic_imu ? kSyntheticBiasReference : reference;
  return r;
}

std::string format_result(const EurocExperimentResult& r) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(4);
  s << r.name << ": " << r.duration_s << " s, " << r.measurements << " relative poses\n"
    << "  position RMSE: fused " << r.fused_rmse_m << " m, chained " << r.chained_rmse_m
    << " m, ratio " << r.fused_rmse_m / r.chained_rmse_m
    << " (issue: median over draws <= 0.4, worst <= 0.7)\n"
    << "  rotation RMSE: fused " << r.fused_rot_rmse_deg << " deg, chained "
    << r.chained_rot_rmse_deg << " deg\n"
    << "  gyro bias error: ";
  if (r.gyro_bias_checked) {
    s << r.gyro_bias_error_at_check << " rad/s at 20 s, max after " << r.gyro_bias_error_max_after
      << " rad/s (target <= 0.003; the filter's own 1-sigma at 20 s " << r.gyro_bias_sigma_at_check
      << ")";
  } else {
    s << "not measured";
  }
  s << "; reference: " << r.bias_reference << "\n  final gyro bias "
    << r.gyro_bias_final.transpose()
    << "\n  camera-IMU time offset at the end: " << 1e3 * r.time_offset_final_s << " ms (1-sigma "
    << 1e3 * r.time_offset_sigma_final_s << " ms)\n"
    << "  odometry-IMU rotation at the end: " << r.extrinsic_rotation_final_deg.transpose()
    << " deg (1-sigma " << r.extrinsic_rotation_sigma_final_deg.transpose() << ")\n"
    << "  2 s gap: max position error in the gap " << r.gap_max_error_m << " m (growth "
    << r.gap_error_growth_m << " m; issue: median over draws <= 0.3), max over the run "
    << r.gap_run_max_error_m << " m, vo_dropout flagged " << (r.gap_flag_raised ? "yes" : "NO")
    << ", 1-sigma position in the gap up to " << r.gap_max_sigma_p_m << " m\n";
  if (const auto& d = r.gap_decomposition; d.measured) {
    s << "  gap start, filter - ground truth: velocity " << d.dv.transpose() << " m/s (1-sigma "
      << d.sigma_v.transpose() << "), attitude " << d.dtheta_deg.transpose()
      << " deg (body; 1-sigma " << d.sigma_theta_deg.transpose() << "), accel bias "
      << d.d_accel_bias.transpose()
      << " m/s^2\n  IMU alone over the gap from the ground truth (max error, m): as is " << d.truth
      << "; with the filter's position " << d.with_position << ", velocity " << d.with_velocity
      << ", attitude " << d.with_attitude << ", biases " << d.with_biases
      << "; the filter's whole state " << d.filter << "\n";
  }
  if (const auto& c = r.imu_consistency; c.windows > 0) {
    s << "  IMU vs ground truth over " << c.windows << " 1 s windows (rms of the mean error): "
      << "accel " << c.accel_rms_m_s2 << " m/s^2 (the YAML's white noise alone "
      << c.accel_yaml_m_s2 << "), gyro " << c.gyro_rms_rad_s << " rad/s (" << c.gyro_yaml_rad_s
      << ")\n";
  }
  s << "  counters: " << r.counters.describe() << "\n";
  return s.str();
}

namespace {

EurocSeedSummary::Spread spread(std::vector<double> v, double target, bool strict) {
  EurocSeedSummary::Spread out;
  if (v.empty()) return out;
  for (const double x : v) out.meeting += (strict ? x < target : x <= target) ? 1 : 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  out.median = n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  out.min = v.front();
  out.max = v.back();
  const double pos = 0.9 * static_cast<double>(n - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, n - 1);
  out.p90 = v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
  return out;
}

}  // namespace

EurocSeedSummary summarise_draws(const std::vector<EurocExperimentResult>& results) {
  if (results.empty()) throw std::invalid_argument("summarise_draws: no results");
  EurocSeedSummary s;
  s.name = results.front().name;
  s.draws = static_cast<int>(results.size());
  std::vector<double> ratio, at_check, max_after, gap;
  for (const auto& r : results) {
    ratio.push_back(r.fused_rmse_m / r.chained_rmse_m);
    if (r.fused_rmse_m > r.chained_rmse_m) ++s.ratio_above_one;
    s.gap_samples += r.gap_samples;
    s.gap_samples_inside_3sigma += r.gap_samples_inside_3sigma;
    gap.push_back(r.gap_max_error_m);
    s.mean_fused_m += r.fused_rmse_m / static_cast<double>(results.size());
    s.mean_chained_m += r.chained_rmse_m / static_cast<double>(results.size());
    if (r.gyro_bias_checked) {
      at_check.push_back(r.gyro_bias_error_at_check);
      max_after.push_back(r.gyro_bias_error_max_after);
    }
  }
  s.bias_draws = static_cast<int>(at_check.size());
  s.ratio = spread(ratio, 0.7, false);
  s.bias_at_check = spread(at_check, 0.005, false);
  s.bias_max_after = spread(max_after, 0.005, false);
  s.gap_max_error = spread(gap, 0.45, false);
  return s;
}

std::string format_summary(const EurocSeedSummary& s) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(4);
  // The targets are over the draws (median, 90th percentile, worst); each line says
  // them and whether they hold, and how many single draws are within the per-draw bound.
  auto yes = [](bool ok) { return ok ? "MET" : "MISSED"; };
  auto line = [&](const char* what, const EurocSeedSummary::Spread& x, int of,
                  const char* per_draw) {
    o << "  " << what << ": median " << x.median << ", p90 " << x.p90 << ", min " << x.min
      << ", max " << x.max << "; " << per_draw << " in " << x.meeting << " of " << of << " draws\n";
  };
  o << s.name << ", " << s.draws << " noise draws (seeds):\n";
  line("fused/chained ratio", s.ratio, s.draws, "<= 0.7");
  o << "    target median <= 0.4: " << yes(s.ratio.median <= 0.4)
    << "; worst <= 0.7: " << yes(s.ratio.max <= 0.7)
    << "; never above 1: " << yes(s.ratio_above_one == 0) << " (" << s.ratio_above_one
    << " above)\n"
    << "    (mean fused " << s.mean_fused_m << " m / mean chained " << s.mean_chained_m
    << " m = " << s.mean_fused_m / s.mean_chained_m << ")\n";
  if (s.bias_draws > 0) {
    line("gyro bias error at 20 s [rad/s]", s.bias_at_check, s.bias_draws, "<= 0.005");
    o << "    target median <= 0.003: " << yes(s.bias_at_check.median <= 0.003)
      << "; p90 <= 0.005: " << yes(s.bias_at_check.p90 <= 0.005) << "\n";
    line("gyro bias error, max after 20 s", s.bias_max_after, s.bias_draws, "<= 0.005");
  }
  line("max position error in the 2 s gap [m]", s.gap_max_error, s.draws, "<= 0.45");
  o << "    target median <= 0.3: " << yes(s.gap_max_error.median <= 0.3)
    << "; p90 <= 0.45: " << yes(s.gap_max_error.p90 <= 0.45) << "\n";
  const double inside = s.gap_samples > 0 ? static_cast<double>(s.gap_samples_inside_3sigma) /
                                                static_cast<double>(s.gap_samples)
                                          : 0.0;
  o << "  gap samples inside the filter's 3-sigma position bound: " << s.gap_samples_inside_3sigma
    << " of " << s.gap_samples << " (" << 100.0 * inside
    << " %); target >= 95 %: " << yes(inside >= 0.95) << "\n";
  return o.str();
}

}  // namespace kestrel::lab
