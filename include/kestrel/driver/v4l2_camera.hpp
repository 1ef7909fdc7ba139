// A V4L2 video capture device driven through the raw ioctls: capabilities, formats and frame
// sizes, format negotiation, memory-mapped streaming, and frames dequeued with a poll() timeout
// so that an unplugged or stalled camera never hangs the caller. Usage: docs/driver.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/core/error.hpp"
#include "kestrel/core/time.hpp"
#include "kestrel/driver/device_io.hpp"

namespace kestrel::driver {

/// A device that cannot be used as asked: missing, busy, not a camera, refusing the format.
/// The message starts with the device's path and says what to do where there is something.
class DeviceError : public InputError {
 public:
  DeviceError(const std::string& device, const std::string& message, int error_number = 0)
      : InputError(device + ": " + message), error_number_(error_number) {}
  /// The errno behind the error, 0 if none.
  [[nodiscard]] int error_number() const { return error_number_; }

 private:
  int error_number_;
};

/// "YUYV" for V4L2_PIX_FMT_YUYV; non-printable bytes become '?'.
[[nodiscard]] std::string fourcc_to_string(std::uint32_t fourcc);
/// A code of 1 to 4 printable characters, padded with spaces ("Y8I" -> "Y8I ").
[[nodiscard]] std::optional<std::uint32_t> fourcc_from_string(std::string_view text);

/// What VIDIOC_QUERYCAP says of a device node.
struct DeviceInfo {
  std::string path;
  std::string driver;              ///< e.g. "uvcvideo", "v4l2 loopback"
  std::string card;                ///< the product name
  std::string bus_info;            ///< e.g. "usb-0000:00:14.0-2"
  std::uint32_t capabilities = 0;  ///< the node's capabilities (device_caps where reported)
  bool can_capture = false;        ///< V4L2_CAP_VIDEO_CAPTURE
  bool can_output = false;         ///< V4L2_CAP_VIDEO_OUTPUT
  bool can_stream = false;         ///< V4L2_CAP_STREAMING
  [[nodiscard]] std::string describe() const;
};

/// One frame size a format offers, with its frame rates where the driver lists them.
struct FrameSizeInfo {
  int width = 0;  ///< discrete size, or the largest of a range
  int height = 0;
  std::string range;  ///< "" for a discrete size, else e.g. "16x16 - 1920x1080 step 2x2"
  std::vector<double> rates_hz;
};

struct FormatInfo {
  std::uint32_t fourcc = 0;
  std::string description;
  std::vector<FrameSizeInfo> sizes;
  /// "YUYV (YUYV 4:2:2): 752x480 @ 30, 60 Hz; 640x480 @ 30 Hz".
  [[nodiscard]] std::string describe() const;
};

/// What to ask of the camera.
struct CameraOptions {
  std::string pixel_format = "YUYV";  ///< fourcc the packed stereo frames come labelled with
  int width = 752;
  int height = 480;
  double rate_hz = 0.0;  ///< 0: leave the device's frame rate as it is
  int buffers = 4;       ///< memory-mapped buffers (2..32)
  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// The format the device agreed to.
struct StreamFormat {
  std::uint32_t fourcc = 0;
  int width = 0;
  int height = 0;
  std::size_t bytes_per_line = 0;
  std::size_t image_bytes = 0;
  double rate_hz = 0.0;            ///< 0 where the device does not say
  std::vector<std::string> notes;  ///< requests the device could not honour (e.g. the rate)
  [[nodiscard]] std::string describe() const;
};

/// The clock behind a frame's time stamp.
enum class TimestampClock {
  kMonotonic,  ///< the driver's CLOCK_MONOTONIC stamp (V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC)
  kCopied,     ///< copied from an output stream (loopback / mem-to-mem devices)
  kUnknown,    ///< the driver stamped the buffer but does not say with which clock
  kHost,       ///< the buffer carried none: CLOCK_MONOTONIC when it was dequeued
};
[[nodiscard]] std::string_view timestamp_clock_name(TimestampClock clock);

/// struct timeval (seconds, microseconds) -> nanoseconds.
[[nodiscard]] constexpr TimeNs timeval_to_ns(std::int64_t seconds, std::int64_t microseconds) {
  return seconds * 1'000'000'000 + microseconds * 1'000;
}

/// The outcome of one wait for a frame: a frame, or why there is none.
struct CapturedFrame {
  enum class Status {
    kFrame,         ///< `data` holds a frame
    kCorrupted,     ///< the driver flagged the frame as bad (or DQBUF said EIO): skip it
    kTimeout,       ///< no frame within the timeout: the stream stalled
    kDisconnected,  ///< the device went away (ENODEV, POLLERR/POLLHUP): unplugged
    kFailed,        ///< any other error of poll() or the ioctls
  };
  Status status = Status::kTimeout;
  /// The bytes the driver filled (bytesused). Valid until the next call of next() or stop().
  std::span<const std::uint8_t> data;
  TimeNs t_ns = 0;
  TimestampClock clock = TimestampClock::kHost;
  bool start_of_exposure = false;  ///< stamped at the start of exposure (else end of frame)
  std::uint32_t sequence = 0;      ///< the driver's frame counter
  std::string message;             ///< what went wrong, for every status but kFrame
};
[[nodiscard]] std::string_view capture_status_name(CapturedFrame::Status status);

/// The video device nodes under `dev_dir` (video0, video1, ...), in numeric order.
[[nodiscard]] std::vector<std::filesystem::path> list_video_devices(
    const std::filesystem::path& dev_dir = "/dev");

/// One open V4L2 device. Opening queries its capabilities; configure() negotiates the format;
/// start() maps the buffers and starts streaming; next() waits for a frame. Everything is
/// released on stop() and in the destructor.
class V4l2Camera {
 public:
  /// Opens the node (non-blocking) and queries its capabilities. Throws DeviceError: "no such
  /// device" (with a hint at `kestrel capture --list`), permission, busy, not a V4L2 device.
  explicit V4l2Camera(std::string path, std::shared_ptr<DeviceIo> io = system_device_io());
  ~V4l2Camera();
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;

  [[nodiscard]] const DeviceInfo& info() const { return info_; }
  /// The capture formats with their frame sizes and rates.
  [[nodiscard]] std::vector<FormatInfo> formats() const;

  /// Sets the pixel format, size and (optionally) rate. Throws DeviceError if the device is not
  /// a streaming capture device, or gives another pixel format or size than asked (the message
  /// lists what it offers).
  StreamFormat configure(const CameraOptions& options);
  /// Maps the buffers and starts streaming. Needs configure() first.
  void start();
  /// Waits up to `timeout_ms` for the next frame; never blocks longer, never throws for what the
  /// device does at run time (that is the returned status). The previous frame's buffer goes
  /// back to the driver first. Once the device is found disconnected, every call says so at
  /// once.
  CapturedFrame next(int timeout_ms);
  /// Stops streaming and unmaps the buffers (errors of a vanished device are ignored).
  void stop();

  [[nodiscard]] bool streaming() const { return streaming_; }
  /// Frames the driver numbered but that never reached us (gaps in the sequence numbers).
  [[nodiscard]] std::uint64_t frames_lost() const { return frames_lost_; }

 private:
  struct Buffer {
    void* start = nullptr;
    std::size_t length = 0;
  };
  [[nodiscard]] CapturedFrame failure(int error, std::string_view what) const;
  [[nodiscard]] CapturedFrame wait_for_frame(int timeout_ms);
  void release_buffers();

  std::string path_;
  std::shared_ptr<DeviceIo> io_;
  int fd_ = -1;
  DeviceInfo info_;
  std::optional<CameraOptions> options_;
  std::vector<Buffer> buffers_;
  bool streaming_ = false;
  std::optional<CapturedFrame> disconnected_;  ///< the first kDisconnected, repeated after
  int held_ = -1;                              ///< buffer lent to the caller by the last next()
  std::optional<std::uint32_t> last_sequence_;
  std::uint64_t frames_lost_ = 0;
};

}  // namespace kestrel::driver
