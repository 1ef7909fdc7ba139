// Recording decoded stereo frames as an EuRoC (ASL) folder that io::EurocSequence reads back:
// mav0/cam0/data/<t_ns>.png, mav0/cam1/data/<t_ns>.png, mav0/cam{0,1}/data.csv; optionally the
// packed frames as they came from the camera (raw/<t_ns>.bin) for decoding again offline.
#pragma once

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "kestrel/core/time.hpp"
#include "kestrel/driver/stereo_frame_decoder.hpp"

namespace kestrel::driver {

struct RecorderOptions {
  /// What the PNGs hold: grey (EuRoC's convention, default), colour, or the raw mosaics.
  ViewKind images = ViewKind::kGray;
  /// Also keep every packed frame, rows unpadded (2 * width bytes each), as `raw/<t_ns>.bin`:
  /// `kestrel capture --decode-file` decodes one again with other options.
  bool raw = false;
  /// PNG deflate level 0..9: 1 keeps up with 30 Hz stereo on one core.
  int png_compression = 1;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// Writes folder `dir`:
///   `mav0/cam0/data/<t_ns>.png` (left), `mav0/cam1/data/<t_ns>.png` (right),
///   mav0/cam{0,1}/data.csv ("#timestamp [ns],filename", after the provenance line),
///   `raw/<t_ns>.bin` when RecorderOptions::raw.
/// The folder is claimed with io::claim_output_dir(dir, "capture", force); a previous capture's
/// frames in it are removed first, so no stale frames remain.
class StereoRecorder {
 public:
  static constexpr std::string_view kCommand = "capture";

  StereoRecorder(std::filesystem::path dir, StereoDecoderOptions decoder,
                 RecorderOptions options = {}, bool force = false);
  /// Finishes if finish() was not called (errors are then swallowed: call finish()).
  ~StereoRecorder();
  StereoRecorder(const StereoRecorder&) = delete;
  StereoRecorder& operator=(const StereoRecorder&) = delete;

  /// One stereo frame at t_ns, which must exceed the previous one's (std::invalid_argument
  /// otherwise: file names are time stamps). `packed` (rows `bytes_per_line` apart, 0:
  /// unpadded) is needed when RecorderOptions::raw is set. Throws InputError if a file cannot
  /// be written.
  void write(TimeNs t_ns, const StereoMosaic& mosaic, std::span<const std::uint8_t> packed = {},
             std::size_t bytes_per_line = 0);
  /// Flushes and closes the lists; later writes throw std::logic_error.
  void finish();

  [[nodiscard]] std::size_t frames_written() const { return frames_; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  [[nodiscard]] std::optional<TimeNs> last_t_ns() const { return last_t_ns_; }

 private:
  void write_raw(const std::filesystem::path& path, std::span<const std::uint8_t> packed,
                 std::size_t bytes_per_line) const;

  std::filesystem::path dir_;
  StereoFrameDecoder decoder_;
  RecorderOptions options_;
  bool finished_ = false;
  std::size_t frames_ = 0;
  std::optional<TimeNs> last_t_ns_;
  std::ofstream cam0_csv_;
  std::ofstream cam1_csv_;
  cv::Mat view_;
};

}  // namespace kestrel::driver
