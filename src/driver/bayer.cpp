// Bayer phases and their OpenCV codes. OpenCV names a pattern by the second row's second and
// third pixels (imgproc's "Bayer" docs); the sensor naming reads the tile from (0,0). The
// round-trip tests in tests/driver check the translation against a known colour image.
#include "kestrel/driver/bayer.hpp"

#include <array>
#include <cctype>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace kestrel::driver {

namespace {

struct PhaseInfo {
  BayerPhase phase;
  std::string_view name;
  int bgr_code;
  int bgr_ea_code;
  int gray_code;
};

// Sensor tile -> OpenCV name: RGGB = BayerBG, BGGR = BayerRG, GRBG = BayerGB, GBRG = BayerGR.
constexpr std::array<PhaseInfo, 4> kPhases{{
    {BayerPhase::kGRBG, "GRBG", cv::COLOR_BayerGB2BGR, cv::COLOR_BayerGB2BGR_EA,
     cv::COLOR_BayerGB2GRAY},
    {BayerPhase::kRGGB, "RGGB", cv::COLOR_BayerBG2BGR, cv::COLOR_BayerBG2BGR_EA,
     cv::COLOR_BayerBG2GRAY},
    {BayerPhase::kBGGR, "BGGR", cv::COLOR_BayerRG2BGR, cv::COLOR_BayerRG2BGR_EA,
     cv::COLOR_BayerRG2GRAY},
    {BayerPhase::kGBRG, "GBRG", cv::COLOR_BayerGR2BGR, cv::COLOR_BayerGR2BGR_EA,
     cv::COLOR_BayerGR2GRAY},
}};

const PhaseInfo& info(BayerPhase phase) {
  for (const auto& p : kPhases) {
    if (p.phase == phase) return p;
  }
  throw std::invalid_argument("unknown Bayer phase");
}

int channel_of_letter(char c) { return c == 'B' ? 0 : c == 'G' ? 1 : 2; }

/// Index of pixel (x, y)'s filter in the 2x2 tile, read row by row.
std::size_t tile_index(int x, int y) {
  return (static_cast<std::size_t>(y) & 1U) * 2 + (static_cast<std::size_t>(x) & 1U);
}

}  // namespace

std::string_view bayer_phase_name(BayerPhase phase) { return info(phase).name; }

std::optional<BayerPhase> parse_bayer_phase(std::string_view name) {
  std::string upper(name);
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  for (const auto& p : kPhases) {
    if (p.name == upper) return p.phase;
  }
  return std::nullopt;
}

std::string_view demosaic_method_name(DemosaicMethod method) {
  return method == DemosaicMethod::kBilinear ? "bilinear" : "edge-aware";
}

std::optional<DemosaicMethod> parse_demosaic_method(std::string_view name) {
  if (name == "bilinear") return DemosaicMethod::kBilinear;
  if (name == "edge-aware") return DemosaicMethod::kEdgeAware;
  return std::nullopt;
}

void parse_option(std::string_view name, BayerPhase& phase) {
  const auto parsed = parse_bayer_phase(name);
  if (!parsed) {
    throw std::invalid_argument("must be GRBG, RGGB, BGGR or GBRG, got '" + std::string(name) +
                                "'");
  }
  phase = *parsed;
}

void parse_option(std::string_view name, DemosaicMethod& method) {
  const auto parsed = parse_demosaic_method(name);
  if (!parsed) {
    throw std::invalid_argument("must be bilinear or edge-aware, got '" + std::string(name) + "'");
  }
  method = *parsed;
}

int bayer_channel(BayerPhase phase, int x, int y) {
  return channel_of_letter(info(phase).name[tile_index(x, y)]);
}

int opencv_bayer_to_bgr_code(BayerPhase phase, DemosaicMethod method) {
  return method == DemosaicMethod::kBilinear ? info(phase).bgr_code : info(phase).bgr_ea_code;
}

int opencv_bayer_to_gray_code(BayerPhase phase) { return info(phase).gray_code; }

cv::Mat mosaic_from_bgr(const cv::Mat& bgr, BayerPhase phase) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("mosaic_from_bgr: needs a CV_8UC3 image");
  const std::array<int, 4> channel{bayer_channel(phase, 0, 0), bayer_channel(phase, 1, 0),
                                   bayer_channel(phase, 0, 1), bayer_channel(phase, 1, 1)};
  cv::Mat mosaic(bgr.size(), CV_8UC1);
  for (int y = 0; y < bgr.rows; ++y) {
    const auto* in = bgr.ptr<cv::Vec3b>(y);
    auto* out = mosaic.ptr<std::uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      out[x] = in[x][channel[tile_index(x, y)]];
    }
  }
  return mosaic;
}

}  // namespace kestrel::driver
