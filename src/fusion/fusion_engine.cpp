// FusionEngine: buffering, initialisation, gating and dropout bookkeeping around the EKF.
#include "kestrel/fusion/fusion_engine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::fusion {
namespace {

using Eigen::Vector3d;

ImuReading mean_reading(const io::ImuSample& a, const io::ImuSample& b) {
  return {0.5 * (a.gyro_rad_s + b.gyro_rad_s), 0.5 * (a.accel_m_s2 + b.accel_m_s2)};
}

bool finite_sample(const io::ImuSample& s) {
  return s.gyro_rad_s.allFinite() && s.accel_m_s2.allFinite();
}

}  // namespace

// ---------------------------------------------------------------- options

FusionOptions FusionOptions::load_yaml(const std::filesystem::path& path) {
  FusionOptions o;
  io::option_fields::read_fields(io::load_yaml_map(path, "fusion"), path.string(), "fusion", o);
  try {
    o.validate();
  } catch (const InputError& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

std::string FusionOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

void FusionOptions::set_imu_noise(const io::ImuNoise& imu) {
  noise.gyro_noise = imu.gyro_noise_density;
  noise.gyro_walk = imu.gyro_random_walk;
  noise.accel_noise = imu.accel_noise_density;
  noise.accel_walk = imu.accel_random_walk;
  if (!(imu_noise_inflation > 0.0)) {  // not set by the options: the sensor file's, or in flight
    imu_noise_inflation = imu.in_flight_noise_inflation.value_or(kInFlightImuNoiseInflation);
  }
  if (imu.accel_range_m_s2) accel_range_m_s2 = *imu.accel_range_m_s2;
  if (imu.gyro_range_rad_s) gyro_range_rad_s = *imu.gyro_range_rad_s;
}

ImuNoiseDensities FusionOptions::filter_noise() const {
  ImuNoiseDensities n = noise;
  const double f = imu_noise_inflation > 0.0 ? imu_noise_inflation : 1.0;
  n.gyro_noise *= f;
  n.accel_noise *= f;
  return n;
}

std::string FusionOptions::describe() const {
  std::ostringstream s;
  s << "gyro_noise=" << noise.gyro_noise << " gyro_walk=" << noise.gyro_walk
    << " accel_noise=" << noise.accel_noise << " accel_walk=" << noise.accel_walk
    << " imu_noise_inflation=" << imu_noise_inflation << " time_offset=" << time_offset_s
    << "s estimate_time_offset=" << (estimate_time_offset ? "on" : "off")
    << " sigma_time_offset=" << init_sigma_time_offset_s
    << " estimate_extrinsic_rotation=" << (estimate_extrinsic_rotation ? "on" : "off")
    << " sigma_extrinsic_rotation=" << init_sigma_extrinsic_rotation_rad << " g=" << gravity_m_s2
    << " gate_p=" << gate_probability << " dropout=" << dropout_timeout_s
    << "s max_imu_gap=" << max_imu_gap_s << "s accel_range=" << accel_range_m_s2
    << "m/s^2 gyro_range=" << gyro_range_rad_s << "rad/s imu_horizon=" << imu_horizon_s
    << "s max_speed=" << max_speed_m_s << "m/s max_jump=" << max_position_jump_m
    << "m reorder=" << reorder_window_s << "s static_init=" << static_init_s
    << "s first_estimates=" << (first_estimate_jacobians ? "on" : "off")
    << " reanchor_after_gate=" << (reanchor_after_gate ? "on" : "off")
    << " adaptive_vo_noise=" << (adaptive_vo_noise.enabled ? "on" : "off");
  if (adaptive_vo_noise.enabled) {
    s << " (window " << adaptive_vo_noise.window_updates << ", scale in ["
      << adaptive_vo_noise.min_scale << ", ";
    if (adaptive_vo_noise.max_scale > 0.0) {
      s << adaptive_vo_noise.max_scale;
    } else {
      s << "gate/6";
    }
    s << "])";
  }
  s << " T_body_cam.t=[" << T_body_cam.translation().transpose() << "]";
  return s.str();
}

void FusionOptions::validate() const {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw InputError(std::string(name) + ": must be positive, got " + std::to_string(v));
    }
  };
  positive(noise.gyro_noise, "gyroscope_noise_density");
  positive(noise.gyro_walk, "gyroscope_random_walk");
  positive(noise.accel_noise, "accelerometer_noise_density");
  positive(noise.accel_walk, "accelerometer_random_walk");
  if (!(std::isfinite(imu_noise_inflation) && imu_noise_inflation >= 0.0)) {
    throw InputError("imu_noise_inflation: must be >= 0 (0: the sensor file's), got " +
                     std::to_string(imu_noise_inflation));
  }
  positive(init_sigma_time_offset_s, "init_sigma_time_offset_s");
  positive(init_sigma_extrinsic_rotation_rad, "init_sigma_extrinsic_rotation_rad");
  if (!(std::abs(time_offset_s) <= 1.0)) {
    throw InputError("time_offset_s: must be within +-1 s, got " + std::to_string(time_offset_s));
  }
  positive(gravity_m_s2, "gravity_m_s2");
  positive(dropout_timeout_s, "dropout_timeout_s");
  positive(max_imu_gap_s, "max_imu_gap_s");
  positive(static_init_s, "static_init_s");
  positive(accel_range_m_s2, "accelerometer_range_m_s2");
  positive(gyro_range_rad_s, "gyroscope_range_rad_s");
  positive(imu_horizon_s, "imu_horizon_s");
  positive(max_speed_m_s, "max_speed_m_s");
  positive(max_position_jump_m, "max_position_jump_m");
  positive(init_sigma_p_m, "init_sigma_p_m");
  positive(init_sigma_roll_pitch_rad, "init_sigma_roll_pitch_rad");
  positive(init_sigma_yaw_rad, "init_sigma_yaw_rad");
  positive(init_sigma_v_m_s, "init_sigma_v_m_s");
  positive(init_sigma_gyro_bias_rad_s, "init_sigma_gyro_bias_rad_s");
  positive(init_sigma_accel_bias_m_s2, "init_sigma_accel_bias_m_s2");
  if (!(gate_probability >= 0.0 && gate_probability < 1.0)) {
    throw InputError("gate_probability: must be in [0, 1), got " +
                     std::to_string(gate_probability));
  }
  if (!(reorder_window_s >= 0.0)) throw InputError("reorder_window_s: must be >= 0");
  adaptive_vo_noise.validate();
}

Matrix15d FusionOptions::initial_covariance() const {
  Vector15d s;
  s << Vector3d::Constant(init_sigma_p_m), init_sigma_roll_pitch_rad, init_sigma_roll_pitch_rad,
      init_sigma_yaw_rad, Vector3d::Constant(init_sigma_v_m_s),
      Vector3d::Constant(init_sigma_gyro_bias_rad_s),
      Vector3d::Constant(init_sigma_accel_bias_m_s2);
  // Roll/pitch/yaw sigmas are world-frame angles; the error state is local, but for a
  // diagonal prior with equal roll/pitch sigma the difference is only the yaw axis' tilt.
  return s.array().square().matrix().asDiagonal();
}

std::string describe_flags(std::uint32_t flags) {
  if (flags == kFlagNone) return "ok";
  std::string s;
  auto add = [&](std::uint32_t bit, const char* name) {
    if ((flags & bit) == 0) return;
    if (!s.empty()) s += "|";
    s += name;
  };
  add(kFlagVoDropout, "vo_dropout");
  add(kFlagImuGap, "imu_gap");
  add(kFlagRejected, "rejected");
  add(kFlagUpdated, "updated");
  add(kFlagImplausible, "implausible");
  return s;
}

std::string FusionCounters::describe() const {
  std::ostringstream s;
  s << "imu=" << imu_samples << " imu_late=" << imu_dropped_late
    << " imu_before_start=" << imu_before_start << " imu_invalid=" << imu_dropped_invalid
    << " imu_out_of_range=" << imu_out_of_range << " imu_duplicate=" << imu_duplicate
    << " imu_gaps=" << imu_gaps << " imu_gaps_beyond_horizon=" << imu_gaps_beyond_horizon
    << " updates=" << updates_accepted << " gated=" << updates_gated
    << " invalid=" << updates_invalid << " no_reference=" << updates_no_reference
    << " vo_late=" << measurements_dropped_late << " vo_before_init=" << measurements_before_init
    << " vo_outside_imu=" << measurements_outside_imu << " implausible=" << implausible_outputs
    << " mean_nis=" << mean_nis();
  if (vo_noise_scale_max > 0.0) {
    s << " vo_noise_scale_mean=" << mean_vo_noise_scale()
      << " vo_noise_scale_max=" << vo_noise_scale_max;
  }
  return s.str();
}

std::string FusionCounters::describe_rejections() const {
  std::string s;
  auto add = [&](std::size_t n, const char* what) {
    if (n == 0) return;
    if (!s.empty()) s += ", ";
    s += std::to_string(n) + " " + what;
  };
  add(imu_out_of_range, "IMU samples beyond the sensor's range");
  add(imu_dropped_invalid, "non-finite IMU samples");
  add(imu_dropped_late, "IMU samples older than the processed time");
  add(imu_duplicate, "IMU samples repeating a time stamp");
  add(imu_gaps_beyond_horizon, "IMU gaps longer than the horizon");
  add(measurements_outside_imu, "odometry measurements outside the IMU's time coverage");
  add(measurements_before_init, "odometry measurements before the initialisation");
  add(measurements_dropped_late, "late odometry measurements");
  add(updates_gated, "odometry updates failing the chi-square gate");
  add(updates_invalid, "invalid odometry updates");
  add(implausible_outputs, "implausible outputs");
  return s;
}

bool imu_sample_in_range(const io::ImuSample& s, const FusionOptions& options) {
  // Negated comparisons: NaN is out of range.
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(s.accel_m_s2[k]) <= options.accel_range_m_s2)) return false;
    if (!(std::abs(s.gyro_rad_s[k]) <= options.gyro_range_rad_s)) return false;
  }
  return true;
}

// ---------------------------------------------------------------- static initialisation

std::optional<NominalState> static_initial_state(const std::vector<io::ImuSample>& samples,
                                                 const FusionOptions& options) {
  if (samples.size() < 2) return std::nullopt;
  Vector3d mg = Vector3d::Zero(), ma = Vector3d::Zero();
  for (const auto& s : samples) {
    mg += s.gyro_rad_s;
    ma += s.accel_m_s2;
  }
  const double n = static_cast<double>(samples.size());
  mg /= n;
  ma /= n;
  double vg = 0.0, va = 0.0;
  for (const auto& s : samples) {
    vg += (s.gyro_rad_s - mg).squaredNorm();
    va += (s.accel_m_s2 - ma).squaredNorm();
  }
  const double sg = std::sqrt(vg / (3.0 * (n - 1.0)));
  const double sa = std::sqrt(va / (3.0 * (n - 1.0)));
  if (sg > options.static_max_gyro_std_rad_s || sa > options.static_max_accel_std_m_s2) {
    return std::nullopt;
  }
  if (std::abs(ma.norm() - options.gravity_m_s2) > 0.1 * options.gravity_m_s2) return std::nullopt;
  // At rest the accelerometer reads R^T (0, 0, g): the body's view of world up.
  Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(ma.normalized(), Vector3d::UnitZ());
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  q = Eigen::AngleAxisd(-yaw, Vector3d::UnitZ()) * q;
  q.normalize();
  NominalState x;
  x.t_ns = samples.back().t_ns;
  x.q_world_body = q;
  x.gyro_bias_rad_s = mg;
  return x;
}

// ---------------------------------------------------------------- engine

namespace {

const FusionOptions& validated(const FusionOptions& o) {
  o.validate();
  return o;
}

}  // namespace

// The filter is built in place (not move-assigned in the body): GCC 12 flags the move of its
// std::optional members as "may be used uninitialized" once the two files share a unity TU.
FusionEngine::FusionEngine(FusionOptions options)
    : options_(std::move(options)),
      ekf_(validated(options_).filter_noise(), Vector3d(0.0, 0.0, -options_.gravity_m_s2)) {
  ekf_.set_first_estimate_jacobians(options_.first_estimate_jacobians);
  gate_chi2_ =
      options_.gate_probability > 0.0 ? chi_square_quantile(options_.gate_probability, 6.0) : 0.0;
  if (options_.adaptive_vo_noise.enabled) {
    // The NIS cap is the gate; without a gate, the default gate's level.
    const double cap = gate_chi2_ > 0.0 ? gate_chi2_ : chi_square_quantile(0.999, 6.0);
    vo_noise_scale_.emplace(options_.adaptive_vo_noise, cap, 6);
  }
}

void FusionEngine::initialize(const NominalState& state) {
  NominalState x = state;
  x.time_offset_s = options_.time_offset_s;
  ekf_.initialize(
      x, options_.initial_covariance(),
      options_.estimate_time_offset ? options_.init_sigma_time_offset_s : 0.0,
      options_.estimate_extrinsic_rotation ? options_.init_sigma_extrinsic_rotation_rad : 0.0);
  initialized_ = true;
  processed_ns_ = std::max(processed_ns_, state.t_ns);
  last_accepted_update_ns_ = state.t_ns;
  anchor_.reset();
  gated_in_a_row_ = 0;
}

void FusionEngine::add_imu(const io::ImuSample& sample) {
  if (!finite_sample(sample)) {
    ++counters_.imu_dropped_invalid;
    return;
  }
  if (!imu_sample_in_range(sample, options_)) {
    ++counters_.imu_out_of_range;
    return;
  }
  if (sample.t_ns <= processed_ns_ && (initialized_ || last_imu_)) {
    // Before the first sample after a given initial state: not late, only before the start.
    ++(last_imu_ ? counters_.imu_dropped_late : counters_.imu_before_start);
    return;
  }
  imu_buffer_.emplace(sample.t_ns, sample);
  newest_input_ns_ = std::max(newest_input_ns_, sample.t_ns);
}

void FusionEngine::add_relative_pose(const RelativePoseMeasurement& m) {
  if (m.t_ns < processed_ns_) {
    ++counters_.measurements_dropped_late;
    return;
  }
  vo_buffer_.emplace(m.t_ns, m);
  newest_input_ns_ = std::max(newest_input_ns_, m.t_ns);
}

std::vector<FusedState> FusionEngine::poll(bool imu_rate) {
  std::vector<FusedState> out;
  if (newest_input_ns_ == std::numeric_limits<TimeNs>::min()) return out;
  process_until(newest_input_ns_ - s_to_ns(options_.reorder_window_s), imu_rate, out);
  return out;
}

std::vector<FusedState> FusionEngine::flush(bool imu_rate) {
  std::vector<FusedState> out;
  process_until(std::numeric_limits<TimeNs>::max(), imu_rate, out);
  return out;
}

void FusionEngine::process_until(TimeNs t_end, bool imu_rate, std::vector<FusedState>& out) {
  for (;;) {
    const bool have_imu = !imu_buffer_.empty() && imu_buffer_.begin()->first <= t_end;
    const bool have_vo = !vo_buffer_.empty() && vo_buffer_.begin()->first <= t_end;
    if (!have_imu && !have_vo) break;
    // IMU first at equal times, so that a measurement sees the propagation up to its time.
    if (have_imu && (!have_vo || imu_buffer_.begin()->first <= vo_buffer_.begin()->first)) {
      const io::ImuSample s = imu_buffer_.begin()->second;
      imu_buffer_.erase(imu_buffer_.begin());
      process_imu(s, imu_rate, out);
    } else {
      const RelativePoseMeasurement m = vo_buffer_.begin()->second;
      vo_buffer_.erase(vo_buffer_.begin());
      process_measurement(m, out);
    }
  }
}

bool FusionEngine::try_static_init(const io::ImuSample& s) {
  init_window_.push_back(s);
  const TimeNs span = s_to_ns(options_.static_init_s);
  while (init_window_.size() > 2 && s.t_ns - init_window_[1].t_ns >= span) {
    init_window_.pop_front();
  }
  if (s.t_ns - init_window_.front().t_ns < span) return false;
  const std::vector<io::ImuSample> window(init_window_.begin(), init_window_.end());
  const auto x = static_initial_state(window, options_);
  if (!x) return false;
  initialize(*x);
  init_window_.clear();
  return true;
}

void FusionEngine::propagate_to(TimeNs t_ns) {
  // The reading over [filter time, t_ns]: the mean of the last sample and the next one.
  const TimeNs t0 = ekf_.state().t_ns;
  if (t_ns <= t0 || !last_imu_) return;
  io::ImuSample next = *last_imu_;
  if (auto it = imu_buffer_.lower_bound(t_ns); it != imu_buffer_.end()) next = it->second;
  ImuReading reading = mean_reading(*last_imu_, next);
  const TimeNs max_step = std::max<TimeNs>(1, s_to_ns(0.5 * options_.max_imu_gap_s));
  TimeNs t = t0;
  while (t < t_ns) {
    const TimeNs step = std::min(max_step, t_ns - t);
    ekf_.propagate(reading, ns_to_s(step));
    t += step;
  }
  ekf_.set_time(t_ns);
}

void FusionEngine::process_imu(const io::ImuSample& s, bool imu_rate,
                               std::vector<FusedState>& out) {
  // Two samples with one time stamp: the second is not a new reading of the interval.
  if (s.t_ns == last_imu_t_ns_) {
    ++counters_.imu_duplicate;
    return;
  }
  last_imu_t_ns_ = s.t_ns;
  ++counters_.imu_samples;
  if (!initialized_) {
    if (try_static_init(s)) last_imu_ = s;
    processed_ns_ = std::max(processed_ns_, s.t_ns);
    return;
  }
  if (s.t_ns < ekf_.state().t_ns) {  // before a given initial state
    last_imu_ = s;
    return;
  }
  // The first sample after a given state bridges the time since that state.
  const TimeNs gap_from = last_imu_ ? last_imu_->t_ns : ekf_.state().t_ns;
  if (!last_imu_) last_imu_ = s;
  const double gap_s = ns_to_s(s.t_ns - gap_from);
  if (gap_s > options_.max_imu_gap_s) {
    ++counters_.imu_gaps;
    sticky_flags_ |= kFlagImuGap;
  }
  if (gap_s > options_.imu_horizon_s) ++counters_.imu_gaps_beyond_horizon;
  const TimeNs t0 = ekf_.state().t_ns;
  if (s.t_ns > t0) {
    const ImuReading reading = mean_reading(*last_imu_, s);
    const TimeNs max_step = std::max<TimeNs>(1, s_to_ns(0.5 * options_.max_imu_gap_s));
    TimeNs t = t0;
    while (t < s.t_ns) {
      const TimeNs step = std::min(max_step, s.t_ns - t);
      ekf_.propagate(reading, ns_to_s(step));
      t += step;
    }
    ekf_.set_time(s.t_ns);
  }
  last_imu_ = s;
  processed_ns_ = std::max(processed_ns_, s.t_ns);
  if (imu_rate) emit(false, out);
}

void FusionEngine::process_measurement(const RelativePoseMeasurement& m,
                                       std::vector<FusedState>& out) {
  processed_ns_ = std::max(processed_ns_, m.t_ns);
  if (!initialized_) {
    ++counters_.measurements_before_init;
    return;
  }
  if (m.t_ns < ekf_.state().t_ns) {
    ++counters_.measurements_dropped_late;
    return;
  }
  // Outside the IMU's coverage: the state at m.t_ns would be the last reading held for longer
  // than the horizon. Refused, with no output; the next measurement then has no reference.
  if (!last_imu_ || ns_to_s(m.t_ns - last_imu_->t_ns) > options_.imu_horizon_s) {
    ++counters_.measurements_outside_imu;
    return;
  }
  propagate_to(m.t_ns);
  // The measurement must start at the cloned frame (0.5 ms tolerance), or at a keyframe that
  // an earlier measurement tied to the clone (anchor_); otherwise it only starts a new
  // reference (first frame, or a frame whose predecessor was never seen).
  constexpr TimeNs kTolerance = 500'000;
  const TimeNs clone_t = ekf_.state().clone_t_ns;
  bool has_reference = std::llabs(m.t_ref_ns - clone_t) <= kTolerance;
  RelativePoseMeasurement rebased = m;
  bool reanchor = false;
  if (!has_reference && anchor_ && anchor_->keyframe_t_ns == m.t_ref_ns &&
      std::llabs(anchor_->clone_t_ns - clone_t) <= kTolerance) {
    // T_clone_cur = T_kf_clone^-1 T_kf_cur. Left perturbations in the keyframe frame, exp(e_c)
    // T_kf_cur and exp(e_a) T_kf_clone, give exp(Ad(T_kf_clone^-1) (e_c - e_a)) T_clone_cur; the
    // two errors are taken as independent (both are alignments to the keyframe: a bound).
    const SE3 T_clone_kf = anchor_->T_keyframe_clone.inverse();
    const Matrix6d Ad = T_clone_kf.adjoint();
    rebased.t_ref_ns = clone_t;
    rebased.T_ref_cur = T_clone_kf * m.T_ref_cur;
    rebased.covariance = Ad * (m.covariance + anchor_->covariance) * Ad.transpose();
    has_reference = true;
  }
  if (!has_reference) {
    ++counters_.updates_no_reference;
    if (m.t_ref_ns != m.t_ns) {
      anchor_ = KeyframeAnchor{m.t_ref_ns, m.t_ns, m.T_ref_cur, m.covariance};
    } else {
      anchor_.reset();
    }
  } else {
    // Odometry camera motion -> body motion: T_b1_b2 = T_BC T_c1_c2 T_BC^-1; a left
    // perturbation moves with the adjoint of T_BC.
    const SE3& T_bc = options_.T_body_cam;
    const SE3 T_body = T_bc * rebased.T_ref_cur * T_bc.inverse();
    const Matrix6d Ad = T_bc.adjoint();
    const double scale = vo_noise_scale();
    const Matrix6d cov = scale * (Ad * rebased.covariance * Ad.transpose());
    const UpdateResult r = ekf_.update(T_body, cov, gate_chi2_);
    last_update_ = r;
    if (vo_noise_scale_ && r.outcome != UpdateOutcome::kRejectedInvalid) {
      // Accepted and gated alike: a gated NIS is the evidence that the covariance is too small.
      counters_.vo_noise_scale_sum += scale;
      counters_.vo_noise_scale_max = std::max(counters_.vo_noise_scale_max, scale);
      vo_noise_scale_->add(r.mahalanobis_sq, scale);
    }
    switch (r.outcome) {
      case UpdateOutcome::kAccepted:
        ++counters_.updates_accepted;
        counters_.nis_sum_accepted += r.mahalanobis_sq;
        gated_in_a_row_ = 0;
        last_accepted_update_ns_ = m.t_ns;
        sticky_flags_ |= kFlagUpdated;
        break;
      case UpdateOutcome::kRejectedGate:
        ++counters_.updates_gated;
        sticky_flags_ |= kFlagRejected;
        // Gated twice in a row from a keyframe that is kept: the odometry jumped against it,
        // and every later measurement from it would carry the same error and be gated too. So
        // the filter clones now and anchors them on this one, T_clone_cur = T_kf_this^-1
        // T_kf_cur, as for a keyframe it never cloned: they then measure only the motion since.
        // A single outlier (the next one accepted) is only rejected: anchoring on it would
        // carry its error into every later measurement.
        if (options_.reanchor_after_gate && !m.starts_new_reference && m.t_ref_ns != m.t_ns &&
            ++gated_in_a_row_ >= 2) {
          anchor_ = KeyframeAnchor{m.t_ref_ns, m.t_ns, m.T_ref_cur, m.covariance};
          reanchor = true;
          gated_in_a_row_ = 0;
        }
        break;
      case UpdateOutcome::kRejectedInvalid:
        ++counters_.updates_invalid;
        sticky_flags_ |= kFlagRejected;
        break;
    }
  }
  // Re-cloning after each update (thesis, after eq. 4.8) when this frame becomes the
  // reference; a keyframe that is kept keeps its clone. Without a reference the frame is
  // cloned anyway: a measurement starting there is the only one that can follow.
  if (m.starts_new_reference || !has_reference || reanchor) ekf_.clone();
  if (m.starts_new_reference && has_reference) anchor_.reset();  // the clone is the keyframe now
  if (m.starts_new_reference) gated_in_a_row_ = 0;
  emit(true, out);
}

void FusionEngine::emit(bool at_odometry, std::vector<FusedState>& out) {
  FusedState f = output(at_odometry);
  if (std::string why = implausibility(f); !why.empty()) {
    f.flags |= kFlagImplausible;
    ++counters_.implausible_outputs;
    if (!first_implausible_) first_implausible_.emplace(f, std::move(why));
  }
  last_output_ = f;
  out.push_back(f);
  sticky_flags_ = kFlagNone;  // event flags are reported once, on the next output
}

std::string FusionEngine::implausibility(const FusedState& f) const {
  if (last_output_) {
    const double dt = ns_to_s(f.t_ns - last_output_->t_ns);
    const double step = (f.state.p_world - last_output_->state.p_world).norm();
    const double bound = options_.max_speed_m_s * std::max(0.0, dt) + options_.max_position_jump_m;
    if (step > bound) {
      return "position moved " + std::to_string(step) + " m in " + std::to_string(dt) +
             " s, more than max_speed_m_s * dt + max_position_jump_m = " + std::to_string(bound) +
             " m";
    }
  }
  const double speed = f.state.v_world.norm();
  if (speed > options_.max_speed_m_s) {
    return "speed " + std::to_string(speed) + " m/s above max_speed_m_s " +
           std::to_string(options_.max_speed_m_s);
  }
  return {};
}

FusedState FusionEngine::output(bool at_odometry) const {
  FusedState f;
  f.state = ekf_.state();
  f.t_ns = f.state.t_ns;
  f.sigma = ekf_.covariance().diagonal().head<9>().cwiseMax(0.0).cwiseSqrt();
  f.sigma_gyro_bias = ekf_.covariance().diagonal().segment<3>(idx::kBg).cwiseMax(0.0).cwiseSqrt();
  f.sigma_time_offset_s = std::sqrt(std::max(0.0, ekf_.covariance()(idx::kTd, idx::kTd)));
  f.sigma_extrinsic_rotation_rad =
      ekf_.covariance().diagonal().segment<3>(idx::kExt).cwiseMax(0.0).cwiseSqrt();
  f.at_odometry = at_odometry;
  f.flags = sticky_flags_;
  if (ns_to_s(f.t_ns - last_accepted_update_ns_) > options_.dropout_timeout_s) {
    f.flags |= kFlagVoDropout;
  }
  if (!f.state.all_finite() || !f.sigma.allFinite()) {
    throw std::runtime_error("fusion: the filter state became non-finite at t=" +
                             std::to_string(ns_to_s(f.t_ns)) + " s");
  }
  return f;
}

}  // namespace kestrel::fusion
