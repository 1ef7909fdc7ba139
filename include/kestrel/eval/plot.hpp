// A small line-plot renderer (PNG through OpenCV drawing), for error-over-time figures and
// top views: axes with tick labels, axis labels, a title, a legend, several coloured series,
// optional equal aspect. Enough for reports without a plotting library on board.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace kestrel::eval {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// The i-th colour of matplotlib's default cycle ("tab10"), repeating after 10.
Rgb palette_colour(std::size_t i);

struct PlotSeries {
  std::string label;          ///< legend text; an empty label keeps the series out of it
  std::vector<double> x, y;   ///< equal lengths; a non-finite value breaks the line there
  std::optional<Rgb> colour;  ///< default: palette_colour(index of the series)
  int thickness_px = 1;
  bool markers = false;  ///< a dot at each point as well as the line
};

/// A closed range of values; the renderer pads an automatic one by 4 % each side.
struct AxisRange {
  double min = 0.0, max = 1.0;
};

struct Plot {
  std::string title;
  std::string x_label;  ///< with units, "time [s]"
  std::string y_label;
  std::vector<PlotSeries> series;
  int width_px = 900;
  int height_px = 450;
  /// One data unit is as long on both axes (top views): the range of the axis that would be
  /// stretched more is widened about its centre.
  bool equal_aspect = false;
  std::optional<AxisRange> x_range;  ///< default: from the data
  std::optional<AxisRange> y_range;

  /// Appends a line series and returns it for further settings.
  PlotSeries& add(std::string label, std::vector<double> x, std::vector<double> y);
};

/// Renders to an 8-bit BGR image of plot.width_px x plot.height_px (white background).
/// Throws std::invalid_argument for a series whose x and y differ in length or a size under
/// 200 x 150 px. A plot without finite data shows empty axes over [0, 1].
cv::Mat render_plot(const Plot& plot);

/// Panels of one figure rendered top to bottom, with their plot areas given the same left
/// and right margins so that shared x axes line up. Widths must agree (std::invalid_argument).
cv::Mat render_stacked(const std::vector<Plot>& panels);

/// Writes an image as PNG; throws InputError naming the file if it cannot be written. PNGs
/// carry no provenance line: callers write them into a folder claimed with
/// io::claim_output_dir().
void write_png(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace kestrel::eval
