// Reading the per-frame log of `kestrel odometry --frames` (io/odometry_frame_log.hpp).
#include "kestrel/io/odometry_frame_log.hpp"

#include <Eigen/Cholesky>
#include <map>

#include "kestrel/core/error.hpp"
#include "kestrel/io/text_lines.hpp"

namespace kestrel::io {

std::string frame_log_covariance_column(int r, int c) {
  return "cov_" + std::to_string(r) + std::to_string(c);
}

std::vector<OdometryFrameRecord> read_odometry_frame_log(const std::filesystem::path& path) {
  TextLineReader reader(path);
  std::string line;
  if (!reader.next(line)) throw InputError(path.string() + ": empty (no header line)");
  std::map<std::string, std::size_t, std::less<>> column;
  const auto header = split_fields(line, ",");
  for (std::size_t i = 0; i < header.size(); ++i) column.emplace(std::string(header[i]), i);
  auto index_of = [&](const std::string& name) {
    const auto it = column.find(name);
    if (it == column.end()) {
      throw InputError(path.string() + ": no column '" + name +
                       "' (a log of `kestrel odometry --frames`?)");
    }
    return it->second;
  };
  const std::size_t i_t = index_of("t_ns"), i_ref = index_of("ref_t_ns"), i_ok = index_of("ok"),
                    i_kf = index_of("new_keyframe");
  int i_cov[6][6];
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c)
      i_cov[r][c] = static_cast<int>(index_of(frame_log_covariance_column(r, c)));
  }
  std::vector<OdometryFrameRecord> out;
  while (reader.next(line)) {
    const auto f = split_fields(line, ",");
    if (f.size() != header.size()) {
      reader.fail("expected " + std::to_string(header.size()) + " fields (the header's), got " +
                  std::to_string(f.size()));
    }
    auto flag = [&](std::size_t i) {
      if (f[i] != "0" && f[i] != "1")
        reader.fail("field " + std::to_string(i + 1) + ": expected 0 or 1");
      return f[i] == "1";
    };
    OdometryFrameRecord rec;
    rec.t_ns = parse_int64(f[i_t], reader, i_t);
    rec.ref_t_ns = parse_int64(f[i_ref], reader, i_ref);
    rec.ok = flag(i_ok);
    rec.new_keyframe = flag(i_kf);
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) {
        const auto i = static_cast<std::size_t>(i_cov[r][c]);
        rec.covariance(r, c) = rec.covariance(c, r) = parse_double(f[i], reader, i);
      }
    }
    const bool first = rec.ref_t_ns == rec.t_ns;  // the reference itself: nothing measured
    if (rec.ok && !first && Eigen::LLT<Matrix6d>(rec.covariance).info() != Eigen::Success) {
      reader.fail("the covariance (cov_* columns) is not positive-definite");
    }
    if (!out.empty() && rec.t_ns <= out.back().t_ns) reader.fail("t_ns does not increase");
    out.push_back(rec);
  }
  return out;
}

}  // namespace kestrel::io
