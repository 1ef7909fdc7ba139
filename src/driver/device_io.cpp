// The real system calls behind DeviceIo.
#include "kestrel/driver/device_io.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>

namespace kestrel::driver {

namespace {

class SystemDeviceIo final : public DeviceIo {
 public:
  int open(const std::string& path) override {
    return ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);  // NOLINT(*-vararg)
  }
  int close(int fd) override { return ::close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override {
    int r = 0;
    do {
      r = ::ioctl(fd, request, arg);  // NOLINT(*-vararg)
    } while (r == -1 && errno == EINTR);
    return r;
  }
  int poll(int fd, int timeout_ms, short& revents) override {
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, timeout_ms);
    revents = p.revents;
    return r;
  }
  void* mmap(int fd, std::size_t length, std::int64_t offset) override {
    void* p =
        ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, static_cast<off_t>(offset));
    return p == MAP_FAILED ? nullptr : p;  // NOLINT(*-cstyle-cast): MAP_FAILED is a macro
  }
  int munmap(void* address, std::size_t length) override { return ::munmap(address, length); }
};

}  // namespace

std::shared_ptr<DeviceIo> system_device_io() {
  static const auto io = std::make_shared<SystemDeviceIo>();
  return io;
}

}  // namespace kestrel::driver
