// kestrel.Fusion: the error-state EKF with stochastic cloning behind its buffering engine
// (fusion/fusion_engine.hpp): IMU samples and relative poses in, fused states out.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "kestrel/fusion/fusion_engine.hpp"
#include "kestrel/fusion/odometry_measurement.hpp"
#include "kestrel/odometry/direct_tracker.hpp"

namespace kestrel::python {
namespace {

using fusion::FusedState;

// The engine, and the builder that turns tracker results into its measurements (as `kestrel
// fuse --vo-frames` and `kestrel run` do).
struct Fusion {
  fusion::FusionEngine engine;
  fusion::OdometryMeasurements measurements;
};

Eigen::Vector4d state_quaternion_xyzw(const Eigen::Quaterniond& q) {
  return {q.x(), q.y(), q.z(), q.w()};
}

std::unique_ptr<Fusion> make_fusion(const std::optional<std::filesystem::path>& options,
                                    const std::optional<SE3>& T_body_cam,
                                    const std::string& odometry_reference,
                                    double covariance_scale) {
  fusion::FusionOptions o =
      options ? fusion::FusionOptions::load_yaml(*options) : fusion::FusionOptions{};
  if (T_body_cam) o.T_body_cam = *T_body_cam;
  o.validate();
  if (!(covariance_scale > 0.0)) throw py::value_error("covariance_scale must be positive");
  return std::make_unique<Fusion>(
      Fusion{fusion::FusionEngine(o),
             fusion::OdometryMeasurements(fusion::parse_odometry_reference(odometry_reference),
                                          covariance_scale)});
}

void add_imu_batch(Fusion& f, const py::array& t_ns, const py::array& gyro_rad_s,
                   const py::array& accel_m_s2) {
  const double* gyro = view_doubles(gyro_rad_s, "gyro_rad_s", {-1, 3});
  const py::ssize_t n = gyro_rad_s.shape(0);
  const std::int64_t* t = view_int64(t_ns, "t_ns", n);
  const double* accel = view_doubles(accel_m_s2, "accel_m_s2", {n, 3});
  py::gil_scoped_release release;
  for (py::ssize_t i = 0; i < n; ++i) {
    f.engine.add_imu({t[i], Eigen::Vector3d(gyro + 3 * i), Eigen::Vector3d(accel + 3 * i)});
  }
}

void bind_fused_state(py::module_& m) {
  py::class_<FusedState>(m, "FusedState", "One output of the fusion, with its health.")
      .def_readonly("t_ns", &FusedState::t_ns, "Time of the state (int64 ns).")
      .def_property_readonly(
          "T_world_body", [](const FusedState& s) { return s.state.T_world_body(); },
          "Body (IMU) pose in the z-up world as an SE3.")
      .def_property_readonly(
          "pose", [](const FusedState& s) { return s.state.T_world_body().matrix(); },
          "T_world_body as a 4x4 float64 array.")
      .def_property_readonly(
          "p_world", [](const FusedState& s) { return s.state.p_world; },
          "Body position in the world (m).")
      .def_property_readonly(
          "q_world_body_xyzw",
          [](const FusedState& s) { return state_quaternion_xyzw(s.state.q_world_body); },
          "Body attitude in the world, unit quaternion (x, y, z, w).")
      .def_property_readonly(
          "v_world", [](const FusedState& s) { return s.state.v_world; },
          "Velocity in the world (m/s).")
      .def_property_readonly(
          "gyro_bias_rad_s", [](const FusedState& s) { return s.state.gyro_bias_rad_s; },
          "Gyroscope bias estimate (rad/s).")
      .def_property_readonly(
          "accel_bias_m_s2", [](const FusedState& s) { return s.state.accel_bias_m_s2; },
          "Accelerometer bias estimate (m/s^2).")
      .def_readonly("sigma", &FusedState::sigma, "Standard deviations of [p, theta, v] (9,).")
      .def_readonly("flags", &FusedState::flags, "Health bits (vo_dropout 1, imu_gap 2, ...).")
      .def_property_readonly(
          "flags_text", [](const FusedState& s) { return fusion::describe_flags(s.flags); },
          "The health bits in words.")
      .def_readonly("at_odometry", &FusedState::at_odometry,
                    "Emitted at an odometry time stamp (after its update).");
}

}  // namespace

void bind_fusion(py::module_& m) {
  bind_fused_state(m);
  py::class_<Fusion>(
      m, "Fusion",
      "IMU + visual odometry fusion (the EKF of `kestrel fuse`): buffers inputs that arrive out "
      "of order within reorder_window_s, initialises from a still start (or initialize()), and "
      "emits fused states.")
      .def(py::init(&make_fusion), py::arg("options") = py::none(),
           py::arg("T_body_cam") = py::none(), py::arg("odometry_reference") = "keyframe",
           py::arg("covariance_scale") = 25.0,
           "options: a fusion options YAML file, None for the defaults; T_body_cam: the "
           "odometry camera in the body (IMU) frame (default identity); odometry_reference "
           "(keyframe or previous_frame) and covariance_scale: how add_track_result() turns "
           "tracker results into measurements (`kestrel fuse --vo-reference, --vo-cov-scale`).")
      .def(
          "initialize",
          [](Fusion& f, std::int64_t t_ns, const SE3& T_world_body,
             const Eigen::Vector3d& v_world) {
            fusion::NominalState x;
            x.t_ns = t_ns;
            x.p_world = T_world_body.translation();
            x.q_world_body = T_world_body.unit_quaternion();
            x.v_world = v_world;
            f.engine.initialize(x);
          },
          py::arg("t_ns"), py::arg("T_world_body"), py::arg("v_world") = Eigen::Vector3d::Zero(),
          "Starts from a given pose and velocity (biases zero) instead of the static "
          "initialisation.")
      .def(
          "add_imu",
          [](Fusion& f, std::int64_t t_ns, const Eigen::Vector3d& gyro,
             const Eigen::Vector3d& accel) {
            f.engine.add_imu({t_ns, gyro, accel});
          },
          py::arg("t_ns"), py::arg("gyro_rad_s"), py::arg("accel_m_s2"), "One IMU sample.")
      .def("add_imu_batch", &add_imu_batch, py::arg("t_ns"), py::arg("gyro_rad_s"),
           py::arg("accel_m_s2"),
           "Many IMU samples: t_ns int64 (N,), gyro_rad_s and accel_m_s2 float64 (N, 3), "
           "C-contiguous.")
      .def(
          "add_relative_pose",
          [](Fusion& f, std::int64_t t_ref_ns, std::int64_t t_ns, const SE3& T_ref_cur,
             const Matrix6d& covariance, bool starts_new_reference) {
            fusion::RelativePoseMeasurement meas;
            meas.t_ref_ns = t_ref_ns;
            meas.t_ns = t_ns;
            meas.T_ref_cur = T_ref_cur;
            meas.covariance = covariance;
            meas.starts_new_reference = starts_new_reference;
            f.engine.add_relative_pose(meas);
          },
          py::arg("t_ref_ns"), py::arg("t_ns"), py::arg("T_ref_cur"), py::arg("covariance"),
          py::arg("starts_new_reference") = true,
          "A relative motion of the odometry camera from t_ref_ns to t_ns, covariance 6x6 of a "
          "left perturbation [v, w] in the reference frame (TrackResult's convention).")
      .def(
          "add_track_result",
          [](Fusion& f, const odometry::TrackResult& r) {
            const auto meas = f.measurements.next(r);
            if (meas) f.engine.add_relative_pose(*meas);
            return meas.has_value();
          },
          py::arg("result"),
          "The measurement of a tracker result (motion to its keyframe, or since the previous "
          "frame; a failed frame restarts the reference). Returns False where the result gives "
          "none.")
      .def(
          "poll", [](Fusion& f, bool imu_rate) { return f.engine.poll(imu_rate); },
          py::arg("imu_rate") = false, py::call_guard<py::gil_scoped_release>(),
          "Processes what is older than the reorder window; returns the states produced (at "
          "every IMU sample if imu_rate, else at odometry time stamps).")
      .def(
          "flush", [](Fusion& f, bool imu_rate) { return f.engine.flush(imu_rate); },
          py::arg("imu_rate") = false, py::call_guard<py::gil_scoped_release>(),
          "Processes all that is buffered.")
      .def_property_readonly(
          "initialized", [](const Fusion& f) { return f.engine.initialized(); },
          "The filter has started (static initialisation or initialize()).")
      .def_property_readonly(
          "counters", [](const Fusion& f) { return f.engine.counters().describe(); },
          "Inputs used and rejected, in words.")
      .def_property_readonly(
          "updates_accepted", [](const Fusion& f) { return f.engine.counters().updates_accepted; },
          "Odometry updates the filter accepted.")
      .def_property_readonly(
          "mean_nis", [](const Fusion& f) { return f.engine.counters().mean_nis(); },
          "Mean normalised innovation squared of the accepted updates "
          "(6 for a consistent filter).");
}

}  // namespace kestrel::python
