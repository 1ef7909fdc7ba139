// kestrel.BlockMatcher: disparity of a rectified stereo pair (sensor/block_matcher.hpp).
#include <filesystem>
#include <optional>

#include "arrays.hpp"
#include "bindings.hpp"
#include "kestrel/sensor/block_matcher.hpp"

namespace kestrel::python {
namespace {

sensor::BlockMatcherOptions matcher_options(const std::optional<std::filesystem::path>& path,
                                            std::optional<int> block_size,
                                            std::optional<int> min_disparity,
                                            std::optional<int> max_disparity) {
  sensor::BlockMatcherOptions o =
      path ? sensor::BlockMatcherOptions::load_yaml(*path) : sensor::BlockMatcherOptions{};
  if (block_size) o.block_size = *block_size;
  if (min_disparity) o.min_disparity = *min_disparity;
  if (max_disparity) o.max_disparity = *max_disparity;
  return o;  // BlockMatcher's constructor validates (std::invalid_argument -> ValueError)
}

}  // namespace

void bind_stereo(py::module_& m) {
  py::class_<sensor::MatchStats>(m, "MatchStats", "What happened to the pixels of one match.")
      .def_readonly("pixels", &sensor::MatchStats::pixels, "Pixels of the left view.")
      .def_readonly("valid", &sensor::MatchStats::valid, "Pixels given a disparity.")
      .def_readonly("rejected_texture", &sensor::MatchStats::rejected_texture,
                    "Pixels whose window has too little texture.")
      .def_readonly("rejected_uniqueness", &sensor::MatchStats::rejected_uniqueness,
                    "Pixels whose best cost is not unique enough.")
      .def_readonly("rejected_lr", &sensor::MatchStats::rejected_lr,
                    "Pixels that failed the left-right consistency check.")
      .def_property_readonly("fill_rate", &sensor::MatchStats::fill_rate, "Valid pixels / pixels.")
      .def("__repr__", &sensor::MatchStats::describe);

  py::class_<sensor::BlockMatcher>(
      m, "BlockMatcher",
      "SAD/census block matching of a rectified pair (the matcher of `kestrel disparity`).")
      .def(py::init([](const std::optional<std::filesystem::path>& options,
                       std::optional<int> block_size, std::optional<int> min_disparity,
                       std::optional<int> max_disparity) {
             return std::make_unique<sensor::BlockMatcher>(
                 matcher_options(options, block_size, min_disparity, max_disparity));
           }),
           py::arg("options") = py::none(), py::kw_only(), py::arg("block_size") = py::none(),
           py::arg("min_disparity") = py::none(), py::arg("max_disparity") = py::none(),
           "options: a block matcher options YAML file, None for the defaults; the keywords "
           "override it. Invalid options raise ValueError naming the field.")
      .def(
          "match",
          [](sensor::BlockMatcher& matcher, const py::array& left, const py::array& right) {
            const std::initializer_list<ImageLayout> layouts{{CV_8U, 1}, {CV_8U, 3}, {CV_32F, 1}};
            const cv::Mat l = view_image(left, "left", layouts);
            const cv::Mat r = view_image(right, "right", layouts);
            if (l.size() != r.size() || l.type() != r.type()) {
              throw py::value_error("right: shape and dtype must equal the left image's");
            }
            cv::Mat disparity;
            sensor::MatchStats stats;
            {
              py::gil_scoped_release release;
              stats = matcher.match(l, r, disparity);
            }
            return std::make_tuple(to_array(std::move(disparity)), stats);
          },
          py::arg("left"), py::arg("right"),
          "Disparity of the LEFT view, float32 (H, W), d = uL - uR, inf where none, and the "
          "MatchStats. Images: uint8 grey (H, W) (fast path), uint8 BGR (H, W, 3) or float32 "
          "grey in [0, 255], C-contiguous, same shape. Releases the GIL while matching.")
      .def_property_readonly(
          "options_yaml", [](const sensor::BlockMatcher& b) { return b.options().to_yaml(); },
          "Every matcher option as YAML (loadable as the options file).");
}

}  // namespace kestrel::python
