// The pipeline's camera source (private to src/pipeline): opens and configures the V4L2 stereo
// camera of a config, then runs the driver's capture loop (capture_stereo: poll deadlines,
// ENODEV, truncated / corrupted / out-of-order frames) and hands each good frame on as a grey
// pair, the form a folder's pairs have.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <ostream>

#include "kestrel/driver/stereo_capture.hpp"
#include "kestrel/pipeline/camera_source_options.hpp"
#include "kestrel/pipeline/stage_stats.hpp"

namespace kestrel::pipeline {

class CameraFrameSource {
 public:
  /// A decoded pair: capture time (the driver's CLOCK_MONOTONIC stamp), grey views, and when its
  /// decoding started and ended on the steady clock.
  using PairSink = std::function<void(TimeNs t_ns, cv::Mat left, cv::Mat right,
                                      Clock::time_point start, Clock::time_point decoded)>;

  /// Opens options.device and negotiates the format. A device that is missing, busy, not a
  /// camera or refuses the format is an InputError naming `config` and the field
  /// (`camera.device`, or `camera` for the format), then the device path.
  CameraFrameSource(const CameraSourceOptions& options, const std::filesystem::path& config,
                    std::shared_ptr<driver::DeviceIo> io);

  /// Captures until `max_frames` good frames (0: no limit), `stop` says so (checked before each
  /// wait), or the camera stops (unplugged, stalled for timeout_s, failed): the report says
  /// which. Problem frames are logged to `log` (first few of each kind) and counted. A device
  /// that fails to start streaming is an InputError naming the config and `camera.device`.
  driver::CaptureReport run(std::size_t max_frames, const std::function<bool()>& stop,
                            const PairSink& sink, std::ostream* log);

  [[nodiscard]] const driver::DeviceInfo& info() const { return camera_->info(); }
  [[nodiscard]] const driver::StreamFormat& format() const { return format_; }

 private:
  CameraSourceOptions options_;
  std::filesystem::path config_;
  std::unique_ptr<driver::V4l2Camera> camera_;
  driver::StreamFormat format_;
  driver::StereoFrameDecoder decoder_;
};

}  // namespace kestrel::pipeline
