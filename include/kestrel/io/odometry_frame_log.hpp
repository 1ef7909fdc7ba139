// The per-frame log of `kestrel odometry --frames` (a CSV with Kestrel's provenance line and a
// header): its covariance columns, and reading back what the fusion needs from it
// (`kestrel fuse --vo-frames`).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::io {

/// Name of the covariance column (r, c), r <= c < 6: "cov_rc". The 21 upper-triangle entries
/// of TrackResult::covariance (left perturbation [v, w] of the motion to the reference, in the
/// reference frame; m^2, m rad, rad^2), row by row.
std::string frame_log_covariance_column(int r, int c);

/// One row of the log, as far as the fusion needs it.
struct OdometryFrameRecord {
  TimeNs t_ns = 0;
  TimeNs ref_t_ns = 0;  ///< the reference (keyframe) the frame was aligned to
  bool ok = false;
  bool new_keyframe = false;
  Matrix6d covariance = Matrix6d::Identity();
};

/// Reads the columns t_ns, ref_t_ns, ok, new_keyframe and the covariance. Throws InputError
/// naming the file and the missing column, or the line and field of a bad value (a
/// covariance that is not positive-definite on an ok row included).
std::vector<OdometryFrameRecord> read_odometry_frame_log(const std::filesystem::path& path);

}  // namespace kestrel::io
