// Decoding the frames of a UVC stereo camera that sends the raw 8-bit Bayer samples of two
// sensors packed in one frame labelled YUYV (Leopard Imaging LI-USB30-V024STEREO: two MT9V024,
// 752x480, GRBG): each 16-bit "pixel" holds one sample of each sensor. Splitting the bytes gives
// two mosaics; demosaicing gives colour or grey views. Format and diagram: docs/driver.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kestrel/driver/bayer.hpp"

namespace kestrel::driver {

struct StereoDecoderOptions {
  /// Size of each view in pixels, which is also the size of the YUYV frame (2 bytes a pixel).
  int width = 752;
  int height = 480;
  /// Byte of each 16-bit word that holds the LEFT sensor's sample (0: the first byte in memory,
  /// the "Y" of YUYV, as in V4L2's Y8I format). Swapping the byte order of the words and
  /// swapping which sensor is left are the same change, so this one field covers both.
  int left_byte = 0;
  /// Colour-filter phase of both sensors (sensor naming; the MT9V024 is GRBG).
  BayerPhase phase = BayerPhase::kGRBG;
  DemosaicMethod demosaic = DemosaicMethod::kBilinear;

  template <typename V>
  void visit_fields(V&& v) {
    v("width", width);
    v("height", height);
    v("left_byte", left_byte);
    v("bayer", phase);
    v("demosaic", demosaic);
  }

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
  /// The YAML fields, as load_yaml() reads them.
  [[nodiscard]] std::string to_yaml() const;
  /// YAML map with any of: width, height, left_byte, bayer (GRBG|RGGB|BGGR|GBRG),
  /// demosaic (bilinear|edge-aware); unknown keys are errors naming the file and field.
  static StereoDecoderOptions load_yaml(const std::filesystem::path& path);

  /// Bytes of one row of the packed frame without padding: 2 * width.
  [[nodiscard]] std::size_t packed_row_bytes() const { return 2 * static_cast<std::size_t>(width); }
};

/// What the views are turned into.
enum class ViewKind {
  kGray,    ///< demosaiced intensity, CV_8UC1 (what the odometry uses)
  kColor,   ///< demosaiced BGR, CV_8UC3
  kMosaic,  ///< the raw Bayer samples, CV_8UC1 (lossless; demosaic later)
};
[[nodiscard]] std::string_view view_kind_name(ViewKind kind);
/// "gray", "color" or "mosaic".
[[nodiscard]] std::optional<ViewKind> parse_view_kind(std::string_view name);

/// The two raw mosaics of one packed frame (CV_8UC1, width x height each).
struct StereoMosaic {
  cv::Mat left;
  cv::Mat right;
};

/// The health of one packed frame as received.
struct FrameHealth {
  enum class Problem { kNone, kEmpty, kTruncated };
  Problem problem = Problem::kNone;
  std::size_t expected_bytes = 0;
  std::size_t received_bytes = 0;
  [[nodiscard]] bool ok() const { return problem == Problem::kNone; }
  /// "ok" or e.g. "truncated: 412000 of 721920 bytes".
  [[nodiscard]] std::string describe() const;
};

class StereoFrameDecoder {
 public:
  /// Throws std::invalid_argument for invalid options.
  explicit StereoFrameDecoder(StereoDecoderOptions options = {});

  [[nodiscard]] const StereoDecoderOptions& options() const { return options_; }

  /// Bytes a frame must hold with rows `bytes_per_line` apart (0: unpadded, 2 * width): the last
  /// row needs only its 2 * width bytes.
  [[nodiscard]] std::size_t frame_bytes(std::size_t bytes_per_line = 0) const;

  /// Checks a received frame's size; a frame with more bytes than needed is accepted (drivers
  /// may report the whole buffer).
  [[nodiscard]] FrameHealth check(std::size_t received_bytes, std::size_t bytes_per_line = 0) const;

  /// Splits a packed frame into its two mosaics (buffers of `out` are reused). A frame that
  /// fails check() leaves `out` untouched and returns the problem. Throws std::invalid_argument
  /// if bytes_per_line is neither 0 nor at least 2 * width.
  FrameHealth split(std::span<const std::uint8_t> frame, std::size_t bytes_per_line,
                    StereoMosaic& out) const;

  /// One view of a mosaic as `kind` (`out` is reused).
  void convert(const cv::Mat& mosaic, ViewKind kind, cv::Mat& out) const;

  /// The inverse of split(): packs two CV_8UC1 mosaics of the options' size into a frame with
  /// rows `bytes_per_line` apart (0: 2 * width; padding bytes are zero). For feeding a loopback
  /// device or a simulated camera.
  [[nodiscard]] std::vector<std::uint8_t> pack(const cv::Mat& left, const cv::Mat& right,
                                               std::size_t bytes_per_line = 0) const;

 private:
  [[nodiscard]] std::size_t stride(std::size_t bytes_per_line) const;

  StereoDecoderOptions options_;
};

}  // namespace kestrel::driver
