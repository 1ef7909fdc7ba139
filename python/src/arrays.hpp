// numpy arrays <-> cv::Mat without copies: an input is checked (dtype, shape, C-contiguous)
// and viewed in place, with a ValueError that names the argument and says what was expected;
// an output cv::Mat is handed to numpy with the Mat as the owner of its buffer.
#pragma once

#include <initializer_list>
#include <opencv2/core.hpp>
#include <string_view>

#include "bindings.hpp"

namespace kestrel::python {

/// One accepted layout: element type (CV_8U, CV_32F, ...) and channels (1: (H, W); 3: (H, W, 3)).
struct ImageLayout {
  int depth = CV_8U;
  int channels = 1;
};

/// A view of `array` as a cv::Mat (no copy). Throws py::value_error naming `name` unless the
/// array is C-contiguous with one of `layouts`. The Mat is valid while `array` is alive.
cv::Mat view_image(const py::array& array, std::string_view name,
                   std::initializer_list<ImageLayout> layouts);

/// A C-contiguous float64 (or int64) array of `shape` (-1: any length), else py::value_error.
const double* view_doubles(const py::array& array, std::string_view name,
                           std::initializer_list<py::ssize_t> shape);
const std::int64_t* view_int64(const py::array& array, std::string_view name, py::ssize_t length);

/// `mat` as a numpy array sharing its buffer (the array keeps the Mat alive).
py::array to_array(cv::Mat mat);

}  // namespace kestrel::python
