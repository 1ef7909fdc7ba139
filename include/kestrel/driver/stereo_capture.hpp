// One stereo capture run: frames from a V4L2 camera, checked, split into their two mosaics and
// handed to a sink (the recorder, or a pipeline), until a frame count, a duration, an interrupt,
// or a fault of the device. Faults are logged and end the run with a report; none hangs it.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <ostream>
#include <span>
#include <string>

#include "kestrel/core/time.hpp"
#include "kestrel/driver/stereo_frame_decoder.hpp"
#include "kestrel/driver/v4l2_camera.hpp"

namespace kestrel::driver {

struct CaptureLimits {
  std::size_t frames = 0;   ///< stop after this many good frames (0: no limit)
  double duration_s = 0.0;  ///< stop once frames span this long (0: no limit)
  double timeout_s = 2.0;   ///< waiting longer than this for a frame ends the run (stalled)
  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

enum class CaptureStop {
  kFrames,        ///< the frame count was reached
  kDuration,      ///< the duration was reached
  kInterrupted,   ///< the interrupt flag was raised (Ctrl-C)
  kTimeout,       ///< no frame within the timeout
  kDisconnected,  ///< the device went away
  kFailed,        ///< another error of the device
};
[[nodiscard]] std::string_view capture_stop_name(CaptureStop stop);

/// What a run did: its health.
struct CaptureReport {
  std::size_t frames = 0;        ///< good frames handed to the sink
  std::size_t truncated = 0;     ///< frames shorter than the format needs: dropped
  std::size_t corrupted = 0;     ///< frames the driver flagged as bad: dropped
  std::size_t out_of_order = 0;  ///< time stamps not after the previous frame's: dropped
  std::uint64_t lost = 0;        ///< frames the driver counted but never delivered
  CaptureStop stop = CaptureStop::kFrames;
  std::string stop_message;  ///< the device's error for kTimeout / kDisconnected / kFailed
  TimeNs first_t_ns = 0;
  TimeNs last_t_ns = 0;
  TimestampClock clock = TimestampClock::kHost;  ///< of the last good frame
  /// True when the run ended as asked (frames, duration, interrupt), not by a fault.
  [[nodiscard]] bool ended_as_asked() const {
    return stop == CaptureStop::kFrames || stop == CaptureStop::kDuration ||
           stop == CaptureStop::kInterrupted;
  }
  [[nodiscard]] std::string describe() const;
};

/// Receives each good frame: its time stamp, its two mosaics, and the packed bytes (rows
/// `bytes_per_line` apart) as the camera delivered them. May throw (e.g. disk full): the
/// exception ends the run and propagates, with the camera stopped.
using StereoFrameSink =
    std::function<void(TimeNs t_ns, const StereoMosaic& mosaic,
                       std::span<const std::uint8_t> packed, std::size_t bytes_per_line)>;

struct CaptureHooks {
  std::ostream* log = nullptr;                         ///< problem frames are logged here
  const std::atomic<bool>* interrupt = nullptr;        ///< raised: stop after the current frame
  std::function<void(const CaptureReport&)> on_frame;  ///< after each good frame (progress)
  /// Asked before each wait for a frame, as `interrupt`: true ends the run as interrupted. For
  /// callers whose stop condition is more than one flag (a pipeline: Ctrl-C or a failed stage).
  std::function<bool()> stop_requested;
};

/// Runs one capture on a configured camera (started here if it is not streaming; stopped on
/// return). The decoder's size must match `format`'s (std::invalid_argument otherwise).
CaptureReport capture_stereo(V4l2Camera& camera, const StreamFormat& format,
                             const StereoFrameDecoder& decoder, const CaptureLimits& limits,
                             const StereoFrameSink& sink, const CaptureHooks& hooks = {});

}  // namespace kestrel::driver
