// The `kestrel._kestrel` extension module: Kestrel's tracker, block matcher, EKF, trajectory
// files and evaluation for Python (python/kestrel/__init__.py re-exports it; docs/api.md).
#include "bindings.hpp"
#include "kestrel/core/error.hpp"

PYBIND11_MODULE(_kestrel, m) {
  namespace py = pybind11;
  m.doc() =
      "Kestrel: direct RGB-D odometry, active-stereo block matching, IMU + odometry EKF and "
      "trajectory evaluation. Images are numpy arrays (uint8 BGR or grey, float32 depth in "
      "metres), poses 4x4 float64 arrays or SE3 objects, times int64 nanoseconds.";
  // Bad input files and option values: a ValueError subclass whose message names the file and
  // line or field, as the CLI prints it.
  py::register_exception<kestrel::InputError>(m, "InputError", PyExc_ValueError).attr("__doc__") =
      "Bad input: an unreadable or malformed file, a missing field, an impossible option value. "
      "The message names the file and line or field.";
  kestrel::python::bind_geometry(m);
  kestrel::python::bind_io(m);
  kestrel::python::bind_tracker(m);
  kestrel::python::bind_stereo(m);
  kestrel::python::bind_fusion(m);
  kestrel::python::bind_eval(m);
}
