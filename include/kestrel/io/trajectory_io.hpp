// Trajectory files: TUM format ("timestamp tx ty tz qx qy qz qw", seconds) and EuRoC CSV
// ("timestamp[ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z[,more columns ignored]").
#pragma once

#include <filesystem>
#include <string_view>

#include "kestrel/io/trajectory.hpp"

namespace kestrel::io {

enum class TrajectoryFormat { kTum, kEurocCsv };

/// TUM format; time stamps parsed exactly (decimal seconds to integer ns). Throws
/// InputError "FILE:LINE: ..." on a malformed line, a non-unit quaternion or time going
/// backwards; accepts any quaternion norm within 1e-3 of one and renormalises.
Trajectory read_tum_trajectory(const std::filesystem::path& path);
/// EuRoC ASL CSV (also the ground-truth state CSVs, whose extra columns are ignored).
Trajectory read_euroc_trajectory(const std::filesystem::path& path);
/// Detects the format from the content (commas -> EuRoC) and reads it.
Trajectory read_trajectory(const std::filesystem::path& path);

/// Writes TUM format, first line io::provenance_line(command); refuses to overwrite a file
/// written by something else unless `force` (see output_guard.hpp).
void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                          std::string_view command, bool force = false);
/// Writes EuRoC CSV, same rules.
void write_euroc_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                            std::string_view command, bool force = false);

}  // namespace kestrel::io
