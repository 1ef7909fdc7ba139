// kestrel.Trajectory, trajectory files (TUM, EuRoC CSV) and TUM RGB-D folders (TumSequence).
#include <filesystem>
#include <string>
#include <tuple>

#include "arrays.hpp"
#include "bindings.hpp"
#include "kestrel/io/trajectory_io.hpp"
#include "kestrel/io/tum_rgbd.hpp"

namespace kestrel::python {
namespace {

using Path = std::filesystem::path;

py::array_t<std::int64_t> trajectory_times(const Trajectory& trajectory) {
  py::array_t<std::int64_t> t(static_cast<py::ssize_t>(trajectory.size()));
  auto out = t.mutable_unchecked<1>();
  for (std::size_t i = 0; i < trajectory.size(); ++i)
    out(static_cast<py::ssize_t>(i)) = trajectory[i].t_ns;
  return t;
}

// (N, cols) float64 of one column block per pose.
template <int Cols, class Fill>
py::array_t<double> trajectory_columns(const Trajectory& trajectory, Fill fill) {
  py::array_t<double> a({static_cast<py::ssize_t>(trajectory.size()), py::ssize_t{Cols}});
  auto out = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Matrix<double, Cols, 1> v = fill(trajectory[i].T_world_body);
    for (int c = 0; c < Cols; ++c) out(static_cast<py::ssize_t>(i), c) = v[c];
  }
  return a;
}

py::array_t<double> trajectory_poses(const Trajectory& trajectory) {
  py::array_t<double> a(
      {static_cast<py::ssize_t>(trajectory.size()), py::ssize_t{4}, py::ssize_t{4}});
  auto out = a.mutable_unchecked<3>();
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Matrix4d T = trajectory[i].T_world_body.matrix();
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) out(static_cast<py::ssize_t>(i), r, c) = T(r, c);
    }
  }
  return a;
}

Trajectory trajectory_from_arrays(const py::array& t_ns, const py::array& positions,
                                  const py::array& quaternions_xyzw) {
  const py::ssize_t n = positions.ndim() > 0 ? positions.shape(0) : 0;
  const std::int64_t* t = view_int64(t_ns, "t_ns", n);
  const double* p = view_doubles(positions, "positions", {-1, 3});
  const double* q = view_doubles(quaternions_xyzw, "quaternions_xyzw", {n, 4});
  Trajectory trajectory;
  trajectory.reserve(static_cast<std::size_t>(n));
  for (py::ssize_t i = 0; i < n; ++i) {
    const Eigen::Quaterniond quat(q[4 * i + 3], q[4 * i], q[4 * i + 1], q[4 * i + 2]);
    if (std::abs(quat.norm() - 1.0) > 1e-6) {
      throw py::value_error("quaternions_xyzw: row " + std::to_string(i) +
                            " is not a unit quaternion");
    }
    trajectory.push_back({t[i], SE3(quat, Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]))});
  }
  return trajectory;
}

void bind_trajectory(py::module_& m) {
  py::class_<Trajectory>(m, "Trajectory",
                         "Time-stamped poses T_world_body, sorted by time (int64 nanoseconds).")
      .def(py::init<>(), "An empty trajectory.")
      .def(py::init(&trajectory_from_arrays), py::arg("t_ns"), py::arg("positions"),
           py::arg("quaternions_xyzw"),
           "From arrays: t_ns int64 (N,), positions float64 (N, 3), quaternions_xyzw float64 "
           "(N, 4) of unit quaternions (x, y, z, w).")
      .def(
          "append",
          [](Trajectory& t, std::int64_t t_ns, const SE3& T) {
            t.push_back({t_ns, T});
          },
          py::arg("t_ns"), py::arg("T_world_body"), "Adds a pose at time t_ns.")
      .def("__len__", [](const Trajectory& t) { return t.size(); })
      .def(
          "__getitem__",
          [](const Trajectory& t, py::ssize_t i) {
            const auto n = static_cast<py::ssize_t>(t.size());
            if (i < 0) i += n;
            if (i < 0 || i >= n) throw py::index_error("trajectory index out of range");
            const StampedPose& p = t[static_cast<std::size_t>(i)];
            return std::make_tuple(p.t_ns, p.T_world_body);
          },
          py::arg("i"), "(t_ns, SE3) of pose i.")
      .def_property_readonly("t_ns", &trajectory_times, "Time stamps, int64 (N,) nanoseconds.")
      .def_property_readonly(
          "positions",
          [](const Trajectory& t) {
            return trajectory_columns<3>(t, [](const SE3& T) { return T.translation(); });
          },
          "Positions, float64 (N, 3).")
      .def_property_readonly(
          "quaternions_xyzw",
          [](const Trajectory& t) { return trajectory_columns<4>(t, &quaternion_xyzw); },
          "Unit quaternions (x, y, z, w), float64 (N, 4).")
      .def_property_readonly("poses", &trajectory_poses, "4x4 matrices, float64 (N, 4, 4).");

  m.def("read_trajectory", &io::read_trajectory, py::arg("path"),
        py::call_guard<py::gil_scoped_release>(),
        "Reads a TUM (`t tx ty tz qx qy qz qw`, seconds) or EuRoC CSV trajectory, detected from "
        "the content. Raises InputError naming the file and line.");
  m.def("write_tum_trajectory", &io::write_tum_trajectory, py::arg("path"), py::arg("trajectory"),
        py::arg("command") = "python", py::arg("force") = false,
        py::call_guard<py::gil_scoped_release>(),
        "Writes TUM format, first line `# written by kestrel <command>`; refuses to overwrite a "
        "file Kestrel did not write unless force.");
  m.def("write_euroc_trajectory", &io::write_euroc_trajectory, py::arg("path"),
        py::arg("trajectory"), py::arg("command") = "python", py::arg("force") = false,
        py::call_guard<py::gil_scoped_release>(), "Writes EuRoC CSV, same rules.");
}

void bind_tum_sequence(py::module_& m) {
  py::class_<io::TumRgbdSequence>(
      m, "TumSequence",
      "A TUM RGB-D folder (rgb.txt, depth.txt, rgb/, depth/): associated colour and depth "
      "frames, decoded one at a time.")
      .def(py::init([](const Path& folder, double depth_scale, double max_association_diff_s) {
             io::TumRgbdOptions options;
             options.depth_scale = depth_scale;
             options.max_association_diff_s = max_association_diff_s;
             py::gil_scoped_release release;
             return io::TumRgbdSequence(folder, options);
           }),
           py::arg("folder"), py::arg("depth_scale") = 5000.0,
           py::arg("max_association_diff_s") = 0.02,
           "Reads and associates the lists (as `kestrel odometry`). depth_scale: depth PNG units "
           "per metre (TUM: 5000).")
      .def("__len__", &io::TumRgbdSequence::size)
      .def("timestamp", &io::TumRgbdSequence::timestamp, py::arg("i"),
           "Time stamp of frame i (int64 ns).")
      .def(
          "__getitem__",
          [](const io::TumRgbdSequence& s, py::ssize_t i) {
            if (i < 0) i += static_cast<py::ssize_t>(s.size());
            if (i < 0 || i >= static_cast<py::ssize_t>(s.size())) {
              throw py::index_error("frame index out of range");
            }
            io::RgbdImages images;
            {
              py::gil_scoped_release release;  // PNG decoding
              images = s.load(static_cast<std::size_t>(i));
            }
            return std::make_tuple(images.t_ns, to_array(images.bgr), to_array(images.depth_m));
          },
          py::arg("i"),
          "Frame i as (t_ns, bgr uint8 (H, W, 3), depth_m float32 (H, W)); raises InputError "
          "for an unreadable image.")
      .def("groundtruth", &io::TumRgbdSequence::groundtruth,
           "groundtruth.txt as a Trajectory, or None.")
      .def_property_readonly("folder", &io::TumRgbdSequence::folder, "The folder read.");
}

}  // namespace

void bind_io(py::module_& m) {
  bind_trajectory(m);
  bind_tum_sequence(m);
}

}  // namespace kestrel::python
