// Random-line projector patterns (thesis 2.3).
#include "kestrel/sensor/pattern.hpp"

#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/core/random.hpp"

namespace kestrel::sensor {
namespace {

int uniform_int(std::mt19937_64& rng, int lo, int hi) {  // inclusive
  return lo + static_cast<int>(std::floor(uniform01(rng) * (hi - lo + 1)));
}

}  // namespace

void PatternOptions::validate() const {
  const auto fail = [](const std::string& m) { throw std::invalid_argument("pattern: " + m); };
  if (lines < 1) fail("lines must be >= 1, got " + std::to_string(lines));
  if (width < 16 || height < 16 || width > 16384 || height > 16384) {
    fail("the image size must lie in [16, 16384], got " + std::to_string(width) + "x" +
         std::to_string(height));
  }
  if (!(min_length_px > 0.0) || !(max_length_px >= min_length_px)) {
    fail("need 0 < min_length_px <= max_length_px");
  }
  if (min_thickness_px < 1 || max_thickness_px < min_thickness_px || max_thickness_px > 64) {
    fail("need 1 <= min_thickness_px <= max_thickness_px <= 64");
  }
}

std::string PatternOptions::describe() const {
  std::ostringstream os;
  os << lines << " lines, " << width << "x" << height;
  if (full_lines) {
    os << ", across the image";
  } else {
    os << ", segments of [" << min_length_px << ", " << max_length_px << "] px";
  }
  os << ", thickness [" << min_thickness_px << ", " << max_thickness_px << "] px, colours "
     << pattern_colors_name(colors) << (antialiased ? ", antialiased" : "");
  return os.str();
}

PatternColors parse_pattern_colors(const std::string& name) {
  if (name == "primaries") return PatternColors::kPrimaries;
  if (name == "random") return PatternColors::kRandom;
  if (name == "white") return PatternColors::kWhite;
  throw InputError("pattern colours '" + name + "': expected primaries, random or white");
}

const char* pattern_colors_name(PatternColors colors) {
  switch (colors) {
    case PatternColors::kPrimaries:
      return "primaries";
    case PatternColors::kRandom:
      return "random";
    case PatternColors::kWhite:
      return "white";
  }
  return "?";
}

cv::Mat generate_pattern(const PatternOptions& options, std::uint64_t seed) {
  options.validate();
  std::mt19937_64 rng(seed);
  cv::Mat image(options.height, options.width, CV_8UC3, cv::Scalar::all(0));
  static const cv::Scalar kPrimaries[] = {{0, 0, 255},    {0, 255, 0},   {255, 0, 0},
                                          {255, 255, 0},  {255, 0, 255}, {0, 255, 255},
                                          {255, 255, 255}};
  for (int i = 0; i < options.lines; ++i) {
    // Centre anywhere (segments may leave the image), orientation uniform over [0, pi). The
    // length is drawn in both modes so that a seed gives the same positions and colours.
    const double cx = uniform(rng, 0.0, options.width);
    const double cy = uniform(rng, 0.0, options.height);
    const double angle = uniform(rng, 0.0, std::numbers::pi);
    const double segment = uniform(rng, options.min_length_px, options.max_length_px);
    // Twice the diagonal: from any point of the image both ends lie outside it.
    const double length =
        options.full_lines ? 2.0 * std::hypot(options.width, options.height) : segment;
    const int thickness = uniform_int(rng, options.min_thickness_px, options.max_thickness_px);
    cv::Scalar color;
    switch (options.colors) {
      case PatternColors::kPrimaries:
        color = kPrimaries[uniform_int(rng, 0, 6)];
        break;
      case PatternColors::kWhite:
        color = cv::Scalar::all(255);
        break;
      case PatternColors::kRandom: {
        color = cv::Scalar(uniform(rng, 0, 255), uniform(rng, 0, 255), uniform(rng, 0, 255));
        color[uniform_int(rng, 0, 2)] = 255.0;
        break;
      }
    }
    const double dx = 0.5 * length * std::cos(angle), dy = 0.5 * length * std::sin(angle);
    // Fixed-point endpoints (4 fractional bits) keep antialiased lines at subpixel positions.
    constexpr int kShift = 4;
    const auto fixed = [](double v) { return static_cast<int>(std::lround(v * (1 << kShift))); };
    cv::line(image, {fixed(cx - dx), fixed(cy - dy)}, {fixed(cx + dx), fixed(cy + dy)}, color,
             thickness, options.antialiased ? cv::LINE_AA : cv::LINE_8, kShift);
  }
  return image;
}

}  // namespace kestrel::sensor
