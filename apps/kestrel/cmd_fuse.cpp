// `kestrel fuse`: VO + IMU fusion with the stochastic-cloning EKF (thesis 4.6).
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include "commands.hpp"
#include "interrupt.hpp"
#include "kestrel/core/error.hpp"
#include "kestrel/core/units.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/io/euroc.hpp"
#include "kestrel/io/odometry_frame_log.hpp"
#include "kestrel/io/output_guard.hpp"
#include "kestrel/io/text_lines.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/yaml_file.hpp"
#include "option_checks.hpp"

namespace kestrel::cli {
namespace {

namespace fs = std::filesystem;
constexpr const char* kFuseCommand = "fuse";

struct FuseArgs {
  fs::path imu_path, vo_path, vo_cov_path, calib_path, camera_calib_path, options_path, out_path;
  fs::path states_path, init_path;
  fs::path vo_frames_path;  // --vo-frames: `kestrel odometry --frames` log
  std::string vo_reference = "keyframe";
  double vo_cov_scale = 25.0;  // with --vo-frames, as kestrel run / kestrel fly
  bool imu_rate = false;
  bool force = false;
  double vo_sigma_p_m = 0.01;
  double vo_sigma_rot_deg = 0.5;
  double imu_noise_inflation = 0.0;  // 0: the sensor file's, or the in-flight default
  bool no_time_offset_state = false;
  bool extrinsic_rotation_state = false;
};

// Covariances per VO time stamp: "timestamp v1 .. v6" (diagonal variances) or
// "timestamp c11 c12 .. c66" (36 values, row-major); [v, w] left perturbation of the motion
// from the previous VO pose to this one, in the previous camera frame.
std::map<TimeNs, Matrix6d> read_vo_covariances(const fs::path& path) {
  std::map<TimeNs, Matrix6d> out;
  io::TextLineReader reader(path);
  std::string line;
  while (reader.next(line)) {
    const auto f = io::split_fields(line, " \t,");
    if (f.size() != 7 && f.size() != 37) {
      reader.fail("expected a time stamp and 6 (diagonal) or 36 (full) covariance values, got " +
                  std::to_string(f.size()) + " fields");
    }
    const TimeNs t = io::parse_seconds_ns(f[0], reader, 0);
    Matrix6d c = Matrix6d::Zero();
    if (f.size() == 7) {
      for (int i = 0; i < 6; ++i)
        c(i, i) = io::parse_double(f[static_cast<std::size_t>(i + 1)], reader,
                                   static_cast<std::size_t>(i + 1));
    } else {
      for (int i = 0; i < 36; ++i)
        c(i / 6, i % 6) = io::parse_double(f[static_cast<std::size_t>(i + 1)], reader,
                                           static_cast<std::size_t>(i + 1));
    }
    if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(1.0, c.cwiseAbs().maxCoeff())) {
      reader.fail("covariance is not symmetric");
    }
    if (Eigen::LLT<Matrix6d>(c).info() != Eigen::Success)
      reader.fail("covariance is not positive-definite");
    out[t] = c;
  }
  return out;
}

// T_body_cam: `T_body_cam` (or `T_BC`) 4x4 in the calib YAML, else T_BS of --camera-calib.
std::optional<SE3> read_T_body_cam(const fs::path& calib, const fs::path& camera_calib) {
  const YAML::Node root = io::load_yaml_file(calib);
  for (const char* key : {"T_body_cam", "T_BC"}) {
    if (!root[key]) continue;
    std::vector<double> m;
    try {
      m = root[key]["data"] ? root[key]["data"].as<std::vector<double>>()
                            : root[key].as<std::vector<double>>();
    } catch (const YAML::Exception&) {
      throw InputError(calib, key, "must be a list of 16 numbers (or a map with data:)");
    }
    if (m.size() != 16) throw InputError(calib, key, "must hold 16 numbers");
    Eigen::Matrix4d T;
    for (int i = 0; i < 16; ++i) T(i / 4, i % 4) = m[static_cast<std::size_t>(i)];
    return SE3::from_matrix(T);
  }
  if (!camera_calib.empty()) {
    const io::CameraFile cam = io::load_camera_file(camera_calib);
    if (!cam.T_body_sensor)
      throw InputError(camera_calib, "T_BS", "missing (camera-to-body extrinsics)");
    return cam.T_body_sensor;
  }
  return std::nullopt;
}

std::string flags_to_text(std::uint32_t flags) { return fusion::describe_flags(flags); }

// --vo-frames: the odometry's own references and covariances (`kestrel odometry --frames`),
// through the same OdometryMeasurements as kestrel run and kestrel fly. The poses come from
// --vo (the tracker's, the prediction for a failed frame), so T_ref_cur = T_w_ref^-1 T_w_cur
// is the motion the tracker reported.
std::vector<fusion::RelativePoseMeasurement> frame_log_measurements(const FuseArgs& a,
                                                                    const Trajectory& vo) {
  fusion::OdometryReference reference{};
  try {
    reference = fusion::parse_odometry_reference(a.vo_reference);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--vo-reference: ") + e.what());
  }
  if (!(a.vo_cov_scale > 0.0)) throw InputError("--vo-cov-scale must be positive");
  const auto rows = io::read_odometry_frame_log(a.vo_frames_path);
  std::map<TimeNs, SE3> pose;
  for (const auto& p : vo) pose.emplace(p.t_ns, p.T_world_body);
  // The TUM file's stamps are rounded to microseconds.
  auto pose_at = [&](TimeNs t) -> const SE3& {
    auto it = pose.lower_bound(t - 1000);
    if (it == pose.end() || std::llabs(it->first - t) > 1000) {
      throw InputError(a.vo_frames_path.string() + ": frame at t_ns " + std::to_string(t) +
                       " has no pose in " + a.vo_path.string());
    }
    return it->second;
  };
  struct Track {  // the fields OdometryMeasurements reads
    TimeNs t_ns = 0, ref_t_ns = 0;
    SE3 T_ref_cur, T_world_cam;
    Matrix6d covariance;
    bool new_keyframe = false, tracked = false;
    [[nodiscard]] bool ok() const { return tracked; }
  };
  fusion::OdometryMeasurements builder(reference, a.vo_cov_scale);
  std::vector<fusion::RelativePoseMeasurement> out;
  for (const auto& r : rows) {
    Track t;
    t.t_ns = r.t_ns;
    t.ref_t_ns = r.ref_t_ns;
    t.tracked = r.ok;
    t.new_keyframe = r.new_keyframe;
    t.covariance = r.covariance;
    t.T_world_cam = pose_at(r.t_ns);
    if (r.ok && r.ref_t_ns != r.t_ns) t.T_ref_cur = pose_at(r.ref_t_ns).inverse() * t.T_world_cam;
    if (auto m = builder.next(t)) out.push_back(*m);
  }
  std::cerr << "kestrel fuse: " << out.size() << " measurements from " << rows.size()
            << " frames of " << a.vo_frames_path.string() << " (reference "
            << fusion::odometry_reference_name(reference) << ", covariance x" << a.vo_cov_scale
            << ")\n";
  return out;
}

void run_fuse(const FuseArgs& a) {
  std::cerr << "kestrel fuse: imu=" << a.imu_path.string() << " vo=" << a.vo_path.string()
            << " vo-cov=" << (a.vo_cov_path.empty() ? "(none)" : a.vo_cov_path.string())
            << " calib=" << a.calib_path.string() << " out=" << a.out_path.string()
            << " imu-rate=" << (a.imu_rate ? "true" : "false") << "\n";
  if (!a.vo_frames_path.empty() && !a.vo_cov_path.empty()) {
    throw InputError("--vo-frames and --vo-cov exclude each other (the log has the covariances)");
  }
  io::OutputGuard(kFuseCommand, a.force)
      .input("--imu", a.imu_path)
      .input("--vo", a.vo_path)
      .input("--vo-cov", a.vo_cov_path)
      .input("--vo-frames", a.vo_frames_path)
      .input("--calib", a.calib_path)
      .input("--camera-calib", a.camera_calib_path)
      .input("--options", a.options_path)
      .input("--init", a.init_path)
      .text_file("--out", a.out_path)
      .text_file("--states", a.states_path);
  if (!(a.vo_sigma_p_m > 0.0) || !(a.vo_sigma_rot_deg > 0.0)) {
    throw InputError("--vo-sigma-pos and --vo-sigma-rot-deg must be positive");
  }

  fusion::FusionOptions options;
  if (!a.options_path.empty()) options = fusion::FusionOptions::load_yaml(a.options_path);
  options.set_imu_noise(io::load_imu_noise(a.calib_path));  // missing field -> InputError
  if (a.imu_noise_inflation > 0.0) options.imu_noise_inflation = a.imu_noise_inflation;
  if (a.no_time_offset_state) options.estimate_time_offset = false;
  if (a.extrinsic_rotation_state) options.estimate_extrinsic_rotation = true;
  if (auto T = read_T_body_cam(a.calib_path, a.camera_calib_path)) {
    options.T_body_cam = *T;
  } else {
    std::cerr << "kestrel fuse: warning: no camera extrinsics (T_body_cam in --calib or "
                 "--camera-calib): the odometry is taken to be the body's own motion\n";
  }
  options.validate();
  std::cerr << "kestrel fuse: options: " << options.describe() << "\n";

  const Trajectory vo = io::read_tum_trajectory(a.vo_path);
  if (vo.size() < 2) throw InputError(a.vo_path.string() + ": needs at least two poses");
  std::map<TimeNs, Matrix6d> covs;
  if (!a.vo_cov_path.empty()) covs = read_vo_covariances(a.vo_cov_path);
  const double sr = a.vo_sigma_rot_deg * M_PI / 180.0;
  Vector6d def;
  def << Eigen::Vector3d::Constant(a.vo_sigma_p_m * a.vo_sigma_p_m),
      Eigen::Vector3d::Constant(sr * sr);

  std::vector<fusion::RelativePoseMeasurement> meas;
  if (!a.vo_frames_path.empty()) {
    meas = frame_log_measurements(a, vo);
  } else {
    for (std::size_t k = 1; k < vo.size(); ++k) {
      fusion::RelativePoseMeasurement m;
      m.t_ref_ns = vo[k - 1].t_ns;
      m.t_ns = vo[k].t_ns;
      m.T_ref_cur = vo[k - 1].T_world_body.inverse() * vo[k].T_world_body;
      if (!covs.empty()) {
        auto it = covs.find(m.t_ns);
        if (it == covs.end()) {
          throw InputError(a.vo_cov_path.string() + ": no covariance for the VO time stamp " +
                           io::format_seconds(m.t_ns) + " s");
        }
        m.covariance = it->second;
      } else {
        m.covariance = def.asDiagonal();
      }
      meas.push_back(m);
    }
  }

  fusion::FusionEngine engine(options);
  std::optional<TimeNs> init_t_ns;
  if (!a.init_path.empty()) {
    // A given state: the body pose of a ground-truth/trajectory file at the first VO time
    // (velocity from the neighbouring poses), biases zero.
    const Trajectory init = io::read_trajectory(a.init_path);
    if (init.size() < 2) throw InputError(a.init_path.string() + ": needs at least two poses");
    const TimeNs t0 = vo.front().t_ns;
    // The state must be the pose at the odometry's start, not one taken from outside the
    // initial trajectory (1 ms for stamps rounded in text files).
    constexpr TimeNs kStampTolerance = 1'000'000;
    if (t0 < init.front().t_ns - kStampTolerance || t0 > init.back().t_ns + kStampTolerance) {
      throw InputError(a.init_path.string() + ": covers " + io::format_seconds(init.front().t_ns) +
                       " s to " + io::format_seconds(init.back().t_ns) +
                       " s, not the first odometry pose of " + a.vo_path.string() + " at " +
                       io::format_seconds(t0) +
                       " s; give an initial trajectory over the odometry's start");
    }
    std::size_t i = 0;
    while (i + 1 < init.size() && init[i + 1].t_ns <= t0) ++i;
    const std::size_t j = std::min(i + 1, init.size() - 1);
    const std::size_t i0 = j == i ? i - 1 : i;
    fusion::NominalState x;
    x.t_ns = init[i].t_ns;
    x.p_world = init[i].T_world_body.translation();
    x.q_world_body = init[i].T_world_body.unit_quaternion();
    x.v_world = (init[j].T_world_body.translation() - init[i0].T_world_body.translation()) /
                ns_to_s(init[j].t_ns - init[i0].t_ns);
    engine.initialize(x);
    init_t_ns = x.t_ns;
    std::cerr << "kestrel fuse: initial state from " << a.init_path.string() << " at "
              << io::format_seconds(x.t_ns) << " s\n";
  }

  Trajectory fused;
  std::ofstream states;
  if (!a.states_path.empty()) {
    states.open(a.states_path);
    states << io::provenance_line(kFuseCommand) << "\n"
           << "# t[s] p_x p_y p_z q_x q_y q_z q_w v_x v_y v_z bg_x bg_y bg_z ba_x ba_y ba_z "
              "sigma_p_x sigma_p_y sigma_p_z sigma_th_x sigma_th_y sigma_th_z flags\n";
  }
  std::size_t dropout_outputs = 0, outputs = 0;
  auto consume = [&](const std::vector<fusion::FusedState>& out) {
    for (const auto& f : out) {
      fused.push_back({f.t_ns, f.state.T_world_body()});
      ++outputs;
      if (f.flags & fusion::kFlagVoDropout) ++dropout_outputs;
      if (states.is_open()) {
        const auto& s = f.state;
        const auto& q = s.q_world_body;
        states << io::format_seconds(f.t_ns) << " " << s.p_world.transpose() << " " << q.x() << " "
               << q.y() << " " << q.z() << " " << q.w() << " " << s.v_world.transpose() << " "
               << s.gyro_bias_rad_s.transpose() << " " << s.accel_bias_m_s2.transpose() << " "
               << f.sigma.head<6>().transpose() << " " << flags_to_text(f.flags) << "\n";
      }
    }
  };

  io::ImuCsvReader reader(a.imu_path);
  io::ImuSample s;
  std::size_t mi = 0, imu_read = 0;
  TimeNs imu_first_ns = 0, imu_last_ns = 0;
  constexpr std::size_t kRejectionsShown = 5;
  const InterruptScope interrupt;  // Ctrl-C: the poses fused so far are written
  while (!interrupt.requested() && reader.next(s)) {
    if (imu_read++ == 0) imu_first_ns = s.t_ns;
    imu_last_ns = s.t_ns;
    while (mi < meas.size() && meas[mi].t_ns <= s.t_ns) engine.add_relative_pose(meas[mi++]);
    const std::size_t out_of_range = engine.counters().imu_out_of_range;
    engine.add_imu(s);
    if (engine.counters().imu_out_of_range > out_of_range &&
        engine.counters().imu_out_of_range <= kRejectionsShown) {
      std::cerr << "kestrel fuse: warning: " << a.imu_path.string() << ":" << reader.line_number()
                << ": sample beyond the IMU's range (|gyro| <= " << options.gyro_range_rad_s
                << " rad/s, |accel| <= " << options.accel_range_m_s2
                << " m/s^2 per axis), rejected\n";
    }
    consume(engine.poll(a.imu_rate));
  }
  const bool interrupted = interrupt.requested();
  while (!interrupted && mi < meas.size()) engine.add_relative_pose(meas[mi++]);
  consume(engine.flush(a.imu_rate));
  if (interrupted) {
    io::write_tum_trajectory(a.out_path, fused, kFuseCommand, a.force);
    throw_interrupted(interrupt,
                      "after " + std::to_string(mi) + " of " + std::to_string(meas.size()) +
                          " odometry measurements; wrote " + a.out_path.string() + " (" +
                          std::to_string(fused.size()) + " poses)" +
                          (a.states_path.empty() ? "" : " and " + a.states_path.string()));
  }
  const fusion::FusionCounters& counters = engine.counters();
  if (imu_read == 0) {
    throw InputError(a.imu_path.string() +
                     ": no IMU samples (the file is empty or holds only comments)");
  }
  if (counters.imu_samples == 0) {
    std::string why = counters.describe_rejections();
    if (counters.imu_before_start > 0) {
      why += (why.empty() ? "" : ", ") + std::to_string(counters.imu_before_start) +
             " samples before the initial state from " + a.init_path.string() + " at " +
             io::format_seconds(init_t_ns.value_or(0)) + " s";
    }
    throw InputError(a.imu_path.string() + ": none of its " + std::to_string(imu_read) +
                     " samples (" + io::format_seconds(imu_first_ns) + " s to " +
                     io::format_seconds(imu_last_ns) + " s) could be used (" + why + ")");
  }
  if (init_t_ns && imu_first_ns > *init_t_ns + s_to_ns(options.imu_horizon_s)) {
    throw InputError(a.imu_path.string() + ": starts at " + io::format_seconds(imu_first_ns) +
                     " s, more than imu_horizon_s (" + std::to_string(options.imu_horizon_s) +
                     " s) after the initial state from " + a.init_path.string() + " at " +
                     io::format_seconds(*init_t_ns) + " s");
  }
  if (const auto& bad = engine.first_implausible()) {
    throw std::runtime_error(
        "fuse: the fused state is implausible for a micro aerial vehicle at t = " +
        io::format_seconds(bad->first.t_ns) + " s (" + bad->second + "; " +
        std::to_string(counters.implausible_outputs) + " implausible outputs): the IMU " +
        a.imu_path.string() + " and the odometry " + a.vo_path.string() +
        " do not agree; the trajectory is not written (limits: max_speed_m_s, "
        "max_position_jump_m in --options)");
  }
  if (!engine.initialized()) {
    throw InputError(a.imu_path.string() + ": the IMU never held still for " +
                     std::to_string(options.static_init_s) +
                     " s, so the static initialisation did not happen; give --init FILE");
  }
  if (fused.empty()) {
    throw InputError("fuse: no fused pose: the odometry " + a.vo_path.string() + " (" +
                     io::format_seconds(vo.front().t_ns) + " s to " +
                     io::format_seconds(vo.back().t_ns) + " s) and the IMU " + a.imu_path.string() +
                     " (" + io::format_seconds(imu_first_ns) + " s to " +
                     io::format_seconds(imu_last_ns) + " s) gave nothing to fuse (" +
                     (counters.describe_rejections().empty() ? std::string("nothing rejected")
                                                             : counters.describe_rejections()) +
                     ")");
  }
  if (counters.measurements_outside_imu > 0) {
    std::cerr << "kestrel fuse: warning: " << counters.measurements_outside_imu
              << " odometry measurements lie more than imu_horizon_s (" << options.imu_horizon_s
              << " s) after the last IMU sample (the IMU " << a.imu_path.string() << " covers "
              << io::format_seconds(imu_first_ns) << " s to " << io::format_seconds(imu_last_ns)
              << " s): refused, no pose written for them\n";
  }
  io::write_tum_trajectory(a.out_path, fused, kFuseCommand, a.force);
  std::cerr << "kestrel fuse: " << counters.describe() << "\n";
  const std::string rejected = counters.describe_rejections();
  std::cout << "rejected: " << (rejected.empty() ? "nothing" : rejected) << "\n";
  {
    const auto& P = engine.filter().covariance();
    std::cout << "camera-IMU time offset t_d: " << 1e3 * engine.filter().state().time_offset_s
              << " ms (1-sigma "
              << 1e3 * std::sqrt(std::max(0.0, P(fusion::idx::kTd, fusion::idx::kTd))) << " ms"
              << (options.estimate_time_offset ? ", estimated" : ", fixed") << ")\n";
    if (options.estimate_extrinsic_rotation) {
      const Eigen::Vector3d sigma =
          P.diagonal().segment<3>(fusion::idx::kExt).cwiseMax(0.0).cwiseSqrt() * kRadToDeg;
      std::cout << "odometry-IMU rotation (rotation vector): "
                << (SO3(engine.filter().state().q_body_odom).log() * kRadToDeg).transpose()
                << " deg (1-sigma " << sigma.transpose() << " deg, estimated)\n";
    }
  }
  std::cout << "fused poses: " << fused.size() << " (" << dropout_outputs
            << " flagged vo_dropout), accepted updates: " << engine.counters().updates_accepted
            << "/" << meas.size() << ", wrote " << a.out_path.string() << std::endl;
}

}  // namespace

void add_fuse_command(CLI::App& app) {
  auto a = std::make_shared<FuseArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fuse",
      "Fuse visual odometry (TUM camera poses) with an IMU (EuRoC CSV) in an error-state EKF "
      "with stochastic cloning (thesis 4.6); writes the body (IMU) pose in TUM format at the "
      "odometry's time stamps, or at IMU rate.");
  cmd->add_option("--imu", a->imu_path,
                  "EuRoC IMU CSV (imu0/data.csv); samples beyond the sensor's range are "
                  "rejected, odometry more than imu_horizon_s past it refused (docs/fusion.md)")
      ->required();
  cmd->add_option("--vo", a->vo_path, "odometry: TUM trajectory of the camera")->required();
  cmd->add_option("--vo-cov", a->vo_cov_path,
                  "per-frame covariance of each relative motion: 'timestamp' + 6 variances or "
                  "36 values, left perturbation [v, w] in the previous camera frame");
  cmd->add_option("--vo-frames", a->vo_frames_path,
                  "the per-frame log of `kestrel odometry --frames` for --vo: measurements "
                  "from the odometry's keyframes with its covariances (instead of consecutive "
                  "poses)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--vo-reference", a->vo_reference,
                  "with --vo-frames: keyframe (default) or previous_frame");
  cmd->add_option("--vo-cov-scale", a->vo_cov_scale,
                  "with --vo-frames: factor on the odometry's covariance")
      ->capture_default_str()
      ->check(number_in(0.0, 1e6, "a factor in (0, 1000000]", true));
  cmd->add_option("--calib", a->calib_path,
                  "IMU sensor YAML (EuRoC imu0/sensor.yaml: noise densities, random walks, "
                  "rate); may hold T_body_cam (4x4) for the odometry camera")
      ->required();
  cmd->add_option("--camera-calib", a->camera_calib_path,
                  "camera sensor YAML with T_BS (EuRoC cam0/sensor.yaml)");
  cmd->add_option("--options", a->options_path, "fusion options YAML (see docs/fusion.md)");
  cmd->add_option("--init", a->init_path,
                  "start from the pose of this trajectory (TUM or EuRoC, body frame, "
                  "gravity-aligned world) at the first odometry time instead of a static start; "
                  "it must cover that time");
  cmd->add_option("--out", a->out_path, "fused body trajectory (TUM)")->required();
  cmd->add_option("--states", a->states_path, "also write full states, sigmas and flags here");
  cmd->add_flag("--imu-rate", a->imu_rate, "output at every IMU sample");
  cmd->add_option("--imu-noise-inflation", a->imu_noise_inflation,
                  "factor on the IMU white-noise densities (default: the sensor file's "
                  "in_flight_noise_inflation, else 15; docs/fusion.md)")
      ->check(number_in(0.0, 1000.0, "a factor in (0, 1000]", true));
  cmd->add_flag("--no-time-offset-state", a->no_time_offset_state,
                "keep the camera-IMU time offset fixed (time_offset_s of --options) instead of "
                "estimating it online");
  cmd->add_flag("--extrinsic-rotation-state", a->extrinsic_rotation_state,
                "estimate the odometry-IMU rotation online (estimate_extrinsic_rotation; "
                "docs/fusion.md)");
  cmd->add_option("--vo-sigma-pos", a->vo_sigma_p_m, "odometry sigma without --vo-cov [m]")
      ->capture_default_str()
      ->check(number_in(0.0, 100.0, "a standard deviation in (0, 100] m", true));
  cmd->add_option("--vo-sigma-rot-deg", a->vo_sigma_rot_deg,
                  "odometry sigma without --vo-cov [deg]")
      ->capture_default_str()
      ->check(number_in(0.0, 180.0, "a standard deviation in (0, 180] deg", true));
  cmd->add_flag("--force", a->force, "overwrite files not written by `kestrel fuse`");
  cmd->callback([a] { run_fuse(*a); });
}

}  // namespace kestrel::cli
