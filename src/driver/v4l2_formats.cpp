// Describing V4L2 devices: fourcc codes, capabilities, the formats / frame sizes / frame rates a
// device offers (VIDIOC_ENUM_FMT, _FRAMESIZES, _FRAMEINTERVALS), and the /dev/video* nodes.
#include <linux/videodev2.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <sstream>

#include "kestrel/driver/v4l2_camera.hpp"

namespace kestrel::driver {

namespace {

// Guards against drivers (or stand-ins) that never end an enumeration with EINVAL.
constexpr std::uint32_t kMaxEnumeration = 256;

std::string format_rate(double hz) {
  std::ostringstream os;
  os.precision(4);
  os << hz;
  return os.str();
}

}  // namespace

std::string fourcc_to_string(std::uint32_t fourcc) {
  std::string s(4, ' ');
  for (std::size_t i = 0; i < 4; ++i) {
    const auto c = static_cast<unsigned char>((fourcc >> (8 * i)) & 0xFFU);
    s[i] = std::isprint(c) != 0 ? static_cast<char>(c) : '?';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::optional<std::uint32_t> fourcc_from_string(std::string_view text) {
  if (text.empty() || text.size() > 4) return std::nullopt;
  std::uint32_t code = 0;
  for (std::size_t i = 0; i < 4; ++i) {
    const char c = i < text.size() ? text[i] : ' ';
    if (std::isprint(static_cast<unsigned char>(c)) == 0) return std::nullopt;
    code |= static_cast<std::uint32_t>(static_cast<unsigned char>(c)) << (8 * i);
  }
  return code;
}

std::string DeviceInfo::describe() const {
  std::ostringstream os;
  os << path << ": " << card << " (driver " << driver;
  if (!bus_info.empty()) os << ", " << bus_info;
  os << ")";
  std::vector<std::string> roles;
  if (can_capture) roles.emplace_back("capture");
  if (can_output) roles.emplace_back("output");
  if (can_stream) roles.emplace_back("streaming");
  if (roles.empty()) roles.emplace_back("neither video capture nor output");
  os << ":";
  for (const auto& r : roles) os << " " << r;
  return os.str();
}

std::string FormatInfo::describe() const {
  std::ostringstream os;
  os << fourcc_to_string(fourcc) << " (" << description << ")";
  if (sizes.empty()) return os.str();
  os << ":";
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    const FrameSizeInfo& s = sizes[i];
    os << (i == 0 ? " " : "; ");
    if (s.range.empty()) {
      os << s.width << "x" << s.height;
    } else {
      os << s.range;
    }
    if (!s.rates_hz.empty()) {
      os << " @";
      for (std::size_t k = 0; k < s.rates_hz.size(); ++k) {
        os << (k == 0 ? " " : ", ") << format_rate(s.rates_hz[k]);
      }
      os << " Hz";
    }
  }
  return os.str();
}

std::string_view timestamp_clock_name(TimestampClock clock) {
  switch (clock) {
    case TimestampClock::kMonotonic:
      return "monotonic (driver)";
    case TimestampClock::kCopied:
      return "copied from the output stream";
    case TimestampClock::kUnknown:
      return "unknown clock (driver)";
    case TimestampClock::kHost:
      return "monotonic (host, at dequeue)";
  }
  return "?";
}

std::string_view capture_status_name(CapturedFrame::Status status) {
  switch (status) {
    case CapturedFrame::Status::kFrame:
      return "frame";
    case CapturedFrame::Status::kCorrupted:
      return "corrupted";
    case CapturedFrame::Status::kTimeout:
      return "timeout";
    case CapturedFrame::Status::kDisconnected:
      return "disconnected";
    case CapturedFrame::Status::kFailed:
      return "failed";
  }
  return "?";
}

std::vector<FormatInfo> V4l2Camera::formats() const {
  std::vector<FormatInfo> out;
  if (!info_.can_capture) return out;
  for (std::uint32_t i = 0; i < kMaxEnumeration; ++i) {
    v4l2_fmtdesc desc{};
    desc.index = i;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (io_->ioctl(fd_, VIDIOC_ENUM_FMT, &desc) == -1) break;  // EINVAL: past the last one
    FormatInfo f;
    f.fourcc = desc.pixelformat;
    const auto* d = desc.description;
    f.description.assign(d, std::find(d, d + sizeof(desc.description), std::uint8_t{0}));
    for (std::uint32_t k = 0; k < kMaxEnumeration; ++k) {
      v4l2_frmsizeenum size{};
      size.index = k;
      size.pixel_format = desc.pixelformat;
      if (io_->ioctl(fd_, VIDIOC_ENUM_FRAMESIZES, &size) == -1) break;
      FrameSizeInfo s;
      if (size.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
        s.width = static_cast<int>(size.discrete.width);
        s.height = static_cast<int>(size.discrete.height);
        for (std::uint32_t j = 0; j < kMaxEnumeration; ++j) {
          v4l2_frmivalenum ival{};
          ival.index = j;
          ival.pixel_format = desc.pixelformat;
          ival.width = size.discrete.width;
          ival.height = size.discrete.height;
          if (io_->ioctl(fd_, VIDIOC_ENUM_FRAMEINTERVALS, &ival) == -1) break;
          if (ival.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;  // ranges: not listed
          if (ival.discrete.numerator != 0) {
            s.rates_hz.push_back(static_cast<double>(ival.discrete.denominator) /
                                 static_cast<double>(ival.discrete.numerator));
          }
        }
      } else {
        const auto& w = size.stepwise;
        s.width = static_cast<int>(w.max_width);
        s.height = static_cast<int>(w.max_height);
        std::ostringstream os;
        os << w.min_width << "x" << w.min_height << " - " << w.max_width << "x" << w.max_height
           << " step " << w.step_width << "x" << w.step_height;
        s.range = os.str();
      }
      f.sizes.push_back(std::move(s));
      if (size.type != V4L2_FRMSIZE_TYPE_DISCRETE) break;  // one entry describes the range
    }
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<std::filesystem::path> list_video_devices(const std::filesystem::path& dev_dir) {
  std::vector<std::pair<long, std::filesystem::path>> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dev_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= 5 || name.compare(0, 5, "video") != 0) continue;
    const std::string number = name.substr(5);
    if (number.size() > 9 || !std::all_of(number.begin(), number.end(), [](char c) {
          return std::isdigit(static_cast<unsigned char>(c)) != 0;
        })) {
      continue;
    }
    found.emplace_back(std::stol(number), entry.path());
  }
  std::sort(found.begin(), found.end());
  std::vector<std::filesystem::path> out;
  out.reserve(found.size());
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

}  // namespace kestrel::driver
