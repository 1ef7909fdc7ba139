// What `kestrel fly` leaves behind: the log (at the control rate; docs/flight.md lists its
// columns), a detail log, the figures (top view; errors, altitude and odometry status over time)
// and the summary line.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "kestrel/flight/flight_simulation.hpp"

namespace kestrel::flight {

/// The log's columns, in order: t,x_true,y_true,z_true,x_ref,y_ref,z_ref,x_est,y_est,z_est,vo_ok
/// (seconds, metres, world frame; vo_ok 0 or 1). The header is the first line.
const std::vector<std::string>& flight_log_columns();

/// Writes log.csv (flight_log_columns), details.csv (mode, filter sigma, command),
/// estimator.csv (FlightSample's estimator-against-truth fields) and odometry.csv (every
/// odometry measurement against the truth, OdometryCheck) into `dir`, which the caller has
/// claimed (io::claim_output_dir). Throws InputError naming the file if writing fails. Returns the
/// paths written.
std::vector<std::filesystem::path> write_flight_logs(const std::filesystem::path& dir,
                                                     const FlightResult& result);

/// Writes top_view.png and errors.png into `dir`; returns their paths.
std::vector<std::filesystem::path> write_flight_plots(const std::filesystem::path& dir,
                                                      const FlightResult& result);

/// One line on FlightResult::odometry_checks: the measurements' translation error RMS per camera
/// axis (mm) and that error over the sigma sent with it, RMS per axis (about 1 where the
/// odometry's covariance describes its errors).
std::string odometry_check_summary(const FlightResult& result);

/// "rms_tracking_m=<v> rms_estimate_m=<v> crashed=<0|1>".
std::string flight_summary_line(const FlightResult& result);

}  // namespace kestrel::flight
