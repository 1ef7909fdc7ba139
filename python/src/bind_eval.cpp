// kestrel.evaluate(): ATE and RPE of an estimate against ground truth, as `kestrel evaluate`.
#include <filesystem>
#include <string>

#include "bindings.hpp"
#include "kestrel/eval/evaluation.hpp"
#include "kestrel/io/trajectory_io.hpp"

namespace kestrel::python {
namespace {

eval::EvaluationOptions evaluation_options(double max_diff_s, double rpe_delta_s) {
  eval::EvaluationOptions o;
  o.max_diff_s = max_diff_s;
  o.rpe_delta_s = rpe_delta_s;
  o.validate();
  return o;
}

}  // namespace

void bind_eval(py::module_& m) {
  py::class_<eval::Evaluation>(m, "Evaluation",
                               "ATE and RPE of an estimate (TUM benchmark conventions).")
      .def_property_readonly(
          "ate_rmse_m", [](const eval::Evaluation& e) { return e.ate.stats_m.rmse; },
          "Absolute trajectory error, RMSE after rigid alignment (m).")
      .def_property_readonly(
          "ate_mean_m", [](const eval::Evaluation& e) { return e.ate.stats_m.mean; },
          "Mean absolute trajectory error (m).")
      .def_property_readonly(
          "ate_median_m", [](const eval::Evaluation& e) { return e.ate.stats_m.median; },
          "Median absolute trajectory error (m).")
      .def_property_readonly(
          "ate_max_m", [](const eval::Evaluation& e) { return e.ate.stats_m.max; },
          "Largest absolute trajectory error (m).")
      .def_property_readonly(
          "rpe_trans_m_s", [](const eval::Evaluation& e) { return e.rpe.trans_rmse_m_s(); },
          "Relative pose error, translational RMSE per second (m/s).")
      .def_property_readonly(
          "rpe_rot_deg_s", [](const eval::Evaluation& e) { return e.rpe.rot_rmse_deg_s(); },
          "Relative pose error, rotational RMSE per second (deg/s).")
      .def_property_readonly(
          "pairs", [](const eval::Evaluation& e) { return e.ate.pairs.size(); },
          "Ground-truth / estimate pose pairs associated for the ATE.")
      .def_readonly("gt_poses", &eval::Evaluation::gt_poses, "Poses in the ground truth.")
      .def_readonly("est_poses", &eval::Evaluation::est_poses, "Poses in the estimate.")
      .def_property_readonly(
          "T_gtworld_estworld", [](const eval::Evaluation& e) { return e.ate.T_gtworld_estworld; },
          "The rigid alignment of the estimate onto the ground truth (SE3).")
      .def("report", &eval::format_report, "The text report `kestrel evaluate` prints.")
      .def("summary_line", &eval::format_summary_line,
           "\"ate_rmse_m=<v> rpe_trans_m_s=<v> rpe_rot_deg_s=<v>\", as the CLI's last line.")
      .def("__repr__", [](const eval::Evaluation& e) {
        return "Evaluation(" + eval::format_summary_line(e) + ")";
      });

  m.def(
      "evaluate",
      [](const std::filesystem::path& gt_path, const std::filesystem::path& est_path,
         double max_diff_s, double rpe_delta_s) {
        const eval::EvaluationOptions options = evaluation_options(max_diff_s, rpe_delta_s);
        return eval::evaluate(io::read_trajectory(gt_path), io::read_trajectory(est_path), options);
      },
      py::arg("gt_path"), py::arg("est_path"), py::arg("max_diff_s") = 0.02,
      py::arg("rpe_delta_s") = 1.0, py::call_guard<py::gil_scoped_release>(),
      "Evaluates an estimate file against a ground-truth file (TUM or EuRoC CSV): ATE after "
      "rigid alignment and RPE over rpe_delta_s windows, as `kestrel evaluate`. Raises "
      "InputError for unreadable files or too few associated poses.");
  m.def(
      "evaluate",
      [](const Trajectory& gt, const Trajectory& est, double max_diff_s, double rpe_delta_s) {
        return eval::evaluate(gt, est, evaluation_options(max_diff_s, rpe_delta_s));
      },
      py::arg("gt"), py::arg("est"), py::arg("max_diff_s") = 0.02, py::arg("rpe_delta_s") = 1.0,
      py::call_guard<py::gil_scoped_release>(), "The same for Trajectory objects.");
}

}  // namespace kestrel::python
