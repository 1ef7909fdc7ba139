// Line plots drawn with OpenCV: "nice" ticks (1, 2, 5 x 10^k), anti-aliased sub-pixel lines
// clipped to the plot area, a rotated y label and a legend box.
#include "kestrel/eval/plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "kestrel/core/error.hpp"

namespace kestrel::eval {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kTickFontScale = 0.4;
constexpr double kLabelFontScale = 0.5;
constexpr double kTitleFontScale = 0.6;
constexpr int kShiftBits = 4;  // sub-pixel precision of cv::line: 1/16 px
constexpr double kShiftScale = 1 << kShiftBits;
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kLegendBorder(160, 160, 160);

cv::Scalar bgr(const Rgb& c) {
  return {static_cast<double>(c.b), static_cast<double>(c.g), static_cast<double>(c.r)};
}

cv::Size text_size(const std::string& text, double scale) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, 1, &baseline);
}

void put_text(cv::Mat& image, const std::string& text, cv::Point origin, double scale) {
  cv::putText(image, text, origin, kFont, scale, kBlack, 1, cv::LINE_AA);
}

/// Range of the finite data of all series along x (axis 0) or y (axis 1), padded.
AxisRange data_range(const Plot& plot, int axis) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (const PlotSeries& s : plot.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      const double v = axis == 0 ? s.x[i] : s.y[i];
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!std::isfinite(lo)) return {0.0, 1.0};
  if (hi - lo <= 1e-12 * std::max(1.0, std::abs(lo))) {
    // Constant data: a range around it, so that the line sits in the middle.
    const double half = std::max(0.5 * std::abs(lo) * 0.1, 0.5);
    return {lo - half, hi + half};
  }
  const double pad = 0.04 * (hi - lo);
  return {lo - pad, hi + pad};
}

/// A step of 1, 2 or 5 times a power of ten giving about `target` intervals over the range.
double nice_step(const AxisRange& range, int target) {
  const double raw = (range.max - range.min) / std::max(target, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double normalised = raw / magnitude;
  const double factor = normalised < 1.5   ? 1.0
                        : normalised < 3.0 ? 2.0
                        : normalised < 7.0 ? 5.0
                                           : 10.0;
  return factor * magnitude;
}

struct Tick {
  double value;
  std::string label;
};

std::vector<Tick> make_ticks(const AxisRange& range, int length_px, int px_per_tick) {
  const double step = nice_step(range, std::max(2, length_px / px_per_tick));
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  const bool use_general = std::max(std::abs(range.min), std::abs(range.max)) >= 1e6 || step < 1e-4;
  std::vector<Tick> ticks;
  const auto first = static_cast<long long>(std::ceil(range.min / step - 1e-9));
  const auto last = static_cast<long long>(std::floor(range.max / step + 1e-9));
  for (long long k = first; k <= last; ++k) {
    double value = static_cast<double>(k) * step;
    if (std::abs(value) < 1e-9 * step) value = 0.0;  // no "-0.0"
    std::array<char, 64> text{};
    if (use_general) {
      std::snprintf(text.data(), text.size(), "%.4g", value);
    } else {
      std::snprintf(text.data(), text.size(), "%.*f", decimals, value);
    }
    ticks.push_back({value, text.data()});
  }
  return ticks;
}

/// Widens the axis whose units per pixel are fewer, about its centre, so both agree.
void equalise_aspect(AxisRange& x, AxisRange& y, int width_px, int height_px) {
  const double x_per_px = (x.max - x.min) / width_px;
  const double y_per_px = (y.max - y.min) / height_px;
  AxisRange& widen = x_per_px < y_per_px ? x : y;
  const double per_px = std::max(x_per_px, y_per_px);
  const double half = 0.5 * per_px * (x_per_px < y_per_px ? width_px : height_px);
  const double centre = 0.5 * (widen.min + widen.max);
  widen = {centre - half, centre + half};
}

struct Layout {
  cv::Rect area;  // the plot area inside the axes box
  AxisRange x, y;
  std::vector<Tick> x_ticks, y_ticks;
};

/// The plot area and ticks. The left margin fits the y tick labels (at least `min_left`),
/// the right one half the last x tick label (at least `min_right`).
Layout make_layout(const Plot& plot, int min_left = 0, int min_right = 0) {
  const int tick_h = text_size("0", kTickFontScale).height;
  const int label_h = text_size("Xy", kLabelFontScale).height;
  const int title_h = text_size("Xy", kTitleFontScale).height;
  const int top = plot.title.empty() ? 14 : title_h + 22;
  const int bottom = tick_h + 12 + (plot.x_label.empty() ? 6 : label_h + 18);
  const int y_label_w = plot.y_label.empty() ? 0 : label_h + 14;
  // The left margin depends on the y tick labels, which depend on the area's height and (with
  // equal aspect) width: iterate until the margin settles (two or three rounds).
  int left = std::max(60, min_left);
  int right = std::max(20, min_right);
  Layout layout;
  for (int round = 0; round < 4; ++round) {
    const cv::Rect area(left, top, plot.width_px - left - right, plot.height_px - top - bottom);
    AxisRange x = plot.x_range.value_or(data_range(plot, 0));
    AxisRange y = plot.y_range.value_or(data_range(plot, 1));
    if (plot.equal_aspect) equalise_aspect(x, y, area.width, area.height);
    layout = {area, x, y, make_ticks(x, area.width, 90), make_ticks(y, area.height, 45)};
    int widest = 0;
    for (const Tick& t : layout.y_ticks) {
      widest = std::max(widest, text_size(t.label, kTickFontScale).width);
    }
    const int last_x_label =
        layout.x_ticks.empty() ? 0 : text_size(layout.x_ticks.back().label, kTickFontScale).width;
    const int needed_left = std::max(widest + 16 + y_label_w, min_left);
    const int needed_right = std::max({20, last_x_label / 2 + 6, min_right});
    if (needed_left == left && needed_right == right) break;
    left = needed_left;
    right = needed_right;
  }
  return layout;
}

cv::Point2d to_pixel(const Layout& l, double x, double y) {
  // Pixel coordinates inside the plot area; clamped far outside it so that the fixed-point
  // conversion cannot overflow (only user-set ranges put data there).
  const double limit = 1e5;
  const double u = (x - l.x.min) / (l.x.max - l.x.min) * (l.area.width - 1);
  const double v = (l.y.max - y) / (l.y.max - l.y.min) * (l.area.height - 1);
  return {std::clamp(u, -limit, limit), std::clamp(v, -limit, limit)};
}

cv::Point fixed_point(const cv::Point2d& p) {
  return {static_cast<int>(std::lround(p.x * kShiftScale)),
          static_cast<int>(std::lround(p.y * kShiftScale))};
}

void draw_grid_and_ticks(cv::Mat& image, const Layout& l) {
  const cv::Rect& a = l.area;
  for (const Tick& t : l.x_ticks) {
    const int u = a.x + static_cast<int>(std::lround(to_pixel(l, t.value, l.y.min).x));
    cv::line(image, {u, a.y}, {u, a.y + a.height - 1}, kGrid, 1);
    cv::line(image, {u, a.y + a.height}, {u, a.y + a.height + 4}, kBlack, 1);
    const cv::Size s = text_size(t.label, kTickFontScale);
    put_text(image, t.label, {u - s.width / 2, a.y + a.height + 8 + s.height}, kTickFontScale);
  }
  for (const Tick& t : l.y_ticks) {
    const int v = a.y + static_cast<int>(std::lround(to_pixel(l, l.x.min, t.value).y));
    cv::line(image, {a.x, v}, {a.x + a.width - 1, v}, kGrid, 1);
    cv::line(image, {a.x - 5, v}, {a.x - 1, v}, kBlack, 1);
    const cv::Size s = text_size(t.label, kTickFontScale);
    put_text(image, t.label, {a.x - 9 - s.width, v + s.height / 2}, kTickFontScale);
  }
}

void draw_series(cv::Mat& image, const Layout& l, const PlotSeries& s, const cv::Scalar& colour) {
  // Drawing into the area's sub-image makes OpenCV clip at the axes.
  cv::Mat area = image(l.area);
  std::vector<cv::Point> run;
  const auto flush = [&] {
    if (run.size() >= 2) {
      cv::polylines(area, run, false, colour, s.thickness_px, cv::LINE_AA, kShiftBits);
    } else if (run.size() == 1) {
      cv::circle(area, run.front(), 2 << kShiftBits, colour, cv::FILLED, cv::LINE_AA, kShiftBits);
    }
    run.clear();
  };
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
      flush();
      continue;
    }
    const cv::Point p = fixed_point(to_pixel(l, s.x[i], s.y[i]));
    run.push_back(p);
    if (s.markers)
      cv::circle(area, p, 3 << kShiftBits, colour, cv::FILLED, cv::LINE_AA, kShiftBits);
  }
  flush();
}

void draw_labels(cv::Mat& image, const Plot& plot, const Layout& l) {
  const cv::Rect& a = l.area;
  if (!plot.title.empty()) {
    const cv::Size s = text_size(plot.title, kTitleFontScale);
    put_text(image, plot.title, {a.x + (a.width - s.width) / 2, 8 + s.height}, kTitleFontScale);
  }
  if (!plot.x_label.empty()) {
    const cv::Size s = text_size(plot.x_label, kLabelFontScale);
    put_text(image, plot.x_label, {a.x + (a.width - s.width) / 2, image.rows - 8}, kLabelFontScale);
  }
  if (!plot.y_label.empty()) {
    // Written horizontally on a patch, then turned a quarter to read bottom to top.
    int baseline = 0;
    const cv::Size s = cv::getTextSize(plot.y_label, kFont, kLabelFontScale, 1, &baseline);
    cv::Mat patch(s.height + baseline + 2, s.width + 2, CV_8UC3, kWhite);
    put_text(patch, plot.y_label, {1, s.height + 1}, kLabelFontScale);
    cv::rotate(patch, patch, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int x0 = 6;
    const int y0 = std::max(0, a.y + (a.height - patch.rows) / 2);
    const cv::Rect target(x0, y0, std::min(patch.cols, image.cols - x0),
                          std::min(patch.rows, image.rows - y0));
    patch(cv::Rect(0, 0, target.width, target.height)).copyTo(image(target));
  }
}

void draw_legend(cv::Mat& image, const Plot& plot, const Layout& l) {
  std::vector<std::size_t> entries;
  int widest = 0;
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    if (plot.series[i].label.empty()) continue;
    entries.push_back(i);
    widest = std::max(widest, text_size(plot.series[i].label, kTickFontScale).width);
  }
  if (entries.empty()) return;
  const int row_h = text_size("Xy", kTickFontScale).height + 9;
  const int sample_w = 24;
  const cv::Rect box(l.area.x + l.area.width - (widest + sample_w + 22) - 8, l.area.y + 8,
                     widest + sample_w + 22, static_cast<int>(entries.size()) * row_h + 8);
  cv::rectangle(image, box, kWhite, cv::FILLED);
  cv::rectangle(image, box, kLegendBorder, 1);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const PlotSeries& s = plot.series[entries[k]];
    const cv::Scalar colour = bgr(s.colour.value_or(palette_colour(entries[k])));
    const int v = box.y + 4 + static_cast<int>(k) * row_h + row_h / 2;
    cv::line(image, {box.x + 8, v}, {box.x + 8 + sample_w, v}, colour, std::max(2, s.thickness_px),
             cv::LINE_AA);
    put_text(image, s.label, {box.x + 14 + sample_w, v + row_h / 2 - 5}, kTickFontScale);
  }
}

void validate(const Plot& plot) {
  if (plot.width_px < 200 || plot.height_px < 150) {
    throw std::invalid_argument("render_plot: size under 200 x 150 px");
  }
  for (const PlotSeries& s : plot.series) {
    if (s.x.size() != s.y.size()) {
      throw std::invalid_argument("render_plot: series '" + s.label + "' has " +
                                  std::to_string(s.x.size()) + " x but " +
                                  std::to_string(s.y.size()) + " y values");
    }
  }
  for (const std::optional<AxisRange>& r : {plot.x_range, plot.y_range}) {
    if (r && !(r->max > r->min && std::isfinite(r->min) && std::isfinite(r->max))) {
      throw std::invalid_argument("render_plot: an axis range is empty or not finite");
    }
  }
}

cv::Mat draw(const Plot& plot, const Layout& layout) {
  cv::Mat image(plot.height_px, plot.width_px, CV_8UC3, kWhite);
  draw_grid_and_ticks(image, layout);
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const PlotSeries& s = plot.series[i];
    draw_series(image, layout, s, bgr(s.colour.value_or(palette_colour(i))));
  }
  cv::rectangle(image, layout.area, kBlack, 1);
  draw_labels(image, plot, layout);
  draw_legend(image, plot, layout);
  return image;
}

}  // namespace

Rgb palette_colour(std::size_t i) {
  static constexpr std::array<Rgb, 10> kTab10 = {{{31, 119, 180},
                                                  {255, 127, 14},
                                                  {44, 160, 44},
                                                  {214, 39, 40},
                                                  {148, 103, 189},
                                                  {140, 86, 75},
                                                  {227, 119, 194},
                                                  {127, 127, 127},
                                                  {188, 189, 34},
                                                  {23, 190, 207}}};
  return kTab10[i % kTab10.size()];
}

PlotSeries& Plot::add(std::string label, std::vector<double> x, std::vector<double> y) {
  PlotSeries s;
  s.label = std::move(label);
  s.x = std::move(x);
  s.y = std::move(y);
  series.push_back(std::move(s));
  return series.back();
}

cv::Mat render_plot(const Plot& plot) {
  validate(plot);
  return draw(plot, make_layout(plot));
}

cv::Mat render_stacked(const std::vector<Plot>& panels) {
  if (panels.empty()) throw std::invalid_argument("render_stacked: no panels");
  int left = 0;
  int right = 0;
  for (const Plot& plot : panels) {
    validate(plot);
    if (plot.width_px != panels.front().width_px) {
      throw std::invalid_argument("render_stacked: panels differ in width");
    }
    const Layout l = make_layout(plot);
    left = std::max(left, l.area.x);
    right = std::max(right, plot.width_px - l.area.x - l.area.width);
  }
  std::vector<cv::Mat> images;
  images.reserve(panels.size());
  for (const Plot& plot : panels) images.push_back(draw(plot, make_layout(plot, left, right)));
  cv::Mat out;
  cv::vconcat(images, out);
  return out;
}

void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image);
  } catch (const cv::Exception& e) {
    throw InputError(path.string() + ": cannot write PNG: " + e.what());
  }
  if (!ok) throw InputError(path.string() + ": cannot write PNG");
}

}  // namespace kestrel::eval
