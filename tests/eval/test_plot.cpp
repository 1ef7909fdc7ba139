// The plotting utility: image size, series drawn in their colours, equal aspect, labels and
// legend present, bad input refused, PNG written.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "kestrel/core/error.hpp"
#include "kestrel/eval/plot.hpp"
#include "test_data.hpp"

namespace kestrel::eval {
namespace {

/// Bounding box of the pixels within `tolerance` of this colour in every channel (lines are
/// anti-aliased, so only their cores have the exact colour).
cv::Rect pixels_of(const cv::Mat& image, const Rgb& c, int tolerance = 40) {
  cv::Mat mask;
  const auto lo = [&](int v) { return std::max(0, v - tolerance); };
  const auto hi = [&](int v) { return std::min(255, v + tolerance); };
  cv::inRange(image, cv::Scalar(lo(c.b), lo(c.g), lo(c.r)), cv::Scalar(hi(c.b), hi(c.g), hi(c.r)),
              mask);
  std::vector<cv::Point> points;
  cv::findNonZero(mask, points);
  return points.empty() ? cv::Rect() : cv::boundingRect(points);
}

Plot circle_plot(bool equal_aspect) {
  Plot plot;
  plot.title = "circle";
  plot.x_label = "x [m]";
  plot.y_label = "y [m]";
  plot.width_px = 900;
  plot.height_px = 400;
  plot.equal_aspect = equal_aspect;
  std::vector<double> x, y;
  for (int i = 0; i <= 360; ++i) {
    x.push_back(std::cos(i * std::numbers::pi / 180));
    y.push_back(std::sin(i * std::numbers::pi / 180));
  }
  plot.add("unit circle", x, y).colour = Rgb{255, 0, 0};
  return plot;
}

TEST(Plot, RendersTheRequestedSize) {
  Plot plot = circle_plot(false);
  const cv::Mat image = render_plot(plot);
  EXPECT_EQ(image.cols, 900);
  EXPECT_EQ(image.rows, 400);
  EXPECT_EQ(image.type(), CV_8UC3);
}

TEST(Plot, DrawsEachSeriesInItsColour) {
  Plot plot;
  plot.add("rising", {0, 1, 2, 3}, {0, 1, 2, 3}).colour = Rgb{0, 200, 0};
  plot.add("falling", {0, 1, 2, 3}, {3, 2, 1, 0});  // palette colour 1
  plot.series[0].thickness_px = 2;
  const cv::Mat image = render_plot(plot);
  const cv::Rect green = pixels_of(image, {0, 200, 0});
  const cv::Rect orange = pixels_of(image, palette_colour(1));
  // Each line spans most of the plot, and the legend sample adds a little.
  EXPECT_GT(green.width, 500);
  EXPECT_GT(green.height, 250);
  EXPECT_GT(orange.width, 500);
}

TEST(Plot, EqualAspectKeepsACircleRound) {
  const cv::Rect stretched = pixels_of(render_plot(circle_plot(false)), {255, 0, 0});
  EXPECT_GT(stretched.width, 2 * stretched.height);
  Plot round = circle_plot(true);
  round.series[0].label.clear();  // no legend sample in the colour's bounding box
  const cv::Rect box = pixels_of(render_plot(round), {255, 0, 0});
  EXPECT_NEAR(box.width, box.height, 3);
}

TEST(Plot, DrawsTextAndTicksOutsideThePlotArea) {
  Plot plot = circle_plot(false);
  const cv::Mat with_text = render_plot(plot);
  plot.title.clear();
  plot.x_label.clear();
  plot.y_label.clear();
  cv::Mat diff;
  cv::absdiff(with_text(cv::Rect(0, 0, 900, 30)), render_plot(plot)(cv::Rect(0, 0, 900, 30)), diff);
  EXPECT_GT(cv::countNonZero(diff.reshape(1)), 50);  // the title is there
  cv::Mat gray;
  cv::cvtColor(with_text, gray, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(gray(cv::Rect(0, 0, 40, 400)) < 128), 20);  // the y label
}

TEST(Plot, BreaksLinesAtNonFiniteValuesAndSurvivesEmptyPlots) {
  Plot plot;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  plot.add("gappy", {0, 1, nan, 3, 4}, {0, 1, 2, nan, 5});
  plot.add("constant", {0, 1, 2}, {7, 7, 7});
  EXPECT_NO_THROW(render_plot(plot));
  EXPECT_NO_THROW(render_plot(Plot{}));
  Plot one_point;
  one_point.add("dot", {1}, {1});
  EXPECT_NO_THROW(render_plot(one_point));
}

TEST(Plot, RefusesBadInput) {
  Plot plot;
  plot.add("bad", {0, 1, 2}, {0, 1});
  EXPECT_THROW(render_plot(plot), std::invalid_argument);
  Plot tiny;
  tiny.width_px = 100;
  EXPECT_THROW(render_plot(tiny), std::invalid_argument);
  Plot empty_range;
  empty_range.x_range = AxisRange{1.0, 1.0};
  EXPECT_THROW(render_plot(empty_range), std::invalid_argument);
}

TEST(Plot, StacksPanelsAndWritesPng) {
  Plot wide_labels = circle_plot(false);
  wide_labels.series[0].y = std::vector<double>(wide_labels.series[0].x.size(), 12345.678);
  const cv::Mat both = render_stacked({circle_plot(false), wide_labels});
  EXPECT_EQ(both.rows, 800);
  EXPECT_EQ(both.cols, 900);
  // The plot areas line up: the left edge of both axes boxes is in the same column.
  cv::Mat gray;
  cv::cvtColor(both, gray, cv::COLOR_BGR2GRAY);
  const auto box_left = [&](int row) {
    for (int u = 0; u < gray.cols; ++u) {
      // The axes box: a black column running down through this row and 20 rows below it.
      bool column = true;
      for (int v = row; v < row + 20; ++v) column = column && gray.at<std::uint8_t>(v, u) == 0;
      if (column) return u;
    }
    return -1;
  };
  EXPECT_GT(box_left(150), 0);
  EXPECT_EQ(box_left(150), box_left(550));
  Plot narrow = circle_plot(false);
  narrow.width_px = 600;
  EXPECT_THROW(render_stacked({circle_plot(false), narrow}), std::invalid_argument);
  const cv::Mat a = render_plot(circle_plot(false));
  const auto dir = test::fresh_temp_dir("plot");
  write_png(dir / "both.png", both);
  const cv::Mat read = cv::imread((dir / "both.png").string());
  EXPECT_EQ(read.size(), both.size());
  EXPECT_THROW(write_png(dir / "no_such_dir" / "x.png", a), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace kestrel::eval
