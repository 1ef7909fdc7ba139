// Reading and writing TUM and EuRoC trajectory files, with exact nanosecond time stamps.
#include "kestrel/io/trajectory_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <optional>

#include "kestrel/core/error.hpp"
#include "kestrel/io/output_guard.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

namespace {

// The header comment says how far from unit a quaternion may be: files written with 4
// decimals (the TUM ground truth) are off by up to ~1e-4.
constexpr double kUnitQuaternionTolerance = 1e-3;
constexpr TimeNs kNsPerS = 1'000'000'000;

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// A header cell such as "timestamp" (but not "nan" or "inf", which are bad numbers).
bool is_column_name(std::string_view field) {
  if (field.empty() || std::isalpha(static_cast<unsigned char>(field.front())) == 0) {
    return false;
  }
  std::string lower(field);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower != "nan" && lower != "inf" && lower != "infinity";
}

std::string quaternion_text(const Eigen::Quaterniond& q) {
  return "(w x y z) = (" + format_double(q.w()) + " " + format_double(q.x()) + " " +
         format_double(q.y()) + " " + format_double(q.z()) + ")";
}

/// Checks and normalises the quaternion, checks that time increases, and appends the pose.
class PoseCollector {
 public:
  explicit PoseCollector(const TextLineReader& reader) : reader_(reader) {}

  void add(TimeNs t_ns, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
    const double norm = q.norm();
    if (norm == 0.0) reader_.fail("quaternion is zero " + quaternion_text(q));
    if (std::abs(norm - 1.0) > kUnitQuaternionTolerance) {
      reader_.fail("quaternion " + quaternion_text(q) + " has norm " + format_double(norm) +
                   "; expected a unit quaternion (norm within 1e-3 of 1)");
    }
    if (!trajectory_.empty()) {
      const TimeNs previous = trajectory_.back().t_ns;
      if (t_ns == previous) {
        reader_.fail("duplicate time stamp " + format_seconds(t_ns) + " s (also on line " +
                     std::to_string(previous_line_) + ")");
      }
      if (t_ns < previous) {
        reader_.fail("time goes backwards: " + format_seconds(t_ns) + " s after " +
                     format_seconds(previous) + " s on line " + std::to_string(previous_line_));
      }
    }
    trajectory_.push_back({t_ns, SE3(q.normalized(), p)});
    previous_line_ = reader_.line_number();
  }

  Trajectory take() { return std::move(trajectory_); }

 private:
  const TextLineReader& reader_;
  Trajectory trajectory_;
  std::size_t previous_line_ = 0;
};

/// Opens `path` for writing after the provenance check; the first line is the provenance.
std::ofstream open_for_writing(const fs::path& path, std::string_view command, bool force) {
  check_can_write_file(path, command, force);
  std::ofstream out(path);
  if (!out) throw InputError(path.string() + ": cannot open file for writing");
  out << provenance_line(command) << "\n";
  return out;
}

void finish_writing(std::ofstream& out, const fs::path& path) {
  out.flush();
  if (!out) throw InputError(path.string() + ": write failed (disk full?)");
}

}  // namespace

std::string_view format_name(TrajectoryFormat format) {
  return format == TrajectoryFormat::kTum ? "TUM" : "EuRoC CSV";
}

TimeNs parse_seconds_ns(std::string_view field, const TextLineReader& reader, std::size_t index) {
  // The value comes from parse_seconds_to_ns (one parser for every time stamp Kestrel reads);
  // the checks here only say precisely what is wrong with the field.
  const auto bad = [&](const std::string& why) {
    reader.fail("field " + std::to_string(index + 1) + " is not a time stamp in seconds (" + why +
                "): '" + std::string(field) + "'");
  };
  const std::size_t dot = field.find('.');
  const std::string_view whole = field.substr(0, dot);
  const std::string_view fraction =
      dot == std::string_view::npos ? std::string_view() : field.substr(dot + 1);
  if (whole.empty()) bad("no digits before the '.'");
  if (!std::all_of(whole.begin(), whole.end(), is_digit) ||
      !std::all_of(fraction.begin(), fraction.end(), is_digit)) {
    bad("expected digits, an optional '.' and more digits");
  }
  const std::optional<TimeNs> t_ns = parse_seconds_to_ns(field);
  if (!t_ns) bad("out of range");
  return *t_ns;
}

std::string format_seconds(TimeNs t_ns) {
  const bool negative = t_ns < 0;
  // Through unsigned so that the most negative value does not overflow.
  const std::uint64_t magnitude =
      negative ? 0 - static_cast<std::uint64_t>(t_ns) : static_cast<std::uint64_t>(t_ns);
  const std::uint64_t ns_per_s = static_cast<std::uint64_t>(kNsPerS);
  std::string fraction = std::to_string(magnitude % ns_per_s);
  fraction.insert(0, 9 - fraction.size(), '0');
  while (fraction.size() > 6 && fraction.back() == '0') fraction.pop_back();
  std::string text = negative ? "-" : "";
  text += std::to_string(magnitude / ns_per_s);
  text += '.';
  text += fraction;
  return text;
}

std::string format_double(double value) {
  std::array<char, 32> buffer{};
  const auto [ptr, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  if (ec != std::errc()) return "nan";  // cannot happen: 32 chars hold any double
  return {buffer.data(), ptr};
}

Trajectory read_tum_trajectory(const fs::path& path) {
  TextLineReader reader(path);
  PoseCollector poses(reader);
  std::string line;
  while (reader.next(line)) {
    const auto fields = split_fields(line, " \t");
    if (fields.size() != 8) {
      reader.fail("expected 8 fields 'timestamp tx ty tz qx qy qz qw', found " +
                  std::to_string(fields.size()));
    }
    std::array<double, 8> v{};
    for (std::size_t i = 1; i < 8; ++i) v[i] = parse_double(fields[i], reader, i);
    poses.add(parse_seconds_ns(fields[0], reader, 0), {v[1], v[2], v[3]},
              Eigen::Quaterniond(v[7], v[4], v[5], v[6]));
  }
  return poses.take();
}

Trajectory read_euroc_trajectory(const fs::path& path) {
  TextLineReader reader(path);
  PoseCollector poses(reader);
  std::string line;
  bool first = true;
  while (reader.next(line)) {
    const auto fields = split_fields(line, ",");
    // EuRoC headers start with '#', but some tools write "timestamp,..." without it.
    if (first && is_column_name(fields.front())) {
      first = false;
      continue;
    }
    first = false;
    if (fields.size() < 8) {
      reader.fail(
          "expected at least 8 comma-separated fields 'timestamp [ns],p_x,p_y,p_z,q_w,"
          "q_x,q_y,q_z', found " +
          std::to_string(fields.size()));
    }
    const TimeNs t_ns = parse_int64(fields[0], reader, 0);
    std::array<double, 8> v{};
    for (std::size_t i = 1; i < 8; ++i) v[i] = parse_double(fields[i], reader, i);
    poses.add(t_ns, {v[1], v[2], v[3]}, Eigen::Quaterniond(v[4], v[5], v[6], v[7]));
  }
  return poses.take();
}

TrajectoryFormat detect_trajectory_format(const fs::path& path) {
  TextLineReader reader(path);
  std::string line;
  if (reader.next(line) && line.find(',') != std::string::npos) {
    return TrajectoryFormat::kEurocCsv;
  }
  return TrajectoryFormat::kTum;
}

Trajectory read_trajectory(const fs::path& path) {
  return detect_trajectory_format(path) == TrajectoryFormat::kEurocCsv ? read_euroc_trajectory(path)
                                                                       : read_tum_trajectory(path);
}

void write_tum_trajectory(const fs::path& path, const Trajectory& trajectory,
                          std::string_view command, bool force) {
  std::ofstream out = open_for_writing(path, command, force);
  out << "# timestamp tx ty tz qx qy qz qw\n";
  for (const StampedPose& pose : trajectory) {
    const Eigen::Vector3d& p = pose.T_world_body.translation();
    const Eigen::Quaterniond& q = pose.T_world_body.unit_quaternion();
    out << format_seconds(pose.t_ns) << ' ' << format_double(p.x()) << ' ' << format_double(p.y())
        << ' ' << format_double(p.z()) << ' ' << format_double(q.x()) << ' ' << format_double(q.y())
        << ' ' << format_double(q.z()) << ' ' << format_double(q.w()) << '\n';
  }
  finish_writing(out, path);
}

void write_euroc_trajectory(const fs::path& path, const Trajectory& trajectory,
                            std::string_view command, bool force) {
  std::ofstream out = open_for_writing(path, command, force);
  out << "#timestamp [ns],p_x [m],p_y [m],p_z [m],q_w [],q_x [],q_y [],q_z []\n";
  for (const StampedPose& pose : trajectory) {
    const Eigen::Vector3d& p = pose.T_world_body.translation();
    const Eigen::Quaterniond& q = pose.T_world_body.unit_quaternion();
    out << pose.t_ns << ',' << format_double(p.x()) << ',' << format_double(p.y()) << ','
        << format_double(p.z()) << ',' << format_double(q.w()) << ',' << format_double(q.x()) << ','
        << format_double(q.y()) << ',' << format_double(q.z()) << '\n';
  }
  finish_writing(out, path);
}

}  // namespace kestrel::io
