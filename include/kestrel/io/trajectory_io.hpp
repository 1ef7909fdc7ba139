// Trajectory files: TUM format ("timestamp tx ty tz qx qy qz qw", seconds) and EuRoC CSV
// ("timestamp[ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z[,more columns ignored]").
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "kestrel/io/text_lines.hpp"
#include "kestrel/io/trajectory.hpp"

namespace kestrel::io {

enum class TrajectoryFormat { kTum, kEurocCsv };

/// "TUM" or "EuRoC CSV", for reports.
std::string_view format_name(TrajectoryFormat format);

/// TUM format; time stamps parsed exactly (decimal seconds to integer ns). Throws
/// InputError "FILE:LINE: ..." on a malformed line, a non-unit quaternion or time going
/// backwards; accepts any quaternion norm within 1e-3 of one and renormalises.
Trajectory read_tum_trajectory(const std::filesystem::path& path);
/// EuRoC ASL CSV (also the ground-truth state CSVs, whose extra columns are ignored).
Trajectory read_euroc_trajectory(const std::filesystem::path& path);
/// Detects the format from the content (commas -> EuRoC) and reads it.
Trajectory read_trajectory(const std::filesystem::path& path);
/// The format read_trajectory() would use: EuRoC CSV if the first line that is not blank or
/// a comment holds a comma, else TUM (also for a file without data lines).
TrajectoryFormat detect_trajectory_format(const std::filesystem::path& path);

/// Writes TUM format, first line io::provenance_line(command); refuses to overwrite a file
/// written by something else unless `force` (see output_guard.hpp).
void write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                          std::string_view command, bool force = false);
/// Writes EuRoC CSV, same rules.
void write_euroc_trajectory(const std::filesystem::path& path, const Trajectory& trajectory,
                            std::string_view command, bool force = false);

/// Decimal seconds ("1305031098.6659", "12", "0.000000001") to integer nanoseconds, exactly:
/// the integer and fractional digits are parsed separately, never through a double (a double
/// holds only ~0.2 us at today's epoch). Digits beyond the 9th decimal are rounded half up.
/// Signs, exponents and other characters are refused through reader.fail() naming field
/// `index`.
TimeNs parse_seconds_ns(std::string_view field, const TextLineReader& reader, std::size_t index);
/// Nanoseconds as decimal seconds with 6 to 9 decimals: exact, and parse_seconds_ns() of the
/// result gives t_ns back ("1305031098.665900", "0.000000001").
std::string format_seconds(TimeNs t_ns);
/// Shortest decimal text that reads back as exactly `value` (std::to_chars).
std::string format_double(double value);

}  // namespace kestrel::io
