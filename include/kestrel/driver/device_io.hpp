// The system calls a V4L2 camera makes, behind an interface: the real ones for devices, and a
// stand-in in the tests that plays back disconnects, timeouts and truncated frames on machines
// without a camera.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace kestrel::driver {

/// Each call mirrors the system call of the same name: on failure it returns -1 (nullptr for
/// mmap) with errno set.
class DeviceIo {
 public:
  DeviceIo() = default;
  virtual ~DeviceIo() = default;
  DeviceIo(const DeviceIo&) = delete;
  DeviceIo& operator=(const DeviceIo&) = delete;

  /// open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC).
  virtual int open(const std::string& path) = 0;
  virtual int close(int fd) = 0;
  /// ioctl(fd, request, arg), retried on EINTR.
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  /// poll() of one descriptor for input: > 0 with `revents` set, 0 on timeout, -1 on error.
  virtual int poll(int fd, int timeout_ms, short& revents) = 0;
  /// A shared read/write mapping of `length` bytes at `offset`.
  virtual void* mmap(int fd, std::size_t length, std::int64_t offset) = 0;
  virtual int munmap(void* address, std::size_t length) = 0;
};

/// The real system calls.
std::shared_ptr<DeviceIo> system_device_io();

}  // namespace kestrel::driver
