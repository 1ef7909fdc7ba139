// A stand-in V4L2 capture device for the driver's tests: it answers the ioctls V4l2Camera makes
// from a small model (formats, buffers, queue) and plays a script of what the camera does next:
// frames, spurious wake-ups, silence, an unplug. Lets the tests check the fault handling that a
// real camera shows only when it misbehaves.
#pragma once

#include <linux/videodev2.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <deque>
#include <thread>
#include <utility>
#include <vector>

#include "kestrel/driver/device_io.hpp"

namespace kestrel::test {

struct FakeEvent {
  enum class Kind {
    kFrame,           ///< a filled buffer: poll wakes, DQBUF returns it
    kSpuriousWakeup,  ///< poll wakes, DQBUF says EAGAIN
    kDqbufError,      ///< poll wakes, DQBUF fails with `error`
    kPollRevents,     ///< poll wakes with `revents` (POLLERR, POLLHUP)
  };
  Kind kind = Kind::kFrame;
  std::vector<std::uint8_t> bytes;  ///< the frame's bytes (bytesused = their count)
  std::int64_t sec = 0;
  std::int64_t usec = 0;
  std::uint32_t sequence = 0;
  std::uint32_t flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  int error = 0;
  short revents = 0;
};

inline FakeEvent fake_frame(std::vector<std::uint8_t> bytes, std::int64_t t_us,
                            std::uint32_t sequence) {
  FakeEvent e;
  e.bytes = std::move(bytes);
  e.sec = t_us / 1'000'000;
  e.usec = t_us % 1'000'000;
  e.sequence = sequence;
  return e;
}
inline FakeEvent fake_event(FakeEvent::Kind kind, int error = 0, short revents = 0) {
  FakeEvent e;
  e.kind = kind;
  e.error = error;
  e.revents = revents;
  return e;
}

class FakeV4l2Device final : public driver::DeviceIo {
 public:
  // --- what the device is
  std::uint32_t caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
  struct Format {
    std::uint32_t fourcc;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> sizes;
  };
  std::vector<Format> formats{{V4L2_PIX_FMT_YUYV, {{752, 480}, {376, 240}}},
                              {V4L2_PIX_FMT_MJPEG, {{640, 480}}}};
  std::uint32_t forced_fourcc = 0;  ///< S_FMT answers with this pixel format when set
  std::uint32_t forced_width = 0;   ///< ... and this size when set
  std::uint32_t forced_height = 0;
  std::uint32_t padding_per_line = 0;  ///< bytesperline = 2 * width + padding
  int open_errno = 0;
  std::deque<FakeEvent> script;  ///< when it runs out, the camera falls silent
  bool wakes_forever = false;  ///< ... or, when set, wakes poll() for ever with nothing to dequeue

  // --- what was done to it
  int opens = 0;
  int closes = 0;
  int maps = 0;
  int unmaps = 0;
  bool streaming = false;
  bool unplugged = false;
  int dqbuf_with_empty_queue = 0;  ///< a DQBUF while no buffer was queued (a driver bug)
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::uint32_t timeperframe_denominator = 30;
  std::uint32_t timeperframe_numerator = 1;

  int open(const std::string& /*path*/) override {
    if (open_errno != 0) {
      errno = open_errno;
      return -1;
    }
    ++opens;
    return 42;
  }
  int close(int /*fd*/) override {
    ++closes;
    return 0;
  }

  int ioctl(int /*fd*/, unsigned long request, void* arg) override {
    switch (request) {
      case VIDIOC_QUERYCAP: {
        auto* c = static_cast<v4l2_capability*>(arg);
        *c = {};
        std::strncpy(reinterpret_cast<char*>(c->driver), "fake", sizeof(c->driver) - 1);
        std::strncpy(reinterpret_cast<char*>(c->card), "Fake stereo", sizeof(c->card) - 1);
        c->capabilities = caps | V4L2_CAP_DEVICE_CAPS;
        c->device_caps = caps;
        return 0;
      }
      case VIDIOC_ENUM_FMT: {
        auto* d = static_cast<v4l2_fmtdesc*>(arg);
        if (d->index >= formats.size()) return fail(EINVAL);
        d->pixelformat = formats[d->index].fourcc;
        std::strncpy(reinterpret_cast<char*>(d->description), "fake format",
                     sizeof(d->description) - 1);
        return 0;
      }
      case VIDIOC_ENUM_FRAMESIZES: {
        auto* s = static_cast<v4l2_frmsizeenum*>(arg);
        const Format* f = find(s->pixel_format);
        if (f == nullptr || s->index >= f->sizes.size()) return fail(EINVAL);
        s->type = V4L2_FRMSIZE_TYPE_DISCRETE;
        s->discrete.width = f->sizes[s->index].first;
        s->discrete.height = f->sizes[s->index].second;
        return 0;
      }
      case VIDIOC_ENUM_FRAMEINTERVALS: {
        auto* i = static_cast<v4l2_frmivalenum*>(arg);
        if (i->index >= 2) return fail(EINVAL);
        i->type = V4L2_FRMIVAL_TYPE_DISCRETE;
        i->discrete = {1, i->index == 0 ? 30U : 60U};
        return 0;
      }
      case VIDIOC_S_FMT: {
        if (streaming) return fail(EBUSY);
        auto& p = static_cast<v4l2_format*>(arg)->fmt.pix;
        if (forced_fourcc != 0) p.pixelformat = forced_fourcc;
        if (forced_width != 0) p.width = forced_width;
        if (forced_height != 0) p.height = forced_height;
        width = p.width;
        height = p.height;
        p.bytesperline = 2 * p.width + padding_per_line;
        p.sizeimage = p.bytesperline * p.height;
        return 0;
      }
      case VIDIOC_G_PARM:
      case VIDIOC_S_PARM: {
        auto& c = static_cast<v4l2_streamparm*>(arg)->parm.capture;
        if (request == VIDIOC_S_PARM) {
          timeperframe_numerator = c.timeperframe.numerator;
          timeperframe_denominator = c.timeperframe.denominator;
        }
        c.capability = V4L2_CAP_TIMEPERFRAME;
        c.timeperframe = {timeperframe_numerator, timeperframe_denominator};
        return 0;
      }
      case VIDIOC_REQBUFS: {
        auto* r = static_cast<v4l2_requestbuffers*>(arg);
        if (unplugged) return fail(ENODEV);
        buffers_.assign(r->count,
                        std::vector<std::uint8_t>((2 * width + padding_per_line) * height));
        queued_.clear();
        return 0;
      }
      case VIDIOC_QUERYBUF: {
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= buffers_.size()) return fail(EINVAL);
        b->length = static_cast<std::uint32_t>(buffers_[b->index].size());
        b->m.offset = b->index << 20U;
        return 0;
      }
      case VIDIOC_QBUF: {
        if (unplugged) return fail(ENODEV);
        auto* b = static_cast<v4l2_buffer*>(arg);
        if (b->index >= buffers_.size()) return fail(EINVAL);
        if (std::find(queued_.begin(), queued_.end(), b->index) != queued_.end()) {
          return fail(EINVAL);  // queued twice
        }
        queued_.push_back(b->index);
        return 0;
      }
      case VIDIOC_DQBUF:
        return dequeue(*static_cast<v4l2_buffer*>(arg));
      case VIDIOC_STREAMON:
        if (unplugged) return fail(ENODEV);
        streaming = true;
        return 0;
      case VIDIOC_STREAMOFF:
        streaming = false;
        if (unplugged) return fail(ENODEV);
        return 0;
      default:
        return fail(ENOTTY);
    }
  }

  int poll(int /*fd*/, int timeout_ms, short& revents) override {
    revents = 0;
    if (unplugged) {  // as v4l2_poll() answers for an unregistered device
      revents = POLLERR | POLLHUP;
      return 1;
    }
    if (!streaming) {
      revents = POLLERR;
      return 1;
    }
    if (script.empty() && wakes_forever) {
      revents = POLLIN;
      return 1;
    }
    if (script.empty()) {
      // Silence: sleep a little of the timeout, as a real wait would, then time out.
      std::this_thread::sleep_for(std::chrono::milliseconds(std::min(timeout_ms, 2)));
      return 0;
    }
    if (script.front().kind == FakeEvent::Kind::kPollRevents) {
      revents = script.front().revents;
      script.pop_front();
      return 1;
    }
    revents = POLLIN;
    return 1;
  }

  void* mmap(int /*fd*/, std::size_t length, std::int64_t offset) override {
    const auto index = static_cast<std::size_t>(offset >> 20);
    if (index >= buffers_.size() || length != buffers_[index].size()) {
      errno = EINVAL;
      return nullptr;
    }
    ++maps;
    return buffers_[index].data();
  }
  int munmap(void* /*address*/, std::size_t /*length*/) override {
    ++unmaps;
    return 0;
  }

  [[nodiscard]] std::size_t queued() const { return queued_.size(); }

 private:
  static int fail(int error) {
    errno = error;
    return -1;
  }
  const Format* find(std::uint32_t fourcc) const {
    for (const auto& f : formats) {
      if (f.fourcc == fourcc) return &f;
    }
    return nullptr;
  }
  int dequeue(v4l2_buffer& b) {
    if (unplugged) return fail(ENODEV);
    if (script.empty()) return fail(EAGAIN);
    const FakeEvent e = script.front();
    script.pop_front();
    switch (e.kind) {
      case FakeEvent::Kind::kSpuriousWakeup:
      case FakeEvent::Kind::kPollRevents:
        return fail(EAGAIN);
      case FakeEvent::Kind::kDqbufError:
        if (e.error == ENODEV) unplugged = true;
        return fail(e.error);
      case FakeEvent::Kind::kFrame:
        break;
    }
    if (queued_.empty()) {
      ++dqbuf_with_empty_queue;
      return fail(EAGAIN);
    }
    const std::uint32_t index = queued_.front();
    queued_.pop_front();
    auto& buffer = buffers_[index];
    const std::size_t n = std::min(buffer.size(), e.bytes.size());
    std::copy_n(e.bytes.begin(), n, buffer.begin());
    b.index = index;
    b.bytesused = static_cast<std::uint32_t>(n);
    b.flags = e.flags;
    b.sequence = e.sequence;
    b.timestamp.tv_sec = static_cast<decltype(b.timestamp.tv_sec)>(e.sec);
    b.timestamp.tv_usec = static_cast<decltype(b.timestamp.tv_usec)>(e.usec);
    return 0;
  }

  std::vector<std::vector<std::uint8_t>> buffers_;
  std::deque<std::uint32_t> queued_;
};

}  // namespace kestrel::test
