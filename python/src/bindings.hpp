// Shared by the binding files of the `kestrel` Python module: pybind11 with its numpy, Eigen,
// STL and filesystem casters, Trajectory kept opaque (a Python class, not a list copied back and
// forth), and the bind_* functions that module.cpp calls in order.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "kestrel/geometry/se3.hpp"
#include "kestrel/io/trajectory.hpp"

PYBIND11_MAKE_OPAQUE(kestrel::Trajectory)

namespace kestrel::python {

namespace py = pybind11;

/// The unit quaternion of T as (x, y, z, w), the order of TUM files.
Eigen::Vector4d quaternion_xyzw(const SE3& T);

void bind_geometry(py::module_& m);  // SE3
void bind_io(py::module_& m);        // Trajectory, its files, TUM RGB-D folders
void bind_tracker(py::module_& m);   // DirectTracker
void bind_stereo(py::module_& m);    // BlockMatcher
void bind_fusion(py::module_& m);    // FusionEngine (the EKF)
void bind_eval(py::module_& m);      // evaluate()

}  // namespace kestrel::python
