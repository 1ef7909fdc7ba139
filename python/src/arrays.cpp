// Checks and wraps numpy arrays for the bindings (arrays.hpp).
#include "arrays.hpp"

#include <cstdint>
#include <sstream>
#include <string>

namespace kestrel::python {
namespace {

std::string shape_text(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

const char* cv_depth_name(int depth) {
  switch (depth) {
    case CV_8U:
      return "uint8";
    case CV_16U:
      return "uint16";
    case CV_32F:
      return "float32";
    case CV_64F:
      return "float64";
    default:
      return "?";
  }
}

bool dtype_is(const py::array& a, int depth) {
  switch (depth) {
    case CV_8U:
      return a.dtype().is(py::dtype::of<std::uint8_t>());
    case CV_16U:
      return a.dtype().is(py::dtype::of<std::uint16_t>());
    case CV_32F:
      return a.dtype().is(py::dtype::of<float>());
    case CV_64F:
      return a.dtype().is(py::dtype::of<double>());
    default:
      return false;
  }
}

std::string layout_text(const ImageLayout& l) {
  return std::string(cv_depth_name(l.depth)) + (l.channels == 1 ? " (H, W)" : " (H, W, 3)");
}

[[noreturn]] void fail(std::string_view name, const std::string& message) {
  throw py::value_error(std::string(name) + ": " + message);
}

void require_c_contiguous(const py::array& array, std::string_view name) {
  if (!(array.flags() & py::array::c_style)) {
    fail(name,
         "the array must be C-contiguous (a slice or transpose is not; pass "
         "numpy.ascontiguousarray(x))");
  }
}

}  // namespace

cv::Mat view_image(const py::array& array, std::string_view name,
                   std::initializer_list<ImageLayout> layouts) {
  std::string expected;
  for (const ImageLayout& l : layouts)
    expected += (expected.empty() ? "" : " or ") + layout_text(l);
  const int channels = array.ndim() == 3 ? static_cast<int>(array.shape(2)) : 1;
  const bool shape_ok = array.ndim() == 2 || (array.ndim() == 3 && array.shape(2) == 3);
  const ImageLayout* match = nullptr;
  for (const ImageLayout& l : layouts) {
    if (shape_ok && l.channels == channels && dtype_is(array, l.depth)) match = &l;
  }
  if (match == nullptr) {
    fail(name, "expected " + expected + ", got dtype " + dtype_text(array) + " shape " +
                   shape_text(array));
  }
  require_c_contiguous(array, name);
  if (array.shape(0) == 0 || array.shape(1) == 0) fail(name, "the image is empty");
  // cv::Mat takes a non-const pointer; the bindings only read inputs.
  return cv::Mat(static_cast<int>(array.shape(0)), static_cast<int>(array.shape(1)),
                 CV_MAKETYPE(match->depth, match->channels), const_cast<void*>(array.data()));
}

const double* view_doubles(const py::array& array, std::string_view name,
                           std::initializer_list<py::ssize_t> shape) {
  bool shape_ok = array.ndim() == static_cast<py::ssize_t>(shape.size());
  std::ostringstream expected;
  expected << "(";
  py::ssize_t i = 0;
  for (py::ssize_t n : shape) {
    if (i > 0) expected << ", ";
    if (n < 0) {
      expected << "N";
    } else {
      expected << n;
    }
    if (shape_ok && n >= 0 && array.shape(i) != n) shape_ok = false;
    ++i;
  }
  expected << (shape.size() == 1 ? ",)" : ")");
  if (!shape_ok || !dtype_is(array, CV_64F)) {
    fail(name, "expected float64 " + expected.str() + ", got dtype " + dtype_text(array) +
                   " shape " + shape_text(array));
  }
  require_c_contiguous(array, name);
  return static_cast<const double*>(array.data());
}

const std::int64_t* view_int64(const py::array& array, std::string_view name, py::ssize_t length) {
  if (array.ndim() != 1 || array.shape(0) != length ||
      !array.dtype().is(py::dtype::of<std::int64_t>())) {
    fail(name, "expected int64 (" + std::to_string(length) + ",), got dtype " + dtype_text(array) +
                   " shape " + shape_text(array));
  }
  require_c_contiguous(array, name);
  return static_cast<const std::int64_t*>(array.data());
}

py::array to_array(cv::Mat mat) {
  if (!mat.isContinuous()) mat = mat.clone();
  auto* owner = new cv::Mat(std::move(mat));
  py::capsule keep_alive(owner, [](void* p) { delete static_cast<cv::Mat*>(p); });
  py::dtype dtype;
  switch (owner->depth()) {
    case CV_8U:
      dtype = py::dtype::of<std::uint8_t>();
      break;
    case CV_16U:
      dtype = py::dtype::of<std::uint16_t>();
      break;
    case CV_32F:
      dtype = py::dtype::of<float>();
      break;
    case CV_64F:
      dtype = py::dtype::of<double>();
      break;
    default:
      throw std::logic_error("to_array: unsupported cv::Mat depth");
  }
  std::vector<py::ssize_t> shape{owner->rows, owner->cols};
  const auto elem = static_cast<py::ssize_t>(owner->elemSize1());
  std::vector<py::ssize_t> strides{static_cast<py::ssize_t>(owner->step[0]),
                                   static_cast<py::ssize_t>(owner->elemSize())};
  if (owner->channels() > 1) {
    shape.push_back(owner->channels());
    strides.push_back(elem);
  }
  return py::array(dtype, shape, strides, owner->data, keep_alive);
}

}  // namespace kestrel::python
