// Bayer mosaics: the colour-filter phase of a sensor, demosaicing with OpenCV, and the inverse
// (a mosaic sampled from a colour image, as a sensor would see it).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string_view>

namespace kestrel::driver {

/// The 2x2 colour-filter tile of a sensor, named the sensor way: the filters of pixels
/// (0,0) (1,0) on row 0, then (0,1) (1,1) on row 1. The MT9V024 is GRBG:
///   row 0: G R G R ...
///   row 1: B G B G ...
/// OpenCV names its Bayer codes after the second row's second and third pixels instead, so
/// sensor GRBG is OpenCV's "BayerGB" (opencv_bayer_code() does the translation).
enum class BayerPhase { kGRBG, kRGGB, kBGGR, kGBRG };

enum class DemosaicMethod {
  kBilinear,   ///< OpenCV's bilinear interpolation (fast)
  kEdgeAware,  ///< OpenCV's edge-aware interpolation (_EA codes): fewer zipper artefacts
};

/// "GRBG", "RGGB", ...: the sensor name; parse accepts either case.
[[nodiscard]] std::string_view bayer_phase_name(BayerPhase phase);
[[nodiscard]] std::optional<BayerPhase> parse_bayer_phase(std::string_view name);
[[nodiscard]] std::string_view demosaic_method_name(DemosaicMethod method);
/// "bilinear" or "edge-aware".
[[nodiscard]] std::optional<DemosaicMethod> parse_demosaic_method(std::string_view name);
/// The options-table hooks (io/option_fields.hpp); parse_option throws std::invalid_argument
/// listing the names.
[[nodiscard]] inline std::string_view to_string(BayerPhase phase) {
  return bayer_phase_name(phase);
}
[[nodiscard]] inline std::string_view to_string(DemosaicMethod method) {
  return demosaic_method_name(method);
}
void parse_option(std::string_view name, BayerPhase& phase);
void parse_option(std::string_view name, DemosaicMethod& method);

/// BGR channel (0 = B, 1 = G, 2 = R) behind the filter at pixel (x, y).
[[nodiscard]] int bayer_channel(BayerPhase phase, int x, int y);

/// The cv::cvtColor code turning a CV_8UC1 mosaic of `phase` into BGR.
[[nodiscard]] int opencv_bayer_to_bgr_code(BayerPhase phase, DemosaicMethod method);
/// The cv::cvtColor code turning a mosaic of `phase` into grey (intensity).
[[nodiscard]] int opencv_bayer_to_gray_code(BayerPhase phase);

/// What a sensor of `phase` records of a CV_8UC3 BGR image: one sample per pixel (CV_8UC1).
[[nodiscard]] cv::Mat mosaic_from_bgr(const cv::Mat& bgr, BayerPhase phase);

}  // namespace kestrel::driver
