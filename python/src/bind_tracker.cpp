// kestrel.Tracker: the direct RGB-D tracker (odometry/direct_tracker.hpp) over numpy frames,
// and kestrel.TrackResult, the pose of a frame with its covariance and health.
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "arrays.hpp"
#include "bindings.hpp"
#include "kestrel/io/camera_io.hpp"
#include "kestrel/odometry/direct_tracker.hpp"

namespace kestrel::python {
namespace {

using odometry::TrackResult;

// The tracker with the camera description it was made from; last_track_s is the C++ tracking
// time of the last frame, for measuring what the Python path adds (bench/python_overhead.py).
class Tracker {
 public:
  Tracker(const std::string& camera, const std::optional<std::filesystem::path>& options)
      : description_(io::load_camera_description(camera)),
        tracker_(description_.camera,
                 options ? odometry::DirectTrackerOptions::load(*options)
                         : odometry::DirectTrackerOptions{},
                 odometry::RollingShutter{description_.rolling_shutter_readout_s}) {}

  TrackResult track(std::int64_t t_ns, const py::array& image, const py::array& depth_m) {
    const cv::Mat image_mat = view_image(image, "image", {{CV_8U, 3}, {CV_8U, 1}, {CV_32F, 1}});
    const cv::Mat depth_mat = view_image(depth_m, "depth_m", {{CV_32F, 1}});
    if (image_mat.size() != depth_mat.size()) {
      throw py::value_error("depth_m: shape (" + std::to_string(depth_mat.rows) + ", " +
                            std::to_string(depth_mat.cols) + ") differs from the image's (" +
                            std::to_string(image_mat.rows) + ", " + std::to_string(image_mat.cols) +
                            ")");
    }
    const odometry::RgbdFrame frame{t_ns, image_mat, depth_mat};
    py::gil_scoped_release release;
    const auto t0 = std::chrono::steady_clock::now();
    TrackResult result = tracker_.track(frame);
    last_track_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
  }

  void reset() { tracker_.reset(); }
  [[nodiscard]] double last_track_s() const { return last_track_s_; }
  [[nodiscard]] const io::CameraFile& description() const { return description_; }
  [[nodiscard]] const odometry::DirectTracker& tracker() const { return tracker_; }

 private:
  io::CameraFile description_;
  odometry::DirectTracker tracker_;
  double last_track_s_ = 0.0;
};

void bind_track_result(py::module_& m) {
  py::class_<TrackResult>(m, "TrackResult",
                          "The result of tracking one frame: its pose, covariance and health.")
      .def_readonly("t_ns", &TrackResult::t_ns, "Time stamp of the frame (int64 ns).")
      .def_property_readonly("ok", &TrackResult::ok, "True unless the frame failed.")
      .def_property_readonly(
          "failure",
          [](const TrackResult& r) { return std::string(odometry::to_string(r.failure)); },
          "Why the frame failed (\"none\" when ok).")
      .def_readonly("failure_detail", &TrackResult::failure_detail,
                    "Human-readable detail of the failure, empty when ok.")
      .def_readonly(
          "T_world_cam", &TrackResult::T_world_cam,
          "Pose of this frame (world = first frame) as an SE3; on failure the prediction.")
      .def_property_readonly(
          "pose", [](const TrackResult& r) { return r.T_world_cam.matrix(); },
          "T_world_cam as a 4x4 float64 array.")
      .def_readonly("T_ref_cur", &TrackResult::T_ref_cur,
                    "This frame relative to the reference (keyframe) it was aligned to.")
      .def_readonly("ref_t_ns", &TrackResult::ref_t_ns, "Time stamp of that reference frame.")
      .def_readonly("covariance", &TrackResult::covariance,
                    "6x6 covariance of xi = [v, w] in T_ref_cur = exp(xi) * estimate "
                    "(reference frame).")
      .def_readonly("converged", &TrackResult::converged,
                    "The finest level stopped by a tolerance, not the iteration cap.")
      .def_readonly("iterations", &TrackResult::iterations,
                    "Gauss-Newton iterations over all levels.")
      .def_readonly("sigma", &TrackResult::sigma, "Final robust sigma (intensity in [0, 1]).")
      .def_readonly("inlier_ratio", &TrackResult::inlier_ratio,
                    "Residuals within the Tukey cut-off / reference points.")
      .def_readonly("overlap", &TrackResult::overlap,
                    "Reference points that project into the image / all.")
      .def_readonly("points", &TrackResult::points,
                    "Reference points on the finest level iterated.")
      .def_readonly("gain", &TrackResult::gain, "g of I_ref = (1 + g) I_cur + b.")
      .def_readonly("bias", &TrackResult::bias, "b of I_ref = (1 + g) I_cur + b.")
      .def_readonly("new_keyframe", &TrackResult::new_keyframe,
                    "This frame became the reference of the next ones.")
      .def_readonly("geometric_fallback", &TrackResult::geometric_fallback,
                    "The pose came from the geometric (point-to-plane) fallback.")
      .def("__repr__", [](const TrackResult& r) {
        return "TrackResult(t_ns=" + std::to_string(r.t_ns) +
               ", ok=" + (r.ok() ? "True" : "False") +
               ", iterations=" + std::to_string(r.iterations) + ")";
      });
}

}  // namespace

void bind_tracker(py::module_& m) {
  bind_track_result(m);
  py::class_<Tracker>(m, "Tracker",
                      "Direct dense RGB-D odometry (the tracker of `kestrel odometry`).")
      .def(py::init<const std::string&, const std::optional<std::filesystem::path>&>(),
           py::arg("camera") = "fr1", py::arg("options") = py::none(),
           "camera: a preset (fr1, fr2, fr3, ros) or a camera YAML file; options: a tracker "
           "options YAML file (as `kestrel odometry --config`), None for the defaults.")
      .def("track", &Tracker::track, py::arg("t_ns"), py::arg("image"), py::arg("depth_m"),
           "Tracks the next frame. image: uint8 BGR (H, W, 3), uint8 grey (H, W) or float32 "
           "grey in [0, 1] (H, W); depth_m: float32 (H, W) metres, 0 = no depth. Arrays must be "
           "C-contiguous (they are read in place); anything else raises ValueError. Releases "
           "the GIL while tracking.")
      .def("reset", &Tracker::reset, "Forgets the keyframe, motion and pose.")
      .def_property_readonly("last_track_s", &Tracker::last_track_s,
                             "C++ time of the last track() call, seconds (conversions excluded).")
      .def_property_readonly(
          "depth_scale", [](const Tracker& t) { return t.description().depth_scale; },
          "Depth PNG units per metre the camera description gives, or None.")
      .def_property_readonly(
          "options_yaml", [](const Tracker& t) { return t.tracker().options().to_yaml(); },
          "Every tracker option as YAML (what the CLI prints at the start of a run).");
}

}  // namespace kestrel::python
