// The projector pattern of the active-stereo sensor (thesis 2.3): random line segments whose
// colour, position and orientation are all random, so that no two matching windows look alike
// along an epipolar line. Deterministic per seed on every platform (own uniform mapping of a
// std::mt19937_64 stream, no std:: distributions).
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

namespace kestrel::sensor {

enum class PatternColors {
  kPrimaries,  ///< red, green, blue, cyan, magenta, yellow, white (saturated: bright in grey)
  kRandom,     ///< uniformly random RGB with at least one channel at full brightness
  kWhite,      ///< white lines only (a monochrome / infrared projector)
};

struct PatternOptions {
  int lines = 200;   ///< thesis 2.3: 200 lines
  int width = 1280;  ///< projector resolution (LG PH300: 1280x720)
  int height = 720;
  /// Thesis 2.3 gives each line a random position and orientation, no length: by default a
  /// line crosses the whole image (through a random point, at a random angle). false: segments
  /// with lengths uniform in [min_length_px, max_length_px].
  bool full_lines = true;
  double min_length_px = 60.0;  ///< segment length range (full_lines = false)
  double max_length_px = 400.0;
  int min_thickness_px = 2;  ///< line width range (pixels of the pattern image)
  int max_thickness_px = 4;
  PatternColors colors = PatternColors::kPrimaries;
  bool antialiased = true;

  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
  [[nodiscard]] std::string describe() const;
};

/// "primaries", "random" or "white"; throws InputError listing the names otherwise.
PatternColors parse_pattern_colors(const std::string& name);
const char* pattern_colors_name(PatternColors colors);

/// The pattern image, CV_8UC3 (BGR), black background.
cv::Mat generate_pattern(const PatternOptions& options, std::uint64_t seed);

}  // namespace kestrel::sensor
