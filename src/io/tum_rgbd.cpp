// TUM RGB-D folder reader: list files, rgb/depth association, image decoding.
#include "kestrel/io/tum_rgbd.hpp"

#include <algorithm>
#include <cstdint>
#include <opencv2/imgcodecs.hpp>

#include "kestrel/core/error.hpp"
#include "kestrel/io/text_lines.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::io {
namespace fs = std::filesystem;

std::vector<TimedFile> read_tum_file_list(const fs::path& list_file) {
  TextLineReader reader(list_file);
  std::vector<TimedFile> out;
  std::string line;
  while (reader.next(line)) {
    const auto fields = split_fields(line, " \t");
    if (fields.size() != 2) {
      reader.fail("expected 'timestamp filename', found " + std::to_string(fields.size()) +
                  " fields");
    }
    const auto t = parse_seconds_to_ns(fields[0]);
    if (!t)
      reader.fail("time stamp is not a decimal number of seconds: '" + std::string(fields[0]) +
                  "'");
    if (!out.empty() && *t <= out.back().t_ns) {
      reader.fail("time stamps must increase (this one is not after the previous line's)");
    }
    out.push_back({*t, list_file.parent_path() / std::string(fields[1]), reader.line_number()});
  }
  return out;
}

std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const std::vector<TimeNs>& a,
                                                                   const std::vector<TimeNs>& b,
                                                                   TimeNs max_diff_ns) {
  // Both lists are sorted, so the candidate pairs of each a lie in a window of b; the greedy
  // "closest pair first" rule then needs only those candidates, sorted by difference.
  struct Candidate {
    TimeNs diff;
    std::size_t ia, ib;
  };
  std::vector<Candidate> candidates;
  if (max_diff_ns <= 0) return {};
  // Differences in uint64, where the difference of any two int64 fits: a - max_diff and
  // a + max_diff overflowed for a huge tolerance (`evaluate --max-diff 1e10`, UBSan) or for
  // stamps near the int64 limits.
  const auto distance = [](TimeNs x, TimeNs y) {
    return x >= y ? static_cast<std::uint64_t>(x) - static_cast<std::uint64_t>(y)
                  : static_cast<std::uint64_t>(y) - static_cast<std::uint64_t>(x);
  };
  const auto max_diff = static_cast<std::uint64_t>(max_diff_ns);
  std::size_t lo = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    while (lo < b.size() && b[lo] < a[i] && distance(a[i], b[lo]) >= max_diff) ++lo;
    for (std::size_t j = lo; j < b.size() && (b[j] <= a[i] || distance(b[j], a[i]) < max_diff);
         ++j) {
      // Below max_diff_ns, so it fits a TimeNs.
      candidates.push_back({static_cast<TimeNs>(distance(a[i], b[j])), i, j});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.diff < y.diff; });
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const auto& c : candidates) {
    if (used_a[c.ia] || used_b[c.ib]) continue;
    used_a[c.ia] = used_b[c.ib] = true;
    out.emplace_back(c.ia, c.ib);
  }
  std::sort(out.begin(), out.end());
  return out;
}

cv::Mat read_color_image(const fs::path& file) {
  if (!fs::exists(file)) throw InputError(file.string() + ": image file does not exist");
  cv::Mat img = cv::imread(file.string(), cv::IMREAD_COLOR);
  if (img.empty()) throw InputError(file.string() + ": cannot decode image");
  return img;
}

cv::Mat read_tum_depth(const fs::path& png, double depth_scale, cv::Size expected_size) {
  if (!fs::exists(png)) throw InputError(png.string() + ": depth image does not exist");
  const cv::Mat raw = cv::imread(png.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (raw.empty()) throw InputError(png.string() + ": cannot decode depth image");
  if (raw.type() != CV_16UC1) {
    throw InputError(png.string() + ": depth image must be 16-bit single-channel (got " +
                     std::to_string(raw.elemSize1() * 8) + "-bit, " +
                     std::to_string(raw.channels()) + " channel(s))");
  }
  if (!expected_size.empty() && raw.size() != expected_size) {
    throw InputError(png.string() + ": depth image is " + std::to_string(raw.cols) + "x" +
                     std::to_string(raw.rows) + " but the colour image is " +
                     std::to_string(expected_size.width) + "x" +
                     std::to_string(expected_size.height));
  }
  cv::Mat depth_m;
  raw.convertTo(depth_m, CV_32F, 1.0 / depth_scale);  // 0 stays 0: no depth
  return depth_m;
}

TumRgbdSequence::TumRgbdSequence(fs::path folder, TumRgbdOptions options)
    : folder_(std::move(folder)), options_(options) {
  if (!fs::is_directory(folder_)) {
    throw InputError(folder_.string() + ": not a folder (expected a TUM RGB-D sequence)");
  }
  for (const char* name : {"rgb.txt", "depth.txt"}) {
    if (!fs::exists(folder_ / name)) {
      throw InputError(folder_.string() + ": missing " + name +
                       " (is this a TUM RGB-D sequence folder?)");
    }
  }
  rgb_ = read_tum_file_list(folder_ / "rgb.txt");
  depth_ = read_tum_file_list(folder_ / "depth.txt");
  std::vector<TimeNs> t_rgb, t_depth;
  for (const auto& f : rgb_) t_rgb.push_back(f.t_ns);
  for (const auto& f : depth_) t_depth.push_back(f.t_ns);
  pairs_ = associate_by_time(t_rgb, t_depth, s_to_ns(options_.max_association_diff_s));
}

RgbdImages TumRgbdSequence::load(std::size_t i) const {
  const TimedFile& rgb = rgb_.at(pairs_.at(i).first);
  const TimedFile& depth = depth_.at(pairs_.at(i).second);
  RgbdImages out;
  out.t_ns = rgb.t_ns;
  out.depth_t_ns = depth.t_ns;
  try {
    out.bgr = read_color_image(rgb.file);
    out.depth_m = read_tum_depth(depth.file, options_.depth_scale, out.bgr.size());
  } catch (const InputError& e) {
    // Say which list line named the file, so a user can find the entry to fix.
    const bool in_rgb = out.bgr.empty();
    throw InputError((folder_ / (in_rgb ? "rgb.txt" : "depth.txt")).string() + ":" +
                     std::to_string(in_rgb ? rgb.line : depth.line) + ": " + e.what());
  }
  return out;
}

std::optional<Trajectory> TumRgbdSequence::groundtruth() const {
  const fs::path gt = folder_ / "groundtruth.txt";
  if (!fs::exists(gt)) return std::nullopt;
  return read_tum_trajectory(gt);
}

}  // namespace kestrel::io
