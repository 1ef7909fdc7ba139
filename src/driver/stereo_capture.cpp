// The capture loop: every outcome of V4l2Camera::next() is either a frame for the sink, a frame
// dropped with a log line, or the end of the run with its reason.
#include "kestrel/driver/stereo_capture.hpp"

#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace kestrel::driver {

namespace {

// Per kind of problem, only the first few are logged; the report counts them all.
constexpr std::size_t kLoggedPerKind = 5;

void log_problem(const CaptureHooks& hooks, std::size_t count, const std::string& kind,
                 const std::string& message) {
  if (hooks.log == nullptr || count > kLoggedPerKind) return;
  *hooks.log << "capture: " << message;
  if (count == kLoggedPerKind) *hooks.log << " (further " << kind << " frames not logged)";
  *hooks.log << "\n";
}

/// Stops the camera however the run ends.
class StopOnExit {
 public:
  explicit StopOnExit(V4l2Camera& camera) : camera_(camera) {}
  ~StopOnExit() { camera_.stop(); }
  StopOnExit(const StopOnExit&) = delete;
  StopOnExit& operator=(const StopOnExit&) = delete;

 private:
  V4l2Camera& camera_;
};

}  // namespace

void CaptureLimits::validate() const {
  if (!(duration_s >= 0.0) || !std::isfinite(duration_s)) {
    throw std::invalid_argument("capture: duration must be >= 0 s (0: no limit)");
  }
  if (!(timeout_s > 0.0) || !(timeout_s <= 3600.0)) {
    throw std::invalid_argument("capture: timeout must be in (0, 3600] s");
  }
}

std::string_view capture_stop_name(CaptureStop stop) {
  switch (stop) {
    case CaptureStop::kFrames:
      return "frame count reached";
    case CaptureStop::kDuration:
      return "duration reached";
    case CaptureStop::kInterrupted:
      return "interrupted";
    case CaptureStop::kTimeout:
      return "timed out";
    case CaptureStop::kDisconnected:
      return "device disconnected";
    case CaptureStop::kFailed:
      return "device failed";
  }
  return "?";
}

std::string CaptureReport::describe() const {
  std::ostringstream os;
  os << frames << " frames";
  if (frames > 1) {
    os.setf(std::ios::fixed);
    os.precision(3);
    const double span_s = ns_to_s(last_t_ns - first_t_ns);
    os << " over " << span_s << " s";
    if (span_s > 0.0) {
      os.precision(1);
      os << " (" << static_cast<double>(frames - 1) / span_s << " Hz)";
    }
  }
  os << ", time stamps " << timestamp_clock_name(clock) << "; dropped: " << truncated
     << " truncated, " << corrupted << " corrupted, " << out_of_order
     << " out of order; lost by the driver: " << lost << "; ended: " << capture_stop_name(stop);
  if (!stop_message.empty()) os << " (" << stop_message << ")";
  return os.str();
}

CaptureReport capture_stereo(V4l2Camera& camera, const StreamFormat& format,
                             const StereoFrameDecoder& decoder, const CaptureLimits& limits,
                             const StereoFrameSink& sink, const CaptureHooks& hooks) {
  limits.validate();
  const StereoDecoderOptions& o = decoder.options();
  if (format.width != o.width || format.height != o.height) {
    throw std::invalid_argument("capture: the decoder expects " + std::to_string(o.width) + "x" +
                                std::to_string(o.height) + " frames, the camera gives " +
                                std::to_string(format.width) + "x" + std::to_string(format.height));
  }
  // Drivers may report 0 for the stride of packed formats: then rows are unpadded.
  const std::size_t bytes_per_line =
      format.bytes_per_line >= o.packed_row_bytes() ? format.bytes_per_line : 0;
  const int timeout_ms = static_cast<int>(std::ceil(limits.timeout_s * 1e3));
  const auto duration_ns = static_cast<TimeNs>(std::llround(limits.duration_s * 1e9));

  if (!camera.streaming()) camera.start();
  const StopOnExit stop_on_exit{camera};
  const std::uint64_t lost_before = camera.frames_lost();
  CaptureReport report;
  StereoMosaic mosaic;
  std::optional<TimeNs> first_seen;
  for (;;) {
    if ((hooks.interrupt != nullptr && hooks.interrupt->load()) ||
        (hooks.stop_requested && hooks.stop_requested())) {
      report.stop = CaptureStop::kInterrupted;
      break;
    }
    if (limits.frames > 0 && report.frames >= limits.frames) {
      report.stop = CaptureStop::kFrames;
      break;
    }
    const CapturedFrame f = camera.next(timeout_ms);
    report.lost = camera.frames_lost() - lost_before;
    using Status = CapturedFrame::Status;
    if (f.status == Status::kTimeout || f.status == Status::kDisconnected ||
        f.status == Status::kFailed) {
      report.stop = f.status == Status::kTimeout        ? CaptureStop::kTimeout
                    : f.status == Status::kDisconnected ? CaptureStop::kDisconnected
                                                        : CaptureStop::kFailed;
      report.stop_message = f.message;
      break;
    }
    if (f.status == Status::kFrame || !f.data.empty()) {
      // The run's length is measured on the camera's clock, from the first frame it sent.
      if (!first_seen) first_seen = f.t_ns;
      if (duration_ns > 0 && f.t_ns - *first_seen >= duration_ns) {
        report.stop = CaptureStop::kDuration;
        break;
      }
    }
    if (f.status == Status::kCorrupted) {
      log_problem(hooks, ++report.corrupted, "corrupted", f.message);
      continue;
    }
    const FrameHealth health = decoder.split(f.data, bytes_per_line, mosaic);
    if (!health.ok()) {
      log_problem(hooks, ++report.truncated, "truncated",
                  "frame " + std::to_string(f.sequence) + " dropped: " + health.describe());
      continue;
    }
    if (report.frames > 0 && f.t_ns <= report.last_t_ns) {
      log_problem(hooks, ++report.out_of_order, "out-of-order",
                  "frame " + std::to_string(f.sequence) + " dropped: time stamp " +
                      std::to_string(f.t_ns) + " ns is not after the previous " +
                      std::to_string(report.last_t_ns) + " ns");
      continue;
    }
    sink(f.t_ns, mosaic, f.data, bytes_per_line);
    if (report.frames == 0) report.first_t_ns = f.t_ns;
    report.last_t_ns = f.t_ns;
    report.clock = f.clock;
    ++report.frames;
    if (hooks.on_frame) hooks.on_frame(report);
  }
  return report;
}

}  // namespace kestrel::driver
