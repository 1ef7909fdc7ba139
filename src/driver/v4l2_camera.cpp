// V4L2 capture through the raw ioctls: open, negotiate, mmap streaming, poll-bounded dequeue.
// Follows the V4L2 API's "Streaming I/O (Memory Mapping)" sequence: REQBUFS, QUERYBUF + mmap,
// QBUF all, STREAMON; DQBUF/QBUF per frame; STREAMOFF, munmap, REQBUFS(0).
#include "kestrel/driver/v4l2_camera.hpp"

#include <linux/videodev2.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace kestrel::driver {

namespace {

std::string error_text(int error) { return std::strerror(error); }

std::string c_string(const std::uint8_t* text, std::size_t size) {
  const auto* end = std::find(text, text + size, std::uint8_t{0});
  return {text, end};
}

TimeNs monotonic_now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<TimeNs>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

v4l2_buffer mmap_buffer(std::uint32_t index = 0) {
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = index;
  return b;
}

std::string offered_formats(const V4l2Camera& camera) {
  std::string text;
  for (const FormatInfo& f : camera.formats()) text += "\n  " + f.describe();
  return text.empty() ? std::string(" (it lists none)") : " (it offers:" + text + ")";
}

}  // namespace

void CameraOptions::validate() const {
  if (!fourcc_from_string(pixel_format)) {
    throw std::invalid_argument(
        "camera: pixel_format must be a fourcc of 1 to 4 characters, got '" + pixel_format + "'");
  }
  if (width < 1 || height < 1) throw std::invalid_argument("camera: width and height must be >= 1");
  if (!(rate_hz >= 0.0) || !std::isfinite(rate_hz)) {
    throw std::invalid_argument("camera: rate_hz must be >= 0 (0: the device's rate)");
  }
  if (buffers < 2 || buffers > 32) throw std::invalid_argument("camera: buffers must be in 2..32");
}

std::string CameraOptions::describe() const {
  std::ostringstream os;
  os << pixel_format << " " << width << "x" << height << " at ";
  if (rate_hz > 0.0) {
    os << rate_hz << " Hz";
  } else {
    os << "the device's rate";
  }
  os << ", " << buffers << " buffers";
  return os.str();
}

std::string StreamFormat::describe() const {
  std::ostringstream os;
  os << fourcc_to_string(fourcc) << " " << width << "x" << height << ", " << bytes_per_line
     << " bytes per line, " << image_bytes << " bytes per frame, ";
  if (rate_hz > 0.0) {
    os << rate_hz << " Hz";
  } else {
    os << "rate not reported";
  }
  for (const auto& n : notes) os << "; " << n;
  return os.str();
}

V4l2Camera::V4l2Camera(std::string path, std::shared_ptr<DeviceIo> io)
    : path_(std::move(path)), io_(std::move(io)) {
  fd_ = io_->open(path_);
  if (fd_ == -1) {
    const int e = errno;
    switch (e) {
      case ENOENT:
        throw DeviceError(path_,
                          "no such video device (is the camera plugged in? `kestrel capture "
                          "--list` lists the video devices)",
                          e);
      case EACCES:
      case EPERM:
        throw DeviceError(path_,
                          "permission denied (add the user to the 'video' group, or check the "
                          "node's permissions)",
                          e);
      case EBUSY:
        throw DeviceError(path_, "device busy (another program holds it)", e);
      case ENODEV:
      case ENXIO:
        throw DeviceError(path_, "the device is gone (unplugged?): " + error_text(e), e);
      default:
        throw DeviceError(path_, "cannot open: " + error_text(e), e);
    }
  }
  v4l2_capability cap{};
  if (io_->ioctl(fd_, VIDIOC_QUERYCAP, &cap) == -1) {
    const int e = errno;
    io_->close(fd_);
    fd_ = -1;
    if (e == ENOTTY || e == EINVAL) {
      throw DeviceError(path_, "not a V4L2 video device (VIDIOC_QUERYCAP: " + error_text(e) + ")",
                        e);
    }
    throw DeviceError(path_, "VIDIOC_QUERYCAP failed: " + error_text(e), e);
  }
  info_.path = path_;
  info_.driver = c_string(cap.driver, sizeof(cap.driver));
  info_.card = c_string(cap.card, sizeof(cap.card));
  info_.bus_info = c_string(cap.bus_info, sizeof(cap.bus_info));
  info_.capabilities =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  info_.can_capture = (info_.capabilities & V4L2_CAP_VIDEO_CAPTURE) != 0;
  info_.can_output = (info_.capabilities & V4L2_CAP_VIDEO_OUTPUT) != 0;
  info_.can_stream = (info_.capabilities & V4L2_CAP_STREAMING) != 0;
}

V4l2Camera::~V4l2Camera() {
  stop();
  if (fd_ != -1) io_->close(fd_);
}

StreamFormat V4l2Camera::configure(const CameraOptions& options) {
  options.validate();
  if (streaming_) throw std::logic_error("V4l2Camera: configure() while streaming");
  if (!info_.can_capture) {
    throw DeviceError(path_, "is not a video capture device (driver '" + info_.driver +
                                 "', card '" + info_.card + "')");
  }
  if (!info_.can_stream) {
    throw DeviceError(path_, "does not support streaming I/O (driver '" + info_.driver + "')");
  }
  const std::uint32_t fourcc = *fourcc_from_string(options.pixel_format);
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(options.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(options.height);
  fmt.fmt.pix.pixelformat = fourcc;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (io_->ioctl(fd_, VIDIOC_S_FMT, &fmt) == -1) {
    const int e = errno;
    if (e == EBUSY) {
      throw DeviceError(path_, "busy: another program is streaming from it (VIDIOC_S_FMT)", e);
    }
    throw DeviceError(path_,
                      "refused the format " + options.pixel_format + " " +
                          std::to_string(options.width) + "x" + std::to_string(options.height) +
                          ": " + error_text(e) + offered_formats(*this),
                      e);
  }
  // Drivers adjust S_FMT requests to what they can do instead of failing: check the answer.
  if (fmt.fmt.pix.pixelformat != fourcc) {
    throw DeviceError(path_, "wrong pixel format: asked for " + options.pixel_format +
                                 ", the device gives " + fourcc_to_string(fmt.fmt.pix.pixelformat) +
                                 offered_formats(*this));
  }
  const auto width = static_cast<int>(fmt.fmt.pix.width);
  const auto height = static_cast<int>(fmt.fmt.pix.height);
  if (width != options.width || height != options.height) {
    throw DeviceError(path_, "wrong frame size: asked for " + std::to_string(options.width) + "x" +
                                 std::to_string(options.height) + ", the device gives " +
                                 std::to_string(width) + "x" + std::to_string(height) +
                                 offered_formats(*this));
  }
  StreamFormat s;
  s.fourcc = fourcc;
  s.width = width;
  s.height = height;
  s.bytes_per_line = fmt.fmt.pix.bytesperline;
  s.image_bytes = fmt.fmt.pix.sizeimage;

  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  const bool has_parm = io_->ioctl(fd_, VIDIOC_G_PARM, &parm) == 0;
  const bool settable = has_parm && (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) != 0;
  if (options.rate_hz > 0.0) {
    if (settable) {
      parm.parm.capture.timeperframe.numerator = 1000;
      parm.parm.capture.timeperframe.denominator =
          static_cast<std::uint32_t>(std::llround(options.rate_hz * 1000.0));
      if (io_->ioctl(fd_, VIDIOC_S_PARM, &parm) == -1) {
        s.notes.push_back("frame rate not set (VIDIOC_S_PARM: " + error_text(errno) + ")");
      }
    } else {
      s.notes.push_back("the device does not let the frame rate be set");
    }
  }
  const v4l2_fract tpf = parm.parm.capture.timeperframe;
  if (has_parm && tpf.numerator != 0 && tpf.denominator != 0) {
    s.rate_hz = static_cast<double>(tpf.denominator) / static_cast<double>(tpf.numerator);
  }
  options_ = options;
  return s;
}

void V4l2Camera::start() {
  if (!options_) throw std::logic_error("V4l2Camera: start() before configure()");
  if (streaming_) return;
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(options_->buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (io_->ioctl(fd_, VIDIOC_REQBUFS, &req) == -1) {
    const int e = errno;
    throw DeviceError(
        path_, "cannot allocate memory-mapped buffers (VIDIOC_REQBUFS: " + error_text(e) + ")", e);
  }
  if (req.count < 2) {
    throw DeviceError(path_, "the driver gave " + std::to_string(req.count) +
                                 " buffer(s); streaming needs at least 2");
  }
  try {
    for (std::uint32_t i = 0; i < req.count; ++i) {
      v4l2_buffer b = mmap_buffer(i);
      if (io_->ioctl(fd_, VIDIOC_QUERYBUF, &b) == -1) {
        throw DeviceError(path_, "VIDIOC_QUERYBUF: " + error_text(errno), errno);
      }
      void* start = io_->mmap(fd_, b.length, b.m.offset);
      if (start == nullptr) throw DeviceError(path_, "mmap: " + error_text(errno), errno);
      buffers_.push_back({start, b.length});
      if (io_->ioctl(fd_, VIDIOC_QBUF, &b) == -1) {
        throw DeviceError(path_, "VIDIOC_QBUF: " + error_text(errno), errno);
      }
    }
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (io_->ioctl(fd_, VIDIOC_STREAMON, &type) == -1) {
      throw DeviceError(path_, "VIDIOC_STREAMON: " + error_text(errno), errno);
    }
  } catch (...) {
    release_buffers();
    throw;
  }
  streaming_ = true;
  held_ = -1;
  last_sequence_.reset();
  disconnected_.reset();
}

CapturedFrame V4l2Camera::failure(int error, std::string_view what) const {
  CapturedFrame f;
  const std::string detail = std::string(what) + ": " + error_text(error);
  if (error == ENODEV || error == ENXIO) {
    f.status = CapturedFrame::Status::kDisconnected;
    f.message = path_ + ": device disconnected (" + detail + ")";
  } else if (error == EIO) {
    // The API allows EIO for temporary problems (lost signal); the next frame may be fine.
    f.status = CapturedFrame::Status::kCorrupted;
    f.message = path_ + ": " + detail;
  } else {
    f.status = CapturedFrame::Status::kFailed;
    f.message = path_ + ": " + detail;
  }
  return f;
}

CapturedFrame V4l2Camera::next(int timeout_ms) {
  if (!streaming_) throw std::logic_error("V4l2Camera: next() before start()");
  if (disconnected_) return *disconnected_;
  CapturedFrame f = wait_for_frame(timeout_ms);
  if (f.status == CapturedFrame::Status::kDisconnected) disconnected_ = f;
  return f;
}

CapturedFrame V4l2Camera::wait_for_frame(int timeout_ms) {
  if (held_ >= 0) {
    v4l2_buffer b = mmap_buffer(static_cast<std::uint32_t>(held_));
    held_ = -1;
    if (io_->ioctl(fd_, VIDIOC_QBUF, &b) == -1) return failure(errno, "VIDIOC_QBUF");
  }
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(0, timeout_ms));
  for (;;) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
    const int wait_ms = static_cast<int>(std::max<std::int64_t>(0, left.count()));
    short revents = 0;
    const int ready = io_->poll(fd_, wait_ms, revents);
    if (ready == -1 && errno != EINTR) return failure(errno, "poll");
    const bool expired = Clock::now() >= deadline;
    if (ready <= 0) {
      if (expired) {
        CapturedFrame f;
        f.status = CapturedFrame::Status::kTimeout;
        f.message = path_ + ": no frame within " + std::to_string(timeout_ms) + " ms";
        return f;
      }
      continue;  // EINTR before the deadline
    }
    if ((revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
      CapturedFrame f;
      f.status = CapturedFrame::Status::kDisconnected;
      f.message = path_ + ": the device reported an error while streaming (poll: " +
                  std::string((revents & POLLHUP) != 0 ? "POLLHUP" : "POLLERR") + "); unplugged?";
      return f;
    }
    v4l2_buffer b = mmap_buffer();
    if (io_->ioctl(fd_, VIDIOC_DQBUF, &b) == -1) {
      const int e = errno;
      if (e == EAGAIN || e == EINTR) {
        if (expired) {
          CapturedFrame f;
          f.status = CapturedFrame::Status::kTimeout;
          f.message = path_ + ": no frame within " + std::to_string(timeout_ms) +
                      " ms (poll woke, VIDIOC_DQBUF said EAGAIN)";
          return f;
        }
        continue;  // woken without a filled buffer
      }
      return failure(e, "VIDIOC_DQBUF");
    }
    if (b.index >= buffers_.size()) {
      CapturedFrame f;
      f.status = CapturedFrame::Status::kFailed;
      f.message = path_ + ": the driver returned buffer " + std::to_string(b.index) + " of " +
                  std::to_string(buffers_.size());
      return f;
    }
    held_ = static_cast<int>(b.index);
    const Buffer& buffer = buffers_[b.index];
    CapturedFrame f;
    f.status = CapturedFrame::Status::kFrame;
    f.data = {static_cast<const std::uint8_t*>(buffer.start),
              std::min<std::size_t>(b.bytesused, buffer.length)};
    f.sequence = b.sequence;
    f.t_ns = timeval_to_ns(b.timestamp.tv_sec, b.timestamp.tv_usec);
    switch (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) {
      case V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC:
        f.clock = TimestampClock::kMonotonic;
        break;
      case V4L2_BUF_FLAG_TIMESTAMP_COPY:
        f.clock = TimestampClock::kCopied;
        break;
      default:
        f.clock = TimestampClock::kUnknown;
    }
    if (f.t_ns == 0) {
      f.t_ns = monotonic_now_ns();
      f.clock = TimestampClock::kHost;
    }
    f.start_of_exposure = (b.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
    if (last_sequence_ && b.sequence > *last_sequence_ + 1) {
      frames_lost_ += b.sequence - *last_sequence_ - 1;
    }
    last_sequence_ = b.sequence;
    if ((b.flags & V4L2_BUF_FLAG_ERROR) != 0) {
      f.status = CapturedFrame::Status::kCorrupted;
      f.message = path_ + ": frame " + std::to_string(b.sequence) +
                  " flagged as corrupted by the driver (V4L2_BUF_FLAG_ERROR)";
    }
    return f;
  }
}

void V4l2Camera::release_buffers() {
  for (const Buffer& b : buffers_) io_->munmap(b.start, b.length);
  buffers_.clear();
  v4l2_requestbuffers req{};
  req.count = 0;
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  io_->ioctl(fd_, VIDIOC_REQBUFS, &req);  // errors ignored: the device may be gone
}

void V4l2Camera::stop() {
  if (!streaming_) return;
  streaming_ = false;
  held_ = -1;
  v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  io_->ioctl(fd_, VIDIOC_STREAMOFF, &type);  // errors ignored: the device may be gone
  release_buffers();
}

}  // namespace kestrel::driver
