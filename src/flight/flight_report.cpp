// Logs, figures and the summary line of a flight.
#include "kestrel/flight/flight_report.hpp"

#include <array>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <iomanip>
#include <sstream>

#include "kestrel/core/error.hpp"
#include "kestrel/eval/plot.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::flight {
namespace fs = std::filesystem;
namespace {

std::ofstream open_for_writing(const fs::path& path) {
  std::ofstream out(path);
  if (!out) throw InputError(path.string() + ": cannot open file for writing");
  return out;
}

void finish(std::ofstream& out, const fs::path& path) {
  out.flush();
  if (!out) throw InputError(path.string() + ": write failed (disk full?)");
}

// One CSV file: the header line, then what `rows` writes; returns its path.
template <typename Rows>
fs::path write_csv(const fs::path& path, const std::string& header, Rows&& rows) {
  std::ofstream out = open_for_writing(path);
  out << header << '\n';
  rows(out);
  finish(out, path);
  return path;
}

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

// Appends ",x,y,z" of each vector with `decimals` decimals: the CSVs' vector columns.
void write_vectors(std::ostream& out, std::initializer_list<const Eigen::Vector3d*> vectors,
                   int decimals) {
  for (const Eigen::Vector3d* v : vectors) {
    for (int k = 0; k < 3; ++k) out << ',' << fixed((*v)[k], decimals);
  }
}

std::vector<double> column(const FlightResult& r,
                           const std::function<double(const FlightSample&)>& f) {
  std::vector<double> values;
  values.reserve(r.samples.size());
  for (const FlightSample& s : r.samples) values.push_back(f(s));
  return values;
}

}  // namespace

const std::vector<std::string>& flight_log_columns() {
  static const std::vector<std::string> columns = {"t",     "x_true", "y_true", "z_true",
                                                   "x_ref", "y_ref",  "z_ref",  "x_est",
                                                   "y_est", "z_est",  "vo_ok"};
  return columns;
}

std::vector<fs::path> write_flight_logs(const fs::path& dir, const FlightResult& result) {
  std::string log_header;
  for (const std::string& c : flight_log_columns())
    log_header += (log_header.empty() ? "" : ",") + c;
  const fs::path log_path = write_csv(dir / "log.csv", log_header, [&](std::ostream& out) {
    for (const FlightSample& s : result.samples) {
      out << fixed(s.t_s, 3);
      write_vectors(out, {&s.p_true, &s.p_ref, &s.p_est}, 5);
      out << ',' << (s.vo_ok ? 1 : 0) << '\n';
    }
  });
  const fs::path details_path = write_csv(
      dir / "details.csv",
      "t,mode,position_sigma_m,roll_cmd_rad,pitch_cmd_rad,yaw_rate_cmd_rad_s,thrust_cmd_N,crashed",
      [&](std::ostream& out) {
        for (const FlightSample& s : result.samples) {
          out << fixed(s.t_s, 3) << ',' << control::to_string(s.mode) << ','
              << fixed(s.position_sigma_m, 5) << ',' << fixed(s.command.roll_rad, 5) << ','
              << fixed(s.command.pitch_rad, 5) << ',' << fixed(s.command.yaw_rate_rad_s, 5) << ','
              << fixed(s.command.thrust_N, 4) << ',' << (s.crashed ? 1 : 0) << '\n';
        }
      });
  const fs::path estimator_path = write_csv(
      dir / "estimator.csv",
      "t,vx_true,vy_true,vz_true,vx_est,vy_est,vz_est,dth_x,dth_y,dth_z,ba_x_est,ba_y_est,"
      "ba_z_est,ba_x_true,ba_y_true,ba_z_true,sp_x,sp_y,sp_z,sth_x,sth_y,sth_z,sv_x,sv_y,sv_z",
      [&](std::ostream& out) {
        for (const FlightSample& s : result.samples) {
          out << fixed(s.t_s, 3);
          write_vectors(
              out,
              {&s.v_true, &s.v_est, &s.attitude_error_rad, &s.accel_bias_est, &s.accel_bias_true},
              6);
          for (int k = 0; k < 9; ++k) out << ',' << fixed(s.sigma_p_theta_v[k], 6);
          out << '\n';
        }
      });
  const fs::path odometry_path = write_csv(
      dir / "odometry.csv",
      "t,t_ref,tx_true,ty_true,tz_true,tx_meas,ty_meas,tz_meas,rx_err_deg,ry_err_deg,rz_err_deg,"
      "sigma_tx,sigma_ty,sigma_tz,sigma_rx_deg,sigma_ry_deg,sigma_rz_deg,fallback,new_reference,"
      "relocalised",
      [&](std::ostream& out) {
        for (const OdometryCheck& c : result.odometry_checks) {
          out << fixed(c.t_s, 4) << ',' << fixed(c.t_ref_s, 4);
          write_vectors(out, {&c.translation_true, &c.translation_measured}, 6);
          write_vectors(out, {&c.rotation_error_deg}, 5);
          write_vectors(out, {&c.sigma_translation}, 6);
          write_vectors(out, {&c.sigma_rotation_deg}, 5);
          out << ',' << (c.geometric_fallback ? 1 : 0) << ',' << (c.new_reference ? 1 : 0) << ','
              << (c.relocalised ? 1 : 0) << '\n';
        }
      });
  return {log_path, details_path, estimator_path, odometry_path};
}

std::string odometry_check_summary(const FlightResult& result) {
  const std::vector<OdometryCheck>& checks = result.odometry_checks;
  if (checks.empty()) return "odometry against the truth: no measurement";
  Eigen::Vector3d error2 = Eigen::Vector3d::Zero(), normalised2 = Eigen::Vector3d::Zero();
  for (const OdometryCheck& c : checks) {
    const Eigen::Vector3d e = c.translation_error();
    error2 += e.cwiseAbs2();
    // (A zero sigma, which the tracker never reports, is floored at a nanometre.)
    normalised2 += e.cwiseQuotient(c.sigma_translation.cwiseMax(1e-9)).cwiseAbs2();
  }
  const double n = static_cast<double>(checks.size());
  const Eigen::Vector3d rms_mm = 1000.0 * (error2 / n).cwiseSqrt();
  const Eigen::Vector3d rms_normalised = (normalised2 / n).cwiseSqrt();
  std::ostringstream os;
  os << std::fixed << std::setprecision(2) << "odometry against the truth (" << checks.size()
     << " measurements, camera x right, y down, z forward): translation error RMS " << rms_mm.x()
     << " / " << rms_mm.y() << " / " << rms_mm.z() << " mm, error / sigma RMS "
     << rms_normalised.x() << " / " << rms_normalised.y() << " / " << rms_normalised.z()
     << " (odometry.csv)";
  return os.str();
}

std::vector<fs::path> write_flight_plots(const fs::path& dir, const FlightResult& result) {
  const auto x = [](int k) { return [k](const FlightSample& s) { return s.p_true[k]; }; };
  const auto r = [](int k) { return [k](const FlightSample& s) { return s.p_ref[k]; }; };
  const auto e = [](int k) { return [k](const FlightSample& s) { return s.p_est[k]; }; };
  const std::vector<double> t = column(result, [](const FlightSample& s) { return s.t_s; });

  eval::Plot top;
  top.title = "kestrel fly " + result.scenario + ": top view";
  top.x_label = "x [m]";
  top.y_label = "y [m]";
  top.equal_aspect = true;
  top.width_px = 800;
  top.height_px = 700;
  top.add("reference", column(result, r(0)), column(result, r(1))).thickness_px = 2;
  top.add("true", column(result, x(0)), column(result, x(1)));
  top.add("estimated", column(result, e(0)), column(result, e(1)));
  const fs::path top_path = dir / "top_view.png";
  eval::write_png(top_path, eval::render_plot(top));

  eval::Plot errors;
  errors.title = "position errors";
  errors.x_label = "time [s]";
  errors.y_label = "error [m]";
  errors.add("|true - reference| (tracking)", t,
             column(result, [](const FlightSample& s) { return (s.p_true - s.p_ref).norm(); }));
  errors.add("|estimated - true| (estimator)", t,
             column(result, [](const FlightSample& s) { return (s.p_est - s.p_true).norm(); }));
  eval::Plot altitude;
  altitude.title = "altitude";
  altitude.x_label = "time [s]";
  altitude.y_label = "z [m]";
  altitude.add("reference", t, column(result, r(2)));
  altitude.add("true", t, column(result, x(2)));
  altitude.add("estimated", t, column(result, e(2)));
  eval::Plot status;
  status.title =
      "odometry and safety (0 nominal, 1 IMU hold, 2 landing, 3 blind descent, 4 landed)";
  status.x_label = "time [s]";
  status.y_label = "state";
  status.height_px = 250;
  status.y_range = eval::AxisRange{-0.2, 4.2};
  status.add("odometry ok", t,
             column(result, [](const FlightSample& s) { return s.vo_ok ? 1.0 : 0.0; }));
  status.add("safety mode", t,
             column(result, [](const FlightSample& s) { return static_cast<double>(s.mode); }));
  std::vector<eval::Plot> panels = {errors, altitude, status};
  if (!result.odometry_checks.empty()) {
    // odometry.csv at a glance: which axis of the measured motion errs, and when.
    eval::Plot odometry;
    odometry.title = "odometry measurement error against the truth (reference camera axes)";
    odometry.x_label = "time [s]";
    odometry.y_label = "error [mm]";
    std::vector<double> tc;
    std::array<std::vector<double>, 3> ec;
    for (const OdometryCheck& c : result.odometry_checks) {
      tc.push_back(c.t_s);
      const Eigen::Vector3d d = 1000.0 * c.translation_error();
      for (int k = 0; k < 3; ++k) ec[static_cast<std::size_t>(k)].push_back(d[k]);
    }
    odometry.add("x (right)", tc, ec[0]);
    odometry.add("y (down)", tc, ec[1]);
    odometry.add("z (forward)", tc, ec[2]);
    panels.push_back(odometry);
  }
  const fs::path errors_path = dir / "errors.png";
  eval::write_png(errors_path, eval::render_stacked(panels));
  return {top_path, errors_path};
}

std::string flight_summary_line(const FlightResult& result) {
  return "rms_tracking_m=" + fixed(result.rms_tracking_m(), 4) +
         " rms_estimate_m=" + fixed(result.rms_estimate_m(), 4) +
         " crashed=" + (result.crashed ? "1" : "0");
}

}  // namespace kestrel::flight
