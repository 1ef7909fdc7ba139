// The figures of an evaluation: per-axis values and errors over time (as in the thesis, 3.11),
// a top view, and the RPE over time.
#include <array>
#include <cstdio>

#include "kestrel/core/units.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/eval/plot.hpp"

namespace kestrel::eval {
namespace {

constexpr int kWidthPx = 900;
constexpr int kPanelHeightPx = 320;
const Rgb kGtColour{0, 0, 0};
const Rgb kEstColour{31, 119, 180};
const Rgb kErrorColour{214, 39, 40};

struct AxisSeries {
  const char* name;  // file name and label
  const char* unit;
  std::vector<double> gt, est, error;
};

std::vector<AxisSeries> axis_series(const std::vector<AxisErrorSample>& samples) {
  std::vector<AxisSeries> axes = {{"x", "m", {}, {}, {}},       {"y", "m", {}, {}, {}},
                                  {"z", "m", {}, {}, {}},       {"roll", "deg", {}, {}, {}},
                                  {"pitch", "deg", {}, {}, {}}, {"yaw", "deg", {}, {}, {}}};
  for (const AxisErrorSample& s : samples) {
    const Eigen::Vector3d p_err = s.p_error_m();
    const Eigen::Vector3d rpy_err = s.rpy_error_rad();
    for (int k = 0; k < 3; ++k) {
      AxisSeries& p = axes[static_cast<std::size_t>(k)];
      p.gt.push_back(s.p_gt_m[k]);
      p.est.push_back(s.p_est_m[k]);
      p.error.push_back(p_err[k]);
      AxisSeries& a = axes[static_cast<std::size_t>(k) + 3];
      a.gt.push_back(s.rpy_gt_rad[k] * kRadToDeg);
      a.est.push_back(s.rpy_est_rad[k] * kRadToDeg);
      a.error.push_back(rpy_err[k] * kRadToDeg);
    }
  }
  return axes;
}

Plot panel(const std::string& title, const std::string& x_label, const std::string& y_label) {
  Plot plot;
  plot.title = title;
  plot.x_label = x_label;
  plot.y_label = y_label;
  plot.width_px = kWidthPx;
  plot.height_px = kPanelHeightPx;
  return plot;
}

}  // namespace

std::vector<std::filesystem::path> write_evaluation_figures(const std::filesystem::path& dir,
                                                            const Trajectory& est,
                                                            const Evaluation& evaluation) {
  std::vector<std::filesystem::path> written;
  const auto seconds_since_t0 = [&](TimeNs t_ns) { return ns_to_s(t_ns - evaluation.t0_ns); };
  const std::string time_label = "time since first pair [s]";

  std::vector<double> t_s;
  for (const AxisErrorSample& s : evaluation.axes) t_s.push_back(seconds_since_t0(s.t_ns));
  for (const AxisSeries& axis : axis_series(evaluation.axes)) {
    const std::string unit = std::string(" [") + axis.unit + "]";
    Plot values =
        panel(std::string(axis.name) + ": ground truth and aligned estimate", "", axis.name + unit);
    values.add("ground truth", t_s, axis.gt).colour = kGtColour;
    values.add("estimate (aligned)", t_s, axis.est).colour = kEstColour;
    Plot errors = panel(std::string(axis.name) + " error (estimate - ground truth)", time_label,
                        "error" + unit);
    errors.add("", t_s, axis.error).colour = kErrorColour;
    written.push_back(dir / (std::string(axis.name) + ".png"));
    write_png(written.back(), render_stacked({values, errors}));
  }

  Plot top = panel("top view (x-y), estimate aligned to ground truth", "x [m]", "y [m]");
  top.height_px = 700;
  top.width_px = 800;
  top.equal_aspect = true;
  std::vector<double> x_gt, y_gt, x_est, y_est;
  for (const AxisErrorSample& s : evaluation.axes) {
    x_gt.push_back(s.p_gt_m.x());
    y_gt.push_back(s.p_gt_m.y());
    x_est.push_back(s.p_est_m.x());
    y_est.push_back(s.p_est_m.y());
  }
  top.add("ground truth", x_gt, y_gt).colour = kGtColour;
  top.add("estimate (aligned)", x_est, y_est).colour = kEstColour;
  written.push_back(dir / "top_view.png");
  write_png(written.back(), render_plot(top));

  std::vector<double> t_rpe_s, trans_m, rot_deg;
  for (const RpePair& p : evaluation.rpe.pairs) {
    t_rpe_s.push_back(seconds_since_t0(est[p.est0].t_ns));
    trans_m.push_back(p.trans_m);
    rot_deg.push_back(p.rot_rad * kRadToDeg);
  }
  std::array<char, 64> window{};
  std::snprintf(window.data(), window.size(), "%g s windows", evaluation.rpe.delta_s);
  Plot trans = panel(std::string("translational RPE over ") + window.data(), "", "error [m]");
  trans.add("", t_rpe_s, trans_m).colour = kEstColour;
  Plot rot = panel(std::string("rotational RPE over ") + window.data(), time_label, "error [deg]");
  rot.add("", t_rpe_s, rot_deg).colour = kErrorColour;
  written.push_back(dir / "rpe.png");
  write_png(written.back(), render_stacked({trans, rot}));
  return written;
}

}  // namespace kestrel::eval
