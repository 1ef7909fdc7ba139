// kestrel.SE3: rigid motions, exact (quaternion and translation as Kestrel holds them), with 4x4
// matrices for numpy.
#include "bindings.hpp"
#include "kestrel/geometry/se3.hpp"

namespace kestrel::python {

Eigen::Vector4d quaternion_xyzw(const SE3& T) {
  const Eigen::Quaterniond& q = T.unit_quaternion();
  return {q.x(), q.y(), q.z(), q.w()};
}

void bind_geometry(py::module_& m) {
  py::class_<SE3>(m, "SE3",
                  "A rigid motion T_a_b mapping points of frame b into frame a: p_a = R p_b + t.")
      .def(py::init<>(), "The identity.")
      .def(py::init([](const Eigen::Vector3d& translation, const Eigen::Vector4d& q_xyzw) {
             const Eigen::Quaterniond q(q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2]);
             if (std::abs(q.norm() - 1.0) > 1e-6) {
               throw py::value_error("quaternion_xyzw: not a unit quaternion (norm " +
                                     std::to_string(q.norm()) + ")");
             }
             return SE3(q, translation);
           }),
           py::arg("translation"), py::arg("quaternion_xyzw"),
           "From a translation (3,) and a unit quaternion (x, y, z, w) (the TUM file order).")
      .def_static("from_matrix", &SE3::from_matrix, py::arg("T"),
                  "From a 4x4 homogeneous matrix (its rotation block is re-orthonormalised).")
      .def("matrix", &SE3::matrix, "The 4x4 homogeneous matrix.")
      .def_property_readonly(
          "translation", [](const SE3& T) { return T.translation(); }, "Translation t (3,).")
      .def_property_readonly("rotation", &SE3::rotation_matrix, "Rotation matrix R (3, 3).")
      .def_property_readonly("quaternion_xyzw", &quaternion_xyzw,
                             "Unit quaternion of R as (x, y, z, w).")
      .def("inverse", &SE3::inverse, "T^-1.")
      .def("log", &SE3::log, "The twist [v, w] (6,) with exp(xi) = T.")
      .def_static("exp", &SE3::exp, py::arg("xi"), "exp([v, w]): translation first.")
      .def(
          "__mul__", [](const SE3& a, const SE3& b) { return a * b; }, py::is_operator())
      .def("__repr__", [](const SE3& T) {
        const Eigen::Vector3d& t = T.translation();
        const Eigen::Vector4d q = quaternion_xyzw(T);
        return "SE3(translation=[" + std::to_string(t.x()) + ", " + std::to_string(t.y()) + ", " +
               std::to_string(t.z()) + "], quaternion_xyzw=[" + std::to_string(q[0]) + ", " +
               std::to_string(q[1]) + ", " + std::to_string(q[2]) + ", " + std::to_string(q[3]) +
               "])";
      });
}

}  // namespace kestrel::python
