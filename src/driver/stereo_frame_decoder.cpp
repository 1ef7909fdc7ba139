// Splitting packed stereo frames into two Bayer mosaics, demosaicing them, and the inverse.
#include "kestrel/driver/stereo_frame_decoder.hpp"

#include <array>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/io/option_fields.hpp"
#include "kestrel/io/yaml_file.hpp"

namespace kestrel::driver {

void StereoDecoderOptions::validate() const {
  // Demosaicing needs at least one full 2x2 tile.
  if (width < 2) throw std::invalid_argument("decoder: width must be at least 2");
  if (height < 2) throw std::invalid_argument("decoder: height must be at least 2");
  if (left_byte != 0 && left_byte != 1) {
    throw std::invalid_argument("decoder: left_byte must be 0 or 1");
  }
}

std::string StereoDecoderOptions::describe() const {
  std::ostringstream os;
  os << width << "x" << height << " per view, left sensor in byte " << left_byte
     << " of each 16-bit word, Bayer " << bayer_phase_name(phase) << ", demosaic "
     << demosaic_method_name(demosaic);
  return os.str();
}

std::string StereoDecoderOptions::to_yaml() const { return io::option_fields::to_yaml(*this); }

StereoDecoderOptions StereoDecoderOptions::load_yaml(const std::filesystem::path& path) {
  StereoDecoderOptions o;
  io::option_fields::read_fields(io::load_yaml_map(path, "stereo decoder"), path.string(),
                                 "stereo decoder", o);
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw InputError(path.string() + ": " + e.what());
  }
  return o;
}

std::string_view view_kind_name(ViewKind kind) {
  switch (kind) {
    case ViewKind::kGray:
      return "gray";
    case ViewKind::kColor:
      return "color";
    case ViewKind::kMosaic:
      return "mosaic";
  }
  return "?";
}

std::optional<ViewKind> parse_view_kind(std::string_view name) {
  for (const ViewKind k : {ViewKind::kGray, ViewKind::kColor, ViewKind::kMosaic}) {
    if (view_kind_name(k) == name) return k;
  }
  return std::nullopt;
}

std::string FrameHealth::describe() const {
  switch (problem) {
    case Problem::kNone:
      return "ok";
    case Problem::kEmpty:
      return "empty frame (0 bytes)";
    case Problem::kTruncated:
      return "truncated: " + std::to_string(received_bytes) + " of " +
             std::to_string(expected_bytes) + " bytes";
  }
  return "?";
}

StereoFrameDecoder::StereoFrameDecoder(StereoDecoderOptions options) : options_(options) {
  options_.validate();
}

std::size_t StereoFrameDecoder::stride(std::size_t bytes_per_line) const {
  if (bytes_per_line == 0) return options_.packed_row_bytes();
  if (bytes_per_line < options_.packed_row_bytes()) {
    throw std::invalid_argument("decoder: " + std::to_string(bytes_per_line) +
                                " bytes per line cannot hold a row of " +
                                std::to_string(options_.width) + " 16-bit pixels");
  }
  return bytes_per_line;
}

std::size_t StereoFrameDecoder::frame_bytes(std::size_t bytes_per_line) const {
  return stride(bytes_per_line) * static_cast<std::size_t>(options_.height - 1) +
         options_.packed_row_bytes();
}

FrameHealth StereoFrameDecoder::check(std::size_t received_bytes,
                                      std::size_t bytes_per_line) const {
  FrameHealth h;
  h.expected_bytes = frame_bytes(bytes_per_line);
  h.received_bytes = received_bytes;
  if (received_bytes == 0) {
    h.problem = FrameHealth::Problem::kEmpty;
  } else if (received_bytes < h.expected_bytes) {
    h.problem = FrameHealth::Problem::kTruncated;
  }
  return h;
}

FrameHealth StereoFrameDecoder::split(std::span<const std::uint8_t> frame,
                                      std::size_t bytes_per_line, StereoMosaic& out) const {
  const std::size_t step = stride(bytes_per_line);
  const FrameHealth h = check(frame.size(), step);
  if (!h.ok()) return h;
  // A two-channel header over the packed bytes: channel k is byte k of every 16-bit word, and
  // cv::split deinterleaves with SIMD straight into the (reused) mosaics.
  // NOLINTNEXTLINE(cppcoreguidelines-pro-type-const-cast): cv::Mat has no const view; read only
  const cv::Mat packed(options_.height, options_.width, CV_8UC2,
                       const_cast<std::uint8_t*>(frame.data()), step);
  out.left.create(options_.height, options_.width, CV_8UC1);
  out.right.create(options_.height, options_.width, CV_8UC1);
  std::array<cv::Mat, 2> channels;
  channels[static_cast<std::size_t>(options_.left_byte)] = out.left;
  channels[static_cast<std::size_t>(1 - options_.left_byte)] = out.right;
  cv::split(packed, channels.data());
  return h;
}

void StereoFrameDecoder::convert(const cv::Mat& mosaic, ViewKind kind, cv::Mat& out) const {
  if (mosaic.type() != CV_8UC1) throw std::invalid_argument("decoder: a mosaic is CV_8UC1");
  switch (kind) {
    case ViewKind::kMosaic:
      mosaic.copyTo(out);
      return;
    case ViewKind::kGray:
      cv::cvtColor(mosaic, out, opencv_bayer_to_gray_code(options_.phase));
      return;
    case ViewKind::kColor:
      cv::cvtColor(mosaic, out, opencv_bayer_to_bgr_code(options_.phase, options_.demosaic));
      return;
  }
}

std::vector<std::uint8_t> StereoFrameDecoder::pack(const cv::Mat& left, const cv::Mat& right,
                                                   std::size_t bytes_per_line) const {
  const cv::Size size(options_.width, options_.height);
  for (const cv::Mat* m : {&left, &right}) {
    if (m->type() != CV_8UC1 || m->size() != size) {
      throw std::invalid_argument("decoder: pack needs two CV_8UC1 mosaics of " +
                                  std::to_string(size.width) + "x" + std::to_string(size.height));
    }
  }
  const std::size_t step = stride(bytes_per_line);
  std::vector<std::uint8_t> frame(step * static_cast<std::size_t>(options_.height), 0);
  cv::Mat packed(options_.height, options_.width, CV_8UC2, frame.data(), step);
  std::array<cv::Mat, 2> channels;
  channels[static_cast<std::size_t>(options_.left_byte)] = left;
  channels[static_cast<std::size_t>(1 - options_.left_byte)] = right;
  cv::merge(channels.data(), 2, packed);
  return frame;
}

}  // namespace kestrel::driver
