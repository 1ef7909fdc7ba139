// TUM RGB-D benchmark folders (rgb.txt, depth.txt, rgb/, depth/, groundtruth.txt): the index
// is read at construction, images are decoded one frame at a time on request.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/io/trajectory.hpp"

namespace kestrel::io {

struct TumRgbdOptions {
  double max_association_diff_s = 0.02;  ///< the benchmark's tolerance for rgb/depth pairs
  double depth_scale = 5000.0;           ///< depth PNG units per metre (TUM: 5000)
};

/// One entry of a TUM list file (rgb.txt, depth.txt).
struct TimedFile {
  TimeNs t_ns = 0;
  std::filesystem::path file;  ///< absolute (folder / relative name in the list)
  std::size_t line = 0;        ///< line number in the list file, for error messages
};

/// An RGB-D frame as decoded from disk.
struct RgbdImages {
  TimeNs t_ns = 0;        ///< time of the colour image (the frame's time stamp)
  TimeNs depth_t_ns = 0;  ///< time of the associated depth image
  cv::Mat bgr;            ///< CV_8UC3
  cv::Mat depth_m;        ///< CV_32FC1, metres; 0 where the sensor gave no depth
};

/// Reads a "timestamp filename" list; throws InputError "FILE:LINE: ..." on a bad line.
std::vector<TimedFile> read_tum_file_list(const std::filesystem::path& list_file);

/// Greedy nearest-time association as the benchmark's associate.py: every pair with
/// |t_a - t_b| < max_diff, closest first, each element used at most once; returned as
/// (index in a, index in b) sorted by a.
std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const std::vector<TimeNs>& a,
                                                                   const std::vector<TimeNs>& b,
                                                                   TimeNs max_diff_ns);

/// Decodes a TUM depth PNG (16-bit, `depth_scale` units per metre) into metres.
/// Throws InputError naming the file if it is missing, undecodable, not 16-bit single
/// channel, or (when expected_size is non-empty) of another size.
cv::Mat read_tum_depth(const std::filesystem::path& png, double depth_scale,
                       cv::Size expected_size = {});
/// Decodes a colour image; throws InputError naming the file if missing or undecodable.
cv::Mat read_color_image(const std::filesystem::path& file);

class TumRgbdSequence {
 public:
  /// Reads and associates the lists; throws InputError naming the file and line.
  explicit TumRgbdSequence(std::filesystem::path folder, TumRgbdOptions options = {});

  [[nodiscard]] std::size_t size() const { return pairs_.size(); }
  [[nodiscard]] const std::filesystem::path& folder() const { return folder_; }
  [[nodiscard]] TimeNs timestamp(std::size_t i) const { return rgb_[pairs_[i].first].t_ns; }
  /// Decodes frame i (colour and depth); depth must match the colour image's size.
  [[nodiscard]] RgbdImages load(std::size_t i) const;
  /// groundtruth.txt, if the folder has one.
  [[nodiscard]] std::optional<Trajectory> groundtruth() const;
  /// Number of colour images that found no depth image within the tolerance.
  [[nodiscard]] std::size_t unmatched_rgb() const { return rgb_.size() - pairs_.size(); }

 private:
  std::filesystem::path folder_;
  TumRgbdOptions options_;
  std::vector<TimedFile> rgb_;
  std::vector<TimedFile> depth_;
  std::vector<std::pair<std::size_t, std::size_t>> pairs_;
};

}  // namespace kestrel::io
